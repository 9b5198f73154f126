//! Hermite RBF surfaces (Eq. 9, Figure 13): the fitted field interpolates
//! its control points, the two shipped scenes render opaque and
//! transparent and agree with the f64 reference, bottom-up quadratic
//! tracing takes fewer steps than revised affine arithmetic on both, and
//! bad control points are one-line errors. The bounds themselves are
//! checked with the other kinds' in tests/inclusion.rs and tests/dispatch.rs,
//! and random HRBF scenes are marched by every method in tests/marching.rs.

use std::path::PathBuf;
use std::time::Duration;

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::bench::{accuracy, reference_hits};
use isomarch::field::Field;
use isomarch::output::MarchStats;
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::render::rays::{camera_rays, protocol_rays};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::file::PrimitiveFile;
use isomarch::scene::hrbf::INTERPOLATION_TOLERANCE;
use isomarch::scene::{Scene, Transparency};

const SCENES: [&str; 2] = ["hrbf8.ron", "hrbf17.ron"];

fn scene_path(name: &str) -> PathBuf {
    repo_root().join("scenes").join(name)
}

/// The control points `(position, unit outward normal)` as the file gives them.
fn control_points(name: &str) -> Vec<(DVec3, DVec3)> {
    let text = std::fs::read_to_string(scene_path(name)).unwrap();
    let file = isomarch::scene::file::parse(&text, name).unwrap();
    file.groups
        .iter()
        .flat_map(|g| &g.primitives)
        .filter_map(|p| match p {
            PrimitiveFile::Hrbf { points, .. } => Some(points.iter().map(|(p, n)| (DVec3::from_array(*p), DVec3::from_array(*n).normalize()))),
            _ => None,
        })
        .flatten()
        .collect()
}

/// The scene opaque, or transparent with refraction.
fn variant(name: &str, transparent: bool) -> Scene {
    let mut s = Scene::load(&scene_path(name)).unwrap();
    s.transparency = transparent.then_some(Transparency {
        opacity: 0.2,
        absorption: DVec3::new(0.15, 0.1, 0.05),
        ior: Some(1.45),
        max_depth: 6,
        reflectivity: 1.0,
    });
    s
}

/// The field the renderer marches, fitted from the file, is 0 at every
/// control point and its gradient there is minus the unit normal (inside
/// positive), within the fit's stated tolerance: |f| <= 1e-6 · the points'
/// box diagonal and |∇f + n| <= 1e-6.
#[test]
fn the_fitted_field_interpolates_the_control_points_of_both_scenes() {
    for name in SCENES {
        let points = control_points(name);
        assert!(points.len() == 8 || points.len() == 17, "{name}: {} control points", points.len());
        let s = Scene::load(&scene_path(name)).unwrap();
        let field = Field::new(&s);
        let (lo, hi) = points.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), (p, _)| (lo.min(*p), hi.max(*p)));
        let diagonal = (hi - lo).length();
        let (mut worst_value, mut worst_gradient) = (0.0f64, 0.0f64);
        for (p, n) in &points {
            let (f, grad) = field.value_gradient(*p);
            worst_value = worst_value.max(f.abs() / diagonal);
            worst_gradient = worst_gradient.max((grad + *n).length());
            // Parallel to the normal, pointing inwards.
            assert!(grad.normalize().dot(-*n) > 1.0 - 1e-9, "{name}: gradient {grad} at {p} is not along -{n}");
        }
        eprintln!("{name}: worst |f| / diagonal {worst_value:.2e}, worst |∇f + n| {worst_gradient:.2e}");
        assert!(worst_value <= INTERPOLATION_TOLERANCE, "{name}: |f| = {worst_value:e} · diagonal at a control point");
        assert!(worst_gradient <= INTERPOLATION_TOLERANCE, "{name}: |∇f + n| = {worst_gradient:e} at a control point");
        // The surface is closed around the points: inside at their centroid.
        let centroid = points.iter().map(|(p, _)| *p).sum::<DVec3>() / points.len() as f64;
        assert!(field.value(centroid) > 0.0, "{name}: the centroid is outside");
    }
}

