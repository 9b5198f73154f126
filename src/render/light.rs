//! Shadows and ambient occlusion: any-hit rays from every shaded hit of an
//! opaque frame, marched with the frame's method (docs/lighting.md).
//!
//! The frame is shaded on the GPU as always, and each hit also returns its
//! unlit colour (`GpuResult::crossings.w`, 11/11/10 bits). Then one more
//! march takes, for every hit, a ray towards each light it faces and the
//! scene's ambient-occlusion rays; like reflected rays (optics.rs) they
//! start just off the surface, on the side the camera sees, and stop at
//! the first sign change of the field, without refinement beyond what the
//! march's own bracket gives. A light whose ray crosses the surface takes
//! its diffuse and specular terms away from the pixel (the same Blinn-Phong
//! terms as shaders/include/shade.glsl); the occluded fraction of the
//! ambient rays takes that fraction of the ambient term away.
//!
//! AO rays are cosine-weighted over the hemisphere: the R2 sequence
//! (Roberts 2018) for `samples` points, shifted per camera ray by a
//! rotation hashed from its direction (Cranley-Patterson), so every run,
//! and the viewer's tiles, cast the same rays, and neighbouring pixels do
//! not repeat one pattern. Each looks `distance`
//! far. Transparent and dielectric scenes are not shadowed.

use anyhow::{Result, bail};
use glam::DVec3;

use super::{MarchOptions, MarchOutput, Renderer};
use crate::layout::{FLAG_HIT, GpuRay, GpuResult};
use crate::method::Method;
use crate::output::AnyHitStats;
use crate::scene::Scene;

/// What the any-hit rays cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LightStats {
    pub shadow_rays: u64,
    pub shadow_steps: u64,
    pub ao_rays: u64,
    pub ao_steps: u64,
    /// GPU time of their march (`None` without timestamps).
    pub gpu_ns: Option<f64>,
}

impl LightStats {
    /// Adds `other`'s rays, steps and time (time stays `None` once either
    /// has none).
    pub fn add(&mut self, other: &LightStats) {
        self.shadow_rays += other.shadow_rays;
        self.shadow_steps += other.shadow_steps;
        self.ao_rays += other.ao_rays;
        self.ao_steps += other.ao_steps;
        self.gpu_ns = self.gpu_ns.zip(other.gpu_ns).map(|(a, b)| a + b);
    }

    /// Per-ray figures, `None` when no any-hit ray was cast.
    pub fn summary(&self) -> Option<AnyHitStats> {
        let per = |steps: u64, rays: u64| if rays > 0 { steps as f64 / rays as f64 } else { 0.0 };
        (self.shadow_rays + self.ao_rays > 0).then(|| AnyHitStats {
            shadow_rays: self.shadow_rays,
            shadow_steps_per_ray: per(self.shadow_steps, self.shadow_rays),
            ao_rays: self.ao_rays,
            ao_steps_per_ray: per(self.ao_steps, self.ao_rays),
            gpu_ms: self.gpu_ns.map(|ns| ns * 1e-6),
        })
    }
}

/// The unlit colour a shaded hit returns in `crossings.w`.
pub fn unpack_base(w: u32) -> DVec3 {
    DVec3::new(f64::from(w >> 21) / 2047.0, f64::from((w >> 10) & 0x7ff) / 2047.0, f64::from(w & 0x3ff) / 1023.0)
}

/// A light's diffuse and specular terms at a point of normal `n` (facing
/// the viewer) seen along `u`, as shade.glsl adds them.
pub fn light_terms(base: DVec3, n: DVec3, u: DVec3, l: DVec3, color: DVec3) -> DVec3 {
    let ndl = n.dot(l).max(0.0);
    let h = (l - u).normalize_or_zero();
    let spec = if ndl > 0.0 { n.dot(h).max(0.0).powf(48.0) } else { 0.0 };
    color * (base * ndl + 0.25 * spec)
}

/// Direction `k` of the cosine-weighted ambient-occlusion rays about unit
/// `normal`, for the camera ray of hash `ray` (its rotation).
pub fn ao_direction(normal: DVec3, k: u32, ray: u32) -> DVec3 {
    // R2: the plastic number's inverse powers.
    const G: f64 = 1.324_717_957_244_746;
    let (a1, a2) = (1.0 / G, 1.0 / (G * G));
    let (rx, ry) = (hash_unit(ray, 0x68bc_21eb), hash_unit(ray, 0x02e5_be93));
    let u1 = (0.5 + a1 * f64::from(k) + rx).fract();
    let u2 = (0.5 + a2 * f64::from(k) + ry).fract();
    let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
    let (t, b) = normal.any_orthonormal_pair();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + normal * (1.0 - u1).max(0.0).sqrt()).normalize()
}

