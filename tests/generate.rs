//! `isomarch generate particles` through the binary: seeded output is
//! byte-identical, the scene loads with the ordinary loader and its bounds
//! hold every support, bad arguments are refused in one line.

use std::path::Path;

use crate::common::{Isomarch, isomarch, json, repo_root, run_ok, scratch};
use glam::DVec3;
use isomarch::scene::{Kernel, Primitive, Scene};

/// `isomarch generate particles ARGS -o OUT`, to run.
fn generate(args: &[&str], out: &Path) -> Isomarch {
    isomarch(["generate", "particles"]).args(args).arg("-o").arg(out)
}

/// Runs `generate`: it succeeds, silent on stderr, with one summary line
/// on stdout, which it returns.
fn assert_ok(run: Isomarch) -> String {
    let out = run.ok();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.is_empty(), "generate wrote to stderr: {stderr}");
    assert_eq!(stdout.lines().count(), 1, "one summary line, got: {stdout}");
    stdout
}

/// Every primitive's support (a Gaussian's: where it exceeds 1e-3 iso, as
/// the loader measures it) lies inside the scene's bounds.
fn assert_bounds_hold_supports(scene: &Scene) {
    for p in scene.primitives() {
        let Primitive::Point { center, kernel } = p else { panic!("only points are generated") };
        let reach = DVec3::splat(kernel.cutoff(scene.iso));
        assert!(
            (center - reach).cmpge(scene.bounds.min).all() && (center + reach).cmple(scene.bounds.max).all(),
            "support of {center} (reach {}) leaves the bounds {:?}",
            reach.x,
            scene.bounds
        );
    }
}

#[test]
fn the_same_seed_writes_the_same_bytes() {
    let dir = scratch("generate-seed");
    let (a, b, c) = (dir.join("a.ron"), dir.join("b.ron"), dir.join("c.ron"));
    for (path, seed) in [(&a, "7"), (&b, "7"), (&c, "8")] {
        assert_ok(generate(&["--count", "300", "--seed", seed, "--motion"], path));
    }
    let (a, b, c) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap(), std::fs::read(c).unwrap());
    assert_eq!(a, b, "seed 7 twice gave different files");
    assert_ne!(a, c, "seeds 7 and 8 gave the same file");
    // Written atomically: no temporary file is left beside it.
    let names: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(names.iter().all(|n| n.ends_with(".ron") && !n.starts_with('.')), "{names:?}");
}

#[test]
fn generated_scenes_load_with_every_support_in_bounds() {
    let dir = scratch("generate-load");
    for (flags, kernel) in [(&[][..], "Compact"), (&["--gaussian"][..], "Gaussian")] {
        let path = dir.join(format!("{kernel}.ron"));
        let mut args = vec!["--count", "1000", "--seed", "3"];
        args.extend_from_slice(flags);
        let summary = assert_ok(generate(&args, &path));
        assert!(summary.contains("1000"), "{summary}");
        let scene = Scene::load(&path).unwrap();
        assert_eq!(scene.primitive_count(), 1000);
        assert_eq!(scene.groups.len(), 1);
        assert!(scene.animation.is_static());
        assert_eq!(scene.marching.method, isomarch::Method::QuadraticTaylor);
        assert_eq!(scene.iso, 0.5);
        for p in scene.primitives() {
            let matches = match p {
                Primitive::Point { kernel: Kernel::Compact { radius, .. }, .. } => kernel == "Compact" && *radius == 1.0,
                Primitive::Point { kernel: Kernel::Gaussian { r, s, .. }, .. } => kernel == "Gaussian" && *r == 0.5 && *s == 2.0,
                _ => false,
            };
            assert!(matches, "{kernel} scene holds {p:?}");
        }
        assert_bounds_hold_supports(&scene);
        // The density is fixed: the centres fill a cube of side 1.5 N^(1/3).
        let side = isomarch::generate::SPACING * 1000f64.cbrt();
        for p in scene.primitives() {
            let Primitive::Point { center, .. } = p else { unreachable!() };
            assert!(center.abs().max_element() <= 0.5 * side + 1e-6, "{center} outside the cube of side {side}");
        }
        // The camera sees the whole box: every corner is inside the view.
        let cam = &scene.camera;
        let forward = (cam.target - cam.eye).normalize();
        let half = (0.5 * cam.fov_y_deg.to_radians()).tan();
        for i in 0..8 {
            let b = scene.bounds;
            let corner = DVec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            );
            let to = corner - cam.eye;
            let depth = to.dot(forward);
            assert!(depth > 0.0 && (to - depth * forward).length() / depth < half, "corner {corner} is out of view");
        }
    }
}

