//! CHARMM/X-PLOR PSF topologies: the `!NATOM` section, one atom per line,
//! whitespace-separated (the standard and the `EXT` layouts alike):
//!
//! ```text
//! id  segment  residue  residue-name  atom-name  type  charge  mass  [imove ...]
//! ```
//!
//! A PSF has no coordinates: it names the atoms of a trajectory (DCD) in
//! the order of its frames. The element comes from the mass (the element
//! whose standard atomic weight lies within 0.6 u of it), since CHARMM
//! atom names and types are ambiguous (`CAL` is calcium, `CA` an alpha
//! carbon); where no element is that close (hydrogen mass repartitioning
//! puts 3 u on hydrogens), the name decides, as in GRO files. Sites of
//! mass 0 (lone pairs, TIP4P's `OM`) are no atoms and are skipped. The
//! segment is the chain. Positions are zero until a frame gives them.

use glam::DVec3;

use super::{Atom, Molecule, MoleculeError, elements, gro};

/// The element of an atom of `mass` named `name` in `residue`, or `None`
/// for a massless site.
pub fn element(mass: f64, name: &str, residue: &str) -> Option<String> {
    if mass <= 0.05 {
        return None;
    }
    if let Some(symbol) = elements::by_mass(mass, 0.6) {
        return Some(symbol.to_string());
    }
    gro::element(name, residue)
}

/// A PSF residue number: digits, optionally followed by an insertion code
/// (`52A`); 0 when it has no digits.
fn residue_number(field: &str) -> i64 {
    let end = field.char_indices().find(|&(i, c)| !(c.is_ascii_digit() || (i == 0 && c == '-'))).map_or(field.len(), |(i, _)| i);
    field[..end].parse().unwrap_or(0)
}

pub fn parse(text: &str, file: &str) -> Result<Molecule, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let lines: Vec<&str> = text.lines().collect();
    if !lines.first().is_some_and(|l| l.trim_start().starts_with("PSF")) {
        return Err(err(1, "not a PSF file: it does not start with PSF".into()));
    }
    let Some(start) = lines.iter().position(|l| l.contains("!NATOM")) else {
        return Err(err(lines.len().max(1), "the file ends here without a !NATOM section".into()));
    };
    let header = lines[start];
    let count: usize = header
        .split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| err(start + 1, format!("the atom count {:?} is not a whole number", header.trim())))?;
    let mut atoms = Vec::with_capacity(count.min(lines.len()));
    let (mut skipped, mut first_skipped) = (0usize, 0usize);
    for k in 0..count {
        let n = start + 2 + k;
        let Some(line) = lines.get(n - 1) else {
            return Err(err(lines.len(), format!("the file is cut short: !NATOM says {count} atoms, it holds {k}")));
        };
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < 8 {
            return Err(err(
                n,
                format!("this atom line has {} fields; a PSF atom needs 8 (id, segment, residue, name, atom, type, charge, mass)", f.len()),
            ));
        }
        let mass = super::number(f[7], "the mass", file, n)?;
        let Some(element) = element(mass, f[4], f[3]) else {
            if skipped == 0 {
                first_skipped = n;
            }
            skipped += 1;
            continue;
        };
        atoms.push(Atom {
            element,
            position: DVec3::ZERO,
            chain: f[1].to_string(),
            label_chain: f[1].to_string(),
            segment: f[1].to_string(),
            line: n,
            site: k,
            resid: residue_number(f[2]),
            icode: f[2].trim_start_matches(|c: char| c == '-' || c.is_ascii_digit()).to_string(),
            resname: f[3].to_string(),
            name: f[4].to_string(),
            atom_type: f[5].to_string(),
            charge: f[6].parse().ok().filter(|c: &f64| c.is_finite()).unwrap_or(0.0),
            mass,
            ..Default::default()
        });
    }
    let bonds = bonds(&lines, count, file)?;
    Ok(Molecule {
        source: file.into(),
        atoms,
        skipped_sites: (skipped > 0).then_some((skipped, first_skipped)),
        extra_models: 0,
        sites: count,
        cell: None,
        bonds,
    })
}

