//! mmCIF files: the `_atom_site` loop of the first data block, first model.
//!
//! A CIF is a stream of tokens: `data_` blocks, `loop_` headers followed by
//! their `_category.item` tags and then the values row after row, quoted
//! strings (`'...'` and `"..."`, closed by a quote followed by white
//! space), text fields between lines that start with `;`, and `#`
//! comments. Only the `_atom_site` loop is read: `type_symbol`,
//! `Cartn_x/y/z`, `label_alt_id`, `auth_asym_id` (else `label_asym_id`)
//! and `pdbx_PDB_model_num`, and what users select by: `group_PDB`, the
//! atom and residue names and residue number (`auth_*`, else `label_*`),
//! `label_asym_id`, `pdbx_PDB_ins_code`, `occupancy` and `B_iso_or_equiv`;
//! and the unit cell (`_cell.length_a/b/c`, `_cell.angle_alpha/beta/gamma`),
//! the periodic box where it is one (as a PDB's `CRYST1`).

use glam::DVec3;

use super::{Atom, Molecule, MoleculeError, element_case, number};

/// A token and the line it starts on.
struct Tok<'a> {
    s: &'a str,
    line: usize,
    /// A quoted string or text field (never a keyword or a tag).
    quoted: bool,
}

fn tokenize<'a>(text: &'a str, file: &str) -> Result<Vec<Tok<'a>>, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let mut out = Vec::new();
    let mut text_field: Option<usize> = None;
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        if let Some(start) = text_field {
            if line.starts_with(';') {
                out.push(Tok { s: "", line: start, quoted: true });
                text_field = None;
            }
            continue;
        }
        if line.starts_with(';') {
            text_field = Some(n);
            continue;
        }
        let b = line.as_bytes();
        let mut k = 0;
        while k < b.len() {
            if b[k].is_ascii_whitespace() {
                k += 1;
                continue;
            }
            if b[k] == b'#' {
                break;
            }
            if b[k] == b'\'' || b[k] == b'"' {
                let q = b[k];
                let close = (k + 1..b.len()).find(|&j| b[j] == q && (j + 1 == b.len() || b[j + 1].is_ascii_whitespace()));
                let Some(j) = close else {
                    return Err(err(n, format!("a quoted string opened at column {} is not closed on its line", k + 1)));
                };
                out.push(Tok { s: &line[k + 1..j], line: n, quoted: true });
                k = j + 1;
                continue;
            }
            let j = (k..b.len()).find(|&j| b[j].is_ascii_whitespace()).unwrap_or(b.len());
            out.push(Tok { s: &line[k..j], line: n, quoted: false });
            k = j;
        }
    }
    if let Some(start) = text_field {
        return Err(err(start, "a text field (;) opened here never closes: the file is cut short".into()));
    }
    Ok(out)
}

/// Whether a token ends the values of a loop.
fn is_keyword(t: &Tok) -> bool {
    if t.quoted {
        return false;
    }
    let lower = t.s.to_ascii_lowercase();
    t.s.starts_with('_') || lower == "loop_" || lower.starts_with("data_") || lower.starts_with("save_") || lower == "stop_" || lower == "global_"
}

/// A missing value in CIF.
fn missing(v: &str) -> bool {
    v == "." || v == "?"
}

pub fn parse(text: &str, file: &str) -> Result<Molecule, MoleculeError> {
    parse_model(text, file, 0)
}