/// Both scenes, opaque and transparent with refraction, render a picture
/// of the surface: the opaque camera rays hit where the f64 reference does
/// (every conservative method), and refraction changes the picture.
#[test]
fn both_scenes_render_opaque_and_transparent() {
    let ctx = gpu();
    let size = 64u32;
    for name in SCENES {
        let mut images = Vec::new();
        for transparent in [false, true] {
            let s = variant(name, transparent);
            let job = RenderJob::new(s.clone(), Method::Quadratic, (size, size), PathBuf::new(), Duration::from_secs(300));
            let (frame, stats) = render_frame(&ctx, &job).unwrap();
            assert!(stats.hit_rate > 0.1 && stats.hit_rate < 0.9, "{name} transparent={transparent}: hit rate {}", stats.hit_rate);
            let shaded = frame.shaded();
            let distinct: std::collections::HashSet<_> = shaded.pixels().map(|p| p.0).collect();
            assert!(distinct.len() > 100, "{name} transparent={transparent}: only {} distinct colours", distinct.len());
            images.push(shaded);
        }
        let differing = images[0].pixels().zip(images[1].pixels()).filter(|(a, b)| a != b).count();
        assert!(differing > (size * size / 10) as usize, "{name}: the transparent picture is the opaque one ({differing} pixels differ)");

        // Opaque camera rays against the f64 reference, for every method,
        // with a minimum step far below the surface's detail (with the
        // file's 0.01, a grazing ray may step over two crossings 0.009
        // apart, as the paper's minimum step allows), and room for
        // sphere tracing to crawl with its global Lipschitz bound.
        let mut s = variant(name, false).recentred_on_camera();
        s.marching.min_step = 1e-4 * s.min_radius();
        s.marching.max_steps = 100_000;
        let (rays, _) = camera_rays(&s.camera, size, size, &s.bounds);
        let reference = reference_hits(&s, &rays, false);
        let hits = reference.iter().filter(|r| r.is_some()).count();
        assert!(hits > rays.len() / 10, "{name}: only {hits} reference hits");
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let tol = 2.0 * s.refine_tolerance() + 1e-5;
        for &method in Method::CONSERVATIVE {
            let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
            let acc = accuracy(&out.results, &reference, tol, tol);
            assert_eq!(MarchStats::of(&out.results, None).out_of_steps_rate, 0.0, "{name} {method}: out of steps");
            assert_eq!(
                (acc.misses, acc.false_hits),
                (0, 0),
                "{name} {method}: (missed or late, early or false) hits (max error {:e})",
                acc.max_abs_error
            );
        }
    }
    assert_no_validation(&ctx);
}

/// Figure 13's claim: bottom-up quadratic tracing takes fewer steps than
/// revised affine arithmetic (with bisection) on both scenes, on the
/// benchmark protocol's rays around the box.
#[test]
fn quadratic_takes_fewer_steps_than_raa_on_both_scenes() {
    let ctx = gpu();
    for name in SCENES {
        let s = variant(name, false);
        let rays = protocol_rays(&s.bounds, 4096, 13);
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let mut steps = |method| {
            let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
            MarchStats::of(&out.results, None).steps_per_ray
        };
        let (quadratic, raa) = (steps(Method::Quadratic), steps(Method::Raa));
        eprintln!("{name}: quadratic {quadratic:.3} steps per ray, raa {raa:.3}");
        assert!(quadratic < raa, "{name}: quadratic {quadratic} steps per ray, raa {raa}");
    }
    assert_no_validation(&ctx);
}

/// An HRBF scene text with `points` in place of the control points.
fn with_points(points: &str) -> String {
    format!("Scene(camera: (eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0)), iso: 0.5, groups: [(primitives: [Hrbf(points: [{points}])])])")
}

#[test]
fn bad_control_points_are_one_line_errors_naming_the_problem() {
    let good = "((1.0, 0.0, 0.0), (1.0, 0.0, 0.0)), ((-1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)), ((0.0, 1.0, 0.0), (0.0, 1.0, 0.0))";
    assert!(Scene::parse(&with_points(good), "good.ron").is_ok());
    let cases = [
        // Two points at one place.
        (format!("{good}, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))"), "groups[0].primitives[0].points", "coincide"),
        // A zero normal.
        (format!("{good}, ((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))"), "points[3].1", "non-zero"),
        // No points.
        (String::new(), "groups[0].primitives[0].points", "at least one"),
        // One point: a plane, whose box needs a margin.
        ("((0.0, 0.0, 1.0), (0.0, 0.0, 1.0))".to_string(), "margin", "margin"),
    ];
    for (points, field, words) in cases {
        let err = Scene::parse(&with_points(&points), "bad.ron").unwrap_err().to_string();
        assert!(err.contains(field) && err.contains(words) && !err.contains('\n'), "{points}: {err}");
    }
    // Through the binary: nothing is written, the error is one line.
    let dir = scratch("hrbf-bad");
    let scene = dir.join("bad.ron");
    std::fs::write(&scene, with_points(&format!("{good}, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))"))).unwrap();
    let out_png = dir.join("out.png");
    let stderr = isomarch(["render", scene.to_str().unwrap(), "-o", out_png.to_str().unwrap()]).fails_in_one_line();
    assert!(stderr.contains("coincide"), "{stderr}");
    assert!(!out_png.exists());
}

