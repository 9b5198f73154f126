//! Memory by role (src/gpu/buffer.rs): every buffer the renderer marches
//! with asks for the memory of its role, device-local for what the GPU
//! reads and writes; the host reaches those buffers only through copies,
//! and a frame reads back its results once per submission, not once per
//! slice of the march, and waits on few fences.

use std::path::PathBuf;
use std::time::Duration;

use crate::common::*;
use ash::vk;
use glam::DVec3;
use isomarch::Method;
use isomarch::gpu::Role;
use isomarch::layout::GpuResult;
use isomarch::render::offscreen::{RenderJob, render_frame_indexed};
use isomarch::render::{MarchOptions, Renderer};

/// 125 blobs on a 5x5x5 lattice: more than 64, so the spatial index and
/// the camera's tile lists are made.
fn lattice() -> isomarch::scene::Scene {
    let blobs = (0..125).map(|i| compact(DVec3::new((i % 5) as f64, (i / 5 % 5) as f64, (i / 25) as f64) - DVec3::splat(2.0), 0.9)).collect();
    scene(vec![blobs], 0.5, Method::QuadraticTaylor, 1e-3)
}

#[test]
fn every_renderer_buffer_asks_for_the_memory_of_its_role() {
    let ctx = gpu();
    let s = lattice();
    let mut renderer = Renderer::for_camera(&ctx, &s, Duration::from_secs(300)).unwrap();
    let options = MarchOptions::for_scene(&s);
    assert!(renderer.prepare_camera(Method::QuadraticTaylor, &options, &s.camera, 64, 64).unwrap(), "the lattice's camera rays take tile lists");
    let roles = renderer.buffer_roles();
    for name in ["rays", "results", "march states", "primitives", "index lists", "tile list starts", "tile list entries"] {
        assert!(roles.iter().any(|(n, _, _)| *n == name), "{name} is not listed among {roles:?}");
    }
    for (name, role, properties) in &roles {
        // The host writes the globals and the lights between submissions;
        // everything else is the GPU's.
        let want = if matches!(*name, "globals" | "lights") { Role::HostWrite } else { Role::Device };
        assert_eq!(*role, want, "{name}");
        if *role == Role::Device {
            assert!(properties.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL), "{name}: {properties:?}");
        } else {
            assert!(properties.contains(vk::MemoryPropertyFlags::HOST_VISIBLE), "{name}: {properties:?}");
        }
    }
    assert_no_validation(&ctx);
}

/// A 64x64 frame of the lattice: its results cross to the host once (64
/// bytes a ray), with the counter of unfinished rays, in a handful of
/// submissions, and the image is what the march found (not a blank frame
/// read from staging that no copy filled).
#[test]
fn a_frame_reads_its_results_back_once_in_few_submissions() {
    let ctx = gpu();
    let s = lattice();
    let job = RenderJob::new(s, Method::QuadraticTaylor, (64, 64), PathBuf::new(), Duration::from_secs(300));
    let report = render_frame_indexed(&ctx, &job).unwrap();
    let t = report.cost.transfers;
    let rays = 64 * 64;
    // One tile of rays, one or two submissions to march it (the warm-ups
    // of the pipelines read nothing back).
    let results = (rays * size_of::<GpuResult>()) as u64;
    assert!(t.readback_bytes >= results, "{t:?}: less than one result per ray came back");
    assert!(t.readback_bytes <= 2 * results + 1024, "{t:?}: the results were read back more than twice");
    assert!(t.submits <= 4, "{t:?}: more than four fences for one 64x64 frame");
    assert!(t.upload_bytes > 0, "{t:?}: the primitives and rays were not uploaded through staging");
    let hits = report.frame.pixels.iter().filter(|r| r.counts[0] & isomarch::layout::FLAG_HIT != 0).count();
    assert!(hits > rays / 10 && hits < rays, "{hits} of {rays} pixels hit the lattice");
    assert_no_validation(&ctx);
}
