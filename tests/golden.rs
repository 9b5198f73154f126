//! Small golden images. On a mismatch the actual image and a difference
//! image are written beside the golden; `UPDATE_GOLDENS=1` rewrites goldens.

mod common;

use std::path::PathBuf;

use common::*;
use image::{Rgb, RgbImage};
use isomarch::Method;
use isomarch::output::heatmap_image;
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::scene::Scene;

fn golden_dir() -> PathBuf {
    repo_root().join("tests").join("goldens")
}

/// Compares `actual` with the golden `name`: a pixel differs when a channel
/// is off by more than 8 (of 255); at most 0.5% of pixels may differ (f32
/// rounding differs between drivers at silhouettes).
fn check_golden(name: &str, actual: &RgbImage) {
    let path = golden_dir().join(format!("{name}.png"));
    if std::env::var("UPDATE_GOLDENS").is_ok_and(|v| v == "1") {
        actual.save(&path).unwrap();
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (create it with UPDATE_GOLDENS=1)", path.display()))
        .to_rgb8();
    assert_eq!(golden.dimensions(), actual.dimensions(), "{name}: size");
    let mut diff = RgbImage::new(golden.width(), golden.height());
    let mut differing = 0usize;
    for (x, y, g) in golden.enumerate_pixels() {
        let a = actual.get_pixel(x, y);
        let d = (0..3).map(|c| g[c].abs_diff(a[c])).max().unwrap();
        if d > 8 {
            differing += 1;
        }
        diff.put_pixel(x, y, Rgb([d.saturating_mul(8), if d > 8 { 255 } else { 0 }, 0]));
    }
    let total = (golden.width() * golden.height()) as usize;
    if differing * 200 > total {
        let actual_path = golden_dir().join(format!("{name}.actual.png"));
        let diff_path = golden_dir().join(format!("{name}.diff.png"));
        actual.save(&actual_path).unwrap();
        diff.save(&diff_path).unwrap();
        panic!(
            "{name}: {differing} of {total} pixels differ; see {} and {}",
            actual_path.display(),
            diff_path.display()
        );
    }
}

fn render(scene: &str, method: Method, size: u32) -> (RgbImage, RgbImage) {
    let ctx = gpu();
    let scene = Scene::load(&repo_root().join("scenes").join(scene)).unwrap();
    let job = RenderJob::new(scene, method, (size, size), PathBuf::new(), std::time::Duration::from_secs(300));
    let (frame, stats) = render_frame(&ctx, &job).unwrap();
    assert!(stats.hit_rate > 0.1 && stats.hit_rate < 0.9, "hit rate {}: not a picture of blobs", stats.hit_rate);
    assert_no_validation(&ctx);
    (frame.shaded(), heatmap_image(size, size, &frame.steps(), Some(75)))
}

#[test]
fn default_scene_matches_its_golden() {
    let (shaded, _) = render("default.ron", Method::Segment, 96);
    // Not a blank image: it has both background and lit surface.
    let distinct: std::collections::HashSet<_> = shaded.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 100, "only {} distinct colours", distinct.len());
    check_golden("default-segment-96", &shaded);
}

#[test]
fn fig10_every_method_matches_its_goldens() {
    for &method in Method::CONSERVATIVE {
        let (shaded, heat) = render("fig10.ron", method, 96);
        check_golden(&format!("fig10-{method}-96"), &shaded);
        check_golden(&format!("fig10-{method}-96-steps"), &heat);
    }
}

/// Transparent rendering: every crossing composited front to back.
#[test]
fn transparent_scenes_match_their_goldens() {
    for scene in ["fig1", "fig17"] {
        for method in [Method::Segment, Method::QuadraticTaylor] {
            let (shaded, heat) = render(&format!("{scene}.ron"), method, 96);
            check_golden(&format!("{scene}-{method}-96"), &shaded);
            check_golden(&format!("{scene}-{method}-96-steps"), &heat);
        }
    }
}

/// Reflection and refraction: fig16's dielectric blobs and ground at t = 0.
#[test]
fn refractive_fig16_matches_its_golden() {
    let (shaded, heat) = render("fig16.ron", Method::QuadraticTaylor, 96);
    check_golden("fig16-quadratic-taylor-96", &shaded);
    check_golden("fig16-quadratic-taylor-96-steps", &heat);
}
