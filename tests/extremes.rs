//! Stability at the extremes: seeded scenes and settings at the edges of
//! what isomarch accepts. Every case: no NaN or infinity in any output, no
//! hang (every march ends within its budget and the deadline), and first
//! hits within a stated bound of the f64 reference, for every method.
//!
//! What runs in CI and why: each case uses a few hundred rays on scenes of
//! a few blobs, enough to meet every code path (supports entered and left,
//! sums, maxes, both kernels) in seconds; the primitive count is swept
//! from 1 to 10,000 on few rays (the f64 reference visits every primitive
//! at each of its many small steps; above 64 primitives the GPU marches
//! with the spatial index); a pile of primitives beyond what one step can
//! visit within the loop budget is refused.

mod common;

use common::*;
use glam::DVec3;
use isomarch::bench::{accuracy, reference_hits};
use isomarch::layout::{FLAG_HIT, FLAG_OUT_OF_STEPS, GpuRay, GpuResult};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::render::rays::protocol_rays;
use isomarch::scene::{Kernel, Primitive, Scene};
use isomarch::Method;

/// Measured regression bounds (of 256 rays); see docs/limits.md.
const SPHERE_SHARP_GAUSSIAN_MISSES: usize = 256;
const BISECTION_TINY_STEP_MISSES: usize = 13;

/// Every method that marches opaque scenes.
const METHODS: &[Method] = Method::CONSERVATIVE;

fn assert_finite(results: &[GpuResult], what: &str) {
    for r in results {
        assert!(r.hit.iter().chain(&r.color).all(|x| x.is_finite()), "{what}: non-finite result {r:?}");
    }
}

/// Marches `rays` with every method; each must agree with the reference
/// to `tol` (scene units; a miss, a false hit or a late hit beyond `late`
/// counts against `allowed`, the measured regression bound).
fn check_all(ctx: &std::sync::Arc<isomarch::gpu::Context>, s: &Scene, rays: &[GpuRay], tol: f64, late: f64, allowed: impl Fn(Method) -> usize, what: &str) {
    check_methods(ctx, s, rays, METHODS, tol, late, allowed, what);
}

#[allow(clippy::too_many_arguments)]
fn check_methods(
    ctx: &std::sync::Arc<isomarch::gpu::Context>,
    s: &Scene,
    rays: &[GpuRay],
    methods: &[Method],
    tol: f64,
    late: f64,
    allowed: impl Fn(Method) -> usize,
    what: &str,
) {
    let reference = reference_hits(s, rays, false);
    let mut renderer = Renderer::new(ctx, s).unwrap();
    let options = MarchOptions { shade: false, ..MarchOptions::for_scene(s) };
    for &method in methods {
        let out = renderer.march(method, options, rays, |_| {}).unwrap();
        assert_finite(&out.results, &format!("{what} {method}"));
        let acc = accuracy(&out.results, &reference, late, tol);
        let allowed = allowed(method);
        assert!(
            acc.misses + acc.false_hits <= allowed,
            "{what} {method}: {} missed, {} false (allowed {allowed}); max error {:e}",
            acc.misses,
            acc.false_hits,
            acc.max_abs_error
        );
    }
}

/// `s` scaled by `k` about the origin: centres, radii and Gaussian scales.
fn scaled(s: &Scene, k: f64) -> Scene {
    let groups = s
        .groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|p| match *p {
                    Primitive::Point { center, kernel: Kernel::Compact { radius, weight } } => {
                        Primitive::Point { center: center * k, kernel: Kernel::Compact { radius: radius * k, weight } }
                    }
                    Primitive::Point { center, kernel: Kernel::Gaussian { r, s, weight } } => {
                        Primitive::Point { center: center * k, kernel: Kernel::Gaussian { r: r * k, s, weight } }
                    }
                    other => other,
                })
                .collect()
        })
        .collect();
    let mut out = scene(groups, s.iso, Method::Segment, 1.0);
    out.marching.min_step = 1e-4 * out.min_radius();
    out
}

#[test]
fn radii_from_1e_minus_3_to_1e3() {
    let ctx = gpu();
    for k in [1e-3, 1.0, 1e3] {
        for max in [false, true] {
            let s = scaled(&random_scene(40, max, Method::Segment), k);
            let rays = protocol_rays(&s.bounds, 256, 40);
            // Relative to the scale: the refinement tolerance plus f32.
            let tol = 2.0 * s.refine_tolerance() + 2e-6 * s.bounds.diagonal();
            check_all(&ctx, &s, &rays, tol, tol, |_| 0, &format!("scale {k} max={max}"));
        }
    }
    assert_no_validation(&ctx);
}

