//! Trajectories through the binary (docs/trajectories.md): every frame of
//! each test trajectory is read as MDAnalysis reads it, every frame
//! renders, a batch frame equals the render of the scene file written for
//! it byte for byte, files of several models play their models, and bad
//! trajectories are one-line errors naming the file and the frame, with
//! nothing written.

use std::path::{Path, PathBuf};

use crate::common::*;

fn data(name: &str) -> String {
    repo_root().join("tests/data/trajectories").join(name).to_str().unwrap().to_string()
}

/// The rows of a CSV as numbers (empty fields as NaN), without its header.
fn rows(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines();
    let head = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines.map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect()).collect();
    (head, rows)
}

/// (name, topology, trajectory, MDAnalysis's reference in reference/),
/// and the variants scripts/trajectory-reference.py writes with it: a DCD
/// with a unit cell in every frame, the same file big-endian (checked
/// against the little-endian rows: MDAnalysis misreads its time step),
/// and an XTC of precision 100.
const PAIRS: [(&str, &str, &str, &str); 6] = [
    ("YiiP_lipids", "YiiP_lipids.gro.gz", "YiiP_lipids.xtc", "YiiP_lipids"),
    ("adk_oplsaa", "adk_oplsaa.gro.gz", "adk_oplsaa.xtc", "adk_oplsaa"),
    ("adk_dims", "adk.psf", "adk_dims.dcd", "adk_dims"),
    ("adk_cell", "adk.psf", "adk_cell.dcd", "adk_cell"),
    ("adk_big", "adk.psf", "adk_big.dcd", "adk_cell"),
    ("adk_prec", "adk_oplsaa.gro.gz", "adk_prec.xtc", "adk_prec"),
];

#[test]
fn every_frame_agrees_with_mdanalysis() {
    for (name, top, traj, reference) in PAIRS {
        let reference = std::fs::read_to_string(data(&format!("reference/{reference}.csv"))).unwrap();
        let (head, want) = rows(&reference);
        // The atoms MDAnalysis printed: 0, 1, n/2, n-1.
        let atoms: Vec<String> = head.iter().filter(|h| h.starts_with('x')).map(|h| h[1..].to_string()).collect();
        let out = isomarch(["frames", &data(top), &data(traj), "--atoms", &atoms.join(",")]).ok();
        let (got_head, got) = rows(&String::from_utf8_lossy(&out.stdout));
        assert_eq!(got_head, head, "{name}: columns");
        assert_eq!(got.len(), want.len(), "{name}: frame count");
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g[0], w[0], "{name}: frame number");
            // Times to the microsecond of a picosecond as printed.
            assert!((g[1] - w[1]).abs() <= 2e-6 * w[1].abs().max(1.0), "{name} frame {}: time {} against {}", w[0], g[1], w[1]);
            assert_eq!(g[2], w[2], "{name} frame {}: atom count", w[0]);
            // Positions: XTC holds 0.01 Å and DCD f32; both readers widen
            // the same f32 values (MDAnalysis scales nm to Å in f32, so
            // 1e-5 relative separates them at most).
            for (c, (a, b)) in g[3..].iter().zip(&w[3..]).enumerate() {
                assert!((a - b).abs() <= 2e-4, "{name} frame {} column {}: {a} against MDAnalysis {b}", w[0], head[3 + c]);
            }
        }
    }
}