fn hash_unit(mut x: u32, seed: u32) -> f64 {
    x ^= seed;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    f64::from(x) / 4_294_967_296.0
}

/// How far off the surface an any-hit ray starts: as reflected rays do.
pub fn start_offset(scene: &Scene) -> f64 {
    10.0 * scene.refine_tolerance()
}

/// What an any-hit ray answers for: the shadow of light `j`, or occlusion
/// sample `k`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Shadow(usize),
    Ao(u32),
}

/// The any-hit rays of a batch of camera rays: each with the index of the
/// camera ray it was cast from and what it answers for.
#[derive(Clone, Debug, Default)]
pub struct AnyHitRays {
    pub rays: Vec<GpuRay>,
    pub owners: Vec<(usize, Kind)>,
}

/// Does `scene` cast any-hit rays from its hits when marched `options`?
pub fn wanted(scene: &Scene, options: &MarchOptions) -> bool {
    (scene.shadows || scene.ao.is_some()) && options.shade && scene.transparency.is_none()
}

/// Refuses `method` where `scene` asks for shadows or ambient occlusion
/// and the method cannot march their rays (the bisection baselines find
/// an entering crossing only, and these rays start on a surface): the
/// commands call it before any GPU work, and [`apply`] again.
pub fn check_method(scene: &Scene, method: Method) -> Result<()> {
    if (scene.shadows || scene.ao.is_some()) && scene.transparency.is_none() && matches!(method, Method::LinearBisection | Method::Raa) {
        bail!("{method} cannot march shadow and occlusion rays (they start on a surface); use an Algorithm 1 method");
    }
    Ok(())
}

/// The march options of any-hit rays cast by a march with `options`.
pub fn any_hit_options(options: MarchOptions) -> MarchOptions {
    MarchOptions { transparent: false, secondary: false, any_hit: true, shade: false, ..options }
}

/// The side of a surface of normal `n` (either orientation) that a ray of
/// direction `u` sees.
fn facing(n: DVec3, u: DVec3) -> DVec3 {
    if n.dot(u) > 0.0 { -n } else { n }
}

/// The rays from `hits[i]` (the distance along camera ray `i` and the
/// surface normal there, either orientation; `None`: no hit) towards each
/// light the surface faces (`scene.shadows`) and over its hemisphere
/// (`scene.ao`), light by light and sample by sample; each starts
/// [`start_offset`] off the surface on the side the camera ray sees and
/// ends at the scene's box (a shadow ray) or `ao.distance` along it. The GPU frame and the f64
/// reference cast them alike, so that they can be compared ray by ray.
pub fn spawn(scene: &Scene, rays: &[GpuRay], hits: &[Option<(f64, DVec3)>]) -> AnyHitRays {
    let eps = start_offset(scene);
    // One batch per light and per occlusion sample, each in camera-ray
    // order: neighbouring lanes then march neighbouring rays in one
    // direction, as a GPU's SIMD groups want (on lavapipe the difference
    // was within its noise).
    let samples = scene.ao.map_or(0, |a| a.samples as usize);
    let mut batches = vec![AnyHitRays::default(); scene.lights.len() + samples];
    for (i, (ray, hit)) in rays.iter().zip(hits).enumerate() {
        let Some((t, n)) = *hit else { continue };
        if ray.d[3] < ray.o[3] || n == DVec3::ZERO {
            continue;
        }
        let o = DVec3::new(ray.o[0].into(), ray.o[1].into(), ray.o[2].into());
        let u = DVec3::new(ray.d[0].into(), ray.d[1].into(), ray.d[2].into());
        let facing = facing(n, u);
        let start = o + t * u + eps * facing;
        let mut cast = |dir: DVec3, reach: f64, kind: Kind| {
            let (t0, t1) = scene.bounds.clip_ray(start, dir).unwrap_or((1.0, 0.0));
            // What clipping removed casts no shadow and hides nothing: the
            // ray keeps only its part on the kept side (none from a cap
            // towards the camera's side).
            let (t0, t1) = if scene.camera.clip.is_empty() || t0 > t1 {
                (t0, t1)
            } else {
                scene.camera.clip.interval(&scene.camera, start, dir, (t0, t1)).map_or((1.0, 0.0), |(a, b, _)| (a, b))
            };
            let f = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
            let batch = match kind {
                Kind::Shadow(j) => &mut batches[j],
                Kind::Ao(k) => &mut batches[scene.lights.len() + k as usize],
            };
            batch.rays.push(GpuRay { o: f(start, t0.max(0.0)), d: f(dir, t1.min(reach)) });
            batch.owners.push((i, kind));
        };
        if scene.shadows {
            for (j, l) in scene.lights.iter().enumerate() {
                if facing.dot(l.direction) > 0.0 {
                    cast(l.direction, f64::INFINITY, Kind::Shadow(j));
                }
            }
        }
        if let Some(ao) = scene.ao {
            // The rotation follows the camera ray itself, not its place in
            // this batch: the viewer's tiles and a whole frame cast the same.
            let key = ray.d[0].to_bits() ^ ray.d[1].to_bits().rotate_left(11) ^ ray.d[2].to_bits().rotate_left(22);
            for k in 0..ao.samples {
                cast(ao_direction(facing, k, key), ao.distance, Kind::Ao(k));
            }
        }
    }
    let mut out = AnyHitRays::default();
    for b in batches {
        out.rays.extend(b.rays);
        out.owners.extend(b.owners);
    }
    out
}