/// The atoms of the `model`-th model (0-based, in order of appearance of
/// `pdbx_PDB_model_num`); `extra_models` counts the models besides it.
/// A file without that model gives no atoms.
pub fn parse_model(text: &str, file: &str, model: usize) -> Result<Molecule, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let toks = tokenize(text, file)?;
    let mut atoms = Vec::new();
    let mut extra_models = 0;
    let mut sites = 0;
    let mut blocks = 0;
    let mut cell = [None; 6];
    let mut i = 0;
    while i < toks.len() {
        let t = &toks[i];
        if !t.quoted && t.s.to_ascii_lowercase().starts_with("data_") {
            blocks += 1;
            if blocks > 1 {
                break;
            }
        }
        // `_atom_site.x value` pairs outside a loop: a table of one row
        // (a file of one atom).
        if !t.quoted && t.s.to_ascii_lowercase().starts_with("_atom_site.") {
            let line = t.line;
            let (mut tags, mut values) = (Vec::new(), Vec::new());
            while i + 1 < toks.len() && !toks[i].quoted && toks[i].s.to_ascii_lowercase().starts_with("_atom_site.") && !is_keyword(&toks[i + 1]) {
                tags.push(toks[i].s.to_ascii_lowercase());
                values.push(Tok { ..toks[i + 1] });
                i += 2;
            }
            if i < toks.len() && !toks[i].quoted && toks[i].s.to_ascii_lowercase().starts_with("_atom_site.") {
                return Err(err(toks[i].line, format!("{} has no value", toks[i].s)));
            }
            extra_models += read_rows(&tags, &values, line, file, model, &mut sites, &mut atoms)?;
            continue;
        }
        // The unit cell's six numbers, as tag-value pairs.
        if !t.quoted
            && let Some(k) = CELL.iter().position(|c| t.s.eq_ignore_ascii_case(c))
            && let Some(v) = toks.get(i + 1).filter(|v| !is_keyword(v))
        {
            cell[k] = cell_number(v.s);
            i += 2;
            continue;
        }
        if t.quoted || !t.s.eq_ignore_ascii_case("loop_") {
            i += 1;
            continue;
        }
        let loop_line = t.line;
        i += 1;
        let mut tags = Vec::new();
        while i < toks.len() && !toks[i].quoted && toks[i].s.starts_with('_') {
            tags.push(toks[i].s.to_ascii_lowercase());
            i += 1;
        }
        let start = i;
        while i < toks.len() && !is_keyword(&toks[i]) {
            i += 1;
        }
        if !tags.iter().any(|t| t.starts_with("_atom_site.")) {
            continue;
        }
        let values = &toks[start..i];
        let width = tags.len();
        if values.len() % width != 0 {
            let last = values.last().map_or(loop_line, |v| v.line);
            let have = values.len() % width;
            return Err(err(
                last,
                if i == toks.len() {
                    format!("the file is cut short inside the _atom_site loop: its last row has {have} of its {width} values")
                } else {
                    format!("the _atom_site loop's last row has {have} of its {width} values")
                },
            ));
        }
        extra_models += read_rows(&tags, values, loop_line, file, model, &mut sites, &mut atoms)?;
    }
    let cell = match cell {
        [Some(a), Some(b), Some(c), Some(alpha), Some(beta), Some(gamma)] => super::pbc::Cell::from_crystal([a, b, c], [alpha, beta, gamma]),
        _ => None,
    };
    Ok(Molecule { source: file.into(), atoms, skipped_sites: None, extra_models, sites, cell, bonds: Vec::new() })
}

/// The unit cell's tags, in the order [`super::pbc::Cell::from_crystal`]
/// takes their values.
const CELL: [&str; 6] = ["_cell.length_a", "_cell.length_b", "_cell.length_c", "_cell.angle_alpha", "_cell.angle_beta", "_cell.angle_gamma"];

/// A cell's number: `61.45`, or `61.450(3)` with its standard
/// uncertainty; none for `?` and `.` (unknown, not applicable).
fn cell_number(v: &str) -> Option<f64> {
    let v = v.split_once('(').map_or(v, |(x, _)| x);
    if missing(v) { None } else { v.parse::<f64>().ok().filter(|x| x.is_finite()) }
}

