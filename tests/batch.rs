//! Batch frames through the binary: shards cover a range exactly once, the
//! scheduler's environment picks the shard, and a batch stopped by Ctrl-C
//! leaves only whole frames and resumes with --skip-existing; merge-stats
//! joins shards' CSVs. On a real SLURM: tests/slurm.rs.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::common::*;

/// The frame numbers listed in a batch's statistics CSV.
fn csv_frames(csv: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(csv).unwrap_or_else(|e| panic!("{}: {e}", csv.display()));
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("frame,time_s,"), "header");
    lines.map(|l| l.split(',').next().unwrap().parse().unwrap()).collect()
}

/// `render scenes/default.ron` at 32x32 into `dir` with `extra` flags, in
/// no scheduler's environment but `envs`; to run.
fn render_batch(dir: &Path, extra: &[&str], envs: &[(&str, &str)]) -> Isomarch {
    isomarch(["render", "scenes/default.ron", "--size", "32x32", "-o"])
        .arg(dir.join("f_####.png"))
        .args(extra)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .envs(envs.iter().copied())
        .current_dir(repo_root())
}

/// Every file in `dir` that a frame pattern names decodes as a whole PNG,
/// and no temporary file is left.
fn assert_only_whole_frames(dir: &Path) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "temporary file {name} left behind");
        if name.ends_with(".png") {
            image::open(dir.join(&name)).unwrap_or_else(|e| panic!("{name} is not a whole PNG: {e}"));
            names.insert(name);
        }
    }
    names
}

#[test]
fn two_shards_cover_a_frame_range_exactly_once() {
    let dir = scratch("shards");
    let mut seen = Vec::new();
    for shard in ["0/2", "1/2"] {
        let csv = dir.join(format!("shard{}.csv", &shard[..1]));
        render_batch(&dir, &["--frames", "0..=6", "--shard", shard, "--csv", csv.to_str().unwrap()], &[]).ok();
        seen.extend(csv_frames(&csv));
    }
    seen.sort();
    assert_eq!(seen, (0..=6).collect::<Vec<u64>>(), "each frame rendered exactly once");
    let names = assert_only_whole_frames(&dir);
    assert_eq!(names.len(), 7);
    assert!(names.contains("f_0000.png") && names.contains("f_0006.png"));
    // merge-stats: one CSV in frame order; a shard left out is refused.
    let merge = |out: &Path, shards: &[&str]| {
        isomarch(["merge-stats", "--frames", "0..=6", "-o"]).arg(out).args(shards.iter().map(|s| dir.join(format!("shard{s}.csv"))))
    };
    let merged = dir.join("merged.csv");
    merge(&merged, &["1", "0"]).ok();
    assert_eq!(csv_frames(&merged), (0..=6).collect::<Vec<u64>>());
    let err = merge(&dir.join("half.csv"), &["0"]).fails();
    assert!(err.contains("3 frame(s) missing (1, 3, 5)"), "{err}");
    assert!(!dir.join("half.csv").exists());
    let err = merge(&dir.join("twice.csv"), &["0", "1", "0"]).fails();
    assert!(err.contains("listed more than once"), "{err}");
}

#[test]
fn the_shard_comes_from_slurm_or_kubernetes() {
    let dir = scratch("scheduler");
    let slurm = [("SLURM_ARRAY_TASK_ID", "5"), ("SLURM_ARRAY_TASK_MIN", "4"), ("SLURM_ARRAY_TASK_COUNT", "3")];
    let csv = dir.join("slurm.csv");
    render_batch(&dir, &["--frames", "0..9", "--csv", csv.to_str().unwrap()], &slurm).ok();
    assert_eq!(csv_frames(&csv), vec![1, 4, 7], "SLURM task 5 of 4..=6 is shard 1 of 3");
    let csv = dir.join("k8s.csv");
    render_batch(&dir, &["--frames", "0..9", "--shard-count", "4", "--csv", csv.to_str().unwrap()], &[("JOB_COMPLETION_INDEX", "2")]).ok();
    assert_eq!(csv_frames(&csv), vec![2, 6]);
    // An Indexed Job without --shard-count is refused.
    let err = render_batch(&dir, &["--frames", "0..9"], &[("JOB_COMPLETION_INDEX", "2")]).fails();
    assert!(err.contains("--shard-count"), "{err}");
    // A count of 0 and an index past the count: one line, nothing written.
    let bad = scratch("scheduler-bad");
    for (count, index) in [("0", "0"), ("3", "3")] {
        let err = render_batch(&bad, &["--frames", "0..9", "--shard-count", count], &[("JOB_COMPLETION_INDEX", index)]).fails_in_one_line();
        assert!(err.contains(&format!("shard {index} of {count} does not exist")), "{err}");
    }
    assert_eq!(std::fs::read_dir(&bad).unwrap().count(), 0, "a refused shard wrote something");
}