#[test]
fn grazing_rays_and_rays_starting_inside() {
    let ctx = gpu();
    let (r, iso) = (2.0, 0.5);
    let rho = r * (1.0 - f64::cbrt(iso)).sqrt();
    let s = scene(vec![vec![compact(DVec3::ZERO, r)]], iso, Method::Segment, 1e-4);
    let mut rays = Vec::new();
    // Tangent, just inside and just outside the sphere, and starts inside.
    for h in [rho * (1.0 - 1e-6), rho, rho * (1.0 + 1e-6), rho * 0.999, rho * 1.001] {
        let o = DVec3::new(-5.0, h, 0.0);
        let (t0, t1) = s.bounds.clip_ray(o, DVec3::X).unwrap();
        rays.push(GpuRay { o: [o.x as f32, o.y as f32, o.z as f32, t0 as f32], d: [1.0, 0.0, 0.0, t1 as f32] });
    }
    for o in [DVec3::ZERO, DVec3::new(0.5 * rho, 0.0, 0.0), DVec3::new(0.0, 0.0, rho * (1.0 - 1e-5))] {
        rays.push(GpuRay { o: [o.x as f32, o.y as f32, o.z as f32, 0.0], d: [0.0, 0.0, 1.0, 3.0] });
    }
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    for &method in METHODS {
        let out = renderer.march(method, MarchOptions::for_scene(&s), &rays, |_| {}).unwrap().results;
        assert_finite(&out, &format!("grazing {method}"));
        for r in &out {
            assert_eq!(r.counts[3] & FLAG_OUT_OF_STEPS, 0, "{method}: a grazing ray ran out of steps");
        }
        // Clearly inside the tangent: hit; clearly outside: no hit.
        assert_ne!(out[3].counts[3] & FLAG_HIT, 0, "{method}: missed a ray 0.1% inside the tangent");
        assert_eq!(out[4].counts[3] & FLAG_HIT, 0, "{method}: hit a ray 0.1% outside the tangent");
        for (i, r) in out[5..].iter().enumerate() {
            assert_ne!(r.counts[3] & FLAG_HIT, 0, "{method}: ray {i} starting inside is not a hit");
            assert_eq!(r.hit[3], 0.0, "{method}: ray {i} starting inside hits at {}", r.hit[3]);
        }
    }
    assert_no_validation(&ctx);
}

#[test]
fn coincident_blobs_iso_extremes_and_gaussian_scales() {
    let ctx = gpu();
    let cases: Vec<(String, Vec<Primitive>, f64)> = vec![
        ("coincident".into(), vec![compact(DVec3::ZERO, 2.0), compact(DVec3::ZERO, 2.0)], 0.5),
        ("nearly coincident".into(), vec![compact(DVec3::ZERO, 2.0), compact(DVec3::new(1e-6, 0.0, 0.0), 2.0)], 0.5),
        ("iso near 0".into(), vec![compact(DVec3::ZERO, 2.0), compact(DVec3::new(1.0, 0.5, 0.0), 1.5)], 1e-6),
        ("iso near the maximum".into(), vec![compact(DVec3::ZERO, 2.0)], 0.999),
        ("tiny Gaussian s".into(), vec![gaussian(DVec3::ZERO, 1.0, 0.01, 0.5), gaussian(DVec3::new(1.5, 0.0, 0.0), 1.0, 0.01, 0.5)], 0.5),
        ("huge Gaussian s".into(), vec![gaussian(DVec3::ZERO, 1.0, 50.0, 0.5), gaussian(DVec3::new(1.5, 0.0, 0.0), 1.0, 50.0, 0.5)], 0.5),
    ];
    for (name, prims, iso) in cases {
        let mut s = scene(vec![prims], iso, Method::Segment, 1.0);
        s.marching.min_step = 1e-4 * s.min_radius();
        let rays = protocol_rays(&s.bounds, 256, 7);
        let tol = 2.0 * s.refine_tolerance() + 2e-6 * s.bounds.diagonal();
        // Sphere tracing's one global Lipschitz bound is e^s times too
        // large for a sharp Gaussian: it crawls at the minimum step and
        // runs out of steps (measured: a regression bound, docs/limits.md).
        let sharp = name == "huge Gaussian s";
        check_all(&ctx, &s, &rays, tol, tol, |m| if sharp && m == Method::Sphere { SPHERE_SHARP_GAUSSIAN_MISSES } else { 0 }, &name);
    }
    assert_no_validation(&ctx);
}

