//! Refinement of crossings: secant refinement against bisection through
//! `bench`, which also checks `--repeat`'s statistics.

use crate::common::{isomarch, repo_root, scratch};
use serde_json::Value;

/// `isomarch bench SCENE --json` with `args`; the report.
fn bench(scene: &str, args: &[&str], name: &str) -> Value {
    let json = scratch(name).join("bench.json");
    isomarch(["bench", scene, "--rays", "8192", "--json"]).arg(&json).args(args).current_dir(repo_root()).ok();
    serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
}

fn num(v: &Value, field: &str) -> f64 {
    v[field].as_f64().unwrap_or_else(|| panic!("no number {field} in {v}"))
}

/// Inclusion, secant and bisection refinement give the same steps, hits,
/// misses and false hits on an opaque and a transparent protocol scene.
/// Secant takes fewer evaluations than bisection on every row, and fewer
/// than half on the point method (segment tracing), whose brackets are a
/// minimum step long; the inclusion methods' opaque brackets start between
/// their bounds' roots, already short. Inclusion refinement is secant for
/// segment tracing; for the inclusion methods it takes fewer than half
/// secant's evaluations on fig10, and fewer than three quarters on fig1,
/// transparent, whose crossings (entering and leaving) are bracketed by a
/// minimum step, not by the bounds' roots (4.35 against 7.04); the
/// default (inclusion) takes at most 10 kernel evaluations per hit on
/// fig10. (Secant on a bracket between the bounds' roots starts without f
/// at its ends, so its first turn bisects: about 10.2 per hit there.)
#[test]
fn refinements_agree_and_inclusion_and_secant_take_fewer_evaluations() {
    let methods = "segment,quadratic-taylor,quadratic";
    for scene in ["scenes/fig10.ron", "scenes/fig1.ron"] {
        let inclusion = bench(scene, &["--methods", methods, "--refine", "inclusion"], "refine-inclusion");
        let secant = bench(scene, &["--methods", methods, "--refine", "secant"], "refine-secant");
        let bisection = bench(scene, &["--methods", methods, "--refine", "bisection"], "refine-bisection");
        let rows = |r: &Value| r["methods"].as_array().unwrap().clone();
        for ((i, s), b) in rows(&inclusion).iter().zip(rows(&secant)).zip(rows(&bisection)) {
            let row = format!("{scene} {}", s["method"]);
            for field in ["steps_per_ray", "hit_rate", "miss_rate", "false_hit_rate", "out_of_steps_rate"] {
                assert_eq!(num(&s, field), num(&b, field), "{row}: {field} differs between secant and bisection");
                assert_eq!(num(i, field), num(&s, field), "{row}: {field} differs between inclusion and secant");
            }
            let (ri, rs, rb) = (num(i, "refine_per_ray"), num(&s, "refine_per_ray"), num(&b, "refine_per_ray"));
            assert!(rb > 0.0 && rs < rb, "{row}: refinement evaluations per ray {rs} (secant) against {rb} (bisection)");
            let point = s["method"] == "segment";
            if point {
                assert!(rs < 0.5 * rb, "{row}: refinement evaluations per ray {rs} (secant) against {rb} (bisection)");
            }
            if point {
                assert_eq!(ri, rs, "{row}: inclusion refinement is secant here");
            } else if scene.ends_with("fig1.ron") {
                assert!(ri < 0.75 * rs, "{row}: refinement evaluations per ray {ri} (inclusion) against {rs} (secant)");
            } else {
                assert!(ri < 0.5 * rs, "{row}: refinement evaluations per ray {ri} (inclusion) against {rs} (secant)");
            }
            // Each refinement stops within its tolerance of the f64 root
            // (plus f32's rounding of the distance), not merely near
            // another refinement's error.
            let tolerance = isomarch::scene::Scene::load(&repo_root().join(scene)).unwrap().refine_tolerance() + 1e-5;
            for (name, r) in [("inclusion", i), ("secant", &s), ("bisection", &b)] {
                assert!(num(r, "max_abs_error") <= tolerance, "{row}: {name}'s error {} beyond the tolerance {tolerance}", num(r, "max_abs_error"));
            }
            if scene.ends_with("fig10.ron") {
                let per_hit = ri / num(i, "hit_rate");
                assert!(per_hit <= 10.0, "{row}: {per_hit} kernel evaluations per hit");
            }
        }
    }
}

/// `--repeat N` runs every method N times: each row has N times, its
/// median between the fastest and the slowest, and the time ratio of the
/// first row is 1 in every repeat.
#[test]
fn bench_repeat_reports_medians_and_ranges() {
    let report = bench("scenes/fig10.ron", &["--methods", "segment,quadratic-taylor", "--repeat", "3"], "bench-repeat");
    assert_eq!(report["repeats"].as_u64(), Some(3));
    for (i, row) in report["methods"].as_array().unwrap().iter().enumerate() {
        let runs: Vec<f64> = row["ns_per_ray_runs"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert_eq!(runs.len(), 3, "{row}");
        let (lo, med, hi) = (num(row, "ns_per_ray_min"), num(row, "ns_per_ray"), num(row, "ns_per_ray_max"));
        assert!(runs.iter().all(|&t| t > 0.0 && lo <= t && t <= hi), "{row}");
        assert!(runs.contains(&med), "{row}: the median of three is one of them");
        let (rlo, r, rhi) = (num(row, "time_ratio_min"), num(row, "time_ratio"), num(row, "time_ratio_max"));
        assert!(rlo <= r && r <= rhi, "{row}");
        if i == 0 {
            assert_eq!((rlo, r, rhi), (1.0, 1.0, 1.0), "{row}");
        }
    }
    // A repeat count of 0 is refused in one line.
    let err = isomarch(["bench", "scenes/fig10.ron", "--repeat", "0"]).current_dir(repo_root()).fails_in_one_line();
    assert!(err.contains("--repeat must be at least 1"), "{err}");
}