#[test]
fn every_frame_of_every_trajectory_renders() {
    for (name, top, traj, reference) in PAIRS {
        let dir = scratch(&format!("traj-all-{name}"));
        let count = rows(&std::fs::read_to_string(data(&format!("reference/{reference}.csv"))).unwrap()).1.len();
        let pattern = dir.join("f_###.png");
        let range = format!("0..{count}");
        isomarch(["render", &data(top), &data(traj), "--frames", &range, "-o", pattern.to_str().unwrap(), "--size", "24x24", "--timeout", "300"])
            .ok();
        for k in 0..count {
            let png = dir.join(format!("f_{k:03}.png"));
            let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display())).to_rgb8();
            let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
            colours.sort_unstable();
            colours.dedup();
            assert!(colours.len() > 20, "{name} frame {k}: a nearly uniform image ({} colours)", colours.len());
        }
        // Past the last frame: refused before anything is rendered.
        let past = format!("0..{}", count + 1);
        let empty = scratch(&format!("traj-past-{name}"));
        let err = isomarch(["render", &data(top), &data(traj), "--frames", &past, "-o", empty.join("f_###.png").to_str().unwrap(), "--size", "8x8"])
            .fails();
        assert!(err.contains(&format!("no frame {count}")), "{name}: {err}");
        assert_eq!(std::fs::read_dir(&empty).unwrap().count(), 0, "{name}: a refused batch wrote something");
    }
}

/// `render TOP TRAJ --frames` and `scene TOP TRAJ --frame n` + `render`.
fn batch_equals_scene_files(name: &str, top: &str, traj: &str, frames: &[usize], extra: &[&str]) {
    let dir = scratch(&format!("traj-same-{name}"));
    let last = frames.iter().max().unwrap() + 1;
    let range = format!("0..{last}");
    let pattern = dir.join("f_###.png");
    let mut args = vec!["render", top, traj, "--frames", &range, "-o", pattern.to_str().unwrap(), "--size", "48x48"];
    args.extend(extra);
    isomarch(args).ok();
    for &k in frames {
        let ron = dir.join(format!("s{k}.ron"));
        let frame = k.to_string();
        let mut args = vec!["scene", top, traj, "--frame", &frame, "-o", ron.to_str().unwrap()];
        args.extend(extra.iter().filter(|a| !a.starts_with("--method")));
        isomarch(args).ok();
        let single = dir.join(format!("r{k}.png"));
        let mut args = vec!["render", ron.to_str().unwrap(), "-o", single.to_str().unwrap(), "--size", "48x48"];
        args.extend(extra.iter().filter(|a| a.starts_with("--method")));
        isomarch(args).ok();
        let a = std::fs::read(&single).unwrap();
        let b = std::fs::read(dir.join(format!("f_{k:03}.png"))).unwrap();
        assert!(a == b, "{name}: frame {k} of the batch differs from the render of its scene file");
    }
}

#[test]
fn a_batch_frame_equals_the_render_of_its_scene_file() {
    batch_equals_scene_files("dcd", &data("adk.psf"), &data("adk_dims.dcd"), &[0, 5, 11], &[]);
    batch_equals_scene_files("xtc", &data("YiiP_lipids.gro.gz"), &data("YiiP_lipids.xtc"), &[0, 4], &["--framing", "all", "--hydrogens"]);
}

/// A PDB of `models` models of three atoms, moved 1 Å along x per model.
fn multi_model_pdb(models: usize) -> String {
    let mut s = String::new();
    for m in 0..models {
        s.push_str(&format!("MODEL     {:>4}\n", m + 1));
        for (i, (name, el, x)) in [(" N  ", "N", 0.0), (" CA ", "C", 1.45), (" C  ", "C", 2.9)].iter().enumerate() {
            let x = x + m as f64;
            s.push_str(&format!("ATOM  {:>5} {name} GLY A   1    {x:>8.3}{:>8.3}{:>8.3}  1.00  0.00          {el:>2}\n", i + 1, 0.0, 0.0));
        }
        s.push_str("ENDMDL\n");
    }
    s.push_str("END\n");
    s
}

