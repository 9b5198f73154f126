//! Scenes: the RON file format, validation, and the validated scene that the
//! renderer and the f64 reference both read.

pub mod file;
pub mod hrbf;
pub mod turn;

use std::path::Path;

use glam::DVec3;

pub use file::SceneFile;

pub mod animation;

pub use animation::{Animation, CameraPath, Motion, Scale};

use crate::method::Method;
use crate::settings::{QuadSettings, Refinement, ValidityScope};

/// Largest kernel weight or slope the GPU's f32 arithmetic takes with room
/// to spare (f32 ends at 3.4e38).
pub const GPU_FLOAT_LIMIT: f64 = 1e36;

pub use crate::settings::GAUSSIAN_BOUNDS_FRACTION;

/// A scene problem, one line: file, field, what is allowed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {}{message}", if field.is_empty() { String::new() } else { format!("{field}: ") })]
pub struct SceneError {
    pub file: String,
    pub field: String,
    pub message: String,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    pub fov_y_deg: f64,
    /// Perspective (through the eye, `fov_y_deg`) or orthographic.
    pub projection: Projection,
    /// What rays keep of the scene: the side of each clipping plane.
    pub clip: Clip,
    pub width: u32,
    pub height: u32,
    /// Anti-aliasing: rays per pixel (1: through its centre).
    pub samples: u32,
}

/// How a camera projects.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Projection {
    /// Rays from the eye through the image, `fov_y_deg` high.
    #[default]
    Perspective,
    /// Rays parallel to the view direction from the plane through the eye,
    /// a view `height` scene units high (the field of view is not used).
    Orthographic { height: f64 },
}

/// Clipping: a camera ray is marched only where it is past `near` and
/// short of `far` (distances from the eye's plane along the view
/// direction: they move with the camera) and on the kept side of every
/// plane (world space: `normal` points to the side kept). Cut faces are
/// capped: a ray that starts inside the surface at a clipping plane hits
/// there, shaded with the plane's normal.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clip {
    pub near: Option<f64>,
    pub far: Option<f64>,
    pub planes: Vec<ClipPlane>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipPlane {
    pub point: DVec3,
    /// Unit; points to the side kept.
    pub normal: DVec3,
}

impl Clip {
    pub fn is_empty(&self) -> bool {
        self.near.is_none() && self.far.is_none() && self.planes.is_empty()
    }

    /// The part of `[t0, t1]` of the ray `o + t d` that is kept, and the
    /// normal (pointing to the side kept) of the plane that set its start
    /// where one did; `None` where nothing is kept.
    pub fn interval(&self, camera: &Camera, o: DVec3, d: DVec3, (mut t0, mut t1): (f64, f64)) -> Option<(f64, f64, Option<DVec3>)> {
        let forward = (camera.target - camera.eye).normalize();
        let mut cut = None;
        let mut keep = |point: DVec3, normal: DVec3, t0: &mut f64, t1: &mut f64| -> bool {
            let (s0, sd) = (normal.dot(o - point), normal.dot(d));
            if sd == 0.0 {
                return s0 >= 0.0;
            }
            let t = -s0 / sd;
            if sd > 0.0 && t > *t0 {
                *t0 = t;
                cut = Some(normal);
            } else if sd < 0.0 && t < *t1 {
                *t1 = t;
            }
            true
        };
        let mut all = true;
        if let Some(near) = self.near {
            all &= keep(camera.eye + near * forward, forward, &mut t0, &mut t1);
        }
        if let Some(far) = self.far {
            all &= keep(camera.eye + far * forward, -forward, &mut t0, &mut t1);
        }
        for p in &self.planes {
            all &= keep(p.point, p.normal, &mut t0, &mut t1);
        }
        (all && t0 <= t1).then_some((t0, t1, cut))
    }
}

/// The largest image side, in pixels: a scene's `camera.resolution`,
/// `--size` and Python's sizes alike.
pub const MAX_SIDE: u32 = 16384;