/// Is any-hit ray `ray` answered "occluded" by its result `m`?
pub fn occluded(ray: &GpuRay, m: &GpuResult) -> bool {
    ray.d[3] >= ray.o[3] && m.counts[3] & FLAG_HIT != 0
}

/// Applies `scene`'s shadows and ambient occlusion to the shaded opaque
/// results `out` of `rays`, marching their any-hit rays with `method`.
pub fn apply(renderer: &mut Renderer, method: Method, options: MarchOptions, rays: &[GpuRay], out: &mut MarchOutput) -> Result<LightStats> {
    let scene = renderer.scene().clone();
    if !wanted(&scene, &options) {
        return Ok(LightStats::default());
    }
    check_method(&scene, method)?;
    let normal = |r: &GpuResult| DVec3::new(r.hit[0].into(), r.hit[1].into(), r.hit[2].into());
    let hits: Vec<Option<(f64, DVec3)>> =
        out.results.iter().map(|r| (r.counts[3] & FLAG_HIT != 0).then(|| (f64::from(r.hit[3]), normal(r)))).collect();
    let any = spawn(&scene, rays, &hits);
    let mut stats = LightStats::default();
    if any.rays.is_empty() {
        return Ok(stats);
    }
    let marched = renderer.march(method, any_hit_options(options), &any.rays, |_| {})?;
    stats.gpu_ns = marched.gpu_ns;
    let mut hidden = vec![0u32; out.results.len()];
    let mut dark = vec![DVec3::ZERO; out.results.len()];
    for ((ray, &(i, kind)), m) in any.rays.iter().zip(&any.owners).zip(&marched.results) {
        let hit = occluded(ray, m);
        match kind {
            Kind::Shadow(j) => {
                stats.shadow_rays += 1;
                stats.shadow_steps += u64::from(m.counts[0]);
                if hit {
                    let r = &out.results[i];
                    let u = DVec3::new(rays[i].d[0].into(), rays[i].d[1].into(), rays[i].d[2].into());
                    let l = &scene.lights[j];
                    dark[i] += light_terms(unpack_base(r.crossings[3]), facing(normal(r), u), u, l.direction, l.color);
                }
            }
            Kind::Ao(_) => {
                stats.ao_rays += 1;
                stats.ao_steps += u64::from(m.counts[0]);
                hidden[i] += u32::from(hit);
            }
        }
    }
    for (i, r) in out.results.iter_mut().enumerate() {
        let mut take = dark[i];
        if let Some(ao) = scene.ao
            && hidden[i] > 0
        {
            let base = unpack_base(r.crossings[3]);
            take += base * scene.ambient * (f64::from(hidden[i]) / f64::from(ao.samples));
        }
        if take != DVec3::ZERO {
            for (c, t) in r.color.iter_mut().zip(take.to_array()) {
                *c = (f64::from(*c) - t).max(0.0) as f32;
            }
        }
    }
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ao_directions_are_unit_in_the_hemisphere_and_cosine_weighted() {
        let n = DVec3::new(0.3, -0.5, 0.81).normalize();
        let (mut mean_cos, count) = (0.0, 4096u32);
        for k in 0..count {
            let d = ao_direction(n, k, 17);
            assert!((d.length() - 1.0).abs() < 1e-12 && d.dot(n) >= 0.0, "{d}");
            mean_cos += d.dot(n);
        }
        // Cosine-weighted: E[cos] = 2/3.
        assert!((mean_cos / f64::from(count) - 2.0 / 3.0).abs() < 2e-3, "{}", mean_cos / f64::from(count));
        assert_ne!(ao_direction(n, 0, 1), ao_direction(n, 0, 2), "rays differ in rotation");
        let w = (1023 << 21) | (2047 << 10) | 512;
        assert!((unpack_base(w) - DVec3::new(1023.0 / 2047.0, 1.0, 512.0 / 1023.0)).length() < 1e-12);
    }
}