#[test]
fn moving_particles_stay_inside_their_bounds() {
    let dir = scratch("generate-motion");
    let path = dir.join("moving.ron");
    assert_ok(generate(&["--count", "200", "--seed", "5", "--motion"], &path));
    let scene = Scene::load(&path).unwrap();
    assert_eq!(scene.animation.primitives.len(), 200, "every centre moves");
    assert!(scene.bounds_explicit, "the box stays put while the blobs move");
    for t in [0.0, 0.37, 1.0, 1.9, 2.6, 3.3] {
        let posed = scene.at_time(t);
        assert_eq!(posed.bounds, scene.bounds);
        assert_bounds_hold_supports(&posed);
    }
    assert_ne!(scene.at_time(0.5).groups, scene.at_time(0.0).groups, "nothing moved");
}

#[test]
fn bad_arguments_are_refused_in_one_line() {
    let dir = scratch("generate-refuse");
    for (args, name, expect) in
        [(&["--count", "0"][..], "zero.ron", "--count"), (&["--count", "10"][..], "scene.txt", ".ron"), (&["--count", "10"][..], "scene", ".ron")]
    {
        let path = dir.join(name);
        let (stderr, stdout) = generate(args, &path).fails_in_one_line_and_stdout();
        assert!(stderr.starts_with("error: ") && stderr.contains(expect), "{stderr}");
        assert!(stdout.is_empty(), "{stdout}");
        assert!(!path.exists(), "{name} was written");
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

/// The index's fields hold sane values for a scene of `primitives`.
fn assert_sane_index(index: &serde_json::Value, primitives: u64) {
    let num = |k: &str| index[k].as_f64().unwrap_or_else(|| panic!("index.{k} missing or not a number: {index}"));
    assert!(num("entries") >= primitives as f64, "every blob is in at least one cell: {index}");
    assert!(num("build_ns") > 0.0, "{index}");
    assert!(num("longest_list") >= 1.0 && num("longest_list") <= num("entries"), "{index}");
    assert!(num("cells") >= 1.0 && num("cell_size") > 0.0 && num("bytes_per_primitive") > 0.0, "{index}");
}

#[test]
fn render_and_bench_report_the_spatial_index() {
    let dir = scratch("generate-stats");
    let scene = dir.join("p1000.ron");
    assert_ok(generate(&["--count", "1000", "--seed", "2"], &scene));
    let (s, stats) = (scene.to_str().unwrap(), dir.join("p1000.json"));
    // A frame of camera rays alone takes the camera's tile lists and
    // builds no index; with the lists off (ISOMARCH_TILES=off), the grid.
    run_ok(&["render", s, "--size", "48x48", "-o", dir.join("p.png").to_str().unwrap(), "--stats", stats.to_str().unwrap()]);
    let v = json(&stats);
    assert_eq!(v["acceleration"], "tiles", "{v}");
    assert!(v["index"].is_null(), "an index was built for camera rays alone: {v}");
    let tiles = &v["tiles"];
    let num = |k: &str| tiles[k].as_f64().unwrap_or_else(|| panic!("tiles.{k} missing or not a number: {tiles}"));
    assert!(num("entries") >= 100.0 && num("longest_list") >= 1.0 && num("tiles") == 36.0 && num("bytes") > 0.0, "{tiles}");
    isomarch(["render", s, "--size", "48x48", "-o", dir.join("p.png").to_str().unwrap(), "--stats", stats.to_str().unwrap()])
        .env("ISOMARCH_TILES", "off")
        .ok();
    let v = json(&stats);
    assert_eq!(v["acceleration"], "grid", "{v}");
    assert!(v["tiles"].is_null(), "{v}");
    assert_sane_index(&v["index"], 1000);

    let bench = dir.join("bench.json");
    let out = run_ok(&["bench", s, "--methods", "quadratic-taylor", "--rays", "256", "--json", bench.to_str().unwrap()]);
    assert_sane_index(&json(&bench)["index"], 1000);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("Spatial index:") && table.contains("entries"), "no index footer:\n{table}");

    // fig10's 36 blobs march without an index: none reported.
    let fig10 = repo_root().join("scenes/fig10.ron");
    let stats = dir.join("fig10.json");
    run_ok(&["render", fig10.to_str().unwrap(), "--size", "32x32", "-o", dir.join("f.png").to_str().unwrap(), "--stats", stats.to_str().unwrap()]);
    let v = json(&stats);
    assert!(v.get("index").is_some_and(serde_json::Value::is_null), "fig10 reports an index: {v}");
    assert!(v["steps_per_ray"].as_f64().is_some(), "{v}");
}

/// `index_build_ms` of a batch's CSV, one entry per frame.
fn index_column(csv: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = header.iter().position(|h| *h == "index_build_ms").unwrap_or_else(|| panic!("no index_build_ms column: {header:?}"));
    // The file column is quoted and holds no comma here.
    lines.map(|l| l.split(',').nth(at).unwrap_or_else(|| panic!("short row {l}")).to_string()).collect()
}

#[test]
fn batch_frames_log_each_index_build() {
    let dir = scratch("generate-batch");
    let moving = dir.join("moving.ron");
    assert_ok(generate(&["--count", "150", "--seed", "4", "--motion"], &moving));
    let csv = dir.join("moving.csv");
    let pattern = dir.join("m_####.png");
    // The grid (the camera's tile lists build no index).
    isomarch([
        "render",
        moving.to_str().unwrap(),
        "--size",
        "24x24",
        "--frames",
        "0..3",
        "-o",
        pattern.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ])
    .env("ISOMARCH_TILES", "off")
    .ok();
    let builds = index_column(&csv);
    assert_eq!(builds.len(), 3);
    for b in &builds {
        assert!(b.parse::<f64>().is_ok_and(|ms| ms > 0.0), "an animated scene rebuilds its index every frame: {builds:?}");
    }
    // Each batch frame is the single frame at its time (n / 25 fps), byte
    // for byte; and the frames differ, so the comparison has moving blobs.
    let frame = |n: usize| std::fs::read(dir.join(format!("m_{n:04}.png"))).unwrap();
    assert_ne!(frame(0), frame(2), "the blobs do not move between frames 0 and 2");
    for n in [1usize, 2] {
        let single = dir.join(format!("single_{n}.png"));
        let time = format!("{}", n as f64 / 25.0);
        // As the batch, through the grid.
        isomarch(["render", moving.to_str().unwrap(), "--size", "24x24", "--time", &time, "-o", single.to_str().unwrap()])
            .env("ISOMARCH_TILES", "off")
            .ok();
        assert!(frame(n) == std::fs::read(&single).unwrap(), "batch frame {n} differs from render --time {time}");
    }
    // Without an index the column is empty.
    let csv = dir.join("fig10.csv");
    let pattern = dir.join("f_####.png");
    let fig10 = repo_root().join("scenes/fig10.ron");
    run_ok(&[
        "render",
        fig10.to_str().unwrap(),
        "--size",
        "16x16",
        "--frames",
        "0..2",
        "-o",
        pattern.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(index_column(&csv), vec![String::new(), String::new()]);
}
