//! Marches at the renderer's size limits: more rays than one tile, and the
//! largest scene the flat primitive loop accepts, where one loop turn
//! fills the per-dispatch loop budget (one turn per slice), with bisection
//! and four lights, against the f64 reference.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::bench::{accuracy, reference_hits};
use isomarch::layout::{FLAG_HIT, GpuResult};
use isomarch::render::rays::protocol_rays;
use isomarch::render::{MarchOptions, Renderer, TILE_RAYS};
use isomarch::scene::{Light, Scene};

/// More rays than a tile: every ray of the second tile gets its own
/// result, the same as when it is marched in a small batch of its own, and
/// the last rays agree with the reference.
#[test]
fn marches_of_more_than_one_tile_complete_ray_for_ray() {
    let ctx = gpu();
    let s = Scene::load(&repo_root().join("scenes/fig10.ron")).unwrap();
    let s = s.recentred(s.bounds.center());
    let rays = protocol_rays(&s.bounds, TILE_RAYS + 1000, 12);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
    let mut reported = Vec::new();
    let all = renderer.march(Method::QuadraticTaylor, options, &rays, |done| reported.push(done)).unwrap().results;
    assert_eq!(all.len(), rays.len());
    assert_eq!(reported, [TILE_RAYS, TILE_RAYS + 1000], "progress after each tile");
    // The rays on both sides of the tile boundary, marched alone.
    let from = TILE_RAYS - 500;
    let alone = renderer.march(Method::QuadraticTaylor, options, &rays[from..], |_| {}).unwrap().results;
    let key = |r: &GpuResult| (r.hit.map(f32::to_bits), r.counts);
    for (i, (a, b)) in all[from..].iter().zip(&alone).enumerate() {
        assert_eq!(key(a), key(b), "ray {}: marched in the second tile and alone differ", from + i);
    }
    let tail = &rays[TILE_RAYS..];
    let reference = reference_hits(&s, tail, false);
    let hits = reference.iter().filter(|r| r.is_some()).count();
    let (late, early) = (s.marching.min_step, s.refine_tolerance());
    let acc = accuracy(&all[TILE_RAYS..], &reference, late, early);
    assert!(hits > 200 && acc.misses + acc.false_hits == 0, "second tile against the reference: {hits} hits, {acc:?}");
    assert_no_validation(&ctx);
}

/// `n` compact blobs in `MAX_INDEX_GROUPS + 1` groups (more than the index
/// takes, so the scene marches flat), four lights.
fn flat_scene(n: usize) -> Scene {
    let side = 2.0 * (n as f64).cbrt();
    let mut state = 99u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let count = isomarch::render::index::MAX_INDEX_GROUPS + 1;
    let mut groups = vec![Vec::new(); count];
    for i in 0..n {
        groups[i % count].push(compact(DVec3::new(next(), next(), next()) * side, 1.0 + 0.5 * next()));
    }
    let mut s = scene(groups, 0.5, Method::LinearBisection, 1.0);
    s.marching.min_step = 1e-4 * s.min_radius();
    s.lights = (0..4).map(|i| Light { direction: DVec3::new(f64::from(i) - 1.5, 1.0, 0.5).normalize(), color: DVec3::splat(0.3) }).collect();
    s
}

#[test]
fn the_largest_flat_scene_marches_at_the_loop_budget_limit() {
    let ctx = gpu();
    // The largest accepted: accepted at n, refused at n + 1 (bisection on
    // the count; the renderer sizes its slices when it is made).
    let accepts = |n: usize| Renderer::new(&ctx, &flat_scene(n)).is_ok();
    let (mut lo, mut hi) = (1000usize, 20_000usize);
    assert!(accepts(lo) && !accepts(hi));
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if accepts(mid) { lo = mid } else { hi = mid }
    }
    let err = Renderer::new(&ctx, &flat_scene(lo + 1)).err().expect("refused").to_string();
    assert!(err.contains("overlap in one place"), "{err}");
    eprintln!("the largest flat scene with four lights: {lo} primitives");
    assert!(lo > 10_000, "only {lo} primitives march flat");
    let s = flat_scene(lo);
    let rays = protocol_rays(&s.bounds, 12, 4);
    let reference = reference_hits(&s, &rays, false);
    let hits = reference.iter().filter(|r| r.is_some()).count();
    assert!(hits >= 6, "only {hits} of 12 rays hit");
    let mut renderer = Renderer::with_timeout(&ctx, &s, std::time::Duration::from_secs(600)).unwrap();
    let tol = 2.0 * s.refine_tolerance() + 2e-6 * s.bounds.diagonal();
    for method in [Method::LinearBisection, Method::QuadraticTaylor] {
        // Shaded: the four lights are in every slice's budget.
        let out = renderer.march(method, MarchOptions::for_scene(&s), &rays, |_| {}).unwrap().results;
        let acc = accuracy(&out, &reference, tol, tol);
        assert_eq!((acc.misses, acc.false_hits), (0, 0), "{method}: {acc:?}");
        for r in out.iter().filter(|r| r.counts[3] & FLAG_HIT != 0) {
            assert!(r.color[..3].iter().all(|c| c.is_finite() && *c > 0.0), "{method}: unlit hit {r:?}");
        }
    }
    assert_no_validation(&ctx);
}
