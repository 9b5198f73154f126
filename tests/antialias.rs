//! Anti-aliasing (`render --samples N`) against the closed form: a straight
//! edge's pixels hold its analytic coverage within 1/N, for every method.

mod common;

use common::*;
use glam::DVec3;
use isomarch::scene::Scene;

/// A plane facing the camera, cut by the scene's box at x = EDGE: a
/// straight vertical edge. The one light lies in the plane, so the surface
/// is its ambient colour everywhere.
const EDGE: f64 = 0.37;

fn scene_text(method: &str) -> String {
    format!(
        r#"Scene(
    camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (40, 8)),
    background: (0.1, 0.1, 0.1),
    ambient: (0.8, 0.8, 0.8),
    surface: (1.0, 1.0, 1.0),
    lights: [(direction: (1.0, 0.0, 0.0))],
    iso: 0.5,
    bounds: Some((min: (-100.0, -100.0, -2.0), max: ({EDGE}, 100.0, 2.0))),
    marching: (method: "{method}", min_step: 0.001),
    groups: [(primitives: [Plane(normal: (0.0, 0.0, 1.0), offset: 0.0, radius: 1.0)])],
)"#
    )
}

#[test]
fn an_edges_pixels_hold_its_analytic_coverage_within_one_over_n() {
    let dir = scratch("antialias");
    let (w, h) = (40u32, 8u32);
    for method in ["quadratic-taylor", "segment", "sphere", "linear-taylor", "quadratic"] {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method)).unwrap();
        let scene = Scene::load(&path).unwrap();
        // The surface's depth, from the f64 reference field by bisection.
        let field = isomarch::field::Field::new(&scene);
        let (mut lo, mut hi) = (0.0, 1.9);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if field.value(DVec3::new(0.0, 0.0, mid)) > 0.0 { lo = mid } else { hi = mid }
        }
        let z = 0.5 * (lo + hi);
        // A pinhole looking down -z at the plane z: screen x is linear in
        // world x. The edge's position in pixels from the left.
        let half_w = (15f64.to_radians()).tan() * f64::from(w) / f64::from(h);
        let edge = (EDGE / (10.0 - z) / half_w + 1.0) * f64::from(w) / 2.0;
        for n in [1u32, 4, 16] {
            let exr_path = dir.join(format!("{method}-{n}.exr"));
            run_ok(&["render", path.to_str().unwrap(), "-o", exr_path.to_str().unwrap(), "--samples", &n.to_string()]);
            let exr = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
            let red = exr_channel(&exr, "R");
            let (inside, outside) = (0.8f64, 0.1f64);
            let mut partial = 0;
            for y in 0..h {
                for x in 0..w {
                    let coverage = (edge - f64::from(x)).clamp(0.0, 1.0);
                    let got = f64::from(red[(y * w + x) as usize]);
                    // One sample (the pixel's centre) is all or nothing:
                    // the surface's colour where the centre is left of the
                    // edge, the background's where it is right of it (a
                    // centre within 1e-3 of the edge may go either way).
                    let centre = f64::from(x) + 0.5;
                    let (want, tolerance) = if n > 1 {
                        (outside + coverage * (inside - outside), (inside - outside) / f64::from(n) + 1e-5)
                    } else if (centre - edge).abs() < 1e-3 {
                        (0.5 * (inside + outside), 0.5 * (inside - outside) + 1e-5)
                    } else {
                        (if centre < edge { inside } else { outside }, 1e-5)
                    };
                    assert!(
                        (got - want).abs() <= tolerance,
                        "{method}, {n} samples, pixel ({x}, {y}): {got} where the edge's coverage {coverage:.4} gives {want:.4} (tolerance {tolerance:.4})"
                    );
                    partial += usize::from(got > outside + 1e-4 && got < inside - 1e-4);
                }
            }
            // The edge runs through one column: its pixels are partly
            // covered once there is more than one sample.
            assert_eq!(partial, if n == 1 { 0 } else { h as usize }, "{method}, {n} samples: partly covered pixels");
        }
    }
}
