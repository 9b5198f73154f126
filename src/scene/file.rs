//! The scene file format as written by users (RON). Unknown fields are
//! errors; every value is range-checked by [`super::validate`].

use serde::{Deserialize, Serialize};

use super::SceneError;

/// The RON options of every scene file: an optional field takes its value
/// plain (`weight: 2.0`, as docs/scene-format.md writes it) or as
/// `Some(2.0)` (RON's `implicit_some`).
pub fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// Parses scene text (not yet validated). A syntax or type error names its
/// line and column and, where it happens inside a field, that field's path
/// (`groups[0].primitives[3].kernel.weight`), as validation errors do.
pub fn parse(text: &str, name: &str) -> Result<SceneFile, SceneError> {
    let error = |e: ron::error::SpannedError, path: &str| {
        let at = format!("line {}, column {}", e.span.start.line, e.span.start.col);
        SceneError { file: name.to_string(), field: if path.is_empty() { at } else { format!("{at}: {path}") }, message: e.code.to_string() }
    };
    let options = ron_options();
    let mut de = ron::Deserializer::from_str_with_options(text, &options).map_err(|e| error(e, ""))?;
    let file = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = field_path(e.path());
        error(de.span_error(e.into_inner()), &path)
    })?;
    de.end().map_err(|e| error(de.span_error(e), ""))?;
    Ok(file)
}

/// A path in the style of validation errors: `groups[0].primitives[3]`
/// with enum variants (`Point`, `Compact`) left out, empty at the root.
fn field_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for segment in path.iter() {
        match segment {
            Segment::Seq { index } => out.push_str(&format!("[{index}]")),
            Segment::Map { key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Enum { .. } | Segment::Unknown => {}
        }
    }
    out
}

/// A whole scene file. See `docs/scene-format.md`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneFile {
    pub camera: CameraFile,
    /// Background colour, linear RGB in [0, 1].
    #[serde(default = "default_background")]
    pub background: [f64; 3],
    /// Directional lights; an empty list gets one default key light.
    #[serde(default)]
    pub lights: Vec<LightFile>,
    /// Ambient light, linear RGB.
    #[serde(default = "default_ambient")]
    pub ambient: [f64; 3],
    /// Surface colour, linear RGB in [0, 1].
    #[serde(default = "default_surface")]
    pub surface: [f64; 3],
    /// Transparent rendering: every crossing along a ray (Section 7.2).
    /// Absent: opaque, the first crossing only.
    #[serde(default)]
    pub transparency: Option<TransparencyFile>,
    /// Shadows: every shaded hit asks, for each light, whether the surface
    /// crosses the ray towards it (opaque scenes).
    #[serde(default)]
    pub shadows: bool,
    /// Ambient occlusion: rays over the hemisphere of each shaded hit
    /// (opaque scenes).
    #[serde(default)]
    pub ao: Option<AoFile>,
    /// The iso value: the surface is where the field equals it.
    pub iso: f64,
    #[serde(default)]
    pub marching: MarchingFile,
    /// Explicit scene bounds; required when the scene has a plane.
    #[serde(default)]
    pub bounds: Option<BoundsFile>,
    /// Groups of primitives: fields are summed within a group and groups are
    /// combined by max (Eq. 20).
    pub groups: Vec<GroupFile>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Ao", deny_unknown_fields)]
pub struct AoFile {
    /// Rays per hit, cosine-weighted over the hemisphere.
    #[serde(default = "default_ao_samples")]
    pub samples: u32,
    /// How far a ray looks for an occluder (scene units).
    pub distance: f64,
}