/// docs/k8s-frames-job.yaml: an Indexed Job whose --shard-count is its
/// completions, with a CSV per pod and --skip-existing.
#[test]
fn the_kubernetes_manifest_shards_by_its_completions() {
    let text = std::fs::read_to_string(repo_root().join("docs/k8s-frames-job.yaml")).unwrap();
    // The manifest without its comments.
    let yaml: String = text.lines().filter(|l| !l.trim_start().starts_with('#')).map(|l| format!("{l}\n")).collect();
    let value = |key: &str| {
        let line = yaml.lines().find(|l| l.trim_start().starts_with(key)).unwrap_or_else(|| panic!("no {key}"));
        line.split_once(key).unwrap().1.trim().to_string()
    };
    assert_eq!(value("completionMode:"), "Indexed");
    let completions = value("completions:");
    let count = yaml.split("--shard-count").nth(1).expect("--shard-count").split_whitespace().next().unwrap();
    assert_eq!(count, completions, "--shard-count must equal completions");
    for needed in ["--skip-existing", "frames-task-$JOB_COMPLETION_INDEX.csv", "--frames"] {
        assert!(yaml.contains(needed), "the manifest lacks {needed}");
    }
}

#[test]
fn an_interrupted_batch_resumes_with_skip_existing() {
    let dir = scratch("resume");
    let frames = 150;
    let range = format!("0..{frames}");
    // Large enough frames that the batch is still running when stopped.
    let mut child = isomarch(["render", "scenes/fig10.ron", "--size", "96x96", "--frames", &range, "-o"])
        .arg(dir.join("f_####.png"))
        .current_dir(repo_root())
        .stderr(Stdio::piped())
        .spawn();
    let start = Instant::now();
    while !dir.join("f_0001.png").exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "no frame after two minutes");
        assert!(child.try_wait().unwrap().is_none(), "the batch ended before it could be interrupted");
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: kill(2) on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "Ctrl-C ends the batch with status 130");
    let before = assert_only_whole_frames(&dir);
    assert!(before.len() < frames, "the interruption came too late to test anything ({} frames)", before.len());
    let mtimes: Vec<_> = before.iter().map(|n| std::fs::metadata(dir.join(n)).unwrap().modified().unwrap()).collect();

    isomarch(["render", "scenes/fig10.ron", "--size", "96x96", "--frames", &range, "--skip-existing", "-o"])
        .arg(dir.join("f_####.png"))
        .current_dir(repo_root())
        .ok();
    let after = assert_only_whole_frames(&dir);
    assert_eq!(after.len(), frames, "every frame is on disk after the resume");
    for (name, mtime) in before.iter().zip(mtimes) {
        assert_eq!(std::fs::metadata(dir.join(name)).unwrap().modified().unwrap(), mtime, "{name} was rendered again");
    }
    // The CSV holds each frame once: the interrupted run's and the resumed run's rows.
    let mut listed = csv_frames(&dir.join("frames.csv"));
    listed.sort();
    assert_eq!(listed, (0..frames as u64).collect::<Vec<_>>());
}