/// Gaussians too sharp for f32 are refused when the scene loads.
#[test]
fn gaussians_beyond_f32_are_refused() {
    let text = r#"Scene(camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0)), iso: 0.5,
        groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Gaussian(r: 1.0, s: 100.0))])])"#;
    let e = Scene::parse(text, "sharp.ron").err().expect("refused").to_string();
    assert!(e.contains("f32") && e.contains("kernel"), "{e}");
    assert!(Scene::parse(&text.replace("100.0", "50.0"), "ok.ron").is_ok());
}

#[test]
fn minimum_steps_and_budgets_at_their_limits() {
    let ctx = gpu();
    let base = random_scene(41, true, Method::Segment);
    let rays = protocol_rays(&base.bounds, 256, 41);
    let reference = reference_hits(&base, &rays, false);
    for (min_step, max_steps) in [(1e-6, 100_000), (1.0, 1000), (0.1, 1), (1e-6, 1)] {
        let mut s = base.clone();
        s.marching.min_step = min_step;
        s.marching.max_steps = max_steps;
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
        for &method in METHODS {
            let out = renderer.march(method, options, &rays, |_| {}).unwrap().results;
            let what = format!("min step {min_step}, {max_steps} steps, {method}");
            assert_finite(&out, &what);
            for r in &out {
                assert!(r.counts[0] <= max_steps, "{what}: {} steps", r.counts[0]);
            }
            // A hit is never early, whatever the settings.
            let acc = accuracy(&out, &reference, f64::INFINITY, 2.0 * s.refine_tolerance() + 1e-5);
            assert_eq!(acc.false_hits, 0, "{what}: hits before the reference");
            if max_steps >= 1000 && min_step <= 1e-4 {
                let acc = accuracy(&out, &reference, 2.0 * s.refine_tolerance() + 1e-5, 2.0 * s.refine_tolerance() + 1e-5);
                // Bisection with pruning descends to the minimum step
                // wherever its bound cannot exclude 0, which near the
                // surface is a great many leaves: at 1e-6 some rays run out
                // of their 100,000 steps (measured regression bound).
                let allowed = if matches!(method, Method::LinearBisection | Method::Raa) { BISECTION_TINY_STEP_MISSES } else { 0 };
                let out_of_steps = out.iter().filter(|r| r.counts[3] & FLAG_OUT_OF_STEPS != 0).count();
                assert!(acc.misses <= allowed, "{what}: {} missed or late hits (allowed {allowed}; {out_of_steps} out of steps)", acc.misses);
                if acc.misses > 0 {
                    eprintln!("{what}: {} missed, {out_of_steps} out of steps", acc.misses);
                }
            }
        }
    }
    assert_no_validation(&ctx);
}

/// `n` compact blobs in a cube whose side grows with n, so density stays
/// moderate.
fn blobs(n: usize) -> Scene {
    let side = 2.0 * (n as f64).cbrt() + 2.0;
    let mut rng_state = 12345u64 + n as u64;
    let mut next = || {
        rng_state = rng_state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (rng_state >> 11) as f64 / (1u64 << 53) as f64
    };
    let prims = (0..n).map(|_| compact(DVec3::new(next(), next(), next()) * side, 1.0 + next())).collect();
    let mut s = scene(vec![prims], 0.5, Method::Segment, 1.0);
    s.marching.min_step = 1e-4 * s.min_radius();
    s
}

