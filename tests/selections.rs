//! Selections (`--select`, src/molecule/select.rs) against an independent
//! implementation: for each expression of tests/data/selections/
//! reference.csv, the atoms isomarch selects are, by index, the atoms
//! MDAnalysis's `select_atoms` selected with the same expression in its
//! grammar (written by scripts/selection-reference.py; the README beside
//! the data lists where the grammars differ).

use std::collections::BTreeMap;
use std::path::Path;

use isomarch::molecule::select::Selection;
use isomarch::molecule::{self, Atom, trajectory};

use crate::common::*;

/// The atoms of a reference file as isomarch reads them: a PSF topology
/// with the first frame of its DCD (positions for `within`).
fn atoms_of(file: &str) -> Vec<Atom> {
    let path = repo_root().join(file);
    if file.ends_with(".psf") {
        let dcd = path.with_file_name("adk_dims.dcd");
        return trajectory::open(&path, Some(&dcd)).unwrap_or_else(|e| panic!("{e}")).topology.atoms;
    }
    molecule::read(&path).unwrap_or_else(|e| panic!("{e}")).atoms
}

/// `0-5 9 12-40` as indices.
fn expand(ranges: &str) -> Vec<usize> {
    ranges
        .split_whitespace()
        .flat_map(|r| {
            let (a, b) = r.split_once('-').unwrap_or((r, r));
            let (a, b): (usize, usize) = (a.parse().unwrap(), b.parse().unwrap());
            a..=b
        })
        .collect()
}

#[test]
fn selections_select_what_mdanalysis_selects() {
    let path = repo_root().join("tests/data/selections/reference.csv");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e} (scripts/selection-reference.py writes it)", path.display()));
    let body: String = text.lines().filter(|l| !l.starts_with('#')).map(|l| format!("{l}\n")).collect();
    let mut reader = csv::Reader::from_reader(body.as_bytes());
    let mut files: BTreeMap<String, Vec<Atom>> = BTreeMap::new();
    let (mut rows, mut failures) = (0, Vec::new());
    for record in reader.records() {
        let record = record.unwrap();
        let (file, ours, theirs, count, indices) = (&record[0], &record[1], &record[2], &record[3], &record[4]);
        let atoms = files.entry(file.to_string()).or_insert_with(|| atoms_of(file));
        let selection = Selection::parse(ours).unwrap_or_else(|e| panic!("{file}: {ours:?}: {e}"));
        let chosen: Vec<usize> = atoms.iter().zip(selection.matches(atoms)).filter(|(_, m)| *m).map(|(a, _)| a.site).collect();
        let expected = expand(indices);
        assert_eq!(expected.len(), count.parse::<usize>().unwrap(), "{file}: {theirs:?}: the row's count and its indices disagree");
        rows += 1;
        if chosen != expected {
            let extra: Vec<&usize> = chosen.iter().filter(|i| !expected.contains(i)).take(5).collect();
            let missing: Vec<&usize> = expected.iter().filter(|i| !chosen.contains(i)).take(5).collect();
            failures.push(format!(
                "{}: {ours:?} selects {} atoms, MDAnalysis's {theirs:?} {}; first extra {extra:?}, first missing {missing:?}",
                Path::new(file).file_name().unwrap().to_string_lossy(),
                chosen.len(),
                expected.len()
            ));
        }
    }
    assert!(rows >= 25, "the Done-when asks for at least 25 expressions; the reference holds {rows}");
    assert!(files.len() == 5, "the reference covers 1A8O, 6WG6, the AdK PSF and GRO and YiiP: {:?}", files.keys());
    assert!(failures.is_empty(), "{} of {rows} selections differ from MDAnalysis:\n{}", failures.len(), failures.join("\n"));
}

/// A PDB ATOM record of atom `serial` (its element, residue and B-factor).
fn record(serial: usize, element: &str, resname: &str, resid: i64, chain: &str, x: f64, beta: f64) -> String {
    format!(
        "HETATM{serial:>5} {:<4} {resname:>3} {chain}{resid:>4}    {x:>8.3}{:>8.3}{:>8.3}  1.00{beta:>6.2}          {element:>2}\n",
        format!(" {element}"),
        0.0,
        0.0
    )
}

