//! The spatial index (scenes of more than 64 primitives): no missed or false
//! crossing against the f64 reference on random scenes of 1,000 and 20,000
//! primitives, every method, opaque and transparent, in one group and as a
//! max of groups; the index rebuilt for moved primitives; the index's
//! statistics. The reference walks its own grid (src/field/grid.rs), so
//! the two indices are independent.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::bench::{accuracy, accuracy_all, reference_crossings, reference_hits};
use isomarch::layout::{FLAG_OUT_OF_STEPS, GpuRay, GpuResult};
use isomarch::render::rays::protocol_rays;
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::{Scene, Transparency};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// `n` compact blobs (radius 0.8 to 1.2) at a fixed density (mean spacing
/// 1.6) in a cube, split into `groups` groups combined by max.
pub(crate) fn particles(n: usize, groups: usize, seed: u64) -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let side = 1.6 * (n as f64).cbrt();
    let mut g: Vec<Vec<_>> = vec![Vec::new(); groups];
    for i in 0..n {
        let c = DVec3::new(rng.random_range(0.0..side), rng.random_range(0.0..side), rng.random_range(0.0..side)) - DVec3::splat(side / 2.0);
        g[i % groups].push(compact(c, rng.random_range(0.8..1.2)));
    }
    let mut s = scene(g, 0.5, Method::QuadraticTaylor, 1.0);
    s.marching.min_step = 1e-4 * s.min_radius();
    s
}

/// Hits within the refinement tolerance plus f32 rounding of the scene.
fn tolerance(s: &Scene) -> f64 {
    2.0 * s.refine_tolerance() + 2e-6 * s.bounds.diagonal()
}

/// `methods`' first hits on `rays` (opaque) agree with the f64 reference:
/// no miss, no false hit.
/// Every method's first hits on `rays` agree with the reference (no miss,
/// no false hit); returns the reference's hit count.
fn assert_first_hits(renderer: &mut Renderer, s: &Scene, rays: &[GpuRay], methods: &[Method], what: &str) -> usize {
    let reference = reference_hits(s, rays, false);
    let tol = tolerance(s);
    for &method in methods {
        let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(s) }, rays, |_| {}).unwrap();
        let acc = accuracy(&out.results, &reference, tol, tol);
        assert!(acc.misses + acc.false_hits == 0, "{method} {what}: {} missed, {} false", acc.misses, acc.false_hits);
    }
    reference.iter().filter(|h| h.is_some()).count()
}

fn assert_finite(results: &[GpuResult], what: &str) {
    for r in results {
        assert!(r.hit.iter().chain(&r.color).all(|x| x.is_finite()), "{what}: non-finite result {r:?}");
    }
}

/// Every method's first hits (opaque) and every Algorithm 1 method's
/// crossings (transparent; sphere tracing's global bound is too small a
/// step for every crossing of a large scene) on `rays` agree with the
/// reference: no miss, no false hit, within the refinement tolerance plus
/// f32 rounding.
fn check_scene(s: &Scene, rays: &[GpuRay], what: &str) {
    let ctx = gpu();
    let tol = tolerance(s);
    let mut renderer = Renderer::new(&ctx, s).unwrap();
    let stats = renderer.index_stats().expect("a scene of more than 64 primitives marches with the index");
    assert!(stats.entries >= s.primitive_count() && stats.longest_list > 0, "{what}: {stats:?}");
    let first = reference_hits(s, rays, false);
    let hits = first.iter().filter(|h| h.is_some()).count();
    assert!(4 * hits >= rays.len(), "{what}: only {hits} of {} rays hit: too few to test", rays.len());
    let opaque = MarchOptions { shade: false, ..MarchOptions::for_scene(s) };
    for &method in Method::CONSERVATIVE {
        let out = renderer.march(method, opaque, rays, |_| {}).unwrap();
        assert_finite(&out.results, &format!("{what} {method}"));
        // Sphere tracing's global Lipschitz bound (Eq. 10) sums every
        // kernel's peak slope, so its steps shrink with the scene: its rays
        // may run out of steps (flagged, and left out); no other method's.
        let finished: Vec<usize> = (0..rays.len()).filter(|&i| out.results[i].counts[3] & FLAG_OUT_OF_STEPS == 0).collect();
        if method != Method::Sphere {
            assert_eq!(finished.len(), rays.len(), "{what} {method}: rays ran out of steps");
        }
        assert!(2 * finished.len() >= rays.len(), "{what} {method}: most rays ran out of steps");
        let results: Vec<GpuResult> = finished.iter().map(|&i| out.results[i]).collect();
        let expected: Vec<Option<f64>> = finished.iter().map(|&i| first[i]).collect();
        let acc = accuracy(&results, &expected, tol, tol);
        assert!(
            acc.misses + acc.false_hits == 0,
            "{what} {method}: {} missed, {} false; max error {:e}",
            acc.misses,
            acc.false_hits,
            acc.max_abs_error
        );
    }
    let all = reference_crossings(s, rays, false, false);
    let transparent = MarchOptions { transparent: true, ..opaque };
    for &method in Method::CONSERVATIVE.iter().filter(|m| !matches!(m, Method::LinearBisection | Method::Raa | Method::Sphere)) {
        let out = renderer.march(method, transparent, rays, |_| {}).unwrap();
        assert_finite(&out.results, &format!("{what} {method} transparent"));
        let acc = accuracy_all(&out.crossings, &all, tol, tol);
        assert!(acc.misses + acc.false_hits == 0, "{what} {method} transparent: {} missed, {} false crossings", acc.misses, acc.false_hits);
    }
    assert_no_validation(&ctx);
}

#[test]
fn a_thousand_primitives_every_method_opaque_and_transparent() {
    for groups in [1, 3] {
        let s = particles(1000, groups, 7 + groups as u64);
        check_scene(&s, &protocol_rays(&s.bounds, 192, 3), &format!("1,000 primitives in {groups} groups"));
    }
}

#[test]
fn twenty_thousand_primitives_every_method_opaque_and_transparent() {
    let s = particles(20_000, 1, 20);
    check_scene(&s, &protocol_rays(&s.bounds, 48, 4), "20,000 primitives");
}

