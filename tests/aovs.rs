//! `render --aov depth,steps,normal,turns,visits`: the OpenEXR channels hold
//! the frame's results pixel for pixel, and for a single blob sphere its
//! closed form.

use std::path::PathBuf;

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::layout::FLAG_HIT;
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::scene::Scene;

/// One compact blob off the image centre (so that a flipped or transposed
/// image cannot match), seen from +z.
const SPHERE: &str = r#"Scene(
    camera: (eye: (0.0, 0.0, 3.5), target: (0.0, 0.0, 0.0), fov_y: 40.0, resolution: (40, 32)),
    iso: 0.5,
    marching: (method: "quadratic-taylor", min_step: 0.0002),
    groups: [(primitives: [Point(center: (0.6, 0.35, 0.0), kernel: Compact(radius: 2.0))])],
)"#;

#[test]
fn exr_aovs_hold_the_frames_results_and_the_spheres_closed_form() {
    let dir = scratch("aovs");
    let scene_path = dir.join("sphere.ron");
    std::fs::write(&scene_path, SPHERE).unwrap();
    let exr_path = dir.join("sphere.exr");
    run_ok(&[
        "render",
        scene_path.to_str().unwrap(),
        "-o",
        dir.join("sphere.png").to_str().unwrap(),
        "--aov",
        "depth,steps,normal,turns,visits",
        "--aov-output",
        exr_path.to_str().unwrap(),
    ]);
    let exr = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
    let (w, h) = (40usize, 32usize);
    assert_eq!((exr.layer_data[0].size.width(), exr.layer_data[0].size.height()), (w, h));
    let (z, steps) = (exr_channel(&exr, "Z"), exr_channel(&exr, "steps"));
    let normal = [exr_channel(&exr, "normal.X"), exr_channel(&exr, "normal.Y"), exr_channel(&exr, "normal.Z")];
    let (turns, visits) = (exr_channel(&exr, "turns"), exr_channel(&exr, "visits"));

    // The frame's results, marched in this process: the same numbers.
    let ctx = gpu();
    let scene = Scene::load(&scene_path).unwrap();
    let job = RenderJob::new(scene.clone(), Method::QuadraticTaylor, (w as u32, h as u32), PathBuf::new(), std::time::Duration::from_secs(300));
    let (frame, _) = render_frame(&ctx, &job).unwrap();
    assert_no_validation(&ctx);
    for (i, p) in frame.pixels.iter().enumerate() {
        let hit = p.counts[3] & FLAG_HIT != 0;
        assert_eq!(z[i].to_bits(), if hit { p.hit[3] } else { f32::INFINITY }.to_bits(), "pixel {i}: Z {} against the frame's {:?}", z[i], p.hit);
        assert_eq!(steps[i], p.counts[0] as f32, "pixel {i}: steps");
        assert_eq!(turns[i], p.crossings[2] as f32, "pixel {i}: turns");
        assert_eq!(visits[i], p.crossings[1] as f32, "pixel {i}: visits");
        // A turn is a step or a refinement's evaluation, and a ray that
        // reaches the blob visits it.
        assert!(turns[i] >= steps[i], "pixel {i}: {} turns, fewer than its {} steps", turns[i], steps[i]);
        if hit {
            assert!(visits[i] >= 1.0, "pixel {i}: a hit with {} visits", visits[i]);
        }
        for (a, axis) in normal.iter().enumerate() {
            assert_eq!(axis[i].to_bits(), p.hit[a].to_bits(), "pixel {i}: normal axis {a}");
        }
    }

    // The closed form: rays from the eye through pixel centres (the
    // camera's pinhole model, written here) meet the sphere of radius
    // R sqrt(1 - iso^(1/3)) about the blob's centre.
    let (centre, rho) = (DVec3::new(0.6, 0.35, 0.0), 2.0 * (1.0 - f64::cbrt(0.5)).sqrt());
    let eye = DVec3::new(0.0, 0.0, 3.5);
    let half_h = 20f64.to_radians().tan();
    let half_w = half_h * w as f64 / h as f64;
    let (mut hits, mut misses) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half_w;
            let sy = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half_h;
            let d = DVec3::new(sx, sy, -1.0).normalize();
            let b = (eye - centre).dot(d);
            let closest2 = (eye - centre).length_squared() - b * b;
            if (closest2.sqrt() - rho).abs() < 1e-3 * rho {
                continue;
            }
            if closest2 < rho * rho {
                let t = -b - (rho * rho - closest2).sqrt();
                assert!((f64::from(z[i]) - t).abs() < 2e-4 * 2.0 + 1e-5, "pixel ({x}, {y}): Z {} against the sphere's {t}", z[i]);
                let n = DVec3::new(normal[0][i].into(), normal[1][i].into(), normal[2][i].into());
                let expected = (eye + t * d - centre) / rho;
                assert!((n.length() - 1.0).abs() < 1e-5, "pixel ({x}, {y}): normal {n} of length {}", n.length());
                let angle = n.normalize().dot(expected).clamp(-1.0, 1.0).acos().to_degrees();
                assert!(angle < 0.5, "pixel ({x}, {y}): normal {n} {angle}° from the sphere's {expected}");
                assert!(steps[i] >= 1.0, "pixel ({x}, {y}): a hit in {} steps", steps[i]);
                hits += 1;
            } else {
                assert_eq!(z[i], f32::INFINITY, "pixel ({x}, {y}): Z {} where the ray passes the sphere", z[i]);
                assert_eq!([normal[0][i], normal[1][i], normal[2][i]], [0.0; 3], "pixel ({x}, {y}): a normal on a miss");
                misses += 1;
            }
        }
    }
    assert!(hits > 200 && misses > 200, "{hits} hits, {misses} misses: the sphere is not framed");
}

/// The turns, visits and steps channels average to `--stats`'
/// `turns_per_ray`, `visits_per_ray` and `steps_per_ray`, which are
/// counted apart (a channel holding another's counts fails): on the blob,
/// marched flat, and on 1A8O, whose camera rays take the tile lists.
#[test]
fn aov_channels_average_to_the_statistics_of_the_same_frame() {
    let dir = scratch("aovs-stats");
    let sphere = dir.join("sphere.ron");
    std::fs::write(&sphere, SPHERE).unwrap();
    let molecule = repo_root().join("tests/data/molecules/1A8O.pdb");
    for (name, scene, size) in [("sphere", sphere.as_path(), "40x32"), ("1A8O", molecule.as_path(), "48x48")] {
        let (exr_path, stats_path) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.json")));
        run_ok(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            dir.join(format!("{name}.png")).to_str().unwrap(),
            "--size",
            size,
            "--aov",
            "steps,turns,visits",
            "--aov-output",
            exr_path.to_str().unwrap(),
            "--stats",
            stats_path.to_str().unwrap(),
        ]);
        let exr = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
        let stats = json(&stats_path);
        assert_eq!(stats["rays"].as_u64(), Some(exr_channel(&exr, "steps").len() as u64), "{name}: one ray per pixel");
        let mut means = Vec::new();
        for (channel, key) in [("steps", "steps_per_ray"), ("turns", "turns_per_ray"), ("visits", "visits_per_ray")] {
            let values = exr_channel(&exr, channel);
            let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64;
            let expected = stats[key].as_f64().unwrap();
            assert!((mean - expected).abs() <= 1e-9 * expected.max(1.0), "{name}: the {channel} channel's mean {mean}, {key} {expected}");
            means.push(mean);
        }
        // Three different numbers, so that no two channels can be swapped.
        assert!(means[0] < means[1] && means[1] != means[2], "{name}: steps, turns and visits per ray {means:?}");
    }
}
