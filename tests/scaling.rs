//! `isomarch scaling` through the binary: a small sweep writes a CSV row
//! per (count, method) with finite, positive figures, a markdown table
//! headed by its command line, and a plot that decodes and is not blank;
//! bad arguments are refused in one line before anything is written.

use crate::common::{isomarch, scratch};

#[test]
fn a_small_sweep_writes_its_table_csv_and_plot() {
    let dir = scratch("scaling");
    let out = isomarch(["scaling", "--counts", "100,300", "--rays", "512", "--repeat", "2", "-o"])
        .arg(&dir)
        .args(["--validation", "--timeout", "300"])
        .ok();
    let stdout = String::from_utf8_lossy(&out.stdout);

    let text = std::fs::read_to_string(dir.join("scaling.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let methods = ["segment", "quadratic-taylor", "quadratic"];
    assert_eq!(rows.len(), 2 * methods.len(), "one row per (count, method):\n{text}");
    for count in ["100", "300"] {
        for m in methods {
            let n = rows.iter().filter(|r| r[col("count")] == count && r[col("method")] == m).count();
            assert_eq!(n, 1, "{count} blobs, {m}: {n} rows");
        }
    }
    let num = |r: &[&str], c: &str| r[col(c)].parse::<f64>().unwrap_or_else(|_| panic!("{c} = {:?} in {r:?}", r[col(c)]));
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        for c in [
            "reference_hit_rate",
            "hit_rate",
            "steps_per_ray",
            "evals_per_ray",
            "ns_per_ray",
            "ns_per_ray_min",
            "ns_per_ray_max",
            "time_ratio",
            "index_build_ms",
            "bytes_per_primitive",
            "index_cells",
            "index_entries",
        ] {
            assert!(num(r, c).is_finite() && num(r, c) > 0.0, "{c} in {r:?}");
        }
        // Every method here is conservative: it finds what the reference
        // finds, and nothing else, within its budget.
        for c in ["miss_rate", "false_hit_rate", "out_of_steps_rate"] {
            assert_eq!(num(r, c), 0.0, "{c} in {r:?}");
        }
        assert_eq!(num(r, "hit_rate"), num(r, "reference_hit_rate"), "{r:?}");
        assert!(num(r, "ns_per_ray_min") <= num(r, "ns_per_ray") && num(r, "ns_per_ray") <= num(r, "ns_per_ray_max"), "{r:?}");
        let each: Vec<f64> = r[col("ns_per_ray_each")].split(';').map(|t| t.parse().unwrap()).collect();
        assert_eq!(each.len(), 2, "one time per repeat: {r:?}");
        assert_eq!(num(r, "repeats"), 2.0);
        if r[col("count")] == "100" {
            assert_eq!(num(r, "time_ratio"), 1.0, "the smallest count is the base of the ratios: {r:?}");
        }
    }

    let md = std::fs::read_to_string(dir.join("scaling.md")).unwrap();
    assert!(md.starts_with("```sh\nisomarch scaling --counts 100,300 --rays 512 --repeat 2 -o "), "no command line on top:\n{md}");
    assert_eq!(stdout, md, "stdout is the markdown written");
    assert_eq!(md.lines().filter(|l| l.starts_with("| 100 |") || l.starts_with("| 300 |")).count(), 2 * methods.len() + 2, "{md}");

    let png = image::open(dir.join("scaling.png")).unwrap().to_rgb8();
    let distinct: std::collections::HashSet<_> = png.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 10, "a blank plot");
    assert!(std::fs::read_to_string(dir.join("scaling.svg")).unwrap().contains("<svg"));
    // Written atomically: no temporary file is left beside them.
    let mut names: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names, ["scaling.csv", "scaling.md", "scaling.png", "scaling.svg"]);
}

#[test]
fn bad_arguments_are_refused_in_one_line() {
    let dir = scratch("scaling-refuse");
    for (args, expect) in [
        (&["--counts", ""][..], "--counts"),
        (&["--counts", "0,100"][..], "at least 1"),
        (&["--counts", "100,abc"][..], "\"abc\""),
        (&["--counts", "100,100"][..], "twice"),
        (&["--methods", "segment,nope"][..], "--methods"),
        (&["--rays", "0"][..], "--rays"),
        (&["--repeat", "0"][..], "--repeat"),
    ] {
        let (stderr, stdout) = isomarch(["scaling"]).args(args).arg("-o").arg(dir.join("out")).fails_in_one_line_and_stdout();
        assert!(stderr.starts_with("error: ") && stderr.contains(expect), "{args:?}: {stderr}");
        assert!(stdout.is_empty(), "{args:?}: {stdout}");
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

/// `--ray-seed` picks the protocol rays: the same seed measures the same
/// counts, another seed other rays (and `--seed`, the scene, stays).
#[test]
fn the_ray_seed_picks_the_rays_and_repeats_them() {
    let dir = scratch("scaling-seed");
    let sweep = |seed: &str, name: &str| -> (f64, f64) {
        let out = dir.join(name);
        isomarch(["scaling", "--counts", "100", "--methods", "segment", "--rays", "256", "--repeat", "1", "--ray-seed", seed, "-o"]).arg(&out).ok();
        let text = std::fs::read_to_string(out.join("scaling.csv")).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let row: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
        let num = |c: &str| row[header.iter().position(|h| *h == c).unwrap()].parse::<f64>().unwrap();
        (num("reference_hit_rate"), num("steps_per_ray"))
    };
    let (a, again, other) = (sweep("7", "a"), sweep("7", "b"), sweep("8", "c"));
    assert_eq!(a, again, "the same --ray-seed measured other counts");
    assert_ne!(a, other, "--ray-seed 7 and 8 measured the same rays");
}