/// The atoms of an `_atom_site` table (`tags`, and `values` row after
/// row), of the `want`-th model only, appended to `atoms` (`sites` counts
/// that model's rows); returns the count of models left out. Alternate locations are chosen per atom site: the
/// first conformer given of each site is kept, so that a site whose only
/// conformers are B and C is kept too.
#[allow(clippy::too_many_arguments)]
fn read_rows(
    tags: &[String],
    values: &[Tok],
    table_line: usize,
    file: &str,
    want: usize,
    sites: &mut usize,
    atoms: &mut Vec<Atom>,
) -> Result<usize, MoleculeError> {
    let err = |line: usize, message: String| MoleculeError { file: file.into(), line: Some(line), message };
    let width = tags.len();
    let col = |name: &str| tags.iter().position(|t| t == &format!("_atom_site.{name}"));
    let need = |name: &str| col(name).ok_or_else(|| err(table_line, format!("the _atom_site table has no {name} column")));
    let (cx, cy, cz) = (need("cartn_x")?, need("cartn_y")?, need("cartn_z")?);
    let symbol = need("type_symbol")?;
    let alt_col = col("label_alt_id");
    let chain_col = col("auth_asym_id").or(col("label_asym_id"));
    let model_col = col("pdbx_pdb_model_num");
    // What users select by: the author's names and numbers where given
    // (they are what PDB files and papers use), else the label's.
    let label_chain_col = col("label_asym_id");
    let name_col = col("auth_atom_id").or(col("label_atom_id"));
    let resname_col = col("auth_comp_id").or(col("label_comp_id"));
    let resid_col = col("auth_seq_id").or(col("label_seq_id"));
    let icode_col = col("pdbx_pdb_ins_code");
    let (beta_col, occupancy_col, group_col) = (col("b_iso_or_equiv"), col("occupancy"), col("group_pdb"));
    // What names a site, of the columns the file has.
    let site_cols: Vec<usize> =
        ["label_atom_id", "auth_atom_id", "label_comp_id", "label_asym_id", "auth_asym_id", "label_seq_id", "auth_seq_id", "pdbx_pdb_ins_code"]
            .iter()
            .filter_map(|n| col(n))
            .collect();
    let mut models: Vec<&str> = Vec::new();
    let mut alt_of_site: std::collections::HashMap<Vec<&str>, &str> = std::collections::HashMap::new();
    let residue_cols: Vec<usize> = [chain_col, resid_col, icode_col].into_iter().flatten().collect();
    let mut chosen_residue: std::collections::HashMap<Vec<&str>, &str> = std::collections::HashMap::new();
    for row in values.chunks(width) {
        let line = row[0].line;
        if let Some(m) = model_col.map(|c| row[c].s) {
            let k = models.iter().position(|x| *x == m).unwrap_or_else(|| {
                models.push(m);
                models.len() - 1
            });
            if k != want {
                continue;
            }
        } else if want > 0 {
            continue;
        }
        let site = *sites;
        *sites += 1;
        if let Some(a) = alt_col.map(|c| row[c].s).filter(|a| !missing(a)) {
            // Conformers that are different residues (microheterogeneity):
            // the first given's residue is kept whole, as in pdb.rs.
            let residue: Vec<&str> = residue_cols.iter().map(|&c| row[c].s).collect();
            let name = resname_col.map_or("", |c| row[c].s);
            if *chosen_residue.entry(residue).or_insert(name) != name {
                continue;
            }
            let site: Vec<&str> = site_cols.iter().map(|&c| row[c].s).collect();
            if *alt_of_site.entry(site).or_insert(a) != a {
                continue;
            }
        }
        let x = number(row[cx].s, "Cartn_x", file, row[cx].line)?;
        let y = number(row[cy].s, "Cartn_y", file, row[cy].line)?;
        let z = number(row[cz].s, "Cartn_z", file, row[cz].line)?;
        let element = if missing(row[symbol].s) { String::new() } else { element_case(row[symbol].s) };
        let text = |c: Option<usize>| c.map(|c| row[c].s).filter(|v| !missing(v)).unwrap_or("").to_string();
        let value = |c: Option<usize>, default: f64| c.and_then(|c| row[c].s.parse::<f64>().ok()).filter(|v| v.is_finite()).unwrap_or(default);
        let chain = text(chain_col);
        atoms.push(Atom {
            element,
            position: DVec3::new(x, y, z),
            label_chain: if label_chain_col.is_some() { text(label_chain_col) } else { chain.clone() },
            chain,
            line,
            site,
            name: text(name_col),
            resname: text(resname_col),
            resid: resid_col.and_then(|c| row[c].s.parse::<i64>().ok()).unwrap_or(0),
            icode: text(icode_col),
            beta: value(beta_col, 0.0),
            occupancy: value(occupancy_col, 1.0),
            hetero: group_col.is_some_and(|c| row[c].s.eq_ignore_ascii_case("HETATM")),
            ..Default::default()
        });
    }
    Ok(models.len().saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "data_TEST\n#\nloop_\n_atom_site.group_PDB\n_atom_site.type_symbol\n_atom_site.label_alt_id\n\
                        _atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n";

    #[test]
    fn the_atom_site_loop_gives_atoms() {
        let t = format!("{HEAD}ATOM N . 1.0 2.0 3.0 A 1\nHETATM SE . -1.5 0 2 'B' 1\nATOM C . 9 9 9 A 2\n#\nloop_\n_other.x\n1\n");
        let m = parse(&t, "t.cif").unwrap();
        assert_eq!(m.atoms.len(), 2);
        assert_eq!(m.atoms[1].element, "Se");
        assert_eq!(m.atoms[1].chain, "B");
        assert_eq!(m.atoms[1].position, DVec3::new(-1.5, 0.0, 2.0));
        assert!(m.atoms[1].hetero && !m.atoms[0].hetero);
        assert_eq!((m.atoms[1].beta, m.atoms[1].occupancy), (0.0, 1.0), "columns the table lacks keep their defaults");
        assert_eq!(m.extra_models, 1);
    }

    #[test]
    fn a_residue_whose_conformers_are_different_residues_keeps_the_first_whole() {
        let head = "data_T\nloop_\n_atom_site.group_PDB\n_atom_site.type_symbol\n_atom_site.label_atom_id\n_atom_site.label_alt_id\n\
                    _atom_site.label_comp_id\n_atom_site.auth_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.auth_asym_id\n";
        let rows = "ATOM N N A PRO 22 1 0 0 A\nATOM N N B SER 22 1.1 0 0 A\nATOM C CA A PRO 22 2 0 0 A\nATOM C CA B SER 22 2.1 0 0 A\n\
                    ATOM O OG B SER 22 4 0 0 A\nATOM N N . GLY 23 6 0 0 A\n";
        let m = parse(&format!("{head}{rows}"), "t.cif").unwrap();
        let kept: Vec<(&str, &str)> = m.atoms.iter().map(|a| (a.resname.as_str(), a.name.as_str())).collect();
        assert_eq!(kept, [("PRO", "N"), ("PRO", "CA"), ("GLY", "N")]);
    }

    #[test]
    fn the_cell_gives_the_box_but_not_the_placeholder_of_one_angstrom() {
        let cell = |lengths: [&str; 3], angles: [&str; 3]| {
            let [a, b, c] = lengths;
            let [alpha, beta, gamma] = angles;
            let t = format!(
                "data_T\n_cell.entry_id T\n_cell.length_a {a}\n_cell.length_a_esd ?\n_cell.length_b {b}\n_cell.length_c {c}\n\
                 _cell.angle_alpha {alpha}\n_cell.angle_beta {beta}\n_cell.angle_gamma {gamma}\n#\n{}ATOM N . 1.0 2.0 3.0 A 1\n",
                &HEAD["data_TEST\n".len()..]
            );
            let m = parse(&t, "t.cif").unwrap();
            assert_eq!(m.atoms.len(), 1);
            m.cell
        };
        // 3KPR's cell (monoclinic), the second length with its uncertainty.
        let box_ = cell(["223.117", "53.217(4)", "143.202"], ["90.000", "102.39", "90.000"]).expect("a box");
        let [a, b, c] = box_.vectors();
        let beta = 102.39f64.to_radians();
        assert!((a - DVec3::new(223.117, 0.0, 0.0)).length() < 1e-9, "{a}");
        assert!((b - DVec3::new(0.0, 53.217, 0.0)).length() < 1e-9, "{b}");
        assert!((c - 143.202 * DVec3::new(beta.cos(), 0.0, beta.sin())).length() < 1e-9, "{c}");
        // Cryo-EM entries' placeholder, a thin cell and an unknown angle
        // are no box.
        assert_eq!(cell(["1.000", "1.000", "1.000"], ["90.00", "90.00", "90.00"]), None);
        assert_eq!(cell(["4.8", "30", "40"], ["90", "90", "90"]), None);
        assert_eq!(cell(["50", "50", "50"], ["90", "?", "90"]), None);
    }

    #[test]
    fn a_row_cut_short_is_an_error_naming_its_line() {
        let t = format!("{HEAD}ATOM N . 1.0 2.0 3.0 A 1\nATOM C . 1.0 2.0");
        let e = parse(&t, "t.cif").unwrap_err();
        assert_eq!(e.to_string(), "t.cif:13: the file is cut short inside the _atom_site loop: its last row has 5 of its 8 values");
        let t = format!("{HEAD}ATOM N . 1.0 x 3.0 A 1\n");
        assert_eq!(parse(&t, "t.cif").unwrap_err().to_string(), "t.cif:12: Cartn_y \"x\" is not a number");
    }
}
