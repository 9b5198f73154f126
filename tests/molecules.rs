//! Molecule files through the binary: every bad input gives a one-line
//! error (or, for unknown elements, one warning) naming the file and the
//! line, a non-zero exit, no panic and no output file; good ones render,
//! with every method including field inversion, and `isomarch scene`
//! writes the scene they render.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use crate::common::*;
use isomarch::molecule::MoleculeOptions;
use isomarch::scene::Scene;

fn pdb_1a8o() -> PathBuf {
    repo_root().join("tests/data/molecules/1A8O.pdb")
}

fn text_1a8o() -> String {
    std::fs::read_to_string(pdb_1a8o()).unwrap()
}

/// The 1-based number of the first line of `text` that starts with `prefix`.
fn line_of(text: &str, prefix: &str) -> usize {
    text.lines().position(|l| l.starts_with(prefix)).unwrap() + 1
}

/// `isomarch render FILE -o OUT.png` at 32x32: must fail with one line of
/// stderr mentioning every part, and leave no PNG; that line.
fn assert_refused(file: &Path, parts: &[&str]) -> String {
    let out_png = file.with_extension("out.png");
    let line = isomarch(["render", file.to_str().unwrap(), "-o", out_png.to_str().unwrap(), "--size", "32x32"]).fails_in_one_line();
    for p in parts {
        assert!(line.contains(p), "{line:?} does not mention {p:?}");
    }
    assert!(!out_png.exists(), "{} written despite the error", out_png.display());
    line
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[test]
fn a_pdb_cut_short_inside_a_record_is_refused_naming_the_line() {
    let dir = scratch("mol-cut");
    let text = text_1a8o();
    // Cut in the middle of the 100th atom's coordinates.
    let line = line_of(&text, "HETATM   10") + 99;
    let start: usize = text.lines().take(line - 1).map(|l| l.len() + 1).sum();
    let f = write(&dir, "cut.pdb", &text.as_bytes()[..start + 40]);
    assert_refused(&f, &["cut.pdb:", &format!(":{line}:"), "cut short"]);
}

#[test]
fn a_file_without_atoms_is_refused_naming_its_last_line() {
    let dir = scratch("mol-empty");
    let text: String = text_1a8o().lines().filter(|l| !l.starts_with("ATOM") && !l.starts_with("HETATM")).map(|l| format!("{l}\n")).collect();
    let last = text.lines().count();
    let f = write(&dir, "empty.pdb", text.as_bytes());
    assert_refused(&f, &["empty.pdb:", &format!(":{last}:"), "no atoms"]);
    let f = write(&dir, "empty.gro", b"nothing here\n0\n   1.0 1.0 1.0\n");
    assert_refused(&f, &["empty.gro:3:", "no atoms"]);
}

#[test]
fn coordinates_that_are_not_numbers_are_refused_naming_the_line_and_field() {
    let dir = scratch("mol-nan");
    let text = text_1a8o();
    let line = line_of(&text, "HETATM   20");
    let bad: String =
        text.lines().enumerate().map(|(i, l)| if i + 1 == line { format!("{}  12.x45{}\n", &l[..38], &l[46..]) } else { format!("{l}\n") }).collect();
    let f = write(&dir, "nan.pdb", bad.as_bytes());
    assert_refused(&f, &["nan.pdb:", &format!(":{line}:"), "y coordinate", "12.x45", "not a number"]);
    let cif = "data_X\nloop_\n_atom_site.type_symbol\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\nC 1.0 2.0 3.0\nN 1.5 nan? 3.0\n";
    let f = write(&dir, "nan.cif", cif.as_bytes());
    assert_refused(&f, &["nan.cif:8:", "Cartn_y", "not a number"]);
}

#[test]
fn mmcif_and_gro_cut_short_are_refused_naming_the_line() {
    let dir = scratch("mol-cut2");
    let cif = "data_X\nloop_\n_atom_site.type_symbol\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\nC 1.0 2.0 3.0\nN 1.5 2.5";
    let f = write(&dir, "cut.cif", cif.as_bytes());
    assert_refused(&f, &["cut.cif:8:", "cut short", "_atom_site"]);
    let gro = "t\n3\n    1ALA      N    1   0.100   0.200   0.300\n    1ALA     CA    2   0.200   0.2";
    let f = write(&dir, "cut.gro", gro.as_bytes());
    assert_refused(&f, &["cut.gro:4:", "cut short"]);
}

#[test]
fn a_gzip_stream_cut_short_is_refused_naming_the_line_it_ends_in() {
    let dir = scratch("mol-gz");
    let text = text_1a8o();
    let gz = gzip(text.as_bytes());
    let f = write(&dir, "cut.pdb.gz", &gz[..gz.len() / 2]);
    let stderr = assert_refused(&f, &["cut.pdb.gz:", "gzip stream is cut short"]);
    // The line named is inside the file, past its start.
    let line: usize = stderr.split(':').nth(2).unwrap().trim().parse().unwrap();
    assert!(line > 10 && line < text.lines().count(), "{stderr}");
    // The whole stream reads.
    let f = write(&dir, "whole.pdb.gz", &gz);
    let m = isomarch::molecule::read(&f).unwrap();
    assert_eq!(m.atoms.len(), 644);
}

#[test]
fn unknown_elements_are_named_in_one_warning_and_take_the_fallback_radius() {
    let dir = scratch("mol-unknown");
    let text = text_1a8o();
    let (a, b) = (line_of(&text, "HETATM   20"), line_of(&text, "HETATM   10"));
    let bad: String = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == a || i + 1 == b { format!("{}Xq{}\n", &l[..76], &l[78..]) } else { format!("{l}\n") })
        .collect();
    let f = write(&dir, "unknown.pdb", bad.as_bytes());
    let png = dir.join("unknown.png");
    let out = isomarch(["render", f.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "32x32"]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for part in ["unknown.pdb", "Xq (2 atoms", &format!("first at line {}", a.min(b)), "fallback radius 1.8"] {
        assert!(warnings[0].contains(part), "{:?} lacks {part:?}", warnings[0]);
    }
    assert!(png.exists());
    let (scene, _) = isomarch::molecule::build::load_scene(&f, &MoleculeOptions::default()).unwrap();
    assert_eq!(scene.primitive_count(), 556, "644 atoms less 88 waters");
}

#[test]
fn scene_writes_the_scene_that_the_molecule_renders() {
    let dir = scratch("mol-scene");
    let ron = dir.join("1a8o.ron");
    isomarch(["scene", pdb_1a8o().to_str().unwrap(), "-o", ron.to_str().unwrap(), "--sharpness", "3", "--color", "chain", "--turntable", "8"]).ok();
    let written = Scene::load(&ron).unwrap();
    let options = MoleculeOptions { sharpness: 3.0, coloring: isomarch::molecule::Coloring::Chain, turntable: Some(8.0), ..Default::default() };
    let (direct, _) = isomarch::molecule::build::load_scene(&pdb_1a8o(), &options).unwrap();
    assert_eq!(Scene { source: String::new(), ..written }, Scene { source: String::new(), ..direct.clone() });
    assert_eq!(direct.primitive_count(), 556, "644 atoms less 88 waters");
    assert!(direct.animation.camera.is_some(), "the turntable is an orbit of the camera");
    // The camera sees the whole molecule: every atom inside the view cone.
    let c = &direct.camera;
    let axis = (c.target - c.eye).normalize();
    for p in direct.primitives() {
        let isomarch::scene::Primitive::Point { center, .. } = p else { unreachable!() };
        let v = *center - c.eye;
        let angle = v.normalize().dot(axis).acos().to_degrees();
        assert!(angle < 0.5 * c.fov_y_deg, "an atom {angle:.1}° off axis");
    }
    // Molecule flags given with a scene file are refused.
    let err = isomarch(["render", ron.to_str().unwrap(), "-o", dir.join("x.png").to_str().unwrap(), "--sharpness", "2"]).fails();
    assert!(err.contains("--sharpness applies to molecule files"), "{err}");
}

/// Every method renders the molecule; field inversion is measured by the
/// bench against the f64 reference, and refuses scenes it cannot invert.
#[test]
fn every_method_renders_a_molecule_and_field_inversion_reports_its_miss_rate() {
    let dir = scratch("mol-methods");
    let pdb = pdb_1a8o();
    for method in isomarch::Method::ALL {
        let png = dir.join(format!("{method}.png"));
        isomarch(["render", pdb.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "48x48", "--method", method.name(), "--validation"]).ok();
        let img = image::open(&png).unwrap().to_rgb8();
        let lit = img.pixels().filter(|p| p.0.iter().map(|&c| u32::from(c)).sum::<u32>() > 120).count();
        assert!(lit > 48 * 48 / 10, "{method}: only {lit} pixels show the molecule");
    }
    let json = dir.join("bench.json");
    isomarch(["bench", pdb.to_str().unwrap(), "--methods", "quadratic-taylor,field-inversion", "--rays", "2048", "--json", json.to_str().unwrap()])
        .ok();
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // Both rows, against the f64 reference on the same rays: quadratic
    // Taylor (conservative) exactly, field inversion within 1% of misses
    // and with no false hit (0 and 0 here, measured).
    let reference = report["reference_hit_rate"].as_f64().expect("a reference hit rate");
    assert!(reference > 0.3, "the rays hardly see the molecule: reference hit rate {reference}");
    let rows = report["methods"].as_array().expect("rows");
    let row = |name: &str| rows.iter().find(|r| r["method"] == name).unwrap_or_else(|| panic!("no {name} row in {report}"));
    let rate = |name: &str, f: &str| row(name)[f].as_f64().unwrap_or_else(|| panic!("{name}: no {f}"));
    assert_eq!((rate("quadratic-taylor", "miss_rate"), rate("quadratic-taylor", "false_hit_rate")), (0.0, 0.0));
    assert_eq!(rate("quadratic-taylor", "hit_rate"), reference);
    assert!(rate("field-inversion", "miss_rate") <= 0.01 && rate("field-inversion", "false_hit_rate") == 0.0, "{}", row("field-inversion"));
    // A scene that is no sum of like Gaussians: refused in one line.
    let stderr = isomarch([
        "render",
        repo_root().join("scenes/fig10.ron").to_str().unwrap(),
        "-o",
        dir.join("f.png").to_str().unwrap(),
        "--method",
        "field-inversion",
        "--size",
        "16x16",
    ])
    .fails_in_one_line();
    assert!(stderr.contains("field-inversion"), "{stderr}");
}

#[test]
fn batch_frames_turn_the_camera_around_the_molecule() {
    let dir = scratch("mol-turntable");
    let pattern = dir.join("f_#.png");
    isomarch([
        "render",
        pdb_1a8o().to_str().unwrap(),
        "--turntable",
        "4",
        "--frames",
        "0..5",
        "--fps",
        "1",
        "--size",
        "40x40",
        "-o",
        pattern.to_str().unwrap(),
    ])
    .ok();
    let frame = |i: u32| image::open(dir.join(format!("f_{i}.png"))).unwrap().to_rgb8();
    // Pixels that differ by more than 8/255 in a channel.
    let differing =
        |a: &image::RgbImage, b: &image::RgbImage| a.pixels().zip(b.pixels()).filter(|(p, q)| (0..3).any(|c| p[c].abs_diff(q[c]) > 8)).count();
    let (f0, f1, f4) = (frame(0), frame(1), frame(4));
    assert!(differing(&f0, &f1) > 40, "a quarter turn later the frame is nearly the same");
    // A period of 4 s at 1 fps: frame 4 is frame 0 again (the angle is 2π,
    // whose cosine and sine round to within an ulp of 1 and 0).
    assert!(differing(&f0, &f4) <= 8, "one full turn later the frame differs in {} pixels", differing(&f0, &f4));
    // A quarter turn of the camera about the vertical is the world (atoms
    // and lights) turned a quarter back about the vertical through the
    // target, seen from the resting camera: frame 1 against that scene,
    // written independently of the orbit's code.
    let ron = dir.join("rest.ron");
    isomarch(["scene", pdb_1a8o().to_str().unwrap(), "-o", ron.to_str().unwrap()]).ok();
    let mut file = isomarch::scene::file::parse(&std::fs::read_to_string(&ron).unwrap(), "rest.ron").unwrap();
    let (target, up) = (glam::DVec3::from(file.camera.target), glam::DVec3::from(file.camera.up).normalize());
    let back = glam::DQuat::from_axis_angle(up, -std::f64::consts::FRAC_PI_2);
    let mut turned = 0;
    for group in &mut file.groups {
        for p in &mut group.primitives {
            if let isomarch::scene::file::PrimitiveFile::Point { center, .. } = p {
                *center = (target + back * (glam::DVec3::from(*center) - target)).to_array();
                turned += 1;
            }
        }
    }
    for light in &mut file.lights {
        light.direction = (back * glam::DVec3::from(light.direction)).to_array();
    }
    assert!(turned > 100 && file.bounds.is_none(), "{turned} atoms turned");
    let turned_ron = dir.join("turned.ron");
    std::fs::write(&turned_ron, ron::ser::to_string(&file).unwrap()).unwrap();
    let still = dir.join("turned.png");
    isomarch(["render", turned_ron.to_str().unwrap(), "--size", "40x40", "-o", still.to_str().unwrap()]).ok();
    let still = image::open(&still).unwrap().to_rgb8();
    let d = differing(&f1, &still);
    assert!(d <= 8, "a quarter turn of the camera differs from the world turned back in {d} pixels");
}

/// On a sample of a molecule's camera rays (`bench --camera-rays`), every
/// conservative Algorithm 1 method and the bisection baselines find every
/// crossing of the f64 reference and no other, within the match window;
/// field inversion with the conservative hit rule misses at most 1% (its
/// steps are not distance bounds), and dynamol's rule reports its rates.
#[test]
fn a_molecules_camera_rays_match_the_reference_for_every_conservative_method() {
    let dir = scratch("mol-camera");
    let json = dir.join("bench.json");
    let methods: Vec<&str> = isomarch::Method::ALL.iter().map(|m| m.name()).collect();
    isomarch([
        "bench",
        pdb_1a8o().to_str().unwrap(),
        "--camera-rays",
        "64x64",
        "--rays",
        "1024",
        "--methods",
        &methods.join(","),
        "--json",
        json.to_str().unwrap(),
    ])
    .ok();
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(report["camera"], serde_json::json!([64, 64]), "{report}");
    let reference = report["reference_hit_rate"].as_f64().unwrap();
    assert!(reference > 0.3, "the sample hardly sees the molecule: reference hit rate {reference}");
    let rows = report["methods"].as_array().unwrap();
    assert_eq!(rows.len(), methods.len());
    for row in rows {
        let name = row["method"].as_str().unwrap();
        let rate = |f: &str| row[f].as_f64().unwrap_or_else(|| panic!("{name}: no {f}"));
        let method: isomarch::Method = name.parse().unwrap();
        if method.conservative() {
            assert_eq!((rate("miss_rate"), rate("false_hit_rate")), (0.0, 0.0), "{name} on 1A8O's camera rays");
            assert_eq!(rate("hit_rate"), reference, "{name}");
        } else if method == isomarch::Method::FieldInversion {
            assert!(rate("miss_rate") <= 0.01 && rate("false_hit_rate") == 0.0, "{name}: {row}");
        } else {
            // dynamol's rule is approximate (docs/molecules.md: on 6WG6 it
            // misses 2.3% and reports 10.2% false hits); here it missed
            // 2.8% and reported 14.7% false hits, bounded with room.
            assert!(rate("miss_rate") <= 0.05 && rate("false_hit_rate") <= 0.25, "{name}: {row}");
            assert!((rate("hit_rate") - reference).abs() <= 0.05, "{name}: hit rate {} against the reference's {reference}", rate("hit_rate"));
        }
    }
}

/// `isomarch scene FILE`: the summary line it prints ("F: N atoms, M
/// chains") and the scene it wrote.
fn scene_summary(file: &Path) -> (String, Scene) {
    let ron = file.with_extension("ron");
    // Every atom: some of these files are all water.
    let out = isomarch(["scene", file.to_str().unwrap(), "-o", ron.to_str().unwrap(), "--select", "all"]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let summary = stderr.lines().find(|l| l.contains(" atoms")).unwrap_or_else(|| panic!("no summary in {stderr:?}")).to_string();
    (summary, Scene::load(&ron).unwrap())
}

/// Reader cases through the binary (issue 28): alternate locations chosen
/// per atom site in PDB and mmCIF (a site given only as B and C keeps B);
/// an mmCIF whose `_atom_site` is key-value pairs (one atom) and a second
/// data block after the first; GRO residue numbers that wrap at 99,999
/// (one chain, not two) with velocities on every line; PDB hydrogens named
/// `1HB` and deuterium `D` left out like hydrogens.
#[test]
fn readers_choose_alternate_locations_per_site_and_read_one_atom_cifs_and_wrapped_gro_residues() {
    let dir = scratch("mol-readers");
    // PDB: site N of residue 1 has A and B; site CA has only B and C; CB blank.
    let atom = |name: &str, alt: char, x: f64, element: &str| {
        format!("ATOM      1 {name:<4}{alt}ALA A   1    {x:8.3}{:8.3}{:8.3}  1.00  0.00          {element:>2}\n", 0.0, 0.0)
    };
    let pdb = [
        atom(" N", 'A', 0.0, "N"),
        atom(" N", 'B', 0.3, "N"),
        atom(" CA", 'B', 1.5, "C"),
        atom(" CA", 'C', 1.8, "C"),
        atom(" CB", ' ', 3.0, "C"),
        atom("1HB", ' ', 3.5, ""),
        atom(" D1", ' ', 4.0, "D"),
    ]
    .concat();
    let (summary, scene) = scene_summary(&write(&dir, "alt.pdb", pdb.as_bytes()));
    assert_eq!(scene.primitive_count(), 3, "N (A), CA (B) and CB: {summary}");
    let xs: Vec<f64> =
        scene.primitives().map(|p| if let isomarch::scene::Primitive::Point { center, .. } = p { center.x } else { f64::NAN }).collect();
    assert_eq!(xs, [0.0, 1.5, 3.0], "the first conformer of each site");
    assert!(summary.contains("3 atoms (2 hydrogens left out)"), "{summary}");

    // mmCIF: the same sites in a loop, then a second data block.
    let cif = "data_ALT\nloop_\n_atom_site.group_PDB\n_atom_site.type_symbol\n_atom_site.label_atom_id\n_atom_site.label_alt_id\n\
               _atom_site.label_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.auth_asym_id\n\
               ATOM N N A 1 0.0 0 0 A\nATOM N N B 1 0.3 0 0 A\nATOM C CA B 1 1.5 0 0 A\nATOM C CA C 1 1.8 0 0 A\nATOM C CB . 1 3.0 0 0 A\n\
               #\ndata_SECOND\nloop_\n_atom_site.type_symbol\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\nO 9 9 9\n";
    let (summary, scene) = scene_summary(&write(&dir, "alt.cif", cif.as_bytes()));
    assert_eq!(scene.primitive_count(), 3, "{summary}");

    // mmCIF of one atom, written as key-value pairs, a quoted name with a prime.
    let one = "data_ONE\n_atom_site.group_PDB HETATM\n_atom_site.type_symbol ZN\n_atom_site.label_atom_id \"ZN'\"\n\
               _atom_site.Cartn_x 1.25\n_atom_site.Cartn_y -2.5\n_atom_site.Cartn_z 3.75\n_atom_site.auth_asym_id B\n#\n";
    let (summary, scene) = scene_summary(&write(&dir, "one.cif", one.as_bytes()));
    assert_eq!(scene.primitive_count(), 1, "{summary}");
    let center = scene.primitives().find_map(|p| if let isomarch::scene::Primitive::Point { center, .. } = p { Some(*center) } else { None });
    assert_eq!(center, Some(glam::DVec3::new(1.25, -2.5, 3.75)));

    // GRO: residue 99999 then 0 (a wrap: one chain), velocities on each line.
    let water = |residue: u32, i: u32, x: f64| format!("{residue:>5}SOL     OW{i:>5}{x:8.3}   1.624   1.679  0.1227 -0.0580  0.0434\n");
    let gro = format!("wrap\n    3\n{}{}{}   1.86206   1.86206   1.86206\n", water(99_999, 1, 0.126), water(0, 2, 0.426), water(1, 3, 0.726));
    let (summary, scene) = scene_summary(&write(&dir, "wrap.gro", gro.as_bytes()));
    assert_eq!(scene.primitive_count(), 3, "{summary}");
    assert!(summary.ends_with("3 atoms, 1 chain"), "{summary}");

    // GRO written at another precision (%10.5f: the decimal points 10 apart).
    let precise =
        "precise\n    2\n    1ALA      N    1   0.12345   0.20000   0.30000\n    1ALA     CA    2   0.27345   0.20000   0.30000\n   1.0 1.0 1.0\n";
    let (summary, scene) = scene_summary(&write(&dir, "precise.gro", precise.as_bytes()));
    let xs: Vec<f64> =
        scene.primitives().map(|p| if let isomarch::scene::Primitive::Point { center, .. } = p { center.x } else { f64::NAN }).collect();
    assert_eq!(xs, [1.2345, 2.7345], "{summary}");
}

/// A structure of 165,175 atoms (the 6ZU5 ribosome) reads, indexes and
/// renders, with its memory and the index's build time in `--stats`.
#[test]
fn a_ribosome_of_165175_atoms_renders_with_its_memory_in_the_statistics() {
    let dir = scratch("mol-large");
    let (png, stats) = (dir.join("6zu5.png"), dir.join("6zu5.json"));
    let file = repo_root().join("tests/data/molecules/6ZU5.cif.gz");
    // Every atom (its 187 waters and ions too), as the memory bounds were
    // measured.
    let out = isomarch(["render", file.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64x64", "--stats", stats.to_str().unwrap()])
        .args(["--select", "all"])
        .ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("165175 atoms, 74 chains"), "{stderr}");
    let s = json(&stats);
    assert!(s["index"]["build_ns"].as_f64().is_some_and(|ns| ns > 0.0), "{s}");
    assert!(s["index"]["entries"].as_u64().is_some_and(|n| n >= 165_175), "{s}");
    let memory = &s["memory"];
    // Bounded both ways. Its primitives alone take 165,175 x 64 bytes
    // (10.1 MiB) on the GPU. Measured at 64x64 (this test, 736b199): peak
    // RSS 320.5 MiB, GPU memory allocated 151.7 MiB (at 750x750: 331 and
    // 183.8 MiB, docs/trajectories.md). A margin of a half over those: a
    // leak of the scene's size a few times over, or a buffer per cell,
    // crosses it.
    let (rss, gpu) = (memory["peak_rss_mib"].as_f64().unwrap(), memory["gpu_allocated_mib"].as_f64().unwrap());
    eprintln!("6ZU5 at 64x64: peak RSS {rss:.1} MiB, GPU allocated {gpu:.1} MiB");
    assert!(rss > 50.0 && rss < 1.5 * 320.5, "peak RSS {rss} MiB: {memory}");
    assert!(gpu > 10.0 && gpu < 1.5 * 151.7, "GPU memory {gpu} MiB: {memory}");
    let img = image::open(&png).unwrap().to_rgb8();
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 100, "a nearly uniform image: {} colours", colours.len());
}

/// Sphere tracing's one global bound is slow on Gaussian fields: chosen
/// for a molecule, it comes with a line saying so (and not for a scene of
/// compact kernels, where it is only the baseline).
#[test]
fn sphere_tracing_a_molecule_comes_with_a_note() {
    let dir = scratch("sphere-note");
    let note = "note: sphere tracing steps by one global Lipschitz bound";
    let out =
        isomarch(["render", pdb_1a8o().to_str().unwrap(), "--method", "sphere", "--size", "8x8", "-o", dir.join("m.png").to_str().unwrap()]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(note), "{stderr}");
    let out = isomarch(["render", pdb_1a8o().to_str().unwrap(), "--size", "8x8", "-o", dir.join("q.png").to_str().unwrap()]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains(note), "{stderr}");
    let fig1 = repo_root().join("scenes/fig1.ron");
    let out = isomarch(["render", fig1.to_str().unwrap(), "--method", "sphere", "--size", "8x8", "-o", dir.join("c.png").to_str().unwrap()]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains(note), "{stderr}");
}

/// The molecule flags reach the scene: `--hydrogens` keeps the hydrogen
/// atoms (the count in the summary and the primitives), `--radius-scale`
/// scales every atom's r, `--iso` is the scene's iso value, and
/// `--sharpness` each atom's s (with its weight e^s).
#[test]
fn molecule_flags_change_the_atoms_and_the_surface() {
    let dir = scratch("mol-flags");
    let pdb = "ATOM      1  N   GLY A   1       0.000   0.000   0.000  1.00  0.00           N\n\
               ATOM      2  CA  GLY A   1       1.450   0.000   0.000  1.00  0.00           C\n\
               ATOM      3  H   GLY A   1      -0.500   0.800   0.000  1.00  0.00           H\n\
               ATOM      4  HA2 GLY A   1       1.800   0.900   0.300  1.00  0.00           H\n\
               END\n";
    let file = write(&dir, "gly.pdb", pdb.as_bytes());
    let scene_with = |flags: &[&str], name: &str| -> (String, Scene) {
        let ron = dir.join(format!("{name}.ron"));
        let out = isomarch(["scene", file.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        let summary = stderr.lines().find(|l| l.contains(" atoms")).unwrap_or_else(|| panic!("no summary in {stderr:?}")).to_string();
        (summary, Scene::load(&ron).unwrap())
    };
    let gaussians = |s: &Scene| -> Vec<(f64, f64, f64)> {
        s.primitives()
            .map(|p| match p {
                isomarch::scene::Primitive::Point { kernel: isomarch::scene::Kernel::Gaussian { r, s, weight }, .. } => (*r, *s, *weight),
                other => panic!("not an atom: {other:?}"),
            })
            .collect()
    };
    let (summary, plain) = scene_with(&[], "plain");
    assert_eq!(plain.primitive_count(), 2, "{summary}");
    let (summary, with_h) = scene_with(&["--hydrogens"], "hydrogens");
    assert_eq!(with_h.primitive_count(), 4, "--hydrogens: {summary}");
    assert!(summary.contains("4 atoms"), "{summary}");
    let (_, scaled) = scene_with(&["--radius-scale", "1.5"], "scaled");
    for (a, b) in gaussians(&plain).iter().zip(gaussians(&scaled)) {
        assert!((b.0 - 1.5 * a.0).abs() < 1e-12, "--radius-scale 1.5: r {} from {}", b.0, a.0);
    }
    let (_, iso) = scene_with(&["--iso", "2"], "iso");
    assert_eq!((plain.iso, iso.iso), (1.0, 2.0), "--iso 2");
    let (_, sharp) = scene_with(&["--sharpness", "3"], "sharp");
    for (_, s, weight) in gaussians(&sharp) {
        assert_eq!(s, 3.0, "--sharpness 3");
        // The scene file writes six decimals.
        assert!((weight - 3f64.exp()).abs() < 1e-5, "--sharpness 3: weight {weight}");
    }
}
