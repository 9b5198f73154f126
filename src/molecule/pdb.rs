//! PDB files: the ATOM and HETATM records of the first model, by the fixed
//! columns of the wwPDB format (v3.3, "Coordinate section"):
//!
//! ```text
//! 1-6 record   13-16 atom name   17 altLoc   22 chain   31-38 x   39-46 y   47-54 z   77-78 element
//! ```
//!
//! An empty element column falls back on the atom name, right-justified in
//! columns 13-14 by the same convention: ` CA ` is an alpha carbon, `CA  `
//! calcium. `CRYST1` gives the periodic box (of the first model), where it
//! is one ([`cryst1`]). Every other record is ignored. Of an atom site's
//! alternate locations, the first given is kept.

use glam::DVec3;

use super::{Atom, Molecule, MoleculeError, element_case, elements, number};

/// Columns `a..=b` (1-based, inclusive) of `line`, cut at its end; `None`
/// when they do not fall on character boundaries (non-ASCII text).
fn cols(line: &str, a: usize, b: usize) -> Option<&str> {
    let end = b.min(line.len());
    if a > end {
        return Some("");
    }
    line.get(a - 1..end)
}

/// The element of a record: columns 77-78, else the atom name's.
fn element(line: &str) -> String {
    let col = cols(line, 77, 78).unwrap_or("").trim();
    if !col.is_empty() {
        return element_case(col);
    }
    let name = cols(line, 13, 16).unwrap_or("");
    let chars: Vec<char> = name.chars().collect();
    let first = chars.first().copied().unwrap_or(' ');
    if first.is_ascii_alphabetic() {
        let two: String = chars.iter().take(2).collect();
        let two = element_case(&two);
        if two.len() == 2 && elements::is_element(&two) {
            return two;
        }
        return element_case(&first.to_string());
    }
    element_case(&chars.get(1).map_or(String::new(), |c| c.to_string()))
}

/// A residue number (columns 23-26): decimal, or hybrid-36 beyond 9999
/// (`A000` is 10000, as VMD, MDAnalysis and gemmi read it); 0 when blank
/// or unreadable, which is no reason to refuse the atom.
fn residue_number(field: &str) -> i64 {
    let t = field.trim();
    if let Ok(n) = t.parse::<i64>() {
        return n;
    }
    // Hybrid-36 for 4 characters: A000..ZZZZ then a000..zzzz.
    let digit = |c: char| c.to_digit(36).map(i64::from);
    let (Some(first), true) = (t.chars().next(), t.len() == 4) else { return 0 };
    let rest: Option<i64> = t.chars().skip(1).try_fold(0i64, |acc, c| Some(acc * 36 + digit(c)?));
    match (first, digit(first), rest) {
        ('A'..='Z', Some(d), Some(r)) => 10_000 + (d - 10) * 36i64.pow(3) + r,
        ('a'..='z', Some(d), Some(r)) => 10_000 + 26 * 36i64.pow(3) + (d - 10) * 36i64.pow(3) + r,
        _ => 0,
    }
}

/// An optional number column (occupancy, B-factor): `default` when blank
/// or unreadable (many files leave them out).
/// The periodic box of a `CRYST1` record (a, b, c in columns 7-33, alpha,
/// beta, gamma in 34-54), as [`super::pbc::Cell::from_crystal`] takes it:
/// none for the 1 Å placeholder, a thin cell, or a record that does not
/// hold six numbers.
pub fn cryst1(line: &str) -> Option<super::pbc::Cell> {
    let field = |a: usize, b: usize| cols(line, a, b)?.trim().parse::<f64>().ok().filter(|x| x.is_finite());
    let lengths = [field(7, 15)?, field(16, 24)?, field(25, 33)?];
    let angles = [field(34, 40)?, field(41, 47)?, field(48, 54)?];
    super::pbc::Cell::from_crystal(lengths, angles)
}

fn optional_number(field: &str, default: f64) -> f64 {
    field.trim().parse::<f64>().ok().filter(|v| v.is_finite()).unwrap_or(default)
}

pub fn parse(text: &str, file: &str) -> Result<Molecule, MoleculeError> {
    parse_at(text, file, 0)
}