/// Rays straight through control points (h = 0, where g'' jumps and ρ's
/// curvature is unbounded), starting on one, and of zero length there:
/// every method's bound is finite on the GPU and in f64, and the marches
/// through and from control points end where the f64 reference puts the
/// first crossing. (Whether a zero-length query on the surface, or one
/// ending on it, holds a crossing depends on the sign of f = 0 rounded:
/// f32 and f64 may disagree there, so only their bounds are checked.)
#[test]
fn rays_through_control_points_get_finite_bounds_and_correct_hits() {
    use isomarch::field::fold::{field_bound, field_raa};
    use isomarch::layout::{FLAG_HIT, GpuRay};
    let ctx = gpu();
    let mut s = Scene::load(&scene_path("hrbf8.ron")).unwrap();
    s.marching.min_step = 1e-4 * s.min_radius();
    s.marching.max_steps = 100_000;
    let field = Field::new(&s);
    let ray = |o: DVec3, d: DVec3, t0: f64, t1: f64| GpuRay {
        o: [o.x as f32, o.y as f32, o.z as f32, t0 as f32],
        d: [d.x as f32, d.y as f32, d.z as f32, t1 as f32],
    };
    // hrbf8 has control points at (±1.4, 0, 0), (0, ±0.95, 0), (0, 0, ±0.8).
    let queries = vec![
        ray(DVec3::new(-4.0, 0.0, 0.0), DVec3::X, 0.0, 8.0), // through (-1.4, 0, 0) and (1.4, 0, 0)
        ray(DVec3::new(0.0, -4.0, 0.0), DVec3::Y, 0.0, 8.0), // through (0, ±0.95, 0)
        ray(DVec3::new(0.0, 0.0, 4.0), -DVec3::Z, 3.2, 8.0), // starting on (0, 0, 0.8)
        ray(DVec3::new(0.0, 0.0, 4.0), -DVec3::Z, 3.2, 3.2), // zero length on it
        ray(DVec3::new(-4.0, 0.0, 0.0), DVec3::X, 2.0, 2.6), // ending on (-1.4, 0, 0)
    ];
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
    for &method in Method::CONSERVATIVE {
        let gpu = renderer.probe_bounds(method, options, &queries).unwrap();
        for (g, q) in gpu.iter().zip(&queries) {
            assert!(g.lo.iter().chain(&g.hi).all(|x| x.is_finite()), "{method}: GPU bound {g:?} on {q:?}");
            let r = isomarch::render::rays::Ray::from_gpu(q);
            let finite = match field_bound(&field, method, Default::default(), r.o, r.d, r.t0, r.t1) {
                Some(b) => [b.v, b.a_lo, b.b_lo, b.a_hi, b.b_hi].iter().all(|x| x.is_finite()),
                None => {
                    let (lo, hi) = field_raa(&field, r.o, r.d, r.t0, r.t1);
                    lo.is_finite() && hi.is_finite()
                }
            };
            assert!(finite, "{method}: non-finite f64 bound on {q:?}");
        }
        let marched = &queries[..3];
        let reference = reference_hits(&s, marched, false);
        let out = renderer.march(method, options, marched, |_| {}).unwrap();
        let tol = 2.0 * s.refine_tolerance() + 1e-5;
        let acc = accuracy(&out.results, &reference, tol, tol);
        assert_eq!(
            (acc.misses, acc.false_hits),
            (0, 0),
            "{method}: hits {:?} against the reference {reference:?}",
            out.results.iter().map(|r| (r.counts[3] & FLAG_HIT != 0, r.hit[3])).collect::<Vec<_>>()
        );
    }
    assert_no_validation(&ctx);
}

/// An HRBF in a max with a group of 80 blobs (more than the 64 that turn
/// the spatial index on): it marches without the index, whose skipped
/// groups would change the max (`Scene::max_needs_every_group`), as does the
/// f64 mirror without its grid, and every method's hits match the reference.
#[test]
fn an_hrbf_beside_many_blobs_marches_flat_and_finds_the_references_hits() {
    let ctx = gpu();
    let points = control_points("hrbf8.ron");
    let blobs: Vec<String> = (0..80)
        .map(|i| {
            let a = std::f64::consts::TAU * f64::from(i) / 80.0;
            format!("Point(center: ({}, {}, 0.0), kernel: Compact(radius: 0.5))", 3.0 * a.cos(), 3.0 * a.sin())
        })
        .collect();
    let text = format!(
        "Scene(camera: (eye: (0.0, 2.0, 9.0), target: (0.0, 0.0, 0.0)), iso: 0.5, groups: [(primitives: [{}]), (primitives: [{}])])",
        hrbf_ron(&points),
        blobs.join(", ")
    );
    let mut s = Scene::parse(&text, "hrbf-and-ring.ron").unwrap();
    assert!(s.primitive_count() > isomarch::render::CULL_MAX_PRIMITIVES && s.max_needs_every_group());
    assert!(isomarch::render::index::GridSpec::for_scene(&s).is_none(), "the index is on");
    assert!(Field::new(&s).grid_cell().is_none(), "the f64 mirror's grid is on");
    s.marching.min_step = 1e-4 * s.min_radius();
    s.marching.max_steps = 100_000;
    let rays = protocol_rays(&s.bounds, 2048, 5);
    let reference = reference_hits(&s, &rays, false);
    let hits = reference.iter().filter(|r| r.is_some()).count();
    assert!(hits > rays.len() / 10, "only {hits} reference hits");
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let tol = 2.0 * s.refine_tolerance() + 1e-5;
    for method in [Method::Segment, Method::QuadraticTaylor, Method::Quadratic, Method::Raa] {
        let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
        let acc = accuracy(&out.results, &reference, tol, tol);
        assert_eq!((acc.misses, acc.false_hits), (0, 0), "{method}: (missed or late, early or false) hits");
    }
    assert_no_validation(&ctx);
}