#[test]
fn one_to_ten_thousand_primitives() {
    let ctx = gpu();
    // Every method up to 1000 primitives; at 10,000 (every pass over the
    // primitives is then one loop turn of its own, and the f64 reference
    // costs seconds per ray set) the baselines and the two quadratic
    // methods, on fewer rays.
    for (n, rays, methods) in [
        (1usize, 64usize, METHODS),
        (64, 64, METHODS),
        (65, 64, METHODS),
        (1000, 64, METHODS),
        (10_000, 24, &[Method::Segment, Method::LinearBisection, Method::QuadraticTaylor, Method::Quadratic][..]),
    ] {
        let s = blobs(n);
        let rays = protocol_rays(&s.bounds, rays, n as u64);
        let tol = 2.0 * s.refine_tolerance() + 2e-6 * s.bounds.diagonal();
        check_methods(&ctx, &s, &rays, methods, tol, tol, |_| 0, &format!("{n} primitives"));
    }
    // More primitives in one place than one step can visit within the
    // loop budget (20,000 coincident blobs): refused with a clear message.
    let mut piled = blobs(1);
    piled.groups[0] = vec![piled.groups[0][0]; 20_000];
    let err = Renderer::new(&ctx, &piled).err().expect("a pile of primitives beyond the loop budget must be refused");
    assert!(format!("{err:#}").contains("overlap in one place"), "{err:#}");
    assert_no_validation(&ctx);
}

/// Largest |t - t_ref| over the pixels both hit, and how many pixels
/// disagree on hitting at all.
fn image_error(frame: &isomarch::output::Frame, rays_pixels: &[Option<u32>], reference: &[Option<f64>]) -> (f64, usize) {
    let (mut worst, mut disagree) = (0.0f64, 0usize);
    for (p, r) in rays_pixels.iter().zip(reference) {
        let Some(p) = p else { continue };
        let px = &frame.pixels[*p as usize];
        let hit = (px.counts[3] & FLAG_HIT != 0).then_some(f64::from(px.hit[3]));
        match (hit, r) {
            (Some(t), Some(tr)) => worst = worst.max((t - tr).abs()),
            (None, None) => {}
            _ => disagree += 1,
        }
    }
    (worst, disagree)
}

#[test]
fn scenes_far_from_the_origin_keep_their_precision() {
    use isomarch::render::offscreen::{RenderJob, render_frame};
    use isomarch::render::rays::camera_rays;
    let ctx = gpu();
    let size = (48, 48);
    for (seed, max) in [(50, false), (51, true)] {
        let near = random_scene(seed, max, Method::Segment);
        // What every run computes from: the scene around its camera, f64.
        let local = near.recentred_on_camera();
        let (rays, pixels) = camera_rays(&local.camera, size.0, size.1, &local.bounds);
        let reference = reference_hits(&local, &rays, false);
        let tol = 2.0 * near.refine_tolerance() + 2e-6 * near.bounds.diagonal();
        for offset in [DVec3::new(1e5, 0.0, 0.0), DVec3::new(-5.7e4, 5.7e4, -5.7e4)] {
            // The same scene and camera, moved far from the world's origin.
            let far = near.recentred(-offset);
            for method in [Method::Segment, Method::QuadraticTaylor, Method::Quadratic] {
                let job = RenderJob::new(far.clone(), method, size, std::path::PathBuf::new(), std::time::Duration::from_secs(300));
                let (frame, _) = render_frame(&ctx, &job).unwrap();
                let (worst, disagree) = image_error(&frame, &pixels, &reference);
                // Printed for docs/benchmarks.md (cargo test -- --nocapture).
                eprintln!("far scene {seed} at {offset}: {method} worst {worst:.2e} = {:.2e} of the scene", worst / near.bounds.diagonal());
                assert!(
                    disagree == 0 && worst <= tol,
                    "{method} at {offset}: {disagree} pixels disagree on hitting, worst distance error {worst:e} (bound {tol:e})"
                );
            }
            // The test can tell: marched in world coordinates (f32 spacing
            // 0.008 at 1e5), the same rays are far off.
            let (world_rays, _) = camera_rays(&far.camera, size.0, size.1, &far.bounds);
            let mut renderer = Renderer::new(&ctx, &far).unwrap();
            let out = renderer.march(Method::Segment, MarchOptions::for_scene(&far), &world_rays, |_| {}).unwrap();
            let frame = isomarch::output::Frame::from_results(size.0, size.1, &out.results, &pixels);
            let (worst, disagree) = image_error(&frame, &pixels, &reference);
            eprintln!("far scene {seed} at {offset}: world coordinates, segment worst {worst:.2e}, {disagree} pixels disagree");
            assert!(disagree > 0 || worst > 10.0 * tol, "without re-centring: worst {worst:e}, {disagree} disagree");
        }
    }
    assert_no_validation(&ctx);
}