#[test]
fn moved_primitives_rebuild_the_index() {
    let ctx = gpu();
    let s = particles(1000, 1, 11);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    // Every blob moved by up to one radius: the old lists would miss them.
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    let mut moved = s.clone();
    for p in moved.groups.iter_mut().flatten() {
        if let isomarch::scene::Primitive::Point { center, .. } = p {
            *center += DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        }
    }
    renderer.set_scene(&moved).unwrap();
    let rays = protocol_rays(&s.bounds, 256, 8);
    let hits = assert_first_hits(&mut renderer, &moved, &rays, &[Method::Segment, Method::QuadraticTaylor], "after the move");
    assert!(4 * hits >= rays.len(), "only {hits} of {} rays hit the moved blobs: too few to test", rays.len());
    assert_no_validation(&ctx);
}

/// A scene of `generate particles --motion` (150 moving blobs, so indexed)
/// posed through its own Animation (`Scene::at_time`, as `render --time`
/// and the viewer pose it) at three times: one renderer, its index rebuilt
/// by `set_scene` at each, agrees with the reference at each, on rays
/// that hit often enough to test.
#[test]
fn an_animated_scene_matches_the_reference_at_three_times() {
    let path = scratch("index-animated").join("moving.ron");
    isomarch(["generate", "particles", "--count", "150", "--seed", "4", "--motion", "-o"]).arg(&path).ok();
    let s = Scene::load(&path).unwrap();
    assert!(!s.animation.is_static() && s.primitive_count() == 150, "{} primitives", s.primitive_count());
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let centers = |s: &Scene| -> Vec<DVec3> {
        s.primitives().filter_map(|p| if let isomarch::scene::Primitive::Point { center, .. } = p { Some(*center) } else { None }).collect()
    };
    for t in [0.0, 0.7, 1.9] {
        let posed = s.at_time(t);
        if t > 0.0 {
            let moved = centers(&posed).iter().zip(centers(&s)).filter(|(a, b)| a.distance(*b) > 0.05).count();
            assert!(moved >= 50, "t = {t}: only {moved} blobs moved: the times test nothing");
        }
        renderer.set_scene(&posed).unwrap();
        assert!(renderer.index_stats().is_some(), "150 primitives march with the index");
        let rays = protocol_rays(&posed.bounds, 256, 12);
        let hits =
            assert_first_hits(&mut renderer, &posed, &rays, &[Method::Segment, Method::QuadraticTaylor, Method::Quadratic], &format!("at t = {t}"));
        assert!(4 * hits >= rays.len(), "t = {t}: only {hits} of {} rays hit: too few to test", rays.len());
    }
    assert_no_validation(&ctx);
}

#[test]
fn transparency_from_the_scene_file_marches_with_the_index() {
    // The scene's own transparency (not only the options) goes through.
    let mut s = particles(300, 1, 12);
    s.transparency = Some(Transparency { opacity: 0.3, absorption: DVec3::splat(0.1), ior: None, max_depth: 1, reflectivity: 1.0 });
    let rays = protocol_rays(&s.bounds, 128, 9);
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let out = renderer.march(Method::Quadratic, MarchOptions::for_scene(&s), &rays, |_| {}).unwrap();
    let all = reference_crossings(&s, &rays, false, false);
    let tol = tolerance(&s);
    let acc = accuracy_all(&out.crossings, &all, tol, tol);
    assert!(all.iter().map(Vec::len).sum::<usize>() > 100, "too few crossings to test");
    assert!(acc.misses + acc.false_hits == 0, "{} missed, {} false crossings", acc.misses, acc.false_hits);
    assert_no_validation(&ctx);
}

/// Gaussians are clipped with the index (docs/spatial-index.md): the
/// clipped field is within ε = 1e-3·iso of the true one everywhere, so a
/// crossing moves by at most about ε / |f'(t)| along its ray. Careless
/// clipping (too small a radius, the paper's Figure 14) leaves seams where
/// the clip spheres cut the surface: hits far from the unclipped f64
/// reference. Every camera ray that hits a surface not grazed by it must
/// be within twice that bound of the reference.
#[test]
fn clipped_gaussians_leave_no_seams() {
    let ctx = gpu();
    let text = isomarch::generate::Particles { count: 400, seed: 3, gaussian: true, motion: false }.ron().unwrap();
    let s = Scene::parse(&text, "gaussian particles").unwrap();
    let s = s.recentred(s.bounds.center());
    let field = isomarch::field::Field::new(&s);
    let (rays, pixels) = isomarch::render::rays::camera_rays(&s.camera, 96, 96, &s.bounds);
    let rays: Vec<GpuRay> = rays.into_iter().zip(pixels).filter(|(_, p)| p.is_some()).map(|(r, _)| r).collect();
    let reference = reference_hits(&s, &rays, false);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    assert!(renderer.index_stats().is_some(), "400 Gaussians march with the index");
    let eps = isomarch::render::index::GAUSSIAN_CLIP_FRACTION * s.iso;
    for method in [Method::QuadraticTaylor, Method::Segment, Method::Quadratic] {
        let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
        let (mut checked, mut worst, mut false_hits) = (0, 0.0f64, 0);
        for ((ray, res), tr) in rays.iter().zip(&out.results).zip(&reference) {
            let r = isomarch::render::rays::Ray::from_gpu(ray);
            // Clipping only removes positive tails: where the unclipped
            // field has no crossing, the clipped one has none either.
            let Some(tr) = tr else {
                false_hits += usize::from(res.counts[3] & isomarch::layout::FLAG_HIT != 0);
                continue;
            };
            let (_, grad) = field.value_gradient(r.o + tr * r.d);
            let slope = grad.dot(r.d).abs();
            if slope < 0.2 * grad.length() {
                continue; // grazing: the crossing itself is ill-conditioned
            }
            assert!(res.counts[3] & isomarch::layout::FLAG_HIT != 0, "{method}: a ray hitting at {tr} squarely was missed");
            let bound = 2.0 * eps / slope + tolerance(&s);
            let err = (f64::from(res.hit[3]) - tr).abs();
            worst = worst.max(err / bound);
            checked += 1;
        }
        assert!(checked > 1000, "{method}: only {checked} rays checked");
        assert_eq!(false_hits, 0, "{method}: hits where the unclipped reference has no crossing");
        assert!(worst <= 1.0, "{method}: a hit is {worst:.2} times the clipping bound away from the unclipped field: a seam");
    }
    assert_no_validation(&ctx);
}

