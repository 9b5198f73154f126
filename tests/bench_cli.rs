//! `isomarch bench` end to end: a small run's table and JSON (fields,
//! ratios, and the steps marching the same rays gives), `--cull` on and off
//! giving identical results, and `--growth` reaching the marcher.

use crate::common::*;
use isomarch::Method;
use isomarch::output::MarchStats;
use isomarch::render::rays::protocol_rays;
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::Scene;
use serde_json::Value;

const RAYS: usize = 512;

/// `bench SCENE --rays 512 --json F` with `extra` flags: its stdout and JSON.
fn bench(scene: &str, extra: &[&str], name: &str) -> (String, Value) {
    let dir = scratch(name);
    let path = dir.join("bench.json");
    let scene = repo_root().join("scenes").join(scene);
    let mut args = vec!["bench", scene.to_str().unwrap(), "--rays", "512", "--json", path.to_str().unwrap()];
    args.extend(extra);
    let out = run_ok(&args);
    (String::from_utf8_lossy(&out.stdout).into_owned(), json(&path))
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} missing or not a number in {v}"))
}

/// The rows of a report, by label.
fn rows(report: &Value) -> Vec<&Value> {
    report["methods"].as_array().unwrap_or_else(|| panic!("no methods array: {report}")).iter().collect()
}

/// Mean steps per ray of `method` on the protocol rays of `scene` (as
/// bench marches them: centred on the box, unshaded).
fn steps_per_ray(scene: &Scene, method: Method, growth: Option<f64>, seed: u64) -> f64 {
    let ctx = gpu();
    let scene = scene.recentred(scene.bounds.center());
    let rays = protocol_rays(&scene.bounds, RAYS, seed);
    let mut renderer = Renderer::new(&ctx, &scene).unwrap();
    let options = MarchOptions { shade: false, growth: growth.or(scene.marching.growth), ..MarchOptions::for_scene(&scene) };
    let out = renderer.march(method, options, &rays, |_| {}).unwrap();
    assert_no_validation(&ctx);
    MarchStats::of(&out.results, None).steps_per_ray
}

#[test]
fn bench_reports_every_method_with_ratios_to_the_first() {
    let (table, report) = bench("fig10.ron", &["--methods", "segment,quadratic-taylor,sphere"], "bench-e2e");
    let scene = Scene::load(&repo_root().join("scenes/fig10.ron")).unwrap();
    assert!(report["scene"].as_str().is_some_and(|s| s.ends_with("fig10.ron")), "{}", report["scene"]);
    assert!(report["device"].as_str().is_some_and(|d| !d.is_empty()), "{}", report["device"]);
    assert_eq!(report["rays"].as_u64(), Some(RAYS as u64));
    assert_eq!(report["seed"].as_u64(), Some(isomarch::bench::DEFAULT_SEED));
    assert_eq!(num(&report, "min_step"), scene.marching.min_step);
    assert_eq!(report["max_steps"].as_u64(), Some(u64::from(scene.marching.max_steps)));
    let reference = num(&report, "reference_hit_rate");
    assert!(reference > 0.2 && reference < 0.9, "reference hit rate {reference}");
    assert!(report["reference_crossings"].is_null() && report["index"].is_null(), "fig10 is opaque and has no index: {report}");
    let rows = rows(&report);
    let labels: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(labels, ["segment", "quadratic-taylor", "sphere"]);
    let first = rows[0];
    for (row, method) in rows.iter().zip([Method::Segment, Method::QuadraticTaylor, Method::Sphere]) {
        let steps = num(row, "steps_per_ray");
        // The figures are those of marching the same seeded rays.
        let own = steps_per_ray(&scene, method, None, isomarch::bench::DEFAULT_SEED);
        assert!((steps - own).abs() <= 1e-9 * own, "{method}: bench says {steps} steps per ray, marching gives {own}");
        assert!((num(row, "step_ratio") - steps / num(first, "steps_per_ray")).abs() < 1e-12, "{method}: step ratio {row}");
        match (row["ns_per_ray"].as_f64(), row["time_ratio"].as_f64()) {
            (Some(ns), Some(ratio)) => {
                assert!(ns > 0.0 && (ratio - ns / num(first, "ns_per_ray")).abs() < 1e-12, "{method}: time ratio {row}");
            }
            (None, None) => {}
            _ => panic!("{method}: a time without a ratio or the reverse: {row}"),
        }
        // Every method finds the reference's hits on fig10.
        assert!((num(row, "hit_rate") - reference).abs() < 1e-12, "{method}: hit rate {row} against {reference}");
        for k in ["miss_rate", "false_hit_rate", "out_of_steps_rate"] {
            assert_eq!(num(row, k), 0.0, "{method}: {k} in {row}");
        }
        // Within the refinement tolerance of the f64 root (plus f32's
        // rounding of the distance), not merely within a minimum step.
        let tolerance = scene.refine_tolerance() + 1e-5;
        assert!(num(row, "evals_per_ray") > 0.0 && num(row, "max_abs_error") <= tolerance, "{method}: error beyond {tolerance}: {row}");
        assert!(row["validity_kept"].is_null(), "{method}: {row}");
        // The table has its row.
        assert!(table.lines().any(|l| l.starts_with(&format!("| {method} | {steps:.2} |"))), "no row for {method}:\n{table}");
    }
    assert_eq!(num(first, "step_ratio"), 1.0);
    // Fewer steps than segment tracing, and sphere tracing more (Figure 10).
    assert!(num(rows[1], "step_ratio") < 0.8 && num(rows[2], "step_ratio") > 2.0, "{report}");
}