fn default_ao_samples() -> u32 {
    8
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Transparency", deny_unknown_fields)]
pub struct TransparencyFile {
    /// How much of the light each surface crossing reflects towards the
    /// viewer (its shaded colour), in [0, 1]; the rest passes on.
    #[serde(default = "default_opacity")]
    pub opacity: f64,
    /// Absorption per unit length inside, linear RGB (Beer-Lambert).
    #[serde(default)]
    pub absorption: [f64; 3],
    /// Index of refraction: given, the surface is a dielectric that
    /// reflects and refracts (Fresnel, Snell) instead of compositing.
    #[serde(default)]
    pub ior: Option<f64>,
    /// The most surface hits a reflected or refracted path may take.
    #[serde(default = "default_max_depth")]
    pub max_depth: u32,
    /// A dielectric's reflectivity in [0, 1]: the exact Fresnel
    /// reflectance is multiplied by it (1, the default: glass as it is).
    #[serde(default = "default_reflectivity")]
    pub reflectivity: f64,
}

fn default_reflectivity() -> f64 {
    1.0
}

fn default_max_depth() -> u32 {
    6
}

fn default_opacity() -> f64 {
    0.2
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Camera", deny_unknown_fields)]
pub struct CameraFile {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees, in (0, 180).
    #[serde(default = "default_fov")]
    pub fov_y: f64,
    /// Image width and height in pixels.
    #[serde(default = "default_resolution")]
    pub resolution: (u32, u32),
    /// Anti-aliasing: rays per pixel (`render --samples`).
    #[serde(default = "default_samples")]
    pub samples: u32,
    /// How the eye moves over scene time; absent: it stays.
    #[serde(default)]
    pub path: Option<CameraPathFile>,
    /// `Perspective` (the default) or `Orthographic(height: H)`: parallel
    /// rays, a view `H` scene units high.
    #[serde(default)]
    pub projection: ProjectionFile,
    /// Clipping: `near` and `far` from the eye's plane along the view,
    /// and planes in world space (`normal` towards the side kept).
    #[serde(default)]
    pub clip: ClipFile,
}

#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(rename = "Clip", deny_unknown_fields)]
pub struct ClipFile {
    #[serde(default)]
    pub near: Option<f64>,
    #[serde(default)]
    pub far: Option<f64>,
    #[serde(default)]
    pub planes: Vec<ClipPlaneFile>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "ClipPlane", deny_unknown_fields)]
pub struct ClipPlaneFile {
    pub point: [f64; 3],
    pub normal: [f64; 3],
}

#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize)]
#[serde(rename = "Projection", deny_unknown_fields)]
pub enum ProjectionFile {
    #[default]
    Perspective,
    Orthographic {
        height: f64,
    },
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Light", deny_unknown_fields)]
pub struct LightFile {
    /// Direction towards the light (need not be unit).
    pub direction: [f64; 3],
    #[serde(default = "default_light_color")]
    pub color: [f64; 3],
    #[serde(default = "default_intensity")]
    pub intensity: f64,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Marching", deny_unknown_fields)]
pub struct MarchingFile {
    /// The marcher when the command line does not choose one.
    #[serde(default = "default_method")]
    pub method: String,
    /// Minimum step in scene units (the benchmark protocol uses 0.1:
    /// docs/benchmark-protocol.md, "Rays").
    #[serde(default = "default_min_step")]
    pub min_step: f64,
    /// Step budget per ray.
    #[serde(default = "default_max_steps")]
    pub max_steps: u32,
    /// Interval growth k of Algorithm 1 (the next candidate interval is k
    /// times the last step); default: each method's own.
    #[serde(default)]
    pub growth: Option<f64>,
    /// Per-primitive extension of compact kernels' bottom-up quadratic
    /// bounds (Section 6.2.1); off builds `max(Q, 0)³` instead.
    #[serde(default = "default_extension")]
    pub extension: bool,
    /// Which Gaussians impose validity intervals on `quadratic`:
    /// "significant" (peak along the ray at least 1e-3·iso) or "every".
    #[serde(default = "default_validity")]
    pub validity: String,
    /// How a bracketed crossing is narrowed to the tolerance: "inclusion"
    /// (the default: the inclusion methods fold their bound over the
    /// bracket, the others use secant), "secant", or "bisection" (the
    /// protocol's figures before secant refinement).
    #[serde(default)]
    pub refine: Option<String>,
}

impl Default for MarchingFile {
    fn default() -> Self {
        MarchingFile {
            method: default_method(),
            min_step: default_min_step(),
            max_steps: default_max_steps(),
            growth: None,
            extension: default_extension(),
            validity: default_validity(),
            refine: None,
        }
    }
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Bounds", deny_unknown_fields)]
pub struct BoundsFile {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Group", deny_unknown_fields)]
pub struct GroupFile {
    pub primitives: Vec<PrimitiveFile>,
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Primitive", deny_unknown_fields)]
pub enum PrimitiveFile {
    /// A point primitive: the kernel of the distance to `center`, which
    /// may move over time.
    Point {
        center: [f64; 3],
        kernel: KernelFile,
        #[serde(default)]
        motion: Option<MotionFile>,
        /// A factor on the kernel's radius (R or r) over scene time.
        #[serde(default)]
        radius_scale: Option<ScaleFile>,
        /// This point's own colour, linear RGB (else the scene's
        /// `surface`); where blobs blend, their colours blend by their
        /// share of the field.
        #[serde(default)]
        color: Option<[f64; 3]>,
    },
    /// The compact kernel of the unsigned distance to the plane
    /// `normal · p = offset`: a slab of half-width `radius`.
    Plane {
        normal: [f64; 3],
        offset: f64,
        radius: f64,
        #[serde(default)]
        weight: Option<f64>,
    },
    /// A Hermite RBF surface (Eq. 9, φ(r) = r³) through `points`, each
    /// `(position, outward normal)`; the normals need not be unit. Its
    /// weights are fitted when the scene loads. Inside is positive, and the
    /// iso value is added so that alone its surface passes through the
    /// points; in a group with blobs they blend by sum.
    Hrbf {
        points: Vec<([f64; 3], [f64; 3])>,
        /// The degree-1 polynomial term of the interpolant.
        #[serde(default = "default_polynomial")]
        polynomial: bool,
        /// Rays are marched in the control points' box grown by this much
        /// on every side (default: a quarter of its largest side).
        #[serde(default)]
        margin: Option<f64>,
    },
}

fn default_polynomial() -> bool {
    true
}

/// A path of offsets added to a point's centre over scene time (seconds).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Motion", deny_unknown_fields)]
pub enum MotionFile {
    /// `axis · amplitude · sin(2π t / period + phase)`.
    Sine {
        axis: [f64; 3],
        amplitude: f64,
        period: f64,
        #[serde(default)]
        phase: f64,
    },
    /// `(time, offset)` keys, linear in between, held at both ends.
    Keyframes(Vec<(f64, [f64; 3])>),
}

/// A factor on a point's radius over scene time (seconds).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Scale", deny_unknown_fields)]
pub enum ScaleFile {
    /// `1 + amplitude · sin(2π t / period + phase)`, amplitude in [0, 1).
    Sine {
        amplitude: f64,
        period: f64,
        #[serde(default)]
        phase: f64,
    },
    /// `(time, factor)` keys, linear in between, held at both ends.
    Keyframes(Vec<(f64, f64)>),
}

/// The camera eye's path over scene time (the target stays).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "CameraPath", deny_unknown_fields)]
pub enum CameraPathFile {
    /// One turn about the vertical axis through the target per `period` seconds.
    Orbit { period: f64 },
    /// `(time, eye)` keys, linear in between, held at both ends.
    Keyframes(Vec<(f64, [f64; 3])>),
}

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename = "Kernel", deny_unknown_fields)]
pub enum KernelFile {
    /// `weight · (1 - d²/radius²)³` inside the support radius, 0 outside.
    Compact {
        radius: f64,
        #[serde(default)]
        weight: Option<f64>,
    },
    /// `weight · exp(-s (d/r)²)`; the weight defaults to `iso · e^s`, which
    /// puts an isolated blob's surface at distance `r`.
    Gaussian {
        r: f64,
        s: f64,
        #[serde(default)]
        weight: Option<f64>,
    },
}

fn default_background() -> [f64; 3] {
    [0.05, 0.06, 0.08]
}
fn default_ambient() -> [f64; 3] {
    [0.12, 0.12, 0.14]
}
fn default_surface() -> [f64; 3] {
    [0.85, 0.55, 0.35]
}
fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_samples() -> u32 {
    1
}

fn default_resolution() -> (u32, u32) {
    (256, 256)
}
fn default_light_color() -> [f64; 3] {
    [1.0, 1.0, 1.0]
}
fn default_intensity() -> f64 {
    1.0
}
fn default_method() -> String {
    "segment".into()
}
fn default_min_step() -> f64 {
    0.01
}

fn default_extension() -> bool {
    true
}

fn default_validity() -> String {
    "significant".into()
}

fn default_max_steps() -> u32 {
    1000
}