/// Reflection and refraction (secondary rays, in generations) through 150
/// dielectric blobs: the same picture with the index and without it.
#[test]
fn refraction_and_reflection_walk_the_index() {
    let ctx = gpu();
    let mut s = particles(150, 1, 13);
    s.transparency = Some(Transparency { opacity: 1.0, absorption: DVec3::new(0.3, 0.1, 0.05), ior: Some(1.3), max_depth: 3, reflectivity: 1.0 });
    s.camera.eye = DVec3::new(14.0, 10.0, 14.0);
    let s = s.recentred_on_camera();
    let (rays, pixels) = isomarch::render::rays::camera_rays(&s.camera, 64, 64, &s.bounds);
    let mut frames = Vec::new();
    for indexed in [true, false] {
        let mut renderer = Renderer::with_index(&ctx, &s, indexed).unwrap();
        assert_eq!(renderer.index_stats().is_some(), indexed);
        // Traced through the grid (optics::trace): no tile lists to build.
        assert!(!renderer.tiles_apply(Method::QuadraticTaylor, &MarchOptions::for_scene(&s)), "a dielectric scene's rays take tile lists");
        let out = isomarch::render::offscreen::march_frame(&mut renderer, Method::QuadraticTaylor, MarchOptions::for_scene(&s), &rays).unwrap();
        frames.push(isomarch::output::Frame::from_results(64, 64, &out.results, &pixels));
    }
    let (mut lit, mut worst) = (0, 0.0f32);
    for (a, b) in frames[0].pixels.iter().zip(&frames[1].pixels) {
        lit += usize::from(a.hit[3] >= 0.0);
        for k in 0..3 {
            worst = worst.max((a.color[k] - b.color[k]).abs());
        }
    }
    assert!(lit > 400, "only {lit} pixels see the blobs");
    // Sums in another order: f32 rounding, amplified at most a little by
    // the bends of refraction.
    assert!(worst < 2e-3, "a pixel differs by {worst} with and without the index");
    assert_no_validation(&ctx);
}

/// A pose whose box is larger (every centre 1.4 times further out) needs
/// another grid: new buffers, the pipelines bound to them again, and hits
/// that stay exact.
#[test]
fn a_pose_with_a_larger_box_reallocates_the_index() {
    let ctx = gpu();
    let s = particles(800, 1, 14);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let rays = protocol_rays(&s.bounds, 64, 2);
    // Pipelines exist before the move, so that rebinding them is tested.
    renderer.march(Method::QuadraticTaylor, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
    let before = renderer.index_stats().unwrap();
    let spread: Vec<Vec<_>> = s
        .groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|p| match *p {
                    isomarch::scene::Primitive::Point { center, kernel } => isomarch::scene::Primitive::Point { center: 1.4 * center, kernel },
                    other => other,
                })
                .collect()
        })
        .collect();
    let mut moved = scene(spread, s.iso, Method::QuadraticTaylor, s.marching.min_step);
    moved.camera = s.camera.clone();
    renderer.set_scene(&moved).unwrap();
    let after = renderer.index_stats().unwrap();
    // (The cell count is capped at 8 per primitive, so the cells grew.)
    assert!(after.cells != before.cells && after.cell_size > before.cell_size, "the grid did not change: {before:?} then {after:?}");
    let rays = protocol_rays(&moved.bounds, 256, 3);
    let methods = [Method::Segment, Method::QuadraticTaylor, Method::LinearBisection];
    assert_first_hits(&mut renderer, &moved, &rays, &methods, "after the larger pose");
    assert_no_validation(&ctx);
}

/// Scenes of many groups march flat: the walk would cross the cells once
/// per group.
#[test]
fn scenes_of_many_groups_march_flat() {
    let ctx = gpu();
    let s = particles(400, isomarch::render::index::MAX_INDEX_GROUPS + 1, 15);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    assert!(renderer.index_stats().is_none());
    assert_first_hits(&mut renderer, &s, &protocol_rays(&s.bounds, 64, 5), &[Method::QuadraticTaylor], "with many groups");
    assert_no_validation(&ctx);
}

