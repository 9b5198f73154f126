//! Reflection and refraction at the surface of a dielectric (Section 7.2,
//! Figure 16): exact unpolarised Fresnel reflectance, Snell refraction with
//! total internal reflection, and a wavefront tracer that marches each
//! generation of reflected and refracted rays on the GPU.

use anyhow::Result;
use glam::DVec3;

use super::{MarchOptions, Renderer};
use crate::layout::{FLAG_HIT, GpuRay};
use crate::method::Method;
use crate::scene::Scene;

/// The exact reflectance of unpolarised light at a smooth interface, for
/// `cos_i` the cosine of the angle of incidence (>= 0) and `eta` = n_i/n_t:
/// the mean of the s and p reflectances. 1 beyond the critical angle.
pub fn fresnel(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The mirror direction of unit `d` about unit `n`.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Snell's law: the refracted direction of unit `d` through a surface with
/// unit normal `n` facing the incoming side (`d · n < 0`), `eta` = n_i/n_t;
/// `None` on total internal reflection.
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin_t2 = eta * eta * (1.0 - cos_i * cos_i);
    if sin_t2 > 1.0 {
        return None;
    }
    Some((eta * d + (eta * cos_i - (1.0 - sin_t2).sqrt()) * n).normalize())
}

/// A dielectric: index of refraction, absorption inside (Beer-Lambert) and
/// the most bounces a path may take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    pub ior: f64,
    pub absorption: DVec3,
    pub max_depth: u32,
    /// Scales the Fresnel reflectance of the reflected path and highlights
    /// (1: an exact dielectric; below 1 the surface absorbs the rest of
    /// the reflected share).
    pub reflectivity: f64,
}

/// One path of light traced back from the camera.
#[derive(Clone, Copy, Debug)]
struct Path {
    pixel: usize,
    weight: DVec3,
    inside: bool,
}

/// What a traced frame gives per camera ray: its colour, the marching
/// steps of every ray spawned from it, and its first hit.
pub struct Traced {
    /// The camera rays' own march (first hits, normals).
    pub first: Vec<crate::layout::GpuResult>,
    pub color: Vec<DVec3>,
    pub steps: Vec<u32>,
    pub evals: Vec<u32>,
    /// List positions visited and loop turns (`GpuResult::crossings.yz`).
    pub visits: Vec<u32>,
    pub turns: Vec<u32>,
    pub gpu_ns: Option<f64>,
}

/// Paths whose weight falls below this end.
const MIN_WEIGHT: f64 = 1e-3;

/// What a path that leaves the scene in direction `d` sees: the background
/// brightening towards the zenith, and each light as a small bright disc.
pub fn environment(scene: &Scene, d: DVec3) -> DVec3 {
    let sky = scene.background * (0.6 + 1.2 * d.dot(scene.camera.up).max(0.0));
    scene.lights.iter().fold(sky, |c, l| c + l.color * d.dot(l.direction).max(0.0).powf(400.0) * 4.0)
}