/// Culling only skips work: hits, normals and steps are identical per ray
/// (on the library, every ray; through `bench --cull both`, the rows).
#[test]
fn culling_on_and_off_give_identical_results() {
    let ctx = gpu();
    for name in ["default.ron", "fig10-gauss.ron"] {
        let s = Scene::load(&repo_root().join("scenes").join(name)).unwrap();
        let rays = protocol_rays(&s.bounds, 2048, 9);
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        for method in [Method::Segment, Method::QuadraticTaylor, Method::Quadratic, Method::Raa] {
            let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
            let on = renderer.march(method, MarchOptions { cull: true, ..options }, &rays, |_| {}).unwrap().results;
            let off = renderer.march(method, MarchOptions { cull: false, ..options }, &rays, |_| {}).unwrap().results;
            let hits = on.iter().filter(|r| r.counts[3] & isomarch::layout::FLAG_HIT != 0).count();
            assert!(hits > 200, "{name} {method}: only {hits} hits");
            for (i, (a, b)) in on.iter().zip(&off).enumerate() {
                assert_eq!((a.counts[0], a.counts[3]), (b.counts[0], b.counts[3]), "{name} {method} ray {i}: steps or flags differ");
                assert_eq!(a.hit.map(f32::to_bits), b.hit.map(f32::to_bits), "{name} {method} ray {i}: hit differs");
            }
        }
    }
    assert_no_validation(&ctx);
    let (_, report) = bench("default.ron", &["--methods", "segment,quadratic-taylor", "--cull", "both"], "bench-cull");
    let rows = rows(&report);
    let labels: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(labels, ["segment", "segment (no cull)", "quadratic-taylor", "quadratic-taylor (no cull)"]);
    for pair in rows.chunks(2) {
        for k in ["steps_per_ray", "hit_rate", "miss_rate", "false_hit_rate", "mean_abs_error", "max_abs_error", "out_of_steps_rate"] {
            assert_eq!(pair[0][k], pair[1][k], "{k}: {} against {}", pair[0], pair[1]);
        }
    }
}