/// Issue 25: a million compact blobs (`generate particles --count
/// 1000000`) need an index of 64 million entries (256 MB), more than
/// lavapipe's 128 MiB storage-buffer range: its entries are a texel buffer
/// (134,217,728 texels), so the scene renders, and its hits on a sample of
/// protocol rays and of camera rays agree with the f64 reference, and so do
/// a 256x256 frame's camera rays through the camera's tile lists.
#[test]
fn a_million_blobs_index_outgrows_a_storage_buffer_and_matches_the_reference() {
    let ctx = gpu();
    let text = isomarch::generate::Particles { count: 1_000_000, seed: 1, gaussian: false, motion: false }.ron().unwrap();
    let s = Scene::parse(&text, "a million particles").unwrap();
    let s = s.recentred(s.bounds.center());
    let spec = isomarch::render::index::GridSpec::for_scene(&s).expect("a million blobs march with the index");
    let entry_bytes = 4 * spec.buffer_words()[1] as u64;
    assert!(entry_bytes > ctx.info.max_storage_buffer_range, "{entry_bytes} bytes of entries fit a storage buffer: the test proves nothing");
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let stats = renderer.index_stats().unwrap();
    assert!(stats.entries > 20_000_000, "{stats:?}");
    let protocol = protocol_rays(&s.bounds, 256, 7);
    let (camera, pixels) = isomarch::render::rays::camera_rays(&s.camera, 24, 24, &s.bounds);
    let camera: Vec<GpuRay> = camera.into_iter().zip(pixels).filter(|(_, p)| p.is_some()).map(|(r, _)| r).collect();
    for (rays, what) in [(protocol, "protocol rays"), (camera, "camera rays")] {
        let reference = reference_hits(&s, &rays, false);
        let hits = reference.iter().filter(|h| h.is_some()).count();
        assert!(4 * hits >= rays.len(), "{what}: only {hits} of {} rays hit: too few to test", rays.len());
        let tol = tolerance(&s);
        for method in [Method::QuadraticTaylor, Method::Segment] {
            let out = renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&s) }, &rays, |_| {}).unwrap();
            let acc = accuracy(&out.results, &reference, tol, tol);
            assert!(acc.misses + acc.false_hits == 0, "{method} {what}: {} missed, {} false", acc.misses, acc.false_hits);
        }
    }
    // A 256x256 frame through the camera's tile lists (issue 39), checked
    // on every 61st ray against the reference.
    let opaque = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
    assert!(renderer.prepare_camera(Method::QuadraticTaylor, &opaque, &s.camera, 256, 256).unwrap(), "the lists do not fit");
    let tiles = renderer.tile_stats().unwrap();
    assert!(tiles.entries >= 1_000_000 && tiles.tiles == 1024, "{tiles:?}");
    let (frame, _) = isomarch::render::rays::camera_rays(&s.camera, 256, 256, &s.bounds);
    let out = renderer.march_camera(Method::QuadraticTaylor, opaque, &frame, 0).unwrap();
    let sample: Vec<usize> = (0..frame.len()).step_by(61).collect();
    let rays: Vec<GpuRay> = sample.iter().map(|&i| frame[i]).collect();
    let reference = reference_hits(&s, &rays, false);
    let hits = reference.iter().filter(|h| h.is_some()).count();
    assert!(4 * hits >= rays.len(), "only {hits} of {} sampled rays hit", rays.len());
    let results: Vec<GpuResult> = sample.iter().map(|&i| out.results[i]).collect();
    let tol = tolerance(&s);
    let acc = accuracy(&results, &reference, tol, tol);
    assert!(acc.misses + acc.false_hits == 0, "through the tile lists: {} missed, {} false", acc.misses, acc.false_hits);
    assert_no_validation(&ctx);
}

/// Issue 26: the march crosses cells that list no primitive in one move
/// (f = -iso there). Two clusters of blobs 60 units apart on x, the far
/// one taller: rays along +x just above the near cluster cross about 50
/// empty cells (of about one unit) before they reach the far one. Without
/// the skip a step spans at most two cells, so such a ray would take 25
/// steps more than the same ray started just before the far cluster; with
/// it, a few at most, and every ray hits where the reference does. With
/// iso <= 0 empty cells would be inside: no skip.
#[test]
fn empty_cells_are_crossed_in_one_move() {
    let ctx = gpu();
    let mut rng = Pcg64Mcg::seed_from_u64(26);
    let mut blobs = Vec::new();
    for i in 0..80 {
        let (x, h) = if i < 40 { (-30.0, 1.0) } else { (30.0, 4.0) };
        let c = DVec3::new(x + rng.random_range(-2.0..2.0), rng.random_range(-h..h), rng.random_range(-1.0..1.0));
        blobs.push(compact(c, rng.random_range(0.8..1.2)));
    }
    let s = scene(vec![blobs], 0.5, Method::QuadraticTaylor, 1e-4);
    let grid = isomarch::render::index::GridSpec::for_scene(&s).expect("80 blobs march with the index");
    assert!(grid.skips_empty_cells(s.iso));
    assert!(!grid.skips_empty_cells(0.0), "iso 0: empty cells are on the surface");
    let rays_from = |x: f64| -> Vec<GpuRay> {
        (0..64)
            .map(|k| {
                let (y, z) = (3.5 + 0.01 * f64::from(k), -0.5 + 0.015 * f64::from(k));
                isomarch::render::rays::clipped_ray(DVec3::new(x, y, z), DVec3::X, &s.bounds)
            })
            .collect()
    };
    let (far, near) = (rays_from(-40.0), rays_from(24.0));
    let reference = reference_hits(&s, &far, false);
    let hits = reference.iter().filter(|t| t.is_some_and(|t| t > 60.0)).count();
    assert!(hits >= 32, "only {hits} of 64 rays hit the far cluster in the reference");
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let tol = tolerance(&s);
    for method in [Method::QuadraticTaylor, Method::Segment, Method::Quadratic, Method::Sphere] {
        let opts = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
        let out = renderer.march(method, opts, &far, |_| {}).unwrap();
        let acc = accuracy(&out.results, &reference, tol, tol);
        assert!(acc.misses + acc.false_hits == 0, "{method}: {} missed, {} false", acc.misses, acc.false_hits);
        if method == Method::Sphere {
            continue; // its global bound crawls near the blobs: steps there, not across the gap, dominate
        }
        let short = renderer.march(method, opts, &near, |_| {}).unwrap();
        for (k, (a, b)) in out.results.iter().zip(&short.results).enumerate() {
            assert!(a.counts[0] <= b.counts[0] + 4, "{method}, ray {k}: {} steps from x = -40, {} from x = 24", a.counts[0], b.counts[0]);
        }
    }
    assert_no_validation(&ctx);
}