#[test]
fn files_of_several_models_play_their_models() {
    let dir = scratch("traj-models");
    let pdb = dir.join("nmr.pdb");
    std::fs::write(&pdb, multi_model_pdb(3)).unwrap();
    let out = isomarch(["frames", pdb.to_str().unwrap(), "--atoms", "0"]).ok();
    let (_, got) = rows(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(got.iter().map(|r| r[6]).collect::<Vec<_>>(), [0.0, 1.0, 2.0], "atom 0's x in models 1 to 3");
    isomarch(["render", pdb.to_str().unwrap(), "--frames", "0..3", "-o", dir.join("m_#.png").to_str().unwrap(), "--size", "16x16"]).ok();
    assert!((0..3).all(|k| dir.join(format!("m_{k}.png")).exists()));

    // mmCIF: models by pdbx_PDB_model_num.
    let mut cif = String::from(
        "data_x\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n\
         _atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.pdbx_PDB_model_num\n",
    );
    for m in 1..=2 {
        for (i, x) in [0.0, 1.5].iter().enumerate() {
            cif.push_str(&format!("ATOM {} C C{i} {} 0.0 0.0 {m}\n", i + 1, x + f64::from(m) * 10.0));
        }
    }
    let path = dir.join("two.cif");
    std::fs::write(&path, cif).unwrap();
    let out = isomarch(["frames", path.to_str().unwrap(), "--atoms", "1"]).ok();
    let (_, got) = rows(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(got.iter().map(|r| r[6]).collect::<Vec<_>>(), [11.5, 21.5], "atom 1's x in models 1 and 2");

    // A GRO of two frames, the second with a time in its title.
    let frame = |t: f64, x: f64| {
        format!(
            "t= {t:.5}\n    2\n    1GLY      N    1   {x:.3}   0.000   0.000\n    1GLY     CA    2   {:.3}   0.000   0.000\n   1.0 1.0 1.0\n",
            x + 0.15
        )
    };
    let gro = dir.join("two.gro");
    std::fs::write(&gro, frame(0.0, 0.0) + &frame(10.0, 1.0)).unwrap();
    let out = isomarch(["frames", gro.to_str().unwrap(), "--atoms", "0"]).ok();
    let (_, got) = rows(&String::from_utf8_lossy(&out.stdout));
    assert_eq!(got.iter().map(|r| (r[1], r[6])).collect::<Vec<_>>(), [(0.0, 0.0), (10.0, 10.0)], "time and atom 0's x (Å)");

    // One model: --frame beyond it is refused.
    let one = dir.join("one.pdb");
    std::fs::write(&one, multi_model_pdb(1)).unwrap();
    let err = isomarch(["render", one.to_str().unwrap(), "--frame", "1", "-o", dir.join("x.png").to_str().unwrap()]).fails();
    assert!(err.contains("holds one frame"), "{err}");
}

/// A copy of `name` in `dir`, changed by `f`.
fn damaged(dir: &Path, name: &str, f: impl FnOnce(&mut Vec<u8>)) -> PathBuf {
    let mut bytes = std::fs::read(data(name)).unwrap();
    f(&mut bytes);
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// `render TOP TRAJ --frames 0..N`: one line of stderr holding every part,
/// a failure, and no file written but what frames came before the bad one.
fn assert_bad(top: &str, traj: &Path, frames: usize, parts: &[&str]) -> usize {
    let out_dir = traj.with_extension("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let range = format!("0..{frames}");
    let err =
        isomarch(["render", top, traj.to_str().unwrap(), "--frames", &range, "-o", out_dir.join("f_###.png").to_str().unwrap(), "--size", "8x8"])
            .fails();
    let last = err.trim().lines().last().unwrap_or("").to_string();
    assert!(last.starts_with("error: "), "{err}");
    for p in parts {
        assert!(last.contains(p), "{p:?} not in the error: {last}");
    }
    assert!(!err.contains("panicked"), "{err}");
    let written: Vec<String> = std::fs::read_dir(&out_dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(written.iter().all(|n| n.ends_with(".png") || n == "frames.csv"), "temporary files left: {written:?}");
    written.iter().filter(|n| n.ends_with(".png")).count()
}

/// Where each frame of an XTC file starts, walking its headers (xdrfile's
/// layout: magic 1995, natoms, step, time, box, natoms, then for more than
/// 9 atoms precision, the integer box, the small index and the byte count
/// of the compressed coordinates, padded to 4 bytes).
fn xtc_frame_starts(bytes: &[u8]) -> Vec<usize> {
    let word = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let mut starts = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        assert_eq!(word(at), 1995, "no frame's magic number at byte {at}");
        assert!(word(at + 4) > 9, "an uncompressed frame");
        starts.push(at);
        at += 88 + 4 + word(at + 88).div_ceil(4) * 4;
    }
    assert_eq!(at, bytes.len(), "the last frame runs past the end");
    starts
}

/// `--framing all` frames every atom of every frame: each frame of the
/// AdK DCD has all its atoms' centres inside the view, its camera is the
/// same for every frame, and it is not `--framing first`'s.
#[test]
fn framing_all_keeps_every_atom_of_every_frame_in_view() {
    use isomarch::molecule::playback::{FramingRule, Stager};
    let (top, traj) = (data("adk.psf"), data("adk_dims.dcd"));
    let open = |rule| {
        let t = isomarch::molecule::trajectory::open(Path::new(&top), Some(Path::new(&traj))).unwrap();
        Stager::new(t, Default::default(), rule).unwrap()
    };
    let first = open(FramingRule::First).scene(0).unwrap().0.camera;
    let mut all = open(FramingRule::All);
    let camera = all.scene(0).unwrap().0.camera;
    assert!(camera.eye != first.eye || camera.target != first.target, "--framing all has --framing first's camera: {camera:?}");
    let forward = (camera.target - camera.eye).normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let half_h = (0.5 * camera.fov_y_deg).to_radians().tan();
    let half_w = half_h * f64::from(camera.width) / f64::from(camera.height);
    let (mut atoms, mut widest) = (0, 0f64);
    assert!(all.len() >= 98, "{} frames", all.len());
    for k in 0..all.len() {
        let scene = all.scene(k).unwrap().0;
        assert_eq!((scene.camera.eye, scene.camera.target), (camera.eye, camera.target), "frame {k}: the camera moved");
        for p in scene.primitives() {
            let isomarch::scene::Primitive::Point { center, .. } = p else { panic!("frame {k}: not an atom: {p:?}") };
            let v = *center - camera.eye;
            let z = v.dot(forward);
            let (x, y) = (v.dot(right) / (z * half_w), v.dot(up) / (z * half_h));
            widest = widest.max(x.abs()).max(y.abs());
            assert!(z > 0.0 && x.abs() < 1.0 && y.abs() < 1.0, "frame {k}: an atom at {center} is out of the view ({x:.3}, {y:.3})");
            atoms += 1;
        }
    }
    assert!(atoms > 98 * 1000, "{atoms} atoms checked");
    // The view is used: the atoms reach across most of it.
    assert!(widest > 0.5, "the atoms reach only {widest} of the half-width");
}

#[test]
fn bad_trajectories_are_one_line_errors_naming_file_and_frame() {
    let dir = scratch("traj-bad");
    let (yiip, adk) = (data("YiiP_lipids.gro.gz"), data("adk.psf"));
    // XTC cut short inside its last frame: refused on opening.
    let cut = damaged(&dir, "YiiP_lipids.xtc", |b| b.truncate(b.len() - 1000));
    assert_eq!(assert_bad(&yiip, &cut, 5, &["YiiP_lipids.xtc", "frame 4", "cut short"]), 0);
    // The atom count differs from the topology's.
    let other = dir.join("other.xtc");
    std::fs::copy(data("adk_oplsaa.xtc"), &other).unwrap();
    assert_bad(&yiip, &other, 1, &["other.xtc", "frame 0", "47681 atoms", "43480"]);
    // A corrupt frame: 4,000 bytes of compressed coordinates overwritten.
    // The frame that holds them, from the frames' offsets: its number is
    // named, and the frames before it are written.
    let original = std::fs::read(data("adk_oplsaa.xtc")).unwrap();
    let at = original.len() / 10 * 2 + 2000;
    let starts = xtc_frame_starts(&original);
    let hit = starts.iter().rposition(|&s| s <= at).unwrap();
    assert!(at + 4000 <= starts.get(hit + 1).copied().unwrap_or(original.len()), "the damage spans two frames");
    let corrupt = damaged(&dir, "adk_oplsaa.xtc", |b| b[at..at + 4000].fill(0xff));
    let frame = format!("frame {hit}");
    let before = assert_bad(&data("adk_oplsaa.gro.gz"), &corrupt, 10, &["adk_oplsaa.xtc", &frame]);
    assert_eq!(before, hit, "frames written before the corrupt {frame}");
    // DCD cut short inside frame 40, and one whose atom count differs.
    let cut = damaged(&dir, "adk_dims.dcd", |b| b.truncate(b.len() - 58 * (3 * (8 + 4 * 3341)) - 100));
    assert_bad(&adk, &cut, 2, &["adk_dims.dcd", "frame 39", "cut short"]);
    assert_bad(&yiip, Path::new(&data("adk_dims.dcd")), 1, &["adk_dims.dcd", "3341 atoms", "43480"]);
    // A multi-frame GRO cut short in its second frame.
    let gro = dir.join("cut.gro");
    let frame = "t= 0.0\n    2\n    1GLY      N    1   0.000   0.000   0.000\n    1GLY     CA    2   0.150   0.000   0.000\n   1.0 1.0 1.0\n";
    std::fs::write(&gro, format!("{frame}{}", &frame[..60])).unwrap();
    let err = isomarch(["frames", gro.to_str().unwrap()]).fails_in_one_line();
    assert!(err.contains("cut.gro:") && err.contains(": frame 1: the file is cut short"), "{err}");
    // A PSF cannot stand alone, and a trajectory needs a known extension.
    let err = isomarch(["render", &adk, "-o", dir.join("x.png").to_str().unwrap()]).fails();
    assert!(err.contains("has no coordinates"), "{err}");
    let err = isomarch(["render", &adk, &data("adk.psf"), "-o", dir.join("x.png").to_str().unwrap()]).fails();
    assert!(err.contains("not a trajectory"), "{err}");
}

#[test]
fn shards_split_a_trajectorys_frames_and_resume() {
    let dir = scratch("traj-shards");
    let pattern = dir.join("f_##.png");
    let (top, traj) = (data("adk.psf"), data("adk_dims.dcd"));
    for shard in ["0/2", "1/2"] {
        let csv = dir.join(format!("shard{}.csv", &shard[..1]));
        isomarch([
            "render",
            &top,
            &traj,
            "--frames",
            "10..16",
            "--shard",
            shard,
            "-o",
            pattern.to_str().unwrap(),
            "--size",
            "16x16",
            "--csv",
            csv.to_str().unwrap(),
        ])
        .ok();
    }
    let mut names: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n.ends_with(".png")).collect();
    names.sort();
    assert_eq!(names, (10..16).map(|k| format!("f_{k}.png")).collect::<Vec<_>>(), "each frame once");
    // A frame lost is rendered again; the others are kept.
    std::fs::remove_file(dir.join("f_13.png")).unwrap();
    let out = isomarch(["render", &top, &traj, "--frames", "10..16", "--skip-existing", "-o", pattern.to_str().unwrap(), "--size", "16x16"]).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("1 frame rendered, 5 kept from disk"), "{err}");
}

/// `isomarch frames ... | head` ends quietly when the pipe closes, as
/// command-line tools do, rather than with "Broken pipe".
#[test]
fn frames_into_a_closed_pipe_ends_quietly() {
    use std::io::{BufRead, BufReader};
    // Rows of a few thousand coordinates: far more than a pipe buffers.
    let atoms: Vec<String> = (0..3000).map(|i| i.to_string()).collect();
    let mut child = isomarch(["frames", &data("adk.psf"), &data("adk_dims.dcd"), "--atoms", &atoms.join(",")])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    for _ in 0..4 {
        lines.next().unwrap().unwrap();
    }
    // `head -4` exits here: the read end closes.
    drop(lines);
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("Broken pipe") && !stderr.contains("error") && !stderr.contains("panicked"), "{stderr}");
}

/// Frame times print as the CSV rounds them: DCD's f32 times read as
/// written (`t = 41 ps`, not `40.99999638872076`), and a batch past the
/// trajectory's end names the first frame that is missing.
#[test]
fn times_are_rounded_and_a_range_past_the_end_names_its_first_missing_frame() {
    let dir = scratch("trajectory-messages");
    let ron = dir.join("f40.ron");
    let out = isomarch(["scene", &data("adk.psf"), &data("adk_dims.dcd"), "--frame", "40", "-o", ron.to_str().unwrap()]).ok();
    let text = std::fs::read_to_string(&ron).unwrap();
    assert!(text.contains("t = 41 ps"), "{}", text.lines().take(3).collect::<Vec<_>>().join("\n"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("the first at 1 ps"), "{stderr}");
    let out =
        isomarch(["render", &data("adk.psf"), &data("adk_dims.dcd"), "--frames", "90..120", "-o", dir.join("f_###.png").to_str().unwrap()]).output();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--frames 90..120") && stderr.contains("no frame 98: the trajectory has 98 (0 to 97)"), "{stderr}");
    assert!(!stderr.contains("no frame 119"), "{stderr}");
    let written: Vec<_> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).filter(|n| n.to_string_lossy().ends_with(".png")).collect();
    assert!(written.is_empty(), "frames written: {written:?}");
}

/// The protein of AdK's GRO (its first 3341 sites) in every frame of its
/// XTC, made whole (`--pbc whole`), against the file's coordinates and
/// MDAnalysis's `make_whole` (scripts/pbc-reference.py): every atom moved
/// by whole box vectors, by the same ones as MDAnalysis moved it, up to
/// one shift of the whole molecule per frame (MDAnalysis keeps the first
/// atom where the file has it, which makes the protein jump when that
/// atom crosses a face; isomarch keeps it from jumping, and moves it
/// nowhere in frame 0); every bond MDAnalysis guessed shorter than 2 Å.
#[test]
fn adk_is_made_whole_as_mdanalysis_makes_it() {
    use isomarch::molecule::pbc::Pbc;
    use isomarch::molecule::trajectory::open_with;
    const PROTEIN: usize = 3341;
    let (top, traj) = (data("adk_oplsaa.gro.gz"), data("adk_oplsaa.xtc"));
    let (mut raw, none) = open_with(Path::new(&top), Some(Path::new(&traj)), Pbc::None).unwrap();
    assert!(none.is_none());
    let (mut whole, note) = open_with(Path::new(&top), Some(Path::new(&traj)), Pbc::Auto).unwrap();
    let note = note.expect("the default makes the split protein whole, with a note");
    assert!(note.contains("split by the periodic box") && note.contains("--pbc none"), "{note}");
    let (_, bonds) = rows(&std::fs::read_to_string(data("reference/adk_oplsaa_bonds.csv")).unwrap());
    assert_eq!(bonds.len(), 3365, "MDAnalysis's bonds (the PSF of the same protein lists 3365 too)");
    let (_, moved) = rows(&std::fs::read_to_string(data("reference/adk_oplsaa_whole.csv")).unwrap());
    let mut previous_centre: Option<glam::DVec3> = None;
    for k in 0..raw.len() {
        let (r, w) = (raw.read(k).unwrap(), whole.read(k).unwrap());
        let cell = r.cell.expect("the XTC gives a box");
        assert_eq!(w.cell, r.cell);
        let mut mda = vec![[0i64; 3]; PROTEIN];
        for m in moved.iter().filter(|m| m[0] as usize == k) {
            mda[m[1] as usize] = [m[2] as i64, m[3] as i64, m[4] as i64];
        }
        assert!(k > 0 || mda.iter().any(|n| *n != [0; 3]), "frame 0 of the file is split");
        let mut offset: Option<[i64; 3]> = None;
        for (i, m) in mda.iter().enumerate() {
            let shift = w.positions[i] - r.positions[i];
            let n = cell.counts(shift);
            assert!(
                (cell.matrix * glam::DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) - shift).length() < 1e-6,
                "frame {k} atom {i}: not whole box vectors"
            );
            let d = [n[0] - m[0], n[1] - m[1], n[2] - m[2]];
            match offset {
                None => offset = Some(d),
                Some(o) => assert_eq!(d, o, "frame {k} atom {i}: moved by {n:?}, MDAnalysis by {m:?}, where the atoms before differ by {o:?}"),
            }
        }
        if k == 0 {
            assert_eq!(offset, Some([0, 0, 0]), "frame 0 is MDAnalysis's, atom for atom");
        }
        for b in &bonds {
            let d = (w.positions[b[0] as usize] - w.positions[b[1] as usize]).length();
            assert!(d < 2.0, "frame {k}: atoms {} and {} are {d:.2} Å apart", b[0], b[1]);
        }
        let centre = w.positions[..PROTEIN].iter().fold(glam::DVec3::ZERO, |a, &p| a + p) / PROTEIN as f64;
        if let Some(p) = previous_centre {
            assert!((centre - p).length() < 5.0, "frame {k}: the protein's centre jumped from {p} to {centre}");
        }
        previous_centre = Some(centre);
    }
    // A seek gives the frame that reading in order gave.
    let (mut seek, _) = open_with(Path::new(&top), Some(Path::new(&traj)), Pbc::Whole).unwrap();
    let last = whole.len() - 1;
    assert_eq!(seek.read(last).unwrap(), whole.read(last).unwrap());
    assert_eq!(seek.read(3).unwrap(), whole.read(3).unwrap());
}