/// The most rays per pixel a scene or `--samples` may ask for.
pub const MAX_SAMPLES: u32 = 4096;
/// The most ambient-occlusion rays per hit a scene or `--ao` may ask for.
pub const MAX_AO_SAMPLES: u32 = 1024;

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Unit direction towards the light.
    pub direction: DVec3,
    /// Colour times intensity.
    pub color: DVec3,
}

/// Transparent rendering (Section 7.2): every crossing along a ray is
/// found; each surface crossing shows its shaded colour with weight
/// `opacity` and passes the rest on, attenuated inside by Beer-Lambert.
/// Ambient occlusion: `samples` rays per hit, each looking `distance` far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ao {
    pub samples: u32,
    pub distance: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transparency {
    pub opacity: f64,
    pub absorption: DVec3,
    /// A dielectric (reflection and refraction) when set.
    pub ior: Option<f64>,
    pub max_depth: u32,
    /// Multiplies the Fresnel reflectance of a dielectric, in [0, 1].
    pub reflectivity: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Marching {
    pub method: Method,
    pub min_step: f64,
    pub max_steps: u32,
    /// Interval growth k; `None`: the method's default.
    pub growth: Option<f64>,
    /// Settings of the bottom-up quadratic bounds.
    pub quad: QuadSettings,
    /// How a bracketed crossing is narrowed to the tolerance.
    pub refine: Refinement,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kernel {
    /// `weight · (1 - d²/radius²)³` for `d < radius`, else 0 (Eq. 7, lost from
    /// the paper's text; our reading in docs/paper-digest.md, section 0).
    Compact { radius: f64, weight: f64 },
    /// `weight · exp(-s d²/r²)` (Eq. 6).
    Gaussian { r: f64, s: f64, weight: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    Point {
        center: DVec3,
        kernel: Kernel,
    },
    /// Compact kernel of the distance to the plane `normal · p = offset`.
    Plane {
        normal: DVec3,
        offset: f64,
        radius: f64,
        weight: f64,
    },
    /// One term of a Hermite RBF (Eq. 9, φ(r) = r³):
    /// `alpha |p - center|³ + 3 |p - center| beta · (p - center)`.
    /// `domain`: its HRBF's box (the control points' box with the margin),
    /// where rays are marched.
    Hrbf {
        center: DVec3,
        alpha: f64,
        beta: DVec3,
        domain: Aabb,
    },
    /// The affine function `gradient · p + offset`: an HRBF's polynomial
    /// term, with the iso value added so that its surface is the HRBF's.
    Affine {
        gradient: DVec3,
        offset: f64,
    },
}

/// Axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    pub fn empty() -> Aabb {
        Aabb { min: DVec3::splat(f64::INFINITY), max: DVec3::splat(f64::NEG_INFINITY) }
    }
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }
    /// The parameter interval where `o + t d` is inside the box (slab test),
    /// clipped to `t >= 0`; `None` when the ray misses.
    pub fn clip_ray(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let inv = d.recip();
        let a = (self.min - o) * inv;
        let b = (self.max - o) * inv;
        // NaN from 0 * inf (ray in a face plane) is dropped by max/min.
        let t0 = a.min(b).max_element().max(0.0);
        let t1 = a.max(b).min_element();
        (t0 <= t1).then_some((t0, t1))
    }
}

impl Kernel {
    /// Distance beyond which the kernel is zero (compact) or below
    /// `GAUSSIAN_BOUNDS_FRACTION · iso` (Gaussian).
    pub fn cutoff(&self, iso: f64) -> f64 {
        match *self {
            Kernel::Compact { radius, .. } => radius,
            Kernel::Gaussian { r, s, weight } => {
                let ratio = weight / (GAUSSIAN_BOUNDS_FRACTION * iso);
                if ratio <= 1.0 { 0.0 } else { r * (ratio.ln() / s).sqrt() }
            }
        }
    }
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Where it came from, for messages.
    pub source: String,
    pub camera: Camera,
    pub background: DVec3,
    pub ambient: DVec3,
    pub surface: DVec3,
    pub lights: Vec<Light>,
    pub iso: f64,
    /// `None`: opaque, the first crossing only.
    pub transparency: Option<Transparency>,
    /// Shadows from every light (opaque scenes; src/render/light.rs).
    pub shadows: bool,
    /// Ambient occlusion (opaque scenes).
    pub ao: Option<Ao>,
    pub marching: Marching,
    /// Max over groups of sums over primitives (Eq. 20).
    pub groups: Vec<Vec<Primitive>>,
    /// Where rays are marched: explicit, or the union of the supports.
    pub bounds: Aabb,
    /// The file fixed `bounds` (else they follow the posed supports).
    pub bounds_explicit: bool,
    /// What moves over scene time.
    pub animation: Animation,
    /// Each primitive's colour (linear RGB), group by group, when any point
    /// gives one (the others take `surface`); `None`: all take `surface`.
    pub colors: Option<Vec<DVec3>>,
}