/// [`parse`] on text that starts after line `skipped` of the file (one
/// model of a trajectory): lines are named as in the file.
pub fn parse_at(text: &str, file: &str, skipped: usize) -> Result<Molecule, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let mut atoms = Vec::new();
    let mut models = 0usize;
    let mut alt_of_site: std::collections::HashMap<(String, String), char> = std::collections::HashMap::new();
    // Per residue (chain, number, insertion code: columns 22-27): the
    // residue name of its first conformer given.
    let mut chosen_residue: std::collections::HashMap<String, String> = std::collections::HashMap::new();
    let cut_short = !text.is_empty() && !text.ends_with('\n');
    let count = text.lines().count();
    let mut sites = 0usize;
    let (mut cell, mut cell_seen) = (None, false);
    for (i, line) in text.lines().enumerate() {
        let n = skipped + i + 1;
        if line.starts_with("MODEL") {
            models += 1;
            continue;
        }
        // The first model's box (a file that gives one per model gives it
        // before each MODEL).
        if line.starts_with("CRYST1") && models <= 1 && !cell_seen {
            cell = cryst1(line);
            cell_seen = true;
            continue;
        }
        if models > 1 || !(line.starts_with("ATOM  ") || line.starts_with("HETATM")) {
            continue;
        }
        if !line.is_ascii() {
            return Err(err(n, "an ATOM or HETATM record that is not ASCII text".into()));
        }
        if line.len() < 54 {
            let record = &line[..6].trim();
            return Err(err(
                n,
                if cut_short && i + 1 == count {
                    format!("the file is cut short inside this {record} record ({} of the 54 columns that hold its coordinates)", line.len())
                } else {
                    format!("this {record} record has {} columns; its coordinates need columns 31-54", line.len())
                },
            ));
        }
        // Alternate locations per atom site (name, residue, chain, number,
        // insertion code: columns 13-16 and 18-27): the first conformer
        // given of each site is kept, so a site given only as B and C stays.
        // Where conformers are different residues (microheterogeneity:
        // 1EJG's residue 22 is PRO in A, SER in B and C), the residue of
        // the first conformer given is kept whole and the others' atoms
        // left out, as gemmi and MDAnalysis do.
        let site = sites;
        sites += 1;
        let altloc = line.as_bytes()[16] as char;
        if altloc != ' ' {
            let chosen = chosen_residue.entry(line[21..27].to_string()).or_insert_with(|| line[17..21].to_string());
            if line[17..21] != *chosen {
                continue;
            }
            let site = (line[12..16].to_string(), line[17..27].to_string());
            if *alt_of_site.entry(site).or_insert(altloc) != altloc {
                continue;
            }
        }
        let x = number(&line[30..38], "x coordinate (columns 31-38)", file, n)?;
        let y = number(&line[38..46], "y coordinate (columns 39-46)", file, n)?;
        let z = number(&line[46..54], "z coordinate (columns 47-54)", file, n)?;
        let text = |a, b| cols(line, a, b).unwrap_or("").trim().to_string();
        let chain = text(22, 22);
        atoms.push(Atom {
            element: element(line),
            position: DVec3::new(x, y, z),
            label_chain: chain.clone(),
            chain,
            line: n,
            site,
            name: text(13, 16),
            // Columns 18-20 in the standard; CHARMM and NAMD write four
            // characters (TIP3, POPC) through column 21, as VMD and
            // MDAnalysis read them.
            resname: text(18, 21),
            resid: residue_number(cols(line, 23, 26).unwrap_or("")),
            icode: text(27, 27),
            segment: text(73, 76),
            beta: optional_number(cols(line, 61, 66).unwrap_or(""), 0.0),
            occupancy: optional_number(cols(line, 55, 60).unwrap_or(""), 1.0),
            hetero: line.starts_with("HETATM"),
            ..Default::default()
        });
    }
    Ok(Molecule { source: file.into(), atoms, skipped_sites: None, extra_models: models.saturating_sub(1), sites, cell, bonds: Vec::new() })
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: &str = "ATOM     61  CG  LYS A 158      22.117  52.841  18.584  1.00 26.02           C  \n";

    #[test]
    fn records_give_element_position_and_chain() {
        let m = parse(A, "t.pdb").unwrap();
        assert_eq!(m.atoms.len(), 1);
        assert_eq!(m.atoms[0].element, "C");
        assert_eq!(m.atoms[0].chain, "A");
        assert_eq!(m.atoms[0].position, DVec3::new(22.117, 52.841, 18.584));
        let a = &m.atoms[0];
        assert_eq!((a.name.as_str(), a.resname.as_str(), a.resid, a.icode.as_str()), ("CG", "LYS", 158, ""));
        assert_eq!((a.occupancy, a.beta, a.hetero), (1.0, 26.02, false));
    }

    #[test]
    fn cryst1_gives_the_box_but_not_the_placeholder_of_one_angstrom() {
        // 1TII's cell: hexagonal, gamma 120.
        let t = format!("CRYST1  105.700  105.700  171.600  90.00  90.00 120.00 P 31 2 1     30          \n{A}");
        let cell = parse(&t, "t.pdb").unwrap().cell.expect("a box");
        let [a, b, c] = cell.vectors();
        assert!((a - DVec3::new(105.7, 0.0, 0.0)).length() < 1e-9, "{a}");
        assert!((b - DVec3::new(-52.85, 105.7 * 3f64.sqrt() / 2.0, 0.0)).length() < 1e-9, "{b}");
        assert!((c - DVec3::new(0.0, 0.0, 171.6)).length() < 1e-9, "{c}");
        // Cryo-EM and NMR entries' placeholder, a thin cell and a record
        // cut short are no box.
        for line in [
            "CRYST1    1.000    1.000    1.000  90.00  90.00  90.00 P 1           1          ",
            "CRYST1    4.800   30.000   40.000  90.00  90.00  90.00 P 1           1          ",
            "CRYST1  105.700  105.700  171.600  90.00",
        ] {
            assert_eq!(parse(&format!("{line}\n{A}"), "t.pdb").unwrap().cell, None, "{line}");
        }
        assert_eq!(parse(A, "t.pdb").unwrap().cell, None, "no CRYST1");
    }

    #[test]
    fn residue_numbers_beyond_9999_are_hybrid_36() {
        assert_eq!(residue_number(" 158"), 158);
        assert_eq!(residue_number("-12"), -12);
        assert_eq!(residue_number("A000"), 10_000);
        assert_eq!(residue_number("A001"), 10_001);
        assert_eq!(residue_number("ZZZZ"), 10_000 + 26 * 36 * 36 * 36 - 1);
        assert_eq!(residue_number("a000"), 10_000 + 26 * 36 * 36 * 36);
        assert_eq!(residue_number("    "), 0);
        assert_eq!(residue_number("#!"), 0);
    }

    #[test]
    fn the_atom_name_gives_the_element_when_the_column_is_empty() {
        let ca = "HETATM    1 CA    CA A 301      10.000  10.000  10.000  1.00 20.00\n";
        let calpha = "ATOM      2  CA  GLY A   1      10.000  10.000  10.000  1.00 20.00\n";
        let h = "ATOM      3 HD11 LEU A   1      10.000  10.000  10.000  1.00 20.00\n";
        let m = parse(&format!("{ca}{calpha}{h}"), "t.pdb").unwrap();
        let els: Vec<&str> = m.atoms.iter().map(|a| a.element.as_str()).collect();
        assert_eq!(els, ["Ca", "C", "H"]);
    }

    #[test]
    fn only_the_first_model_and_the_first_alternate_location_are_read() {
        let t = "MODEL        1\n\
                 ATOM      1  N  AGLY A   1       1.000   1.000   1.000  0.50 20.00           N  \n\
                 ATOM      2  N  BGLY A   1       2.000   2.000   2.000  0.50 20.00           N  \n\
                 ENDMDL\nMODEL        2\n\
                 ATOM      1  N   GLY A   1       1.000   1.000   1.000  1.00 20.00           N  \n\
                 ENDMDL\n";
        let m = parse(t, "t.pdb").unwrap();
        assert_eq!(m.atoms.len(), 1);
        assert_eq!(m.atoms[0].position.x, 1.0);
        assert_eq!(m.extra_models, 1);
    }

    #[test]
    fn a_residue_whose_conformers_are_different_residues_keeps_the_first_whole() {
        // 1EJG's residue 22: PRO in conformer A, SER in B (and C).
        let t = "ATOM      1  N  APRO A  22       1.000   0.000   0.000  0.60  5.00           N  \n\
                 ATOM      2  N  BSER A  22       1.100   0.000   0.000  0.40  5.00           N  \n\
                 ATOM      3  CA APRO A  22       2.000   0.000   0.000  0.60  5.00           C  \n\
                 ATOM      4  CA BSER A  22       2.100   0.000   0.000  0.40  5.00           C  \n\
                 ATOM      5  CB BSER A  22       3.100   0.000   0.000  0.40  5.00           C  \n\
                 ATOM      6  OG BSER A  22       4.100   0.000   0.000  0.40  5.00           O  \n\
                 ATOM      7  CD APRO A  22       5.000   0.000   0.000  0.60  5.00           C  \n\
                 ATOM      8  N   GLY A  23       6.000   0.000   0.000  1.00  5.00           N  \n";
        let m = parse(t, "t.pdb").unwrap();
        let kept: Vec<(&str, &str)> = m.atoms.iter().map(|a| (a.resname.as_str(), a.name.as_str())).collect();
        assert_eq!(kept, [("PRO", "N"), ("PRO", "CA"), ("PRO", "CD"), ("GLY", "N")]);
        assert_eq!(m.atoms.iter().map(|a| a.site).collect::<Vec<_>>(), [0, 2, 6, 7], "sites still count every record");
    }

    #[test]
    fn bad_records_are_errors_naming_the_line() {
        let bad = A.replace("22.117", " abcde");
        let e = parse(&format!("HEADER\n{bad}"), "t.pdb").unwrap_err();
        assert_eq!(e.to_string(), "t.pdb:2: x coordinate (columns 31-38) \"abcde\" is not a number");
        let e = parse(&A[..40], "t.pdb").unwrap_err();
        assert!(e.to_string().starts_with("t.pdb:1: the file is cut short inside this ATOM record"), "{e}");
    }
}