/// `--pbc`: the default note on stderr, `--pbc none` the file's
/// coordinates (the scene and the image, byte for byte, of a copy of the
/// file without its box: what every version before `--pbc` drew; and the
/// image of that scene file), a box asked for where there is none refused
/// in one line, and `--pbc` with a scene file refused in one line.
#[test]
fn pbc_none_keeps_the_files_coordinates_and_the_default_says_what_it_did() {
    let dir = scratch("traj-pbc");
    let gro = data("adk_oplsaa.gro.gz");
    let mut text = String::new();
    std::io::Read::read_to_string(&mut flate2::read::GzDecoder::new(std::fs::File::open(&gro).unwrap()), &mut text).unwrap();
    let boxless = dir.join("adk_nobox.gro");
    let mut lines: Vec<&str> = text.lines().collect();
    let last = lines.len() - 1;
    lines[last] = "   0.00000   0.00000   0.00000";
    std::fs::write(&boxless, lines.join("\n") + "\n").unwrap();
    let scene = |input: &str, name: &str, extra: &[&str]| -> (String, String) {
        let out = dir.join(name);
        let o = isomarch(["scene", input, "-o", out.to_str().unwrap()]).args(extra).ok();
        // Without the comments, which name the file.
        let text = std::fs::read_to_string(out).unwrap().lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
        (text, String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (before, quiet) = scene(boxless.to_str().unwrap(), "before.ron", &[]);
    assert!(!quiet.contains("periodic box"), "{quiet}");
    let (none, quiet) = scene(&gro, "none.ron", &["--pbc", "none"]);
    assert!(!quiet.contains("periodic box"), "{quiet}");
    assert_eq!(none, before, "--pbc none is the file's coordinates");
    let (auto, note) = scene(&gro, "auto.ron", &[]);
    assert!(note.contains("adk_oplsaa.gro.gz: a molecule of the structure is split by the periodic box (triclinic"), "{note}");
    assert_ne!(auto, none, "the default makes AdK whole");
    let (centred, _) = scene(&gro, "center.ron", &["--pbc", "center"]);
    assert_ne!(centred, auto);
    // The image too: `--pbc none` renders what the GRO's coordinates
    // rendered before --pbc existed, the boxless copy's image (no box, so
    // no periodic code runs) and the image of its scene file, byte for
    // byte; the default's image differs.
    let png = |input: &str, name: &str, extra: &[&str]| -> Vec<u8> {
        let out = dir.join(name);
        isomarch(["render", input, "--size", "96x96", "-o", out.to_str().unwrap()]).args(extra).ok();
        std::fs::read(out).unwrap()
    };
    let none_png = png(&gro, "none.png", &["--pbc", "none"]);
    assert!(none_png == png(boxless.to_str().unwrap(), "before.png", &[]), "--pbc none's image is not the boxless GRO's");
    let before_ron = dir.join("before.ron");
    assert!(none_png == png(before_ron.to_str().unwrap(), "before-ron.png", &[]), "--pbc none's image is not its scene file's");
    assert!(none_png != png(&gro, "auto.png", &[]), "the default draws AdK whole, not as the file has it");
    // A scene file has no box: --pbc with one is refused, as the other
    // molecule flags are, `auto` included.
    for pbc in ["none", "auto"] {
        let err = isomarch(["render", before_ron.to_str().unwrap(), "--pbc", pbc, "-o", dir.join("x.png").to_str().unwrap()]).fails_in_one_line();
        assert_eq!(
            err,
            format!("error: --pbc applies to molecule files (.pdb, .cif, .gro, optionally .gz); {} is a scene file", before_ron.display())
        );
    }
    let e = isomarch(["render", &data("adk.psf"), &data("adk_dims.dcd"), "--pbc", "whole", "-o", dir.join("x.png").to_str().unwrap()])
        .fails_in_one_line();
    assert_eq!(e, format!("error: {}: frame 0: --pbc whole: the file gives no periodic box", data("adk_dims.dcd")));
}

/// `--interpolate 3` on AdK's DCD: 4 x 97 + 1 frames, the saved ones
/// every fourth, an interpolated frame's atoms at the midpoint (within
/// f32) of the two saved frames' it lies between, and `frames` and the
/// scene's note saying which saved frames those are.
#[test]
fn interpolated_frames_lie_between_the_saved_ones() {
    use isomarch::molecule::trajectory::open;
    let (top, traj) = (data("adk.psf"), data("adk_dims.dcd"));
    let mut t = open(Path::new(&top), Some(Path::new(&traj))).unwrap();
    let (a, b) = (t.read(40).unwrap(), t.read(41).unwrap());
    t.set_interpolate(3);
    assert_eq!(t.len(), 4 * 97 + 1);
    assert_eq!(t.read(160).unwrap().positions, a.positions, "rendered frame 160 is saved frame 40");
    let mid = t.read(162).unwrap();
    for (i, ((p, q), m)) in a.positions.iter().zip(&b.positions).zip(&mid.positions).enumerate() {
        let want = 0.5 * (*p + *q);
        assert!((*m - want).abs().max_element() <= 1e-6 * want.abs().max_element().max(1.0), "atom {i}: {m} where the midpoint is {want}");
    }
    assert!(a.positions.iter().zip(&mid.positions).any(|(p, m)| (*p - *m).length() > 0.05), "AdK moves between saved frames 40 and 41");
    let out = isomarch(["frames", &top, &traj, "--interpolate", "3", "--atoms", "0"]).ok();
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 389);
    assert!(lines[0].ends_with(",saved_from,saved_to,fraction"), "{}", lines[0]);
    assert!(lines[1 + 162].starts_with("162,") && lines[1 + 162].ends_with(",40,41,0.500000"), "{}", lines[1 + 162]);
    assert!(lines[1 + 388].ends_with(",97,97,0.000000"), "{}", lines[1 + 388]);
    let dir = scratch("traj-interpolate");
    let ron = dir.join("f162.ron");
    let o = isomarch(["scene", &top, &traj, "--interpolate", "3", "--frame", "162", "-o", ron.to_str().unwrap()]).ok();
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("389 frames (98 saved, 3 interpolated between each two)"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let scene = std::fs::read_to_string(&ron).unwrap();
    assert!(scene.contains("Frame 162 of") && scene.contains("389 frames, 0.5000 of the way from saved frame 40 to 41 of 98"), "{}", &scene[..600]);
    let e = isomarch(["render", &data("adk_oplsaa.gro.gz"), "--interpolate", "3", "-o", dir.join("x.png").to_str().unwrap()]).fails_in_one_line();
    assert!(e.contains("--interpolate applies to trajectories"), "{e}");
}