#[test]
fn animated_frames_move_and_static_frames_do_not() {
    let dir = scratch("animated");
    // 0..=25 in shard 0 of 25: frames 0 and 25, one second apart.
    let frames = |scene: &str, sub: &str| {
        let out = dir.join(sub);
        isomarch(["render", scene, "--size", "48x40", "--frames", "0..=25", "--shard", "0/25", "-o"])
            .arg(out.join("f_##.png"))
            .current_dir(repo_root())
            .ok();
        let a = image::open(out.join("f_00.png")).unwrap().to_rgb8();
        let b = image::open(out.join("f_25.png")).unwrap().to_rgb8();
        a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
    };
    assert!(frames("scenes/fig16.ron", "moving") > 20, "fig16's blobs move between t = 0 s and t = 1 s");
    assert_eq!(frames("scenes/default.ron", "still"), 0, "a scene without motion renders the same frame");
}

/// `isomarch tradeoff --quick`: a CSV row per setting with finite figures,
/// a plot in PNG and SVG, a Pareto front of undominated settings, and more
/// steps or a finer minimum step never make a method less accurate.
#[test]
fn tradeoff_writes_its_csv_and_plot() {
    let dir = scratch("tradeoff");
    isomarch(["tradeoff", "scenes/fig10.ron", "--quick", "-o"]).arg(&dir).current_dir(repo_root()).ok();
    let text = std::fs::read_to_string(dir.join("tradeoff.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert_eq!(rows.len(), 2 * 2 * 2, "2 methods x 2 minimum steps x 2 budgets");
    let num = |r: &Vec<String>, c: &str| r[col(c)].parse::<f64>().unwrap_or_else(|_| panic!("{c} = {:?}", r[col(c)]));
    let mut front = Vec::new();
    for r in &rows {
        for c in ["ns_per_ray", "steps_per_ray", "error", "mean_error", "p99_error", "miss_rate"] {
            assert!(num(r, c).is_finite() && num(r, c) >= 0.0, "{c} in {r:?}");
        }
        if r[col("pareto")] == "true" {
            front.push((num(r, "ns_per_ray"), num(r, "error")));
        }
    }
    assert!(!front.is_empty(), "an empty Pareto front");
    for r in &rows {
        let (t, e) = (num(r, "ns_per_ray"), num(r, "error"));
        for &(ft, fe) in &front {
            assert!(!(t <= ft && e <= fe && (t < ft || e < fe)), "front point ({ft}, {fe}) is dominated by {r:?}");
        }
    }
    for method in ["segment", "quadratic-taylor"] {
        let error = |min_step: &str, max_steps: &str| {
            let r = rows.iter().find(|r| r[0] == method && r[1] == min_step && r[2] == max_steps).unwrap();
            num(r, "error")
        };
        // Within rounding: an inclusion method's crossings are bracketed by
        // its bounds whatever the minimum step, so its two errors differ
        // only by the f32 rounding of different refinement paths.
        assert!(error("0.01", "1000") <= 1.01 * error("0.1", "32") + 1e-9, "{method}: the finest, longest setting is less accurate");
    }
    let png = image::open(dir.join("tradeoff.png")).unwrap().to_rgb8();
    let distinct: std::collections::HashSet<_> = png.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 10, "a blank plot");
    let svg = std::fs::read_to_string(dir.join("tradeoff.svg")).unwrap();
    assert!(svg.contains("<svg"));
    let texts: Vec<&str> =
        svg.split("<text").skip(1).filter_map(|t| t.split_once('>')).map(|(_, rest)| rest.split("</text>").next().unwrap().trim()).collect();
    // Every decade the times and the errors span is labelled on its axis.
    let span = |c: &str| rows.iter().map(|r| num(r, c).max(1e-7)).fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    for c in ["ns_per_ray", "error"] {
        let (lo, hi) = span(c);
        for k in lo.log10().floor() as i32..=hi.log10().ceil() as i32 {
            let label = isomarch::output::plot::decade_label(10f64.powi(k));
            assert!(texts.contains(&label.as_str()), "{c}: decade {label} not labelled: {texts:?}");
        }
    }
    // --replot draws the plot again from the CSV alone.
    std::fs::remove_file(dir.join("tradeoff.png")).unwrap();
    isomarch(["tradeoff", "scenes/fig10.ron", "--replot", "-o"]).arg(&dir).current_dir(repo_root()).ok();
    assert!(image::open(dir.join("tradeoff.png")).is_ok(), "--replot wrote no PNG");
}

/// A small animated scene: blobs that move and change size, a camera
/// fixed on them.
const MOVING: &str = r#"Scene(
    camera: (eye: (0.0, 1.5, 7.0), target: (0.0, 0.0, 0.0), resolution: (32, 32)),
    iso: 0.5,
    marching: (method: "quadratic-taylor", min_step: 0.01),
    groups: [(primitives: [
        Point(center: (-1.0, 0.0, 0.0), kernel: Compact(radius: 1.8),
              motion: Some(Sine(axis: (0.0, 1.0, 0.0), amplitude: 0.6, period: 1.0, phase: 0.3))),
        Point(center: (1.0, 0.0, 0.0), kernel: Gaussian(r: 0.9, s: 2.0),
              radius_scale: Some(Sine(amplitude: 0.3, period: 0.7, phase: 0.0))),
    ])],
)"#;

