//! The camera's tile lists built on the GPU (src/render/tile_build.rs,
//! shaders/tiles.comp) against the host's build (src/render/tiles.rs),
//! the reference: every support a camera ray meets is in the GPU's lists,
//! the lists hold the host's entries in depth order, and images through
//! them are the host-built lists' within one 8-bit level.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::common::*;
use isomarch::method::Method;
use isomarch::render::tiles::TileLists;
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::Scene;

/// Builds the lists of `s`'s camera at `w` x `h` on the GPU, reads them
/// back, and checks them against the host's: the same entries in depth
/// order (extra ones counted, and returned with the lists).
fn gpu_lists(renderer: &mut Renderer, s: &Scene, (w, h): (u32, u32), what: &str) -> (TileLists, usize) {
    let opaque = MarchOptions { shade: false, ..MarchOptions::for_scene(s) };
    renderer.set_tile_builder(Some(true));
    assert!(renderer.gpu_tiles_apply(w, h), "{what}: the GPU does not build the lists");
    assert!(renderer.prepare_camera(Method::QuadraticTaylor, &opaque, &s.camera, w, h).unwrap(), "{what}: no lists");
    let stats = renderer.tile_stats().unwrap();
    assert!(stats.gpu, "{what}: the lists were built on the host");
    let lists = renderer.camera_tile_lists().unwrap().unwrap();
    let groups = lists.groups;
    let host = TileLists::build(&renderer.primitives(), groups, &s.camera, w, h);
    let extra = lists.agreement(&host).unwrap_or_else(|e| panic!("{what} at {w}x{h}: {e}"));
    assert_eq!(stats.entries, lists.entries.len(), "{what}: the statistics' entries");
    assert_eq!(stats.longest_list, host.longest.max(lists.longest), "{what}: the longest list");
    (lists, extra)
}

/// The host's containment test's primitives (src/render/tiles.rs), as a
/// scene of compact blobs in two groups: 300 at random, and some behind
/// the eye, straddling its plane, around it, larger than the screen, and
/// off every edge of the frame.
fn awkward_scene() -> Scene {
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    let mut groups = vec![Vec::new(), Vec::new()];
    for _ in 0..300 {
        let c = DVec3::new(rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0));
        let r = rng.random_range(0.2..2.5);
        groups[rng.random_range(0..2)].push(compact(c, r));
    }
    let eye = DVec3::new(0.0, 0.0, 9.0);
    groups[0].push(compact(eye + DVec3::new(0.0, 0.0, 3.0), 1.0));
    groups[0].push(compact(eye + DVec3::new(2.0, 0.5, 0.3), 1.0));
    groups[1].push(compact(eye, 0.5));
    groups[0].push(compact(DVec3::new(0.0, 0.0, -5.0), 40.0));
    for (x, y) in [(-9.0, 0.0), (9.0, 0.0), (0.0, -9.0), (0.0, 9.0), (8.5, 8.5)] {
        groups[1].push(compact(DVec3::new(x, y, -2.0), 1.5));
    }
    let mut s = scene(groups, 0.5, Method::QuadraticTaylor, 1e-3);
    s.camera.eye = eye;
    s.camera.fov_y_deg = 60.0;
    s
}

/// The containment test on GPU-built lists, at frames of partial tiles, a
/// single pixel and long thin strips: every support a sampled camera ray
/// meets is in its tile's list with its pixel; the lists hold the host's
/// entries (none extra on lavapipe, whose f64 is IEEE's); lists with one
/// tile edge taken out are refused.
#[test]
fn gpu_built_lists_hold_every_support_a_camera_ray_meets() {
    let ctx = gpu();
    let s = awkward_scene();
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let prims = renderer.primitives();
    let mut met = 0;
    for (w, h) in [(64, 64), (61, 37), (1, 1), (4096, 16), (16, 4096)] {
        let (lists, extra) = gpu_lists(&mut renderer, &s, (w, h), "awkward");
        assert_eq!(extra, 0, "{w}x{h}: entries beyond the host's");
        let samples = if w * h > 20_000 { 1 } else { 3 };
        met += lists.check_containment(&prims, &s.camera, samples, u64::from(w) * 31 + u64::from(h)).unwrap_or_else(|e| panic!("{w}x{h}: {e}"));
        if (w, h) == (64, 64) {
            let broken = lists.without_last_tile_columns();
            assert!(broken.check_containment(&prims, &s.camera, 1, 1).is_err(), "lists without a tile edge pass the containment test");
        }
    }
    assert!(met > 10_000, "only {met} ray-support meetings were checked");
    assert_no_validation(&ctx);
}