/// Traces `rays` through a dielectric scene: at every hit the Fresnel
/// reflectance splits the path into a reflected and a refracted one (all
/// reflected beyond the critical angle); inside, light is absorbed by
/// Beer-Lambert; a path that leaves the scene sees the [`environment`], lit
/// surfaces add their specular highlight weighted by the reflectance. Each
/// generation is one GPU march of secondary rays (they start just past the
/// surface and stop at the next crossing, entering or leaving). A path
/// still bouncing after `max_depth` hits takes the environment ahead.
/// `options` are the camera rays' own; every generation stops at its next
/// crossing whatever their `transparent` says.
pub fn trace(renderer: &mut Renderer, method: Method, options: MarchOptions, rays: &[GpuRay], material: Dielectric) -> Result<Traced> {
    if matches!(method, Method::LinearBisection | Method::Raa) {
        anyhow::bail!("{method} marches opaque scenes only; use an Algorithm 1 method for reflection and refraction");
    }
    let scene: Scene = renderer.scene().clone();
    let eps = 10.0 * scene.refine_tolerance();
    let mut out = Traced {
        first: Vec::new(),
        color: vec![DVec3::ZERO; rays.len()],
        steps: vec![0; rays.len()],
        evals: vec![0; rays.len()],
        visits: vec![0; rays.len()],
        turns: vec![0; rays.len()],
        gpu_ns: Some(0.0),
    };
    let mut paths: Vec<Path> = (0..rays.len()).map(|pixel| Path { pixel, weight: DVec3::ONE, inside: false }).collect();
    let mut current: Vec<GpuRay> = rays.to_vec();
    for depth in 0..=material.max_depth {
        if current.is_empty() {
            break;
        }
        let generation = MarchOptions { transparent: false, secondary: depth > 0, ..options };
        let marched = renderer.march(method, generation, &current, |_| {})?;
        if depth == 0 {
            out.first = marched.results.clone();
        }
        out.gpu_ns = out.gpu_ns.zip(marched.gpu_ns).map(|(a, b)| a + b);
        let (mut next_rays, mut next_paths) = (Vec::new(), Vec::new());
        for ((ray, path), res) in current.iter().zip(&paths).zip(&marched.results) {
            out.steps[path.pixel] += res.counts[0];
            out.evals[path.pixel] += res.counts[1];
            out.visits[path.pixel] += res.crossings[1];
            out.turns[path.pixel] += res.crossings[2];
            let o = DVec3::new(ray.o[0].into(), ray.o[1].into(), ray.o[2].into());
            let d = DVec3::new(ray.d[0].into(), ray.d[1].into(), ray.d[2].into());
            if ray.d[3] < ray.o[3] || res.counts[3] & FLAG_HIT == 0 {
                // Inside, the light crossed the rest of the bounds.
                let crossed = if path.inside { (f64::from(ray.d[3]) - f64::from(ray.o[3])).max(0.0) } else { 0.0 };
                out.color[path.pixel] += path.weight * (-material.absorption * crossed).exp() * environment(&scene, d);
                continue;
            }
            let t = f64::from(res.hit[3]);
            let n = DVec3::new(res.hit[0].into(), res.hit[1].into(), res.hit[2].into());
            let mut weight = path.weight;
            if path.inside {
                weight *= (-material.absorption * (t - f64::from(ray.o[3]))).exp();
            }
            if depth == material.max_depth || n == DVec3::ZERO {
                out.color[path.pixel] += weight * environment(&scene, d);
                continue;
            }
            let p = o + t * d;
            // The normal on the incoming side, and n_i / n_t.
            let (facing, eta) = if path.inside { (-n, material.ior) } else { (n, 1.0 / material.ior) };
            let cos_i = (-d.dot(facing)).max(0.0);
            let refracted = refract(d, facing, eta);
            let r = if refracted.is_some() { fresnel(cos_i, eta) } else { 1.0 };
            let reflected = material.reflectivity * r;
            if !path.inside {
                for l in &scene.lights {
                    let h = (l.direction - d).normalize();
                    out.color[path.pixel] += weight * reflected * l.color * facing.dot(h).max(0.0).powf(96.0);
                }
            }
            let mut spawn = |dir: DVec3, w: DVec3, inside: bool, side: f64| {
                if w.max_element() < MIN_WEIGHT {
                    return;
                }
                let start = p + side * eps * facing;
                let (t0, t1) = scene.bounds.clip_ray(start, dir).unwrap_or((1.0, 0.0));
                let f = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
                next_rays.push(GpuRay { o: f(start, t0), d: f(dir, t1) });
                next_paths.push(Path { pixel: path.pixel, weight: w, inside });
            };
            spawn(reflect(d, facing), weight * reflected, path.inside, 1.0);
            if let Some(dir) = refracted {
                spawn(dir, weight * (1.0 - r), !path.inside, -1.0);
            }
        }
        current = next_rays;
        paths = next_paths;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reflectances from the transmitted angle, written independently:
    /// rs = -sin(θi - θt)/sin(θi + θt), rp = tan(θi - θt)/tan(θi + θt).
    fn fresnel_by_angles(theta_i: f64, n1: f64, n2: f64) -> f64 {
        let theta_t = (n1 / n2 * theta_i.sin()).asin();
        if theta_i == 0.0 {
            let r = (n1 - n2) / (n1 + n2);
            return r * r;
        }
        let rs = -(theta_i - theta_t).sin() / (theta_i + theta_t).sin();
        let rp = (theta_i - theta_t).tan() / (theta_i + theta_t).tan();
        0.5 * (rs * rs + rp * rp)
    }

    #[test]
    fn fresnel_matches_the_exact_formula_at_several_angles() {
        for (n1, n2) in [(1.0f64, 1.5f64), (1.0, 1.33), (1.5, 1.0)] {
            let critical = if n1 > n2 { (n2 / n1).asin() } else { std::f64::consts::FRAC_PI_2 };
            for deg in [0.0, 10.0, 30.0, 45.0, 56.0, 70.0, 85.0] {
                let theta = f64::to_radians(deg);
                if theta >= critical {
                    assert_eq!(fresnel(theta.cos(), n1 / n2), 1.0, "total internal reflection at {deg}°");
                    continue;
                }
                let (r, exact) = (fresnel(theta.cos(), n1 / n2), fresnel_by_angles(theta, n1, n2));
                assert!((r - exact).abs() < 1e-12, "{n1}->{n2} at {deg}°: {r} vs {exact}");
            }
        }
        // Normal incidence on glass: 4%; Brewster's angle: only s is reflected.
        assert!((fresnel(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-12);
        let brewster = 1.5f64.atan();
        let rs = (brewster - (brewster.sin() / 1.5).asin()).sin() / (brewster + (brewster.sin() / 1.5).asin()).sin();
        assert!((fresnel(brewster.cos(), 1.0 / 1.5) - 0.5 * rs * rs).abs() < 1e-12);
    }

    #[test]
    fn refraction_obeys_snell_and_reflects_totally_beyond_the_critical_angle() {
        let n = DVec3::Y;
        for deg in [0.0, 20.0, 40.0, 60.0, 80.0] {
            let th = f64::to_radians(deg);
            let d = DVec3::new(th.sin(), -th.cos(), 0.0);
            let t = refract(d, n, 1.0 / 1.5).unwrap();
            assert!((t.length() - 1.0).abs() < 1e-12);
            // n1 sin θ1 = n2 sin θ2, in the plane of incidence, going down.
            assert!((th.sin() - 1.5 * t.x).abs() < 1e-12 && t.y < 0.0 && t.z == 0.0, "{deg}°: {t}");
            let r = reflect(d, n);
            assert!((r - DVec3::new(d.x, -d.y, 0.0)).length() < 1e-12);
        }
        // From glass to air: beyond asin(1/1.5) = 41.8° nothing is transmitted.
        let th = f64::to_radians(45.0);
        assert!(refract(DVec3::new(th.sin(), -th.cos(), 0.0), n, 1.5).is_none());
        let th = f64::to_radians(40.0);
        assert!(refract(DVec3::new(th.sin(), -th.cos(), 0.0), n, 1.5).is_some());
    }
}