/// Frame n of `--frames` is, byte for byte, `render --time n/fps` of the
/// same scene (the time written as Rust prints n as f64 / fps, so that both
/// pose the scene at the same f64).
#[test]
fn batch_frames_equal_single_renders_at_their_times() {
    let dir = scratch("batch-equal");
    let scene = dir.join("moving.ron");
    std::fs::write(&scene, MOVING).unwrap();
    let s = scene.to_str().unwrap();
    let fps = 7.0;
    run_ok(&["render", s, "--frames", "0..4", "--fps", "7", "-o", dir.join("f_####.png").to_str().unwrap()]);
    let mut frames = Vec::new();
    for n in 0..4u32 {
        let batch = std::fs::read(dir.join(format!("f_{n:04}.png"))).unwrap();
        let time = format!("{}", f64::from(n) / fps);
        let single = dir.join(format!("single_{n}.png"));
        run_ok(&["render", s, "--time", &time, "-o", single.to_str().unwrap()]);
        assert!(batch == std::fs::read(&single).unwrap(), "frame {n} of the batch differs from render --time {time}");
        frames.push(batch);
    }
    // The scene moves: the frames are not all the same picture.
    for n in 1..4 {
        assert_ne!(frames[0], frames[n], "frames 0 and {n} are identical: nothing moves");
    }
}

/// Two batches of different scenes into one folder share the default
/// `frames.csv`: the second is refused before it renders, in one line
/// that says what to do, and the CSV keeps only the first's rows; the same
/// scene's batch may append (a resumed batch, another range), and with
/// its own `--csv` the second batch runs.
#[test]
fn a_batch_does_not_append_rows_to_another_scenes_csv() {
    let dir = scratch("batch-two-scenes");
    let csv = dir.join("frames.csv");
    render_batch(&dir, &["--frames", "0..2"], &[]).ok();
    let stderr = isomarch(["render", "scenes/fig1.ron", "--size", "32x32", "--frames", "0..2", "-o"])
        .arg(dir.join("g_####.png"))
        .current_dir(repo_root())
        .fails_in_one_line();
    assert!(stderr.contains("lists a frame of scenes/default.ron, and this batch renders scenes/fig1.ron") && stderr.contains("--csv"), "{stderr}");
    assert!(!dir.join("g_0000.png").exists(), "the refused batch rendered");
    assert_eq!(csv_frames(&csv), vec![0, 1]);
    // The same scene appends: frames 2 and 3 after 0 and 1.
    render_batch(&dir, &["--frames", "2..4"], &[]).ok();
    assert_eq!(csv_frames(&csv), vec![0, 1, 2, 3]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.lines().skip(1).all(|l| l.ends_with(",\"scenes/default.ron\"")), "{text}");
    // Its own CSV: the other scene runs.
    isomarch(["render", "scenes/fig1.ron", "--size", "32x32", "--frames", "0..2", "-o"])
        .arg(dir.join("g_####.png"))
        .arg("--csv")
        .arg(dir.join("fig1.csv"))
        .current_dir(repo_root())
        .ok();
    assert_eq!(csv_frames(&dir.join("fig1.csv")), vec![0, 1]);
}