/// The colour (linear RGB) of each atom of the scene that `isomarch scene
/// FILE FLAGS` writes, in the file's order.
fn scene_colors(file: &Path, flags: &[&str]) -> Vec<[f64; 3]> {
    let ron = file.with_extension(format!("{}.ron", flags.len()));
    isomarch(["scene", file.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
    let scene = isomarch::scene::Scene::load(&ron).unwrap();
    scene.colors.expect("a coloured scene").iter().map(|c| c.to_array()).collect()
}

/// An sRGB colour in the linear RGB the scene file holds (six decimals).
fn linear(c: [u8; 3]) -> [f64; 3] {
    c.map(|v| format!("{:.6}", isomarch::molecule::elements::linear(v)).parse().unwrap())
}

/// Colour by B-factor in closed form: three atoms 100 Å apart with B at
/// the range's ends and its middle take the palette's published end and
/// middle colours (viridis #440154, #20908C, #FDE725; blue-white-red's
/// ends and white); outside a given range they clamp to its ends;
/// AlphaFold's bands go by the value itself.
#[test]
fn a_bfactor_colouring_has_the_palettes_ends_and_middle() {
    let dir = scratch("sel-bfactor");
    let pdb = dir.join("three.pdb");
    let text: String =
        [(10.0, 0.0), (30.0, 100.0), (50.0, 200.0)].iter().enumerate().map(|(i, &(b, x))| record(i + 1, "C", "LIG", 1, "A", x, b)).collect();
    std::fs::write(&pdb, text).unwrap();
    // colorous's viridis (a fitted curve) has #20908C in the middle where
    // matplotlib's 256-entry table has #21918C: one level apart.
    let viridis = [[0x44, 0x01, 0x54], [0x20, 0x90, 0x8C], [0xFD, 0xE7, 0x25]];
    assert_eq!(scene_colors(&pdb, &["--color", "bfactor"]), viridis.map(linear), "viridis over the values' own range 10:50");
    let bwr = [[0x21, 0x66, 0xAC], [0xFF, 0xFF, 0xFF], [0xB2, 0x18, 0x2B]];
    assert_eq!(scene_colors(&pdb, &["--color", "bfactor", "--palette", "blue-white-red"]), bwr.map(linear));
    // A range of 20:40: B 10 clamps to the low end, 30 is the middle, 50 the high end.
    assert_eq!(scene_colors(&pdb, &["--color", "bfactor", "--range", "20:40"]), viridis.map(linear));
    // A range of 30:70: B 30 is the low end, 50 the middle.
    let shifted = scene_colors(&pdb, &["--color", "bfactor", "--range", "30:70"]);
    assert_eq!((shifted[0], shifted[1], shifted[2]), (linear(viridis[0]), linear(viridis[0]), linear(viridis[1])));
    // AlphaFold's bands: 10 very low (orange), 30 very low, 50 low (yellow).
    let af = scene_colors(&pdb, &["--color", "bfactor", "--palette", "alphafold"]);
    assert_eq!(af, [[0xFF, 0x7D, 0x45], [0xFF, 0x7D, 0x45], [0xFF, 0xDB, 0x13]].map(linear));
    // Occupancy the same way (all 1.00: the middle of a one-value range).
    assert_eq!(scene_colors(&pdb, &["--color", "occupancy"]), [viridis[1]; 3].map(linear));
    // --legend: 26 rows under the image, the bar from the low end's colour
    // (2 pixels in) to the high end's (2 pixels from the right), white in
    // the middle.
    let png = dir.join("legend.png");
    isomarch(["render", pdb.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64x48"])
        .args(["--color", "bfactor", "--palette", "blue-white-red", "--legend"])
        .ok();
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (64, 48 + 26));
    let bar = |x: u32| img.get_pixel(x, 48 + 6).0;
    assert_eq!((bar(2), bar(61)), ([0x21, 0x66, 0xAC], [0xB2, 0x18, 0x2B]), "the bar's ends");
    let middle = bar(32);
    assert!(middle.iter().all(|&c| c >= 0xF4), "white in the middle: {middle:?}");
}

/// Values from a file colour as the B-factors do: one per atom, as a
/// line or a column; a row per frame of a trajectory.
#[test]
fn values_from_a_file_colour_atoms_by_site_or_by_atom_drawn() {
    let dir = scratch("sel-values");
    let pdb = dir.join("four.pdb");
    // A water between the atoms: left out by default, so the file has 4
    // atoms and 3 are drawn.
    let text: String = [("C", "LIG", 0.0), ("O", "HOH", 50.0), ("C", "LIG", 100.0), ("C", "LIG", 200.0)]
        .iter()
        .enumerate()
        .map(|(i, &(e, r, x))| record(i + 1, e, r, i as i64 + 1, "A", x, 0.0))
        .collect();
    std::fs::write(&pdb, text).unwrap();
    let viridis = [[0x44, 0x01, 0x54], [0x20, 0x90, 0x8C], [0xFD, 0xE7, 0x25]].map(linear);
    // By site (4 values; the water's 99 is not drawn but is in the range).
    std::fs::write(dir.join("site.csv"), "0,99,49.5,99\n").unwrap();
    let by_site = scene_colors(&pdb, &["--color-values", dir.join("site.csv").to_str().unwrap()]);
    assert_eq!(by_site, [viridis[0], viridis[1], viridis[2]]);
    // By atom drawn (3 values), as a column with a comment.
    std::fs::write(dir.join("drawn.csv"), "# one per atom drawn\n5\n6\n7\n").unwrap();
    assert_eq!(scene_colors(&pdb, &["--color-values", dir.join("drawn.csv").to_str().unwrap()]), viridis);
    // With a surface per chain the scene holds chain A's atoms, then B's;
    // values per atom drawn still follow the file's order.
    let chains: String =
        [("A", 0.0), ("B", 100.0), ("A", 200.0)].iter().enumerate().map(|(i, &(c, x))| record(i + 1, "C", "LIG", i as i64 + 1, c, x, 0.0)).collect();
    let two = dir.join("chains.pdb");
    std::fs::write(&two, chains).unwrap();
    let per_chain = scene_colors(&two, &["--color-values", dir.join("drawn.csv").to_str().unwrap(), "--surfaces", "per-chain"]);
    assert_eq!(per_chain, [viridis[0], viridis[2], viridis[1]], "scene order A, A, B: values 5, 7, 6");
}

/// Twenty bad selections, ranges and values files: each refused in one
/// line naming what is wrong, exit status 1, no image written.
#[test]
fn bad_selections_and_values_are_refused_in_one_line_and_write_nothing() {
    let dir = scratch("sel-bad");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let png = dir.join("out.png");
    let file = |name: &str, text: &str| -> String {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["--select".into(), "chian A".into()], "unknown keyword 'chian' at column 1; did you mean 'chain'?"),
        (vec!["--select".into(), "protein and chian A".into()], "at column 13; did you mean 'chain'?"),
        (vec!["--select".into(), "resid".into()], "'resid' at column 1 needs at least one value"),
        (vec!["--select".into(), "within of protein".into()], "expected a number after 'within' at column 8"),
        (vec!["--select".into(), "within 5 protein".into()], "expected 'of'"),
        (vec!["--select".into(), "(protein".into()], "unclosed '(' at column 1"),
        (vec!["--select".into(), "protein)".into()], "unexpected ')' at column 8"),
        (vec!["--select".into(), "resid 10 to".into()], "'to' at column 10"),
        (vec!["--select".into(), "beta > abc".into()], "column 8"),
        (vec!["--select".into(), "resid 50 to 10".into()], "column"),
        (vec!["--select".into(), "".into()], "the selection is empty"),
        (vec!["--select".into(), "protein foo".into()], "column 9"),
        (vec!["--select".into(), "name 'CA".into()], "column 6"),
        (vec!["--select".into(), "resname XYZ".into()], "the selection 'resname XYZ' picks none of its 644 atoms"),
        (vec!["--select".into(), "hydrogen".into()], "picks none"),
        (vec!["--color".into(), "bfactor".into(), "--range".into(), "50:10".into()], "--range MIN:MAX needs MIN below MAX"),
        (vec!["--palette".into(), "viridis".into()], "--palette applies to colourings by value"),
        (vec!["--color-values".into(), file("short.csv", "1,2,3\n")], "3 values per frame, but"),
        (vec!["--color-values".into(), file("nan.csv", "1,x,3\n")], "nan.csv:1: value 2 (\"x\") is not a finite number"),
        (vec!["--color-values".into(), file("ragged.csv", "1,2\n1,2,3\n")], "row 2 has 3 values where the first has 2"),
        (vec!["--color-values".into(), file("empty.csv", "# nothing\n")], "no values"),
        (vec!["--color-values".into(), dir.join("missing.csv").to_str().unwrap().into()], "cannot read the values"),
        (
            vec!["--color-values".into(), file("site.csv", &"1\n".repeat(644)), "--color".into(), "chain".into()],
            "--color chain cannot be given with it",
        ),
    ];
    for (flags, expected) in &cases {
        let line = isomarch(["render", pdb.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "16x16"]).args(flags).fails_in_one_line();
        assert!(line.contains(expected), "{flags:?}: {line:?} lacks {expected:?}");
        assert!(!png.exists(), "{flags:?} wrote an image");
    }
}

/// 1A8O without its 88 crystal waters by default, saying so; `--select
/// all` draws every atom, as the same file with its waters renamed (no
/// longer water) does by default, pixel for pixel.
#[test]
fn waters_are_left_out_by_default_with_a_note_and_select_all_keeps_them() {
    let dir = scratch("sel-default");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let out = isomarch(["render", pdb.to_str().unwrap(), "-o", dir.join("default.png").to_str().unwrap(), "--size", "48x48"]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("556 atoms (88 water and ion atoms left out: --select all keeps them)"), "{stderr}");
    let out = isomarch(["render", pdb.to_str().unwrap(), "-o", dir.join("all.png").to_str().unwrap(), "--size", "48x48", "--select", "all"]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(": 644 atoms, 1 chain"), "{stderr}");
    let renamed = dir.join("renamed.pdb");
    std::fs::write(&renamed, std::fs::read_to_string(&pdb).unwrap().replace(" HOH ", " WWW ")).unwrap();
    isomarch(["render", renamed.to_str().unwrap(), "-o", dir.join("renamed.png").to_str().unwrap(), "--size", "48x48"]).ok();
    let read = |name: &str| image::open(dir.join(name)).unwrap().to_rgb8().into_raw();
    assert_eq!(read("all.png"), read("renamed.png"), "--select all is not the file drawn whole");
    assert_ne!(read("all.png"), read("default.png"), "the waters made no difference");
}

/// `--surfaces per-chain`: two carbons of two chains 3.6 Å apart (their
/// radii 1.7 Å), so that their Gaussians summed hold the point between
/// them inside (2 e^{2(1 - (1.8/1.7)²)} = 1.57 > iso 1) while either alone
/// does not (0.785). One group per chain; along the segment between the
/// centres the field of the max of the chains crosses the iso value twice
/// (out of one atom, into the other), the single sum never. `--apart`
/// makes the same seam for a selection within one chain.
#[test]
fn a_surface_per_chain_meets_its_neighbour_with_a_seam() {
    use glam::DVec3;
    let dir = scratch("sel-chains");
    let two =
        |chain_b: &str, resname_b: &str| -> String { record(1, "C", "LIG", 1, "A", 0.0, 0.0) + &record(2, "C", resname_b, 2, chain_b, 3.6, 0.0) };
    let crossings = |file: &Path, flags: &[&str], name: &str| -> (usize, usize) {
        let ron = dir.join(format!("{name}.ron"));
        isomarch(["scene", file.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
        let scene = isomarch::scene::Scene::load(&ron).unwrap();
        let field = isomarch::field::Field::new(&scene);
        let inside: Vec<bool> = (0..=1000).map(|k| field.value(DVec3::new(3.6 * f64::from(k) / 1000.0, 0.0, 0.0)) > 0.0).collect();
        (scene.groups.len(), inside.windows(2).filter(|w| w[0] != w[1]).count())
    };
    let chains = dir.join("chains.pdb");
    std::fs::write(&chains, two("B", "LIG")).unwrap();
    assert_eq!(crossings(&chains, &[], "one"), (1, 0), "one sum: inside all the way");
    assert_eq!(crossings(&chains, &["--surfaces", "per-chain"], "per-chain"), (2, 2), "a group per chain: out of one, into the other");
    let ligand = dir.join("ligand.pdb");
    std::fs::write(&ligand, two("A", "HEM")).unwrap();
    assert_eq!(crossings(&ligand, &["--surfaces", "per-chain"], "one-chain"), (1, 0), "one chain: one surface");
    assert_eq!(crossings(&ligand, &["--apart", "resname HEM"], "apart"), (2, 2), "the ligand apart");
    let line = isomarch(["scene", ligand.to_str().unwrap(), "-o", dir.join("x.ron").to_str().unwrap(), "--apart", "resname XYZ"]).fails_in_one_line();
    assert!(line.contains("--apart 'resname XYZ' picks none of the atoms drawn"), "{line}");
}

/// A PDB HETATM record with the residue name in columns 18-21 (three
/// letters and a blank, or CHARMM's four) and the chain in column 22.
fn record4(serial: usize, element: &str, resname: &str, chain: &str, resid: i64, [x, y, z]: [f64; 3]) -> String {
    format!(
        "HETATM{serial:>5} {:<4} {resname:<4}{chain}{resid:>4}    {x:>8.3}{y:>8.3}{z:>8.3}  1.00  0.00          {element:>2}\n",
        format!(" {element}")
    )
}

/// The centres of each group's primitives of a scene file.
fn group_centres(ron: &Path) -> Vec<Vec<[f64; 3]>> {
    let scene = isomarch::scene::Scene::load(ron).unwrap();
    scene
        .groups
        .iter()
        .map(|g| {
            g.iter()
                .map(|p| match p {
                    isomarch::scene::Primitive::Point { center, .. } => center.to_array(),
                    other => panic!("not an atom: {other:?}"),
                })
                .collect()
        })
        .collect()
}

/// `--legend` draws the key of a colouring by value under a PNG with a
/// background: with an EXR `-o`, with `--transparent-background` and with
/// a colouring that is not by value it is refused (exit status 1, one
/// error line after the molecule's summary) before any image is marched,
/// a batch of frames as a single frame, and no image is written.
#[test]
fn a_legend_is_refused_where_it_cannot_be_drawn() {
    let dir = scratch("sel-legend-refused");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let cases: [(&[&str], &str, &str); 6] = [
        (&["--color", "bfactor"], "x.exr", "--legend draws the colour bar on a PNG image; -o"),
        (&["--color", "bfactor", "--transparent-background"], "x.png", "--legend and --transparent-background cannot be drawn together"),
        (&[], "x.png", "--legend draws the key of a colouring by value"),
        (&["--color", "restype"], "x.png", "--legend draws the key of a colouring by value"),
        (&["--color", "bfactor", "--frames", "0..2"], "f_#.exr", "--legend draws the colour bar on a PNG image; -o"),
        (&["--color", "bfactor", "--frames", "0..2", "--transparent-background"], "f_#.png", "--legend and --transparent-background"),
    ];
    for (flags, out, says) in cases {
        let run =
            isomarch(["render", pdb.to_str().unwrap(), "--legend", "--size", "16x16", "-o", dir.join(out).to_str().unwrap()]).args(flags).output();
        let stderr = String::from_utf8_lossy(&run.stderr);
        let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(run.status.code(), Some(1), "{flags:?} -o {out}: not refused:\n{stderr}");
        assert!(errors.len() == 1 && errors[0].contains(says), "{flags:?} -o {out}: {stderr:?} lacks one error line with {says:?}");
        assert!(stderr.lines().count() <= 2, "{flags:?} -o {out}: more than the summary and the error:\n{stderr}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "a refused --legend wrote {left:?}");
}

/// `--color restype` (VMD's residue classes: basic blue, acidic red, polar
/// green, nonpolar white) and `--color resname` (Jmol's shapely colours)
/// end to end, one atom per residue: the colour of each residue the table
/// knows, and where it does not (HEM for both, MSE for shapely, a
/// nucleotide for restype), the atom's element colour (`--color element`'s).
#[test]
fn residue_colourings_take_their_tables_and_fall_back_on_element_colours() {
    let dir = scratch("sel-residues");
    let pdb = dir.join("residues.pdb");
    let residues = [("LYS", "C"), ("ASP", "C"), ("SER", "C"), ("GLY", "C"), ("MSE", "SE"), ("HEM", "FE"), ("DA", "C")];
    let text: String = residues.iter().enumerate().map(|(i, &(r, e))| record4(i + 1, e, r, "A", i as i64 + 1, [20.0 * i as f64, 0.0, 0.0])).collect();
    std::fs::write(&pdb, text).unwrap();
    let element = scene_colors(&pdb, &["--color", "element"]);
    let restype = scene_colors(&pdb, &["--color", "restype"]);
    let resname = scene_colors(&pdb, &["--color", "resname"]);
    let (white, green, red, blue) = (linear([255; 3]), linear([0, 160, 0]), linear([220, 0, 0]), linear([0, 0, 220]));
    assert_eq!(restype, [blue, red, green, white, white, element[5], element[6]], "restype: LYS ASP SER GLY MSE HEM DA");
    let shapely = [[0x47, 0x47, 0xB8], [0xA0, 0x00, 0x42], [0xFF, 0x70, 0x42], [0xFF, 0xFF, 0xFF]].map(linear);
    assert_eq!(
        resname,
        [shapely[0], shapely[1], shapely[2], shapely[3], element[4], element[5], linear([0xA0, 0xA0, 0xFF])],
        "resname: LYS ASP SER GLY MSE HEM DA"
    );
    // The fallbacks are the elements' colours (Jmol's Se, Fe and C), none a
    // residue's.
    assert_eq!([element[4], element[5], element[6]], [[0xFF, 0xA1, 0x00], [0xE0, 0x66, 0x33], [0x90, 0x90, 0x90]].map(linear));
}

/// PDB residue names of four characters (CHARMM's TIP3, POPC) are read
/// through column 21, and the chain from column 22 after them: TIP3 is
/// water (left out by default), `resname POPC` and `resname TIP3` pick
/// their atoms, `chain W` the water, and `resname POP` none.
#[test]
fn four_character_residue_names_are_read_through_column_21() {
    let dir = scratch("sel-four");
    let pdb = dir.join("membrane.pdb");
    let atoms = [("P", "POPC", "A", 1), ("C", "POPC", "A", 1), ("O", "TIP3", "W", 2), ("C", "LYS", "A", 3)];
    let text: String = atoms.iter().enumerate().map(|(i, &(e, r, c, n))| record4(i + 1, e, r, c, n, [20.0 * i as f64, 0.0, 0.0])).collect();
    assert!(text.contains(" POPCA   1 ") && text.contains(" TIP3W   2 "), "{text}");
    std::fs::write(&pdb, text).unwrap();
    let drawn = |flags: &[&str]| -> (usize, String) {
        let ron = dir.join("m.ron");
        let out = isomarch(["scene", pdb.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
        (isomarch::scene::Scene::load(&ron).unwrap().primitive_count(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (n, stderr) = drawn(&[]);
    assert!(n == 3 && stderr.contains("3 atoms (1 water and ion atoms left out"), "TIP3 is not water: {n} atoms drawn, {stderr}");
    for (select, count) in [("resname POPC", 2), ("resname TIP3", 1), ("chain W", 1), ("chain A and not resname POPC", 1)] {
        assert_eq!(drawn(&["--select", select]).0, count, "--select '{select}'");
    }
    let err = isomarch(["scene", pdb.to_str().unwrap(), "-o", dir.join("x.ron").to_str().unwrap(), "--select", "resname POP"]).fails_in_one_line();
    assert!(err.contains("the selection 'resname POP' picks none of its 4 atoms"), "{err}");
}

/// `--apart` given twice makes two surfaces of their own, in the order
/// given, after the rest: three groups, the HEM atom alone in the second
/// and the LIG atom in the third. An `--apart` whose atoms an earlier one
/// took is refused in one line.
#[test]
fn apart_given_twice_makes_two_surfaces() {
    let dir = scratch("sel-apart-twice");
    let pdb = dir.join("ligands.pdb");
    let atoms = [("C", "ALA", 1, 0.0), ("C", "ALA", 2, 1.5), ("C", "ALA", 3, 3.0), ("FE", "HEM", 4, 30.0), ("C", "LIG", 5, 60.0)];
    let text: String = atoms.iter().enumerate().map(|(i, &(e, r, n, x))| record4(i + 1, e, r, "A", n, [x, 0.0, 0.0])).collect();
    std::fs::write(&pdb, text).unwrap();
    let ron = dir.join("apart.ron");
    isomarch(["scene", pdb.to_str().unwrap(), "-o", ron.to_str().unwrap(), "--apart", "resname LIG", "--apart", "resname HEM"]).ok();
    let at = |x: f64| [x, 0.0, 0.0];
    assert_eq!(group_centres(&ron), vec![vec![at(0.0), at(1.5), at(3.0)], vec![at(60.0)], vec![at(30.0)]], "the rest, then LIG, then HEM");
    let err = isomarch(["scene", pdb.to_str().unwrap(), "-o", dir.join("x.ron").to_str().unwrap()])
        .args(["--apart", "resname HEM or resname LIG", "--apart", "resname LIG"])
        .fails_in_one_line();
    assert!(err.contains("--apart 'resname LIG' picks none of the atoms drawn (or an earlier --apart took them all)"), "{err}");
}

/// A trajectory's selection is made on its first frame and kept, by atom,
/// for every frame: in a PDB of two models, `within 5 of resname LIG`
/// picks the ALA atom 3 Å from the ligand in model 1, not the GLY atom 50
/// Å away; in model 2 they have swapped places, and frame 1's scene still
/// draws the ALA atom (now 50 Å away) and not the GLY atom (now 3 Å).
#[test]
fn a_trajectorys_selection_is_made_on_its_first_frame_and_kept_by_atom() {
    let dir = scratch("sel-trajectory");
    let pdb = dir.join("models.pdb");
    let model = |k: usize, ala: f64, gly: f64| -> String {
        format!(
            "MODEL     {k:>4}\n{}{}{}ENDMDL\n",
            record4(1, "C", "LIG", "A", 1, [0.0, 0.0, 0.0]),
            record4(2, "C", "ALA", "A", 2, [ala, 0.0, 0.0]),
            record4(3, "C", "GLY", "A", 3, [gly, 0.0, 0.0])
        )
    };
    std::fs::write(&pdb, model(1, 3.0, 50.0) + &model(2, 50.0, 3.0)).unwrap();
    let frame = |k: &str| -> Vec<Vec<[f64; 3]>> {
        let ron = dir.join(format!("frame{k}.ron"));
        isomarch(["scene", pdb.to_str().unwrap(), "-o", ron.to_str().unwrap(), "--frame", k, "--select", "within 5 of resname LIG"]).ok();
        group_centres(&ron)
    };
    let at = |x: f64| [x, 0.0, 0.0];
    assert_eq!(frame("0"), vec![vec![at(0.0), at(3.0)]], "frame 0: the ligand and ALA");
    assert_eq!(frame("1"), vec![vec![at(0.0), at(50.0)]], "frame 1: the ligand and ALA where ALA has moved, not GLY");
}
