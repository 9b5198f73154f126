//! GROMACS GRO files: a title line, the number of atoms, one fixed-column
//! line per atom, and the box:
//!
//! ```text
//! 1-5 residue number   6-10 residue name   11-15 atom name   16-20 atom number   21-44 x y z (nm)
//! ```
//!
//! Coordinates are in nanometres (read into ångström); their field width
//! is 8 unless the first atom's decimal points say otherwise (GRO allows
//! other precisions). GRO has no element column and no chains:
//!
//! - the element comes from the atom name: names of dummy and virtual
//!   sites (`MW`, `DM`, `LP`, `EP`, `VS` first) are no atoms and are
//!   skipped; a single-atom residue named as its atom (`NA NA`, `ZN ZN`,
//!   `NA+ NA`) is that ion; a name starting with H, C, N, O, S or P is that element
//!   (force fields name atoms by their element first: `CA` is an alpha
//!   carbon); other names try their first two letters (`ZND` is zinc),
//!   then their first;
//! - a chain ends where residue numbers start again lower.

use glam::DVec3;

use super::{Atom, Molecule, MoleculeError, element_case, elements, number};

/// Atom-name prefixes of sites that are not atoms: TIP4P's massless `MW`,
/// dummy (`DM`), lone-pair (`LP`), extra-point (`EP`) and virtual (`VS`)
/// sites.
const NOT_ATOMS: &[&str] = &["MW", "DM", "LP", "EP", "VS"];

/// The element of an atom named `name` in residue `residue`, or `None` for
/// a site that is no atom.
pub fn element(name: &str, residue: &str) -> Option<String> {
    let upper = name.to_ascii_uppercase();
    if NOT_ATOMS.iter().any(|p| upper.starts_with(p)) {
        return None;
    }
    // The residue's name may carry the ion's charge (`NA+`, `CL-`).
    let residue = residue.trim_end_matches(['+', '-']);
    if upper == residue.to_ascii_uppercase() && elements::is_element(&element_case(name)) {
        return Some(element_case(name));
    }
    let first: String = upper.chars().take(1).collect();
    if "HCNOSP".contains(first.as_str()) && !first.is_empty() {
        return Some(first);
    }
    let two = element_case(&upper.chars().take(2).collect::<String>());
    if two.len() == 2 && elements::is_element(&two) {
        return Some(two);
    }
    Some(if first.is_empty() { String::new() } else { element_case(&first) })
}

pub fn parse(text: &str, file: &str) -> Result<Molecule, MoleculeError> {
    parse_at(text, file, 0)
}