/// `tradeoff --min-steps` and `--max-steps-list` are the sweep: exactly
/// their settings, each a row, and each minimum step and budget reaching
/// the march (a budget of 4 runs rays out of steps that 64 finishes).
#[test]
fn tradeoff_sweeps_the_settings_it_is_given() {
    let dir = scratch("tradeoff-lists");
    isomarch(["tradeoff", "scenes/fig10.ron", "--methods", "segment", "--min-steps", "0.05,0.2", "--max-steps-list", "4,64", "--rays", "256", "-o"])
        .arg(&dir)
        .current_dir(repo_root())
        .ok();
    let text = std::fs::read_to_string(dir.join("tradeoff.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name}"));
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let mut settings: Vec<(&str, &str, &str)> = rows.iter().map(|r| (r[0], r[1], r[2])).collect();
    settings.sort_unstable();
    assert_eq!(
        settings,
        [("segment", "0.05", "4"), ("segment", "0.05", "64"), ("segment", "0.2", "4"), ("segment", "0.2", "64")],
        "the rows are not the settings given:\n{text}"
    );
    let num = |min: &str, max: &str, c: &str| {
        let r = rows.iter().find(|r| r[1] == min && r[2] == max).unwrap();
        r[col(c)].parse::<f64>().unwrap()
    };
    for min in ["0.05", "0.2"] {
        assert!(num(min, "4", "out_of_steps_rate") > num(min, "64", "out_of_steps_rate"), "minimum step {min}: budget 4 against 64\n{text}");
    }
    // A larger minimum step takes fewer steps.
    assert!(num("0.2", "64", "steps_per_ray") < num("0.05", "64", "steps_per_ray"), "{text}");
}

/// The look's flags and `--legend` under `--frames`: frame 1 of a batch of
/// 1A8O turning (`--turntable 4`, one frame a second) with a B-factor
/// legend, depth cueing and a magenta outline is, byte for byte, `render
/// --time 1` with the same flags: 26 legend rows under the image and an
/// outline; and so is a batch frame with a transparent background (an
/// RGBA PNG, its corners transparent).
#[test]
fn batch_frames_keep_the_look_and_the_legend() {
    let dir = scratch("batch-look");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let common = ["--turntable", "4", "--size", "48x48", "--color", "bfactor"];
    let looks: [&[&str]; 2] = [
        &["--legend", "--depth-cue", "0.2:0.9", "--outline", "2", "--outline-jump", "0.05", "--outline-color", "#ff00ff"],
        &["--transparent-background", "--outline", "--depth-cue"],
    ];
    let mut frames = Vec::new();
    for (k, flags) in looks.iter().enumerate() {
        let pattern = dir.join(format!("look{k}_#.png"));
        isomarch(["render", pdb.to_str().unwrap(), "--frames", "0..2", "--fps", "1", "-o", pattern.to_str().unwrap()])
            .args(["--csv", dir.join(format!("look{k}.csv")).to_str().unwrap()])
            .args(common)
            .args(*flags)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .ok();
        let single = dir.join(format!("single{k}.png"));
        isomarch(["render", pdb.to_str().unwrap(), "--time", "1", "-o", single.to_str().unwrap()]).args(common).args(*flags).ok();
        let batch = std::fs::read(dir.join(format!("look{k}_1.png"))).unwrap();
        assert!(batch == std::fs::read(&single).unwrap(), "batch frame 1 with {flags:?} differs from render --time 1 with them");
        frames.push(image::load_from_memory(&batch).unwrap());
    }
    let legend = frames[0].to_rgb8();
    assert_eq!(legend.dimensions(), (48, 48 + 26), "the legend's rows under the frame");
    let outline = legend.pixels().take(48 * 48).filter(|p| p.0 == [255, 0, 255]).count();
    assert!(outline > 40, "only {outline} outline pixels");
    assert_eq!(frames[1].color(), image::ColorType::Rgba8, "a transparent background's frame is RGBA");
    let clear = frames[1].to_rgba8();
    assert!([(0, 0), (47, 0), (0, 47), (47, 47)].iter().all(|&(x, y)| clear.get_pixel(x, y)[3] == 0), "the corners are not transparent");
}