/// `--growth k` is the interval growth every method marches with: the
/// steps equal marching the rays with growth k, segment's default (1.5)
/// changes nothing, and another k changes the steps.
#[test]
fn bench_growth_reaches_the_marcher() {
    let scene = Scene::load(&repo_root().join("scenes/fig10.ron")).unwrap();
    let steps = |flags: &[&str], name: &str| {
        let (_, report) = bench("fig10.ron", &[&["--methods", "segment,quadratic-taylor"], flags].concat(), name);
        rows(&report).iter().map(|r| num(r, "steps_per_ray")).collect::<Vec<_>>()
    };
    let default = steps(&[], "growth-default");
    let slow = steps(&["--growth", "1"], "growth-1");
    for (i, method) in [Method::Segment, Method::QuadraticTaylor].into_iter().enumerate() {
        let own = steps_per_ray(&scene, method, Some(1.0), isomarch::bench::DEFAULT_SEED);
        assert!((slow[i] - own).abs() <= 1e-9 * own, "{method}: bench --growth 1 says {} steps, marching with growth 1 gives {own}", slow[i]);
        // Intervals that never grow cost steps.
        assert!(slow[i] > 1.05 * default[i], "{method}: growth 1 takes {} steps per ray, the default {}", slow[i], default[i]);
    }
    assert_eq!(steps(&["--growth", "1.5"], "growth-1.5")[0], default[0], "segment's default growth is 1.5");
    let err = isomarch(["bench", "scenes/fig10.ron", "--growth", "0.5"]).current_dir(repo_root()).fails_in_one_line();
    assert!(err.contains("--growth"), "{err}");
}

/// `--opaque` marches the first crossing only: the bisection baselines,
/// which refuse a refractive scene, run on it, and a transparent method's
/// steps drop to the opaque march's (it no longer follows every crossing).
#[test]
fn opaque_flag_marches_a_transparent_scene_for_the_first_crossing() {
    let err = isomarch(["bench", "scenes/hrbf17.ron", "--methods", "raa", "--rays", "64"]).current_dir(repo_root()).fails();
    assert!(err.contains("opaque"), "{err}");
    let (_, transparent) = bench("hrbf17.ron", &["--methods", "quadratic"], "transparent");
    let (_, opaque) = bench("hrbf17.ron", &["--opaque", "--methods", "quadratic,raa"], "opaque");
    let (t, o) = (num(rows(&transparent)[0], "steps_per_ray"), rows(&opaque).iter().map(|r| num(r, "steps_per_ray")).collect::<Vec<_>>());
    assert!(o[0] < t, "opaque quadratic {} steps per ray, transparent {t}", o[0]);
    assert!(o[0] < o[1], "opaque quadratic {} steps per ray, raa {}", o[0], o[1]);
    let mut scene = Scene::load(&repo_root().join("scenes/hrbf17.ron")).unwrap();
    scene.transparency = None;
    let own = steps_per_ray(&scene, Method::Quadratic, None, isomarch::bench::DEFAULT_SEED);
    assert!((o[0] - own).abs() <= 1e-9 * own, "bench --opaque says {} steps, marching the scene without transparency gives {own}", o[0]);
}

/// An anchor outside every record: on fig10's protocol rays, the steps of
/// quadratic Taylor, bottom-up quadratic and bottom-up linear bisection
/// relative to segment tracing's are the paper's Table 1 ratios (0.538,
/// 0.625, 1.410; 11.5 million rays) within 25%. Ours are lower: an
/// inclusion refinement brackets a hit without the step that finds
/// f >= 0 (docs/refinement.md). Measured on 16,384 rays: 0.468, 0.509,
/// 1.248.
#[test]
fn fig10_step_ratios_are_the_papers_table_1_within_a_quarter() {
    let path = scratch("bench-paper-ratios").join("bench.json");
    let scene = repo_root().join("scenes/fig10.ron");
    let methods = "segment,quadratic-taylor,quadratic,linear-bisection";
    run_ok(&["bench", scene.to_str().unwrap(), "--rays", "8192", "--methods", methods, "--json", path.to_str().unwrap()]);
    let report = json(&path);
    let rows = rows(&report);
    let segment = num(rows[0], "steps_per_ray");
    assert_eq!(rows[0]["method"], "segment");
    for (row, paper) in rows[1..].iter().zip([4.79 / 8.90, 5.56 / 8.90, 12.55 / 8.90]) {
        let ratio = num(row, "steps_per_ray") / segment;
        assert!((ratio / paper - 1.0).abs() <= 0.25, "{}: {ratio:.3} of segment's steps, the paper's {paper:.3}", row["method"]);
    }
}