/// [`parse`] on text that starts after line `before` of the file (one
/// frame of a trajectory): lines are named as in the file.
pub fn parse_at(text: &str, file: &str, before: usize) -> Result<Molecule, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(before + line), message };
    let lines: Vec<&str> = text.lines().collect();
    let count_line = lines.get(1).ok_or_else(|| err(lines.len().max(1), "the file is cut short before its atom count (line 2)".into()))?;
    let count: usize = count_line.trim().parse().map_err(|_| err(2, format!("the atom count {:?} is not a whole number", count_line.trim())))?;
    let cut_short = !text.ends_with('\n');
    // Never more atoms than the file has lines: a count of 10^18 is an
    // error below (the file is cut short), not an allocation (fuzz/).
    let mut atoms = Vec::with_capacity(count.min(lines.len()));
    let (mut skipped, mut first_skipped) = (0usize, 0usize);
    let mut chain = 1usize;
    let mut last_residue: Option<i64> = None;
    let mut width = 8usize;
    for k in 0..count {
        let n = k + 3;
        let Some(&line) = lines.get(n - 1) else {
            return Err(err(lines.len(), format!("the file is cut short: its atom count (line 2) says {count} atoms, it holds {k}")));
        };
        if !line.is_ascii() {
            return Err(err(n, "an atom line that is not ASCII text".into()));
        }
        if k == 0 {
            // The precision: the distance between the first two decimal points.
            let dots: Vec<usize> = line.match_indices('.').map(|(i, _)| i).filter(|&i| i >= 20).take(2).collect();
            if dots.len() == 2 && dots[1] > dots[0] {
                width = dots[1] - dots[0];
            }
        }
        let end = 20 + 3 * width;
        if line.len() < end {
            return Err(err(
                n,
                if cut_short && n == lines.len() {
                    format!("the file is cut short inside this atom line ({} of the {end} columns that hold its coordinates)", line.len())
                } else {
                    format!("this atom line has {} columns; its coordinates need columns 21-{end}", line.len())
                },
            ));
        }
        let residue_number: Option<i64> = line[0..5].trim().parse().ok();
        // Residue numbers going down start a chain, except where they wrap:
        // GROMACS writes them modulo 100,000, so 99999 is followed by 0.
        if let (Some(r), Some(last)) = (residue_number, last_residue)
            && r < last
            && !(last == 99_999 && r <= 1)
        {
            chain += 1;
        }
        if residue_number.is_some() {
            last_residue = residue_number;
        }
        let Some(element) = element(line[10..15].trim(), line[5..10].trim()) else {
            if skipped == 0 {
                first_skipped = before + n;
            }
            skipped += 1;
            continue;
        };
        let c = |i: usize, what: &str| number(&line[20 + i * width..20 + (i + 1) * width], what, file, before + n);
        let p = DVec3::new(c(0, "x (nm)")?, c(1, "y (nm)")?, c(2, "z (nm)")?) * 10.0;
        atoms.push(Atom {
            element,
            position: p,
            chain: chain.to_string(),
            label_chain: chain.to_string(),
            line: before + n,
            site: k,
            name: line[10..15].trim().to_string(),
            resname: line[5..10].trim().to_string(),
            resid: residue_number.unwrap_or(0),
            ..Default::default()
        });
    }
    if lines.len() < count + 3 {
        return Err(err(lines.len(), "the file is cut short: the box line after the atoms is missing".into()));
    }
    // The box: 3 numbers (rectangular) or 9 (triclinic), nm; anything
    // else (or a box of zeros) is no box.
    let numbers: Option<Vec<f64>> = lines[count + 2].split_whitespace().map(|t| t.parse().ok().filter(|v: &f64| v.is_finite())).collect();
    let cell = numbers.and_then(|n| super::pbc::Cell::from_gro(&n));
    // Frames after the first (a trajectory written as GRO): as many
    // blocks of this size as the text after the box holds.
    let rest = lines[count + 3..].iter().rposition(|l| !l.trim().is_empty()).map_or(0, |last| last + 1);
    let extra_models = rest.div_ceil(count + 3);
    Ok(Molecule {
        source: file.into(),
        atoms,
        skipped_sites: (skipped > 0).then_some((skipped, first_skipped)),
        extra_models,
        sites: count,
        cell,
        bonds: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_atom_count_beyond_the_file_is_an_error_not_an_allocation() {
        // The fuzzer's first crash (fuzz/regressions/gro): capacity overflow.
        let e = parse("t\n 2222222222222222222 \n2 6\n", "big.gro").unwrap_err();
        assert_eq!(e.to_string(), "big.gro:3: this atom line has 3 columns; its coordinates need columns 21-44");
    }

    #[test]
    fn names_give_elements_and_dummies_are_skipped() {
        assert_eq!(element("CA", "ALA").as_deref(), Some("C"));
        assert_eq!(element("H16Z", "POPG").as_deref(), Some("H"));
        assert_eq!(element("ZND", "ZNM").as_deref(), Some("Zn"));
        assert_eq!(element("DM1", "ZNM"), None);
        assert_eq!(element("MW", "SOL"), None);
        assert_eq!(element("NA", "NA").as_deref(), Some("Na"));
        assert_eq!(element("CL", "CL").as_deref(), Some("Cl"));
        assert_eq!(element("NA", "NA+").as_deref(), Some("Na"), "GROMACS names ions with their charge");
        assert_eq!(element("CL", "CL-").as_deref(), Some("Cl"));
        assert_eq!(element("P", "POPE").as_deref(), Some("P"));
    }

    #[test]
    fn atoms_are_read_in_angstrom_and_chains_restart_with_residue_numbers() {
        let t = "title\n3\n    7TYR      N    1   2.127   1.135   6.289 -0.8703  0.7491  0.0338\n\
                 \x20   8ALA     CA    2   2.000   1.000   6.000\n\
                 \x20   7TYR      N    3   1.000   1.000   1.000\n   1.0 1.0 1.0\n";
        let m = parse(t, "t.gro").unwrap();
        assert_eq!(m.atoms.len(), 3);
        assert!((m.atoms[0].position - DVec3::new(21.27, 11.35, 62.89)).length() < 1e-9);
        assert_eq!(m.atoms.iter().map(|a| a.chain.as_str()).collect::<Vec<_>>(), ["1", "1", "2"]);
        assert_eq!((m.atoms[1].name.as_str(), m.atoms[1].resname.as_str(), m.atoms[1].resid), ("CA", "ALA", 8));
        let e = parse("title\n3\n    7TYR      N    1   2.127   1.135   6.289\n", "t.gro").unwrap_err();
        assert_eq!(e.to_string(), "t.gro:3: the file is cut short: its atom count (line 2) says 3 atoms, it holds 1");
    }
}