impl Scene {
    /// Reads, parses and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: name.clone(),
            field: String::new(),
            message: format!("cannot read: {e}"),
        })?;
        Scene::parse(&text, &name)
    }

    /// Parses and validates scene text; `name` labels errors.
    pub fn parse(text: &str, name: &str) -> Result<Scene, SceneError> {
        validate(&file::parse(text, name)?, name)
    }

    /// Whether any primitive has a Gaussian kernel (the rest are compact).
    pub fn has_gaussians(&self) -> bool {
        self.primitives().any(|p| matches!(p, Primitive::Point { kernel: Kernel::Gaussian { .. }, .. }))
    }

    /// Whether the max over groups needs every group's sum, even that of a
    /// group no primitive of which reaches the query. Per-ray culling and
    /// the spatial index skip such groups, which is exact while every
    /// group's sum is >= 0 (a skipped group's is 0). An HRBF group goes
    /// far below 0, so with other groups skipping them would give
    /// `max(H) - iso` where the field is `max(H, 0) - iso`: the same
    /// surface (iso > 0), but other values and steps than the f64 mirror.
    pub fn max_needs_every_group(&self) -> bool {
        self.groups.len() > 1 && self.primitives().any(|p| matches!(p, Primitive::Hrbf { .. } | Primitive::Affine { .. }))
    }

    /// Whether a first crossing has a bracket the primitives give alone:
    /// with iso > 0 and every primitive a point kernel of non-negative
    /// weight, each group's sum is at least any one of its terms and the
    /// max of the groups at least any group, so f >= 0 wherever one
    /// primitive alone reaches iso (f is no further than there from its
    /// first crossing), and f = -iso < 0 before the ray enters any
    /// support. Planes, HRBF and affine terms, and negative weights, give
    /// no such bound.
    pub fn bracket_holds(&self) -> bool {
        self.iso > 0.0
            && self.primitives().all(|p| match p {
                Primitive::Point { kernel: Kernel::Compact { weight, .. } | Kernel::Gaussian { weight, .. }, .. } => *weight >= 0.0,
                _ => false,
            })
    }

    pub fn primitive_count(&self) -> usize {
        self.groups.iter().map(Vec::len).sum()
    }

    pub fn primitives(&self) -> impl Iterator<Item = &Primitive> {
        self.groups.iter().flatten()
    }

    /// How far occlusion rays look when neither the scene file nor the
    /// command line says: 4 times the smallest primitive radius.
    pub fn default_ao_distance(&self) -> f64 {
        4.0 * self.min_radius()
    }

    /// The smallest support radius or Gaussian scale: the length that sets
    /// refinement tolerances.
    pub fn min_radius(&self) -> f64 {
        self.primitives()
            .map(|p| match *p {
                Primitive::Point { kernel: Kernel::Compact { radius, .. }, .. } => radius,
                Primitive::Point { kernel: Kernel::Gaussian { r, .. }, .. } => r,
                Primitive::Plane { radius, .. } => radius,
                // An HRBF's detail is taken to be a tenth of its box.
                Primitive::Hrbf { domain, .. } => 0.1 * domain.diagonal(),
                Primitive::Affine { .. } => f64::INFINITY,
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Bisection tolerance for crossings: `1e-4 · R_min` (docs/benchmark-protocol.md,
    /// "Hits, the minimum step and refinement").
    pub fn refine_tolerance(&self) -> f64 {
        1e-4 * self.min_radius()
    }
}

struct Checker<'a> {
    file: &'a str,
}

impl Checker<'_> {
    fn err(&self, field: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError { file: self.file.into(), field: field.into(), message: message.into() }
    }
    fn finite(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() { Ok(v) } else { Err(self.err(field, format!("must be a finite number, got {v}"))) }
    }
    fn positive(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v > 0.0 { Ok(v) } else { Err(self.err(field, format!("must be positive and finite, got {v}"))) }
    }
    fn vec3(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        for (i, c) in v.iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), *c)?;
        }
        Ok(DVec3::from_array(v))
    }
    fn color(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let c = self.vec3(field, v)?;
        if c.min_element() < 0.0 {
            return Err(self.err(field, format!("colour components must be >= 0, got {v:?}")));
        }
        Ok(c)
    }
    fn unit(&self, field: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let d = self.vec3(field, v)?;
        if d.length() < 1e-12 {
            return Err(self.err(field, "must be a non-zero vector"));
        }
        Ok(d.normalize())
    }
    fn weight(&self, field: &str, w: Option<f64>, default: f64) -> Result<f64, SceneError> {
        w.map_or(Ok(default), |w| self.positive(field, w))
    }
    /// Keyframes: at least one, finite, in increasing time.
    fn keyframes(&self, field: &str, keys: &[(f64, [f64; 3])]) -> Result<Vec<(f64, DVec3)>, SceneError> {
        if keys.is_empty() {
            return Err(self.err(field, "needs at least one (time, position) key"));
        }
        let mut out = Vec::with_capacity(keys.len());
        for (i, (t, p)) in keys.iter().enumerate() {
            let t = self.finite(&format!("{field}[{i}].0"), *t)?;
            if out.last().is_some_and(|&(prev, _)| t <= prev) {
                return Err(self.err(format!("{field}[{i}]"), format!("key times must increase, got {t} after {}", out[i - 1].0)));
            }
            out.push((t, self.vec3(&format!("{field}[{i}].1"), *p)?));
        }
        Ok(out)
    }
    /// An HRBF: its fitted terms (one per control point, then the affine
    /// term with the iso value added) and the box rays are marched in.
    fn hrbf(
        &self,
        at: &str,
        points: &[([f64; 3], [f64; 3])],
        polynomial: bool,
        margin: Option<f64>,
        iso: f64,
    ) -> Result<(Vec<Primitive>, Aabb), SceneError> {
        let field = format!("{at}.points");
        if points.is_empty() {
            return Err(self.err(&field, "needs at least one (position, normal) control point"));
        }
        let mut positions = Vec::with_capacity(points.len());
        let mut normals = Vec::with_capacity(points.len());
        for (i, (p, n)) in points.iter().enumerate() {
            positions.push(self.vec3(&format!("{field}[{i}].0"), *p)?);
            normals.push(self.unit(&format!("{field}[{i}].1"), *n)?);
        }
        let fit = hrbf::fit(&positions, &normals, polynomial).map_err(|e| self.err(&field, e.to_string()))?;
        let mut domain = positions.iter().fold(Aabb::empty(), |b, &p| b.union(Aabb { min: p, max: p }));
        let side = (domain.max - domain.min).max_element();
        let margin = match margin {
            Some(m) => self.positive(&format!("{at}.margin"), m)?,
            None if side > 0.0 => hrbf::DEFAULT_MARGIN * side,
            None => return Err(self.err(format!("{at}.margin"), "the control points are all at one place: give the margin of the box to march")),
        };
        domain = Aabb { min: domain.min - DVec3::splat(margin), max: domain.max + DVec3::splat(margin) };
        // The GPU computes in f32: every term's size over the box must fit.
        let reach = domain.diagonal();
        let largest = fit.alpha.iter().zip(&fit.beta).map(|(&a, &b)| hrbf::term_size(a, b, reach)).fold(0.0, f64::max);
        if !(largest < GPU_FLOAT_LIMIT) {
            return Err(self.err(&field, format!("the fitted terms reach {largest:.3e} in the box, beyond the GPU's f32 range ({GPU_FLOAT_LIMIT:.0e}); lower the margin or move the points apart")));
        }
        let mut terms: Vec<Primitive> = positions
            .iter()
            .zip(fit.alpha.iter().zip(&fit.beta))
            .map(|(&center, (&alpha, &beta))| Primitive::Hrbf { center, alpha, beta, domain })
            .collect();
        terms.push(Primitive::Affine { gradient: fit.gradient, offset: fit.offset + iso });
        Ok((terms, domain))
    }
    fn motion(&self, field: &str, m: &file::MotionFile) -> Result<Motion, SceneError> {
        Ok(match m {
            file::MotionFile::Sine { axis, amplitude, period, phase } => Motion::Sine {
                axis: self.unit(&format!("{field}.axis"), *axis)?,
                amplitude: self.finite(&format!("{field}.amplitude"), *amplitude)?,
                period: self.positive(&format!("{field}.period"), *period)?,
                phase: self.finite(&format!("{field}.phase"), *phase)?,
            },
            file::MotionFile::Keyframes(keys) => Motion::Keyframes(self.keyframes(field, keys)?),
        })
    }
    fn scale(&self, field: &str, m: &file::ScaleFile) -> Result<Scale, SceneError> {
        Ok(match m {
            file::ScaleFile::Sine { amplitude, period, phase } => {
                let amplitude = self.finite(&format!("{field}.amplitude"), *amplitude)?;
                if !(0.0..1.0).contains(&amplitude) {
                    return Err(self.err(format!("{field}.amplitude"), format!("must be in [0, 1) so the radius stays positive, got {amplitude}")));
                }
                Scale::Sine {
                    amplitude,
                    period: self.positive(&format!("{field}.period"), *period)?,
                    phase: self.finite(&format!("{field}.phase"), *phase)?,
                }
            }
            file::ScaleFile::Keyframes(keys) => {
                let as_points: Vec<(f64, [f64; 3])> = keys.iter().map(|&(t, f)| (t, [f, 0.0, 0.0])).collect();
                let checked = self.keyframes(field, &as_points)?;
                for (i, &(_, f)) in keys.iter().enumerate() {
                    self.positive(&format!("{field}[{i}].1"), f)?;
                }
                Scale::Keyframes(checked.iter().map(|&(t, p)| (t, p.x)).collect())
            }
        })
    }
}