/// The `!NBOND` section's bonds, as pairs of sites (the atoms' ids less
/// one: ids count the `!NATOM` lines from 1); none where the section is
/// absent. Ids outside the atoms are an error naming the line.
fn bonds(lines: &[&str], atoms: usize, file: &str) -> Result<Vec<[usize; 2]>, MoleculeError> {
    let Some(start) = lines.iter().position(|l| l.contains("!NBOND")) else { return Ok(Vec::new()) };
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let count: usize = lines[start]
        .split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| err(start + 1, format!("the bond count {:?} is not a whole number", lines[start].trim())))?;
    let mut ids = Vec::with_capacity(2 * count.min(4 * lines.len()));
    let mut n = start + 1;
    while ids.len() < 2 * count {
        let Some(line) = lines.get(n) else {
            return Err(err(lines.len(), format!("the file is cut short: !NBOND says {count} bonds, it holds {}", ids.len() / 2)));
        };
        n += 1;
        for t in line.split_whitespace() {
            let id: usize = t.parse().map_err(|_| err(n, format!("the atom id {t:?} of a bond is not a whole number")))?;
            if id == 0 || id > atoms {
                return Err(err(n, format!("a bond to atom {id}, where !NATOM has {atoms}")));
            }
            ids.push(id - 1);
        }
        if line.trim().is_empty() {
            return Err(err(n, format!("!NBOND says {count} bonds; the section ends after {}", ids.len() / 2)));
        }
    }
    Ok(ids.chunks_exact(2).map(|p| [p[0], p[1]]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elements_come_from_masses_then_names() {
        assert_eq!(element(14.007, "N", "MET").as_deref(), Some("N"));
        assert_eq!(element(1.008, "HT1", "MET").as_deref(), Some("H"));
        assert_eq!(element(40.08, "CAL", "CAL").as_deref(), Some("Ca"));
        assert_eq!(element(12.011, "CA", "ALA").as_deref(), Some("C"));
        assert_eq!(element(3.024, "HA", "ALA").as_deref(), Some("H"), "repartitioned hydrogen mass: the name decides");
        assert_eq!(element(0.0, "OM", "TIP4"), None);
    }

    #[test]
    fn the_natom_section_gives_atoms_with_segments_as_chains() {
        let t = "PSF\n\n       1 !NTITLE\n REMARKS x\n\n       3 !NATOM\n\
                 \x20      1 4AKE     1        MET      N        NH3   -0.300000       14.0070           0\n\
                 \x20      2 4AKE     1        MET      HT1      HC     0.330000        1.0080           0\n\
                 \x20      3 SOLV     2        TIP4     OM       OM    -1.040000        0.0000           0\n\n";
        let m = parse(t, "t.psf").unwrap();
        assert_eq!(m.sites, 3);
        let n = &m.atoms[0];
        assert_eq!((n.name.as_str(), n.resname.as_str(), n.resid, n.atom_type.as_str(), n.charge, n.mass), ("N", "MET", 1, "NH3", -0.3, 14.007));
        assert_eq!((residue_number("52A"), residue_number("-3"), residue_number("X")), (52, -3, 0));
        assert_eq!(m.atoms.iter().map(|a| (a.element.as_str(), a.chain.as_str(), a.site)).collect::<Vec<_>>(), [("N", "4AKE", 0), ("H", "4AKE", 1)]);
        assert_eq!(m.skipped_sites, Some((1, 9)));
        assert!(m.bonds.is_empty(), "no !NBOND section, no bonds");
        let b = format!("{t}       2 !NBOND: bonds\n       1       2       2       3\n\n");
        assert_eq!(parse(&b, "t.psf").unwrap().bonds, [[0, 1], [1, 2]]);
        let bad = format!("{t}       2 !NBOND: bonds\n       1       2       2       4\n\n");
        assert_eq!(parse(&bad, "t.psf").unwrap_err().to_string(), "t.psf:12: a bond to atom 4, where !NATOM has 3");
        let e = parse(&t[..t.len() - 60], "t.psf").unwrap_err();
        assert!(e.to_string().starts_with("t.psf:9: this atom line has"), "{e}");
    }
}