/// The first-crossing bracket (`render::brackets`, shaders/include/fold.glsl)
/// holds where every term is a point kernel of non-negative weight and iso
/// is positive, and is off elsewhere: with a negative term, a plane, an
/// HRBF or iso 0; for transparent and secondary rays; for the bisection
/// baselines; and when the options turn it off.
#[test]
fn the_first_crossing_bracket_holds_only_for_sums_of_non_negative_point_kernels() {
    use isomarch::render::brackets;
    use isomarch::scene::{Kernel, Primitive};
    let s = particles(200, 2, 5);
    assert!(s.bracket_holds(), "a max of sums of compact blobs");
    let opaque = MarchOptions::for_scene(&s);
    assert!(brackets(&s, Method::QuadraticTaylor, &opaque) && brackets(&s, Method::Segment, &opaque));
    assert!(brackets(&s, Method::QuadraticTaylor, &isomarch::render::light::any_hit_options(opaque)));
    for (what, o) in [
        ("transparent", MarchOptions { transparent: true, ..opaque }),
        ("secondary", MarchOptions { secondary: true, ..opaque }),
        ("turned off", MarchOptions { bracket: false, ..opaque }),
    ] {
        assert!(!brackets(&s, Method::QuadraticTaylor, &o), "{what}");
    }
    assert!(!brackets(&s, Method::Raa, &opaque) && !brackets(&s, Method::LinearBisection, &opaque));
    let mut negative = s.clone();
    negative.groups[0].push(Primitive::Point { center: DVec3::ZERO, kernel: Kernel::Compact { radius: 1.0, weight: -0.5 } });
    assert!(!negative.bracket_holds(), "a negative term");
    let mut zero_iso = s.clone();
    zero_iso.iso = 0.0;
    assert!(!zero_iso.bracket_holds(), "iso 0");
    assert!(!plane_scene(false).bracket_holds(), "planes");
    assert!(!random_hrbf_scene(3, false, Method::QuadraticTaylor).bracket_holds(), "an HRBF");
}

/// Where the bracket does not hold it is not used: 100 hollow blobs apart, each
/// a positive compact kernel whose ball of reach (where it alone is at
/// least iso) lies inside a negative one that cancels it, have no surface
/// at all; every conservative method finds none, as the reference. The
/// positive blobs alone are hit by most of the same rays, inside those
/// balls.
#[test]
fn hollow_blobs_cancelled_by_negative_terms_are_not_bracketed() {
    use isomarch::scene::{Kernel, Primitive};
    // Apart (spacing 5, supports of radius 2), so that no two overlap.
    let centres: Vec<DVec3> =
        (0..100).map(|i| 5.0 * DVec3::new(f64::from(i % 5), f64::from(i / 5 % 5), f64::from(i / 25)) - DVec3::splat(10.0)).collect();
    let point = |c: DVec3, radius: f64, weight: f64| Primitive::Point { center: c, kernel: Kernel::Compact { radius, weight } };
    let hollow: Vec<Primitive> = centres.iter().flat_map(|&c| [point(c, 2.0, 1.0), point(c, 1.5, -1.0)]).collect();
    let solid: Vec<Primitive> = centres.iter().map(|&c| point(c, 2.0, 1.0)).collect();
    let (hollow, solid) = (scene(vec![hollow], 0.5, Method::QuadraticTaylor, 1e-3), scene(vec![solid], 0.5, Method::QuadraticTaylor, 1e-3));
    assert!(!hollow.bracket_holds() && solid.bracket_holds());
    // Rays aimed at the centres, through the balls of reach.
    let rays: Vec<GpuRay> =
        centres.iter().map(|&c| isomarch::render::rays::clipped_ray(c - DVec3::new(30.0, 0.1, 0.05), DVec3::X, &hollow.bounds)).collect();
    assert!(reference_hits(&hollow, &rays, false).iter().all(Option::is_none), "the hollow blobs have no surface");
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &hollow).unwrap();
    assert!(renderer.index_stats().is_some());
    assert_first_hits(&mut renderer, &hollow, &rays, Method::CONSERVATIVE, "hollow blobs");
    let mut renderer = Renderer::new(&ctx, &solid).unwrap();
    let hits = assert_first_hits(&mut renderer, &solid, &rays, Method::CONSERVATIVE, "solid blobs");
    assert!(hits >= 50, "only {hits} of 100 rays hit the solid blobs");
    assert_no_validation(&ctx);
}

/// Where the bracket holds it is used: on a molecule's shadow and
/// occlusion rays an any-hit query that enters an atom's ball of reach is
/// answered there, so quadratic Taylor and segment tracing take at least
/// 8% fewer steps with it than without (measured: 9.5% and 10.8%); every
/// ray that hits without it hits with it, every ray that hits only with it
/// crosses the surface in the f64 reference, and first hits of camera rays
/// stay the reference's.
#[test]
fn a_molecules_any_hit_queries_end_where_a_ray_enters_an_atoms_reach() {
    let path = repo_root().join("tests/data/molecules/1A8O.pdb");
    let (s, _) = isomarch::molecule::build::load_scene(&path, &Default::default()).unwrap();
    let s = isomarch::bench::with_any_hit_defaults(s);
    assert!(s.bracket_holds());
    let (camera, _) = isomarch::render::rays::camera_rays(&s.camera, 48, 48, &s.bounds);
    let (any_hit, _) = isomarch::bench::any_hit_rays(&s, &camera);
    let ctx = gpu();
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    for method in [Method::QuadraticTaylor, Method::Segment] {
        let with = isomarch::render::light::any_hit_options(MarchOptions::for_scene(&s));
        let without = MarchOptions { bracket: false, ..with };
        let a = renderer.march(method, with, &any_hit.rays, |_| {}).unwrap().results;
        let b = renderer.march(method, without, &any_hit.rays, |_| {}).unwrap().results;
        let steps = |r: &[GpuResult]| r.iter().map(|r| u64::from(r.counts[0])).sum::<u64>();
        let hit = |r: &GpuResult| r.counts[3] & isomarch::layout::FLAG_HIT != 0;
        let lost = a.iter().zip(&b).filter(|(a, b)| hit(b) && !hit(a)).count();
        let gained = a.iter().zip(&b).filter(|(a, b)| hit(a) && !hit(b)).count();
        assert_eq!(lost, 0, "{method}: rays hit without the bracket and not with it");
        assert!(gained * 200 <= a.len(), "{method}: {gained} of {} rays hit only with the bracket", a.len());
        // A hit only the bracket finds must be a crossing the reference
        // finds too, not one the bracket made up.
        let only: Vec<GpuRay> = a.iter().zip(&b).zip(&any_hit.rays).filter(|((a, b), _)| hit(a) && !hit(b)).map(|(_, r)| *r).collect();
        let crossed = reference_crossings(&s, &only, true, false);
        let invented = crossed.iter().filter(|c| c.is_empty()).count();
        assert_eq!(invented, 0, "{method}: {invented} of {} rays that hit only with the bracket cross nothing in the f64 reference", only.len());
        // The saving grows with the window: with one-cell windows of half
        // a radius (0927fac) it was 9.5% for quadratic Taylor and 10.8% for
        // segment tracing, with windows of a radius over 10%; steps are
        // deterministic, so at least 8% (without the bracket it is none).
        assert!(
            100 * steps(&a) <= 92 * steps(&b),
            "{method}: {} steps with the bracket, {} without: {:.1}% saved, at least 8% expected",
            steps(&a),
            steps(&b),
            100.0 * (1.0 - steps(&a) as f64 / steps(&b) as f64)
        );
    }
    assert_first_hits(&mut renderer, &s, &camera, &[Method::QuadraticTaylor, Method::Segment, Method::Quadratic], "1A8O camera rays");
    assert_no_validation(&ctx);
}