/// The camera a file's camera block gives, checked.
fn camera_of(c: &Checker, cam: &file::CameraFile) -> Result<Camera, SceneError> {
    let eye = c.vec3("camera.eye", cam.eye)?;
    let target = c.vec3("camera.target", cam.target)?;
    if (target - eye).length() < 1e-12 {
        return Err(c.err("camera.target", "must differ from camera.eye"));
    }
    let up = c.unit("camera.up", cam.up)?;
    if (target - eye).normalize().cross(up).length() < 1e-9 {
        return Err(c.err("camera.up", "must not be parallel to the viewing direction"));
    }
    let fov = c.finite("camera.fov_y", cam.fov_y)?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(c.err("camera.fov_y", format!("must be in (0, 180) degrees, got {fov}")));
    }
    let projection = match cam.projection {
        file::ProjectionFile::Perspective => Projection::Perspective,
        file::ProjectionFile::Orthographic { height } => Projection::Orthographic { height: c.positive("camera.projection.height", height)? },
    };
    let clip = Clip {
        near: cam.clip.near.map(|d| c.finite("camera.clip.near", d)).transpose()?,
        far: cam.clip.far.map(|d| c.finite("camera.clip.far", d)).transpose()?,
        planes: cam
            .clip
            .planes
            .iter()
            .enumerate()
            .map(|(i, p)| {
                Ok(ClipPlane {
                    point: c.vec3(&format!("camera.clip.planes[{i}].point"), p.point)?,
                    normal: c.unit(&format!("camera.clip.planes[{i}].normal"), p.normal)?,
                })
            })
            .collect::<Result<Vec<_>, SceneError>>()?,
    };
    if let (Some(n), Some(f)) = (clip.near, clip.far)
        && n >= f
    {
        return Err(c.err("camera.clip", format!("near ({n}) must be closer than far ({f})")));
    }
    let (w, h) = cam.resolution;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(c.err("camera.resolution", format!("must be 1..={MAX_SIDE} pixels each way, got ({w}, {h})")));
    }
    if !(1..=MAX_SAMPLES).contains(&cam.samples) {
        return Err(c.err("camera.samples", format!("must be 1..={MAX_SAMPLES} rays per pixel, got {}", cam.samples)));
    }
    let (w, h) = cam.resolution;
    Ok(Camera { eye, target, up, fov_y_deg: fov, projection, clip, width: w, height: h, samples: cam.samples })
}

