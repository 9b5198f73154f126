//! Small golden images. On a mismatch the actual image and a difference
//! image are written beside the golden; `UPDATE_GOLDENS=1` rewrites goldens.

use std::path::PathBuf;

use crate::common::*;
use image::{Rgb, RgbImage};
use isomarch::Method;
use isomarch::output::heatmap_image;
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::scene::Scene;

thread_local! {
    /// This test rewrote goldens (UPDATE_GOLDENS=1): it fails at its end,
    /// so that a run that rewrites records never passes for one that
    /// checked them.
    static REWROTE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// The end of a test that compared goldens: fails if it rewrote them.
fn goldens_done() {
    assert!(!REWROTE.with(|r| r.get()), "goldens rewritten (UPDATE_GOLDENS=1): look at them, then run again without it to check");
}

fn golden_dir() -> PathBuf {
    repo_root().join("tests").join("goldens")
}

/// Compares `actual` with the golden `name`: a pixel differs when a channel
/// is off by more than 8 (of 255); at most 0.5% of pixels may differ (f32
/// rounding differs between drivers at silhouettes).
fn check_golden(name: &str, actual: &RgbImage) {
    let path = golden_dir().join(format!("{name}.png"));
    if rewriting("UPDATE_GOLDENS") {
        actual.save(&path).unwrap();
        REWROTE.with(|r| r.set(true));
        return;
    }
    let golden = image::open(&path).unwrap_or_else(|e| panic!("{}: {e} (create it with UPDATE_GOLDENS=1)", path.display())).to_rgb8();
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
        panic!("{name}: {differing} of {total} pixels differ; see {} and {}", actual_path.display(), diff_path.display());
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
    goldens_done();
}

#[test]
fn fig10_every_method_matches_its_goldens() {
    for &method in Method::CONSERVATIVE {
        let (shaded, heat) = render("fig10.ron", method, 96);
        check_golden(&format!("fig10-{method}-96"), &shaded);
        check_golden(&format!("fig10-{method}-96-steps"), &heat);
    }
    goldens_done();
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
    goldens_done();
}

/// Reflection and refraction: fig16's dielectric blobs and ground at t = 0.
#[test]
fn refractive_fig16_matches_its_golden() {
    let (shaded, heat) = render("fig16.ron", Method::QuadraticTaylor, 96);
    check_golden("fig16-quadratic-taylor-96", &shaded);
    check_golden("fig16-quadratic-taylor-96-steps", &heat);
    goldens_done();
}

/// Where the expected mean steps per ray are kept, with how they were made.
fn step_counts_path() -> PathBuf {
    repo_root().join("tests").join("data").join("step-counts.csv")
}

/// The size of the frames whose steps are counted.
const STEP_COUNT_SIZE: u32 = 64;

/// The methods each shipped scene is counted with: every conservative method on opaque
/// scenes; transparent and dielectric ones refuse the bisection baselines.
fn counted_methods(scene: &Scene) -> Vec<Method> {
    // Field inversion marches molecules only (one sum of like Gaussians):
    // tests/molecules.rs covers it.
    Method::CONSERVATIVE.iter().copied().filter(|m| scene.transparency.is_none() || !matches!(m, Method::LinearBisection | Method::Raa)).collect()
}

/// The heatmaps clamp at 75 steps and allow 8/255, so a regression of a
/// step or two is invisible in them: the mean steps per ray (every ray
/// spawned for a pixel, as `render --stats` reports it) of every method on
/// every shipped scene must stay within 1% of tests/data/step-counts.csv.
/// Rows name their method, whatever the scene file's own method is.
/// `UPDATE_STEP_COUNTS=1` rewrites the file.
#[test]
fn mean_steps_per_ray_of_every_method_on_every_shipped_scene_match_the_record() {
    let ctx = gpu();
    let mut names: Vec<String> = std::fs::read_dir(repo_root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron"))
        .collect();
    names.sort();
    assert!(names.len() >= 6, "only {names:?} in scenes/");
    let mut measured = Vec::new();
    for name in &names {
        let scene = Scene::load(&repo_root().join("scenes").join(name)).unwrap();
        for method in counted_methods(&scene) {
            let size = (STEP_COUNT_SIZE, STEP_COUNT_SIZE);
            let job = RenderJob::new(scene.clone(), method, size, PathBuf::new(), std::time::Duration::from_secs(300));
            let (_, stats) = render_frame(&ctx, &job).unwrap();
            measured.push((name.trim_end_matches(".ron").to_string(), method.to_string(), stats.steps_per_ray));
        }
    }
    assert_no_validation(&ctx);
    let path = step_counts_path();
    let rows: Vec<String> = measured.iter().map(|(scene, method, steps)| format!("{scene},{method},{steps:.4}")).collect();
    let text = record(
        &path,
        "UPDATE_STEP_COUNTS",
        "# Mean steps per ray (every ray spawned for a pixel, all generations) of each method on each shipped\n\
         # scene, rendered at 64x64 at scene time 0 with the scene file's other marching settings, on lavapipe.\n\
         # Written by: UPDATE_STEP_COUNTS=1 cargo test --release --test tests mean_steps\n\
         # Checked to within 1% by that test (tests/golden.rs).\n\
         scene,method,steps_per_ray\n",
        &rows,
    );
    let mut expected = std::collections::HashMap::new();
    for fields in record_rows(&text, &path) {
        let steps: f64 = fields[2].parse().unwrap_or_else(|e| panic!("{}: {fields:?}: {e}", path.display()));
        expected.insert((fields[0].to_string(), fields[1].to_string()), steps);
    }
    let recorded = expected.clone();
    let mut failures = Vec::new();
    for (scene, method, steps) in &measured {
        match expected.remove(&(scene.clone(), method.clone())) {
            None => failures.push(format!("{scene} {method}: {steps:.4} steps per ray, no row in the record")),
            Some(e) if (steps - e).abs() > 0.01 * e => {
                failures.push(format!("{scene} {method}: {steps:.4} steps per ray, recorded {e:.4} ({:+.2}%)", 100.0 * (steps - e) / e))
            }
            Some(_) => {}
        }
    }
    failures.extend(expected.keys().map(|(s, m)| format!("{s} {m}: recorded but not measured (no such scene or method)")));
    assert!(failures.is_empty(), "mean steps per ray differ from {}:\n{}", path.display(), failures.join("\n"));
    // Anchors outside the record: on the opaque scenes, rows of the record
    // against the f64 mirror's march of the same 64x64 camera rays (rays
    // that miss the bounds count 0 steps, as `render --stats` counts them).
    // The GPU may stop a step earlier than the mirror on a few rays (tests/
    // marching.rs, StepAgreement), so 3%. Measured: within 0.5%.
    for (scene, method) in
        [("fig10", Method::Segment), ("fig10", Method::QuadraticTaylor), ("fig10", Method::Quadratic), ("default", Method::QuadraticTaylor)]
    {
        let s = Scene::load(&repo_root().join("scenes").join(format!("{scene}.ron"))).unwrap();
        let field = isomarch::field::Field::new(&s);
        let settings = isomarch::field::march::MarchSettings::for_scene(&s, method);
        let (rays, _) = isomarch::render::rays::camera_rays(&s.camera, STEP_COUNT_SIZE, STEP_COUNT_SIZE, &s.bounds);
        let steps: u64 = rays
            .iter()
            .map(isomarch::render::rays::Ray::from_gpu)
            .filter(|ray| !ray.misses())
            .map(|ray| u64::from(isomarch::field::march::march(&field, method, ray.o, ray.d, ray.t0, ray.t1, settings).steps))
            .sum();
        let mirror = steps as f64 / rays.len() as f64;
        let row = recorded[&(scene.to_string(), method.to_string())];
        eprintln!("{scene} {method}: recorded {row:.4} steps per ray, f64 mirror {mirror:.4}");
        assert!((row - mirror).abs() <= 0.03 * mirror, "{scene} {method}: recorded {row:.4} steps per ray, the f64 mirror marches {mirror:.4}");
    }
}