/// Camera rays through the camera's screen-space tile lists
/// (src/render/tiles.rs), built on the GPU (src/render/tile_build.rs),
/// find the f64 reference's first hits, for every
/// conservative method they serve (all but the bisection baselines), on
/// particles in one group and in three, and on two molecules; the lists'
/// hits and depths are the grid's within the tolerance (on 6WG6 the
/// reference is taken on every fourth ray, the grid on all); transparent, every
/// crossing the reference finds (the particles and 1A8O).
#[test]
fn camera_rays_through_tile_lists_find_the_references_hits() {
    let molecule =
        |name: &str| isomarch::molecule::build::load_scene(&repo_root().join("tests/data/molecules").join(name), &Default::default()).unwrap().0;
    let ctx = gpu();
    for (what, s, (w, h)) in [
        ("1,000 particles", particles(1000, 1, 5), (64, 64)),
        ("900 particles in 3 groups", particles(900, 3, 6), (40, 40)),
        ("1A8O", molecule("1A8O.pdb"), (64, 64)),
        ("6WG6", molecule("6WG6.cif.gz"), (64, 64)),
    ] {
        let s = s.recentred_on_camera();
        let tol = tolerance(&s);
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        // The lists built on the GPU (render::tile_build; the host's build
        // is tests/tile_build.rs's reference).
        renderer.set_tile_builder(Some(true));
        let (rays, pixels) = isomarch::render::rays::camera_rays(&s.camera, w, h, &s.bounds);
        // 6WG6's f64 reference costs about 13 ms a ray on 2 cores (most of
        // this test's time): it is taken on every fourth ray, 16 of each
        // 8x8 tile's 64, while the lists are held against the grid on
        // every ray.
        let stride = if what == "6WG6" { 4 } else { 1 };
        let sampled: Vec<GpuRay> = rays.iter().step_by(stride).copied().collect();
        let mut reference = vec![None; rays.len()];
        for (k, hit) in reference_hits(&s, &sampled, false).into_iter().enumerate() {
            reference[k * stride] = hit;
        }
        let referenced = |i: usize| i.is_multiple_of(stride);
        let hits = reference.iter().filter(|h| h.is_some()).count();
        assert!(5 * hits * stride >= pixels.len(), "{what}: only {hits} hits among {} rays", sampled.len());
        let opaque = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
        let served: Vec<Method> = Method::CONSERVATIVE.iter().copied().filter(|&m| renderer.tiles_apply(m, &opaque)).collect();
        assert!(served.len() == Method::CONSERVATIVE.len() - 2 && served.iter().all(|m| !m.bisects()), "{what}: the lists serve {served:?}");
        for &method in &served {
            assert!(renderer.prepare_camera(method, &opaque, &s.camera, w, h).unwrap(), "{what} {method}: the lists do not fit");
            assert!(renderer.tile_stats().unwrap().gpu, "{what} {method}: the lists were built on the host");
            let tiled = renderer.march_camera(method, opaque, &rays, 0).unwrap().results;
            let grid = renderer.march(method, opaque, &rays, |_| {}).unwrap().results;
            assert_finite(&tiled, &format!("{what} {method}"));
            let finished: Vec<usize> = (0..rays.len()).filter(|&i| tiled[i].counts[3] & FLAG_OUT_OF_STEPS == 0).collect();
            if method != Method::Sphere {
                assert_eq!(finished.len(), rays.len(), "{what} {method}: rays ran out of steps");
            }
            let checked: Vec<usize> = finished.iter().copied().filter(|&i| referenced(i)).collect();
            let results: Vec<GpuResult> = checked.iter().map(|&i| tiled[i]).collect();
            let expected: Vec<Option<f64>> = checked.iter().map(|&i| reference[i]).collect();
            let acc = accuracy(&results, &expected, tol, tol);
            assert!(acc.misses + acc.false_hits == 0, "{what} {method}: {} missed, {} false through the tile lists", acc.misses, acc.false_hits);
            let hit = |r: &GpuResult| r.counts[3] & isomarch::layout::FLAG_HIT != 0;
            for &i in &finished {
                if grid[i].counts[3] & FLAG_OUT_OF_STEPS != 0 {
                    continue;
                }
                assert_eq!(hit(&tiled[i]), hit(&grid[i]), "{what} {method}: ray {i} hits through one walk only");
                if hit(&tiled[i]) {
                    let (a, b) = (tiled[i].hit[3], grid[i].hit[3]);
                    assert!(f64::from((a - b).abs()) <= 2.0 * tol, "{what} {method}: ray {i} at {a} through the lists, {b} through the grid");
                }
            }
        }
        // Transparent: every crossing through the lists (the walk without
        // the bracket), as the reference finds them. At the molecule
        // defaults' minimum step (0.1 Å) every method, through the grid as
        // through the lists, steps over a few crossings of 1A8O that come
        // in pairs closer than that (its documented resolution): a tenth
        // of it finds them all. Within twice the tolerance: where a ray
        // grazes a sliver of surface 0.07 Å thick (ray 2303), the field's
        // slope is so small that the refined crossing lands 4.0e-4 from
        // the reference's through the grid and 4.7e-4 through the lists
        // (bottom-up quadratic; the tolerance is 4.4e-4), the sums' f32
        // rounding in another order.
        if what != "6WG6" {
            let mut s = s.clone();
            s.marching.min_step = s.marching.min_step.min(0.01);
            let mut renderer = Renderer::new(&ctx, &s).unwrap();
            let transparent = MarchOptions { transparent: true, ..opaque };
            let all = reference_crossings(&s, &rays, false, false);
            for &method in served.iter().filter(|&&m| m != Method::Sphere) {
                assert!(renderer.prepare_camera(method, &transparent, &s.camera, w, h).unwrap(), "{what} {method} transparent: no lists");
                let out = renderer.march_camera(method, transparent, &rays, 0).unwrap();
                assert_finite(&out.results, &format!("{what} {method} transparent"));
                let acc = accuracy_all(&out.crossings, &all, 2.0 * tol, 2.0 * tol);
                assert!(
                    acc.misses + acc.false_hits == 0,
                    "{what} {method} transparent: {} missed, {} false crossings through the tile lists",
                    acc.misses,
                    acc.false_hits
                );
            }
        }
        let stats = renderer.tile_stats().unwrap();
        assert!(stats.entries >= s.primitive_count() / 4 && stats.longest_list > 0, "{what}: {stats:?}");
    }
    assert_no_validation(&ctx);
}