impl Camera {
    /// A camera from a file holding a RON camera block (what the viewer's
    /// `C` key writes; `render --camera FILE`): the scene file's `camera:
    /// (...)` alone.
    pub fn load(path: &Path) -> Result<Camera, SceneError> {
        let name = path.display().to_string();
        let c = Checker { file: &name };
        let text = std::fs::read_to_string(path).map_err(|e| c.err("", format!("cannot read: {e}")))?;
        let cam: file::CameraFile = ron::from_str(&text).map_err(|e| c.err("", format!("not a camera block: {e}")))?;
        camera_of(&c, &cam)
    }

    /// This camera as a RON camera block, every number to the last digit
    /// (its path, if any, is the scene's and not written).
    pub fn to_ron(&self) -> String {
        let v = |p: DVec3| format!("({:?}, {:?}, {:?})", p.x, p.y, p.z);
        let mut s = format!(
            "(\n    eye: {},\n    target: {},\n    up: {},\n    fov_y: {:?},\n    resolution: ({}, {}),\n    samples: {},\n",
            v(self.eye),
            v(self.target),
            v(self.up),
            self.fov_y_deg,
            self.width,
            self.height,
            self.samples
        );
        if let Projection::Orthographic { height } = self.projection {
            s += &format!("    projection: Orthographic(height: {height:?}),\n");
        }
        if !self.clip.is_empty() {
            let planes: Vec<String> = self.clip.planes.iter().map(|p| format!("(point: {}, normal: {})", v(p.point), v(p.normal))).collect();
            s += &format!("    clip: (near: {:?}, far: {:?}, planes: [{}]),\n", self.clip.near, self.clip.far, planes.join(", "));
        }
        s + ")\n"
    }
}