/// GPU and host lists agree on the molecules, the particles (one group and
/// three) and a frame larger than a million entries' sort needs several
/// radix passes for; a frame built twice (the buffers grown in between)
/// gives the same lists.
#[test]
fn gpu_and_host_lists_agree_on_molecules_and_particles() {
    let molecule =
        |name: &str| isomarch::molecule::build::load_scene(&repo_root().join("tests/data/molecules").join(name), &Default::default()).unwrap().0;
    let ctx = gpu();
    for (what, s, size) in [
        ("1A8O", molecule("1A8O.pdb"), (256, 256)),
        ("6WG6", molecule("6WG6.cif.gz"), (750, 750)),
        ("1,000 particles", crate::index::particles(1000, 1, 5), (500, 500)),
        ("900 particles in 3 groups", crate::index::particles(900, 3, 6), (123, 77)),
    ] {
        let s = s.recentred_on_camera();
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let (lists, extra) = gpu_lists(&mut renderer, &s, size, what);
        assert_eq!(extra, 0, "{what}: entries beyond the host's");
        assert!(lists.entries.len() > 1000, "{what}: only {} entries", lists.entries.len());
        // Another frame size, then this one again: the same lists.
        gpu_lists(&mut renderer, &s, (size.0 / 2 + 1, size.1 / 3 + 1), what);
        let (again, _) = gpu_lists(&mut renderer, &s, size, what);
        assert_eq!(again.entries, lists.entries, "{what}: the lists differ when built again");
    }
    assert_no_validation(&ctx);
}

/// Images through GPU-built lists are the host-built lists' within one
/// 8-bit level at every pixel (`ISOMARCH_TILE_BUILD=off` builds them on
/// the host), on a molecule and the particles, and not blank.
#[test]
fn images_through_gpu_built_lists_are_the_host_built_lists() {
    let dir = scratch("tile_build_images");
    let particles = dir.join("particles.ron");
    isomarch(["generate", "particles", "--count", "1000", "--seed", "2", "-o"]).arg(&particles).ok();
    for (what, input) in [("1A8O", repo_root().join("tests/data/molecules/1A8O.pdb")), ("particles", particles.clone())] {
        let render = |build: &str| {
            let out = dir.join(format!("{what}-{build}.png"));
            let stats = dir.join(format!("{what}-{build}.json"));
            isomarch(["render", "--size", "96x96", "--stats"]).arg(&stats).arg(&input).arg("-o").arg(&out).env("ISOMARCH_TILE_BUILD", build).ok();
            let s = json(&stats);
            assert_eq!(s["acceleration"], "tiles", "{what} {build}: {s}");
            assert_eq!(s["tiles"]["gpu"], build == "on", "{what} {build}: {s}");
            image::open(&out).unwrap().to_rgba8()
        };
        let (gpu, host) = (render("on"), render("off"));
        let worst = gpu.as_raw().iter().zip(host.as_raw()).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
        assert!(worst <= 1, "{what}: a pixel differs by {worst} levels");
        let lit = gpu.pixels().filter(|p| p.0[..3] != host.get_pixel(0, 0).0[..3]).count();
        assert!(lit > 96 * 96 / 10, "{what}: only {lit} pixels differ from the background");
    }
}
