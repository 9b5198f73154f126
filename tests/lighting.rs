//! Shadows and ambient occlusion (`--shadows`, `--ao N`) against closed
//! forms, through the binary, for every method that marches them.

mod common;

use common::*;
use glam::DVec3;
use isomarch::scene::Scene;

const METHODS: [&str; 5] = ["quadratic-taylor", "segment", "sphere", "linear-taylor", "quadratic"];

/// A plane y = 0 seen from above; with `sphere`, a compact blob of R = 2
/// at (0, 6, 0) over it (their supports apart, so the blob's surface is the
/// sphere of radius 2·sqrt(1 - 0.5^(1/3))). One white light.
fn scene_text(method: &str, sphere: bool, light: DVec3) -> String {
    let blob = if sphere { "Point(center: (0.0, 6.0, 0.0), kernel: Compact(radius: 2.0))," } else { "" };
    format!(
        r#"Scene(
    camera: (eye: (0.0, 30.0, 0.0), target: (0.0, 0.0, 0.0), up: (0.0, 0.0, -1.0), fov_y: 40.0, resolution: (128, 128)),
    background: (0.0, 0.0, 0.0),
    ambient: (0.2, 0.2, 0.2),
    surface: (0.8, 0.8, 0.8),
    lights: [(direction: ({}, {}, {}))],
    iso: 0.5,
    bounds: Some((min: (-14.0, -1.5, -14.0), max: (14.0, 10.5, 14.0))),
    marching: (method: "{method}", min_step: 0.01),
    groups: [(primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: 0.0, radius: 1.0), {blob}])],
)"#,
        light.x, light.y, light.z
    )
}

fn red(exr: &std::path::Path) -> Vec<f32> {
    exr_channel(&exr::prelude::read_all_flat_layers_from_file(exr).unwrap(), "R")
}

#[test]
fn a_plane_alone_is_not_occluded_and_casts_no_shadow() {
    let dir = scratch("light-plane");
    for method in METHODS {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method, false, DVec3::new(0.3, 1.0, 0.2).normalize())).unwrap();
        let plain = dir.join(format!("{method}.png"));
        run_ok(&["render", path.to_str().unwrap(), "-o", plain.to_str().unwrap()]);
        let lit = dir.join(format!("{method}-lit.png"));
        run_ok(&["render", path.to_str().unwrap(), "-o", lit.to_str().unwrap(), "--shadows", "--ao", "16", "--ao-distance", "50"]);
        // AO exactly 1 and no shadow: not one ray of 16 per pixel, nor the
        // shadow ray, finds a crossing, so nothing is taken away.
        assert!(std::fs::read(&plain).unwrap() == std::fs::read(&lit).unwrap(), "{method}: the plane darkened itself");
    }
}

#[test]
fn a_spheres_shadow_on_a_plane_is_its_analytic_ellipse_within_a_pixel() {
    let dir = scratch("light-shadow");
    // Tilted so that the shadow falls clear of the blob as the camera sees it.
    let l = DVec3::new(0.6, 1.0, 0.2).normalize();
    let (w, h) = (128usize, 128usize);
    let centre = DVec3::new(0.0, 6.0, 0.0);
    let radius = 2.0 * (1.0 - 0.5f64.powf(1.0 / 3.0)).sqrt();
    for method in METHODS {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method, true, l)).unwrap();
        let scene = Scene::load(&path).unwrap();
        // The plane's surface height, from the f64 reference field.
        let field = isomarch::field::Field::new(&scene);
        let (mut lo, mut hi) = (0.0, 1.4);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if field.value(DVec3::new(12.0, mid, 12.0)) > 0.0 { lo = mid } else { hi = mid }
        }
        let y = 0.5 * (lo + hi);
        // Where each pixel centre's ray meets the plane, and whether the
        // light's ray from there meets the sphere.
        let half = (20f64.to_radians()).tan();
        let ground = |x: f64, z: f64| -> (DVec3, bool, bool) {
            let (sx, sy) = ((2.0 * (x + 0.5) / w as f64 - 1.0) * half, (1.0 - 2.0 * (z + 0.5) / h as f64) * half);
            let d = DVec3::new(sx, -1.0, -sy);
            let q = DVec3::new(0.0, 30.0, 0.0) + (30.0 - y) * d;
            let v = centre - q;
            let s = v.dot(l).max(0.0);
            let shadowed = (v - s * l).length() < radius;
            // The camera's ray passes the blob's support: the pixel may show it.
            let u = d.normalize();
            let c = centre - DVec3::new(0.0, 30.0, 0.0);
            let seen = (c - c.dot(u) * u).length() < 2.0;
            (q, shadowed, seen)
        };
        let exr = dir.join(format!("{method}.exr"));
        run_ok(&["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--shadows"]);
        let red = red(&exr);
        let shade_only = 0.8 * 0.2;
        let (mut inside, mut outside) = (0, 0);
        for z in 1..h - 1 {
            for x in 1..w - 1 {
                let around: Vec<(DVec3, bool, bool)> = (-1..=1)
                    .flat_map(|dz| (-1..=1).map(move |dx| (dx, dz)))
                    .map(|(dx, dz)| ground((x as i32 + dx) as f64, (z as i32 + dz) as f64))
                    .collect();
                if around.iter().any(|g| g.2) {
                    continue;
                }
                let v = f64::from(red[z * w + x]);
                if around.iter().all(|g| g.1) {
                    inside += 1;
                    assert!((v - shade_only).abs() < 2e-3, "{method}: pixel ({x}, {z}) lies a pixel inside the shadow but is lit: {v}");
                } else if around.iter().all(|g| !g.1) {
                    outside += 1;
                    assert!(v > shade_only + 0.3, "{method}: pixel ({x}, {z}) lies a pixel outside the shadow but is dark: {v}");
                }
            }
        }
        assert!(inside > 30 && outside > 5000, "{method}: {inside} pixels checked in the shadow, {outside} outside");
    }
}