/// Checks every value of a parsed file and resolves defaults.
pub fn validate(f: &SceneFile, name: &str) -> Result<Scene, SceneError> {
    let c = Checker { file: name };
    let camera = camera_of(&c, &f.camera)?;
    let iso = c.positive("iso", f.iso)?;
    let method: Method = f.marching.method.parse().map_err(|e: String| c.err("marching.method", e))?;
    let min_step = c.positive("marching.min_step", f.marching.min_step)?;
    if f.marching.max_steps == 0 {
        return Err(c.err("marching.max_steps", "must be at least 1"));
    }
    let growth = match f.marching.growth {
        Some(k) if !(k.is_finite() && k >= 1.0) => {
            return Err(c.err("marching.growth", format!("must be a finite number >= 1, got {k}")));
        }
        k => k,
    };
    let refine = match f.marching.refine.as_deref() {
        None => Refinement::default(),
        Some(name) => {
            Refinement::from_name(name).ok_or_else(|| c.err("marching.refine", format!("expected \"secant\" or \"bisection\", got {name:?}")))?
        }
    };
    let validity = match f.marching.validity.as_str() {
        "significant" => ValidityScope::Significant,
        "every" => ValidityScope::Every,
        other => return Err(c.err("marching.validity", format!("expected \"significant\" or \"every\", got {other:?}"))),
    };
    let ao = match &f.ao {
        None => None,
        Some(a) => {
            if !(1..=MAX_AO_SAMPLES).contains(&a.samples) {
                return Err(c.err("ao.samples", format!("must be 1..={MAX_AO_SAMPLES} rays per hit, got {}", a.samples)));
            }
            Some(Ao { samples: a.samples, distance: c.positive("ao.distance", a.distance)? })
        }
    };
    let transparency = match &f.transparency {
        None => None,
        Some(t) => {
            if !(0.0..=1.0).contains(&t.opacity) {
                return Err(c.err("transparency.opacity", format!("must be in [0, 1], got {}", t.opacity)));
            }
            let absorption = c.vec3("transparency.absorption", t.absorption)?;
            if absorption.min_element() < 0.0 {
                return Err(c.err("transparency.absorption", format!("must be >= 0 on every channel, got {:?}", t.absorption)));
            }
            let ior = t.ior.map(|n| c.positive("transparency.ior", n)).transpose()?;
            if !(1..=16).contains(&t.max_depth) {
                return Err(c.err("transparency.max_depth", format!("must be in 1..=16, got {}", t.max_depth)));
            }
            if !(0.0..=1.0).contains(&t.reflectivity) {
                return Err(c.err("transparency.reflectivity", format!("must be in [0, 1], got {}", t.reflectivity)));
            }
            Some(Transparency { opacity: t.opacity, absorption, ior, max_depth: t.max_depth, reflectivity: t.reflectivity })
        }
    };
    let mut lights = Vec::new();
    for (i, l) in f.lights.iter().enumerate() {
        let direction = c.unit(&format!("lights[{i}].direction"), l.direction)?;
        let color = c.color(&format!("lights[{i}].color"), l.color)?;
        let intensity = c.finite(&format!("lights[{i}].intensity"), l.intensity)?;
        if intensity < 0.0 {
            return Err(c.err(format!("lights[{i}].intensity"), format!("must be >= 0, got {intensity}")));
        }
        lights.push(Light { direction, color: color * intensity });
    }
    if lights.is_empty() {
        lights.push(Light { direction: DVec3::new(0.4, 0.8, 0.45).normalize(), color: DVec3::splat(0.9) });
    }
    if lights.len() > 8 {
        return Err(c.err("lights", format!("at most 8 lights, got {}", lights.len())));
    }

    let surface = c.color("surface", f.surface)?;
    if f.groups.is_empty() {
        return Err(c.err("groups", "the scene has no groups; give at least one group with one primitive"));
    }
    let mut groups = Vec::new();
    let mut animation = Animation::default();
    if let Some(path) = &f.camera.path {
        animation.camera = Some(match path {
            file::CameraPathFile::Orbit { period } => CameraPath::Orbit { period: c.positive("camera.path.period", *period)? },
            file::CameraPathFile::Keyframes(keys) => CameraPath::Keyframes(c.keyframes("camera.path", keys)?),
        });
    }
    let mut support = Aabb::empty();
    let mut has_plane = false;
    // Per-primitive colours, once a point gives one (the earlier ones None).
    let mut colors: Option<Vec<Option<DVec3>>> = None;
    let mut prims_before = 0;
    for (gi, g) in f.groups.iter().enumerate() {
        if g.primitives.is_empty() {
            return Err(c.err(format!("groups[{gi}].primitives"), "is empty; every group needs a primitive"));
        }
        let mut prims = Vec::new();
        for (pi, p) in g.primitives.iter().enumerate() {
            let at = format!("groups[{gi}].primitives[{pi}]");
            let prim = match p {
                file::PrimitiveFile::Point { center, kernel, motion, radius_scale, color } => {
                    let center = c.vec3(&format!("{at}.center"), *center)?;
                    if let Some(rgb) = color {
                        colors.get_or_insert_with(|| vec![None; prims_before + prims.len()]);
                        let rgb = c.color(&format!("{at}.color"), *rgb)?;
                        if let Some(v) = colors.as_mut() {
                            v.push(Some(rgb));
                        }
                    } else if let Some(v) = colors.as_mut() {
                        v.push(None);
                    }
                    if let Some(m) = motion {
                        animation.primitives.push(((gi, prims.len()), c.motion(&format!("{at}.motion"), m)?));
                    }
                    // The smallest size the point takes, for the f32 check.
                    let mut shrink = 1.0;
                    if let Some(m) = radius_scale {
                        let scale = c.scale(&format!("{at}.radius_scale"), m)?;
                        shrink = scale.min_factor().min(1.0);
                        animation.radii.push(((gi, prims.len()), scale));
                    }
                    let kernel = match kernel {
                        file::KernelFile::Compact { radius, weight } => {
                            let radius = c.positive(&format!("{at}.kernel.radius"), *radius)?;
                            let weight = c.weight(&format!("{at}.kernel.weight"), *weight, 1.0)?;
                            Kernel::Compact { radius, weight }
                        }
                        file::KernelFile::Gaussian { r, s, weight } => {
                            let r = c.positive(&format!("{at}.kernel.r"), *r)?;
                            let s = c.positive(&format!("{at}.kernel.s"), *s)?;
                            let default = iso * s.exp();
                            let weight = c.weight(&format!("{at}.kernel.weight"), *weight, default)?;
                            // The GPU computes in f32: the weight and the
                            // kernel's Lipschitz bound w·sqrt(2s)/r must fit.
                            let slope = weight * (2.0 * s).sqrt() / (r * shrink);
                            if !(weight.max(slope) < GPU_FLOAT_LIMIT) {
                                return Err(c.err(
                                    format!("{at}.kernel"),
                                    format!("weight {weight:.3e} (iso·e^s by default) and slope {slope:.3e} must stay below {GPU_FLOAT_LIMIT:.0e}, the GPU's f32 range; lower s (about 80 at most) or the weight"),
                                ));
                            }
                            Kernel::Gaussian { r, s, weight }
                        }
                    };
                    let reach = DVec3::splat(kernel.cutoff(iso));
                    support = support.union(Aabb { min: center - reach, max: center + reach });
                    Primitive::Point { center, kernel }
                }
                file::PrimitiveFile::Hrbf { points, polynomial, margin } => {
                    let (terms, domain) = c.hrbf(&at, points, *polynomial, *margin, iso)?;
                    if let Some(v) = colors.as_mut() {
                        v.extend(std::iter::repeat_n(None, terms.len()));
                    }
                    support = support.union(domain);
                    prims.extend(terms);
                    continue;
                }
                file::PrimitiveFile::Plane { normal, offset, radius, weight } => {
                    has_plane = true;
                    if let Some(v) = colors.as_mut() {
                        v.push(None);
                    }
                    Primitive::Plane {
                        normal: c.unit(&format!("{at}.normal"), *normal)?,
                        offset: c.finite(&format!("{at}.offset"), *offset)?,
                        radius: c.positive(&format!("{at}.radius"), *radius)?,
                        weight: c.weight(&format!("{at}.weight"), *weight, 1.0)?,
                    }
                }
            };
            prims.push(prim);
        }
        prims_before += prims.len();
        groups.push(prims);
    }
    let bounds = match &f.bounds {
        Some(b) => {
            let min = c.vec3("bounds.min", b.min)?;
            let max = c.vec3("bounds.max", b.max)?;
            if !(min.cmplt(max).all()) {
                return Err(c.err("bounds", format!("min must be below max on every axis, got {:?} and {:?}", b.min, b.max)));
            }
            Aabb { min, max }
        }
        None if has_plane => {
            return Err(c.err("bounds", "a scene with a plane needs explicit bounds (the plane is infinite)"));
        }
        None => support,
    };
    if !(bounds.min.cmplt(bounds.max).all()) {
        return Err(c.err("groups", "no primitive reaches the iso value, so the scene is empty"));
    }
    Ok(Scene {
        source: name.to_string(),
        camera,
        background: c.color("background", f.background)?,
        ambient: c.color("ambient", f.ambient)?,
        surface,
        lights,
        iso,
        transparency,
        shadows: f.shadows,
        ao,
        marching: Marching {
            method,
            min_step,
            max_steps: f.marching.max_steps,
            growth,
            quad: QuadSettings { extension: f.marching.extension, validity },
            refine,
        },
        groups,
        bounds,
        bounds_explicit: f.bounds.is_some(),
        animation,
        colors: colors.map(|v| v.into_iter().map(|c| c.unwrap_or(surface)).collect()),
    })
}