/// A scene file of compact blobs `(x, y, z, support radius)`, one group per
/// list (combined by max), seen from `eye` towards the origin at `size` x
/// `size`.
fn groups_ron(groups: &[Vec<[f64; 4]>], eye: [f64; 3], size: u32) -> String {
    let mut s = format!(
        "Scene(camera: (eye: ({:?}, {:?}, {:?}), target: (0.0, 0.0, 0.0), fov_y: 40.0, resolution: ({size}, {size})), \
         lights: [(direction: (0.4, 0.8, 0.45))], iso: 0.5, marching: (method: \"quadratic-taylor\", min_step: 0.001), groups: [\n",
        eye[0], eye[1], eye[2]
    );
    for g in groups {
        s += "    (primitives: [";
        for b in g {
            s += &format!("Point(center: ({:?}, {:?}, {:?}), kernel: Compact(radius: {:?})), ", b[0], b[1], b[2], b[3]);
        }
        s += "]),\n";
    }
    s + "])\n"
}

/// `bench --json`'s rows against the f64 reference: no miss and no false
/// hit for any method, on a sample where the reference hits at least a
/// quarter of the rays; the report's spatial index.
fn bench_matches_the_reference(scene: &std::path::Path, extra: &[&str], what: &str) -> serde_json::Value {
    let json_path = scene.with_extension("json");
    isomarch(["bench", scene.to_str().unwrap(), "--methods", "quadratic-taylor,segment", "--json", json_path.to_str().unwrap()]).args(extra).ok();
    let report = json(&json_path);
    assert!(report["reference_hit_rate"].as_f64().unwrap() >= 0.25, "{what}: too few reference hits to test: {}", report["reference_hit_rate"]);
    for row in report["methods"].as_array().unwrap() {
        assert_eq!((row["miss_rate"].as_f64(), row["false_hit_rate"].as_f64()), (Some(0.0), Some(0.0)), "{what}: {}", row);
    }
    report["index"].clone()
}

/// Scenes of 17 to 256 groups (more than the 16 the index took before
/// issue 40; docs/limits.md) march with the spatial index, and `bench`'s
/// rows match the f64 reference: no miss, no false hit, at 17 groups and
/// at 256, 768 blobs at the density of the other index tests.
#[test]
fn scenes_of_17_to_256_groups_march_indexed_against_the_reference() {
    let dir = scratch("index-groups");
    for groups in [17, 256] {
        let s = particles(768, groups, 40 + groups as u64);
        let blobs: Vec<Vec<[f64; 4]>> = s
            .groups
            .iter()
            .map(|g| {
                g.iter()
                    .map(|p| match *p {
                        isomarch::scene::Primitive::Point { center, kernel: isomarch::scene::Kernel::Compact { radius, .. } } => {
                            [center.x, center.y, center.z, radius]
                        }
                        other => panic!("{other:?}"),
                    })
                    .collect()
            })
            .collect();
        assert!(blobs.iter().all(|g| !g.is_empty()));
        let path = dir.join(format!("groups{groups}.ron"));
        std::fs::write(&path, groups_ron(&blobs, [0.0, 0.0, 30.0], 64)).unwrap();
        let index = bench_matches_the_reference(&path, &["--rays", "1024"], &format!("{groups} groups"));
        assert!(index["entries"].as_u64().is_some_and(|e| e >= 768), "{groups} groups march without the index: {index}");
    }
}

/// Tile lists of many overlapping groups: twenty groups of 100 coinciding
/// blobs each (one pile per group, the piles 0.3 apart), every tile that
/// sees them listing 2,000 entries. `bench --camera-rays` on every pixel's
/// ray marches the grid against the f64 reference (no miss, no false hit);
/// `render` through the tile lists (`--stats` says so) hits and misses
/// where the grid does (`ISOMARCH_TILES=off`), each depth within twice the
/// refinement tolerance. (It found the tile walk adding a grid everywhere
/// list's primitives, read from the tile lists' buffers: every hit up to
/// 0.2 early.)
#[test]
fn tile_lists_of_many_overlapping_groups_hit_where_the_grid_does() {
    let dir = scratch("index-crowd");
    let piles: Vec<Vec<[f64; 4]>> = (0..20)
        .map(|g| {
            let a = std::f64::consts::TAU * f64::from(g) / 20.0;
            vec![[0.3 * a.cos(), 0.3 * a.sin(), 0.0, 1.0]; 100]
        })
        .collect();
    let path = dir.join("piles.ron");
    std::fs::write(&path, groups_ron(&piles, [0.0, 0.0, 5.0], 32)).unwrap();
    let index = bench_matches_the_reference(&path, &["--camera-rays", "--rays", "1024"], "20 piles, camera rays through the grid");
    assert!(index["entries"].as_u64().is_some(), "20 groups march without the index: {index}");
    let render = |name: &str, tiles: &str| -> (Vec<f32>, serde_json::Value) {
        let (exr, stats) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.json")));
        isomarch(["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--aov", "depth", "--stats", stats.to_str().unwrap()])
            .env("ISOMARCH_TILES", tiles)
            .ok();
        (exr_channel(&exr::prelude::read_all_flat_layers_from_file(&exr).unwrap(), "Z"), json(&stats))
    };
    let ((tiled, tiled_stats), (grid, grid_stats)) = (render("tiles", "on"), render("grid", "off"));
    assert_eq!((tiled_stats["acceleration"].as_str(), grid_stats["acceleration"].as_str()), (Some("tiles"), Some("grid")));
    assert!(tiled_stats["tiles"]["longest_list"].as_u64().is_some_and(|n| n >= 100), "{}", tiled_stats["tiles"]);
    let tol = 2.0 * isomarch::scene::Scene::load(&path).unwrap().refine_tolerance();
    let mut hits = 0;
    for (i, (a, b)) in tiled.iter().zip(&grid).enumerate() {
        assert_eq!(a.is_finite(), b.is_finite(), "pixel {i}: depth {a} through the tile lists, {b} through the grid");
        if a.is_finite() {
            assert!(f64::from((a - b).abs()) <= tol, "pixel {i}: depth {a} through the tile lists, {b} through the grid");
            hits += 1;
        }
    }
    assert!(hits >= 256, "only {hits} of 1024 pixels hit the piles");
}