/// `bench --camera-rays` without a size samples the scene camera's own frame
/// (its `resolution`), as `--help` says; with a size, that frame.
#[test]
fn bench_camera_takes_the_scenes_resolution_when_no_size_is_given() {
    let (text, report) = bench("fig10.ron", &["--methods", "segment", "--camera-rays"], "bench-camera-default");
    assert_eq!(report["camera"], serde_json::json!([512, 512]), "{report}");
    assert!(text.contains("of the camera's 512x512 frame"), "{text}");
    let (_, report) = bench("fig10.ron", &["--methods", "segment", "--camera-rays", "64x48"], "bench-camera-size");
    assert_eq!(report["camera"], serde_json::json!([64, 48]), "{report}");
}

/// An any-hit query answers yes or no: its table shows no error columns
/// (they printed `0.00e0`, as if measured).
#[test]
fn bench_any_hit_prints_no_error_columns() {
    let (text, _) = bench("fig10.ron", &["--methods", "segment,quadratic-taylor", "--any-hit"], "bench-any-hit-errors");
    let header = text.lines().find(|l| l.starts_with("| method | steps/ray")).unwrap_or_else(|| panic!("no table: {text}"));
    fn cells(l: &str) -> Vec<&str> {
        l.split('|').map(str::trim).collect()
    }
    let at = |name: &str| cells(header).iter().position(|c| *c == name).unwrap_or_else(|| panic!("no {name} column: {header}"));
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| segment |") || l.starts_with("| quadratic-taylor |")).take(2).collect();
    assert_eq!(rows.len(), 2, "{text}");
    for row in rows {
        assert_eq!(cells(row)[at("mean err")], "n/a", "{row}");
        assert_eq!(cells(row)[at("max err")], "n/a", "{row}");
    }
}

/// The settings `bench` compares reach the marcher: `--extension both`
/// (per-primitive bounds of compact kernels) saves quadratic Taylor steps
/// on fig10, `--validity both` on Gaussians (fig10-gauss) costs bottom-up
/// quadratic steps where every Gaussian sets a validity interval, and
/// `--generic` pipelines give the specialised ones' counts exactly.
#[test]
fn bench_compares_extension_validity_and_generic_pipelines() {
    let labelled = |report: &Value| -> Vec<(String, f64)> {
        rows(report).iter().map(|r| (r["method"].as_str().unwrap().to_string(), num(r, "steps_per_ray"))).collect()
    };
    let (_, report) = bench("fig10.ron", &["--methods", "quadratic-taylor", "--extension", "both"], "bench-extension");
    let got = labelled(&report);
    assert_eq!(got.iter().map(|r| r.0.as_str()).collect::<Vec<_>>(), ["quadratic-taylor", "quadratic-taylor (no extension)"]);
    assert!(got[0].1 < got[1].1, "the extension saves no steps: {got:?}");
    let (_, report) = bench("fig10-gauss.ron", &["--methods", "quadratic", "--validity", "both"], "bench-validity");
    let got = labelled(&report);
    assert_eq!(got.iter().map(|r| r.0.as_str()).collect::<Vec<_>>(), ["quadratic", "quadratic (validity: every)"]);
    assert!(got[0].1 < got[1].1, "every Gaussian's validity interval costs no steps: {got:?}");
    let (_, report) = bench("fig10.ron", &["--methods", "segment,quadratic-taylor", "--generic"], "bench-generic");
    let rows = rows(&report);
    let labels: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    assert_eq!(labels, ["segment", "segment (generic)", "quadratic-taylor", "quadratic-taylor (generic)"]);
    for pair in rows.chunks(2) {
        let (specialised, generic) = (pair[0], pair[1]);
        for k in ["steps_per_ray", "hit_rate", "miss_rate", "false_hit_rate", "mean_abs_error", "max_abs_error"] {
            assert_eq!(specialised[k], generic[k], "{k}: {specialised} against {generic}");
        }
    }
}