/// A renderer whose tile lists were built for a perspective frame drops
/// them when the camera turns orthographic (whose parallel rays walk the
/// grid: the lists bin rays through the eye): the orthographic frame is,
/// byte for byte, the one a fresh renderer makes of it.
#[test]
fn a_renderer_drops_its_tile_lists_when_the_camera_turns_orthographic() {
    use isomarch::render::offscreen::{Effects, march_image};
    let ctx = gpu();
    let s = particles(400, 1, 11);
    let mut ortho = s.clone();
    ortho.camera.projection = isomarch::scene::Projection::Orthographic { height: 16.0 };
    let (s, ortho) = (s.recentred_on_camera(), ortho.recentred_on_camera());
    let options = MarchOptions::for_scene(&s);
    let frame = |r: &mut Renderer, scene: &Scene| {
        march_image(r, Method::QuadraticTaylor, options, scene, (48, 48), 1, Effects::default(), false).unwrap().0.shaded()
    };
    let timeout = std::time::Duration::from_secs(300);
    let mut renderer = Renderer::for_camera(&ctx, &s, timeout).unwrap();
    let perspective = frame(&mut renderer, &s);
    assert!(renderer.tile_stats().is_some(), "the perspective frame took no tile lists");
    let after = frame(&mut renderer, &ortho);
    let alone = frame(&mut Renderer::for_camera(&ctx, &ortho, timeout).unwrap(), &ortho);
    let background = perspective.get_pixel(0, 0).0;
    let hits = alone.pixels().filter(|p| p.0 != background).count();
    assert!(hits > 500 && alone != perspective, "the orthographic frame shows {hits} hits");
    let differing = after.pixels().zip(alone.pixels()).filter(|(p, q)| p != q).count();
    assert!(differing == 0, "after a perspective frame, the orthographic frame differs from a fresh renderer's in {differing} pixels");
    assert_no_validation(&ctx);
}

/// The tile lists' loop budget covers every entry a tile lists, summed
/// over its groups (`crowd`), not one group's longest list: twenty groups
/// of 500 coinciding blobs (one pile per group, the piles 0.3 apart), so
/// that every tile seeing them lists 10,000 entries and a fold near the
/// surface reads them all. The grid cannot march this scene (a cell would
/// hold 10,000 entries, beyond a dispatch's loop budget: refused in one
/// line), the tile lists can, one turn per slice: `render` through them
/// (`--stats` says so) hits where the f64 reference does on every pixel's
/// ray, within twice the refinement tolerance, and misses where it misses.
#[test]
fn tile_lists_budget_every_groups_entries_of_a_tile() {
    let dir = scratch("index-crowd-budget");
    let piles: Vec<Vec<[f64; 4]>> = (0..20)
        .map(|g| {
            let a = std::f64::consts::TAU * f64::from(g) / 20.0;
            vec![[0.3 * a.cos(), 0.3 * a.sin(), 0.0, 1.0]; 500]
        })
        .collect();
    let path = dir.join("piles.ron");
    std::fs::write(&path, groups_ron(&piles, [0.0, 0.0, 5.0], 16)).unwrap();
    let (exr, stats) = (dir.join("piles.exr"), dir.join("piles.json"));
    isomarch(["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--aov", "depth", "--stats", stats.to_str().unwrap()]).ok();
    let stats = json(&stats);
    assert_eq!(stats["acceleration"].as_str(), Some("tiles"), "{stats}");
    assert_eq!(stats["tiles"]["longest_list"].as_u64(), Some(500), "{}", stats["tiles"]);
    let depth = exr_channel(&exr::prelude::read_all_flat_layers_from_file(&exr).unwrap(), "Z");
    let s = Scene::load(&path).unwrap().recentred_on_camera();
    let (rays, pixels) = isomarch::render::rays::camera_rays(&s.camera, 16, 16, &s.bounds);
    let reference = reference_hits(&s, &rays, false);
    let tol = 2.0 * s.refine_tolerance();
    let mut hits = 0;
    for (r, p) in reference.iter().zip(&pixels) {
        let Some(p) = p else { continue };
        let got = depth[*p as usize];
        match r {
            Some(t) => {
                assert!((f64::from(got) - t).abs() <= tol, "pixel {p}: depth {got} through the tile lists, the reference's {t}");
                hits += 1;
            }
            None => assert!(!got.is_finite(), "pixel {p}: depth {got} through the tile lists, where the reference misses"),
        }
    }
    assert!(hits >= 64, "only {hits} of 256 pixels hit the piles");
    let err =
        isomarch(["render", path.to_str().unwrap(), "-o", dir.join("grid.png").to_str().unwrap()]).env("ISOMARCH_TILES", "off").fails_in_one_line();
    assert!(err.contains("overlap in one place"), "{err}");
}
