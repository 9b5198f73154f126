//! Molecules: PDB, mmCIF and GRO files, gzipped or not, read into atoms
//! and turned into scenes of one Gaussian blob per atom (docs/molecules.md).
//!
//! The readers are small and written here rather than taken from a crate:
//! pdbtbx (0.12) was tried first. It reads the five test structures only
//! with `only_atomic_coords` (SEQADV and SSBOND records of 1TII.pdb stop it
//! otherwise), it replaces an element it does not know by one guessed from
//! the atom name without saying so (element `XX` on atom `CG` became
//! carbon), and its atoms no longer know their line, so neither the
//! unknown-element warning nor a one-line error naming the line could be
//! given. PDB and GRO are fixed columns; mmCIF needs a tokenizer for the
//! `_atom_site` loop (`cif.rs`). Gzip goes through flate2.
//!
//! Every problem is one line naming the file and, where there is one, the
//! line: [`MoleculeError`]. Reading never writes anything.

pub mod build;
pub mod cif;
pub mod color;
pub mod elements;
pub mod gro;
pub mod pbc;
pub mod pdb;
pub mod playback;
pub mod psf;
pub mod select;
pub mod trajectory;

use std::io::Read as _;
use std::path::Path;

use glam::DVec3;

pub use build::{Coloring, MoleculeChoices, MoleculeOptions};

/// One atom as read: its element symbol as written in the periodic table
/// (`C`, `Se`, `Zn`; an unrecognised symbol as found, upper case), its
/// position in ångström, its chain (empty when the file has none), and
/// what users select it by (`select.rs`). A field the format lacks keeps
/// its default: empty text, residue 0, B-factor 0, occupancy 1, charge
/// and mass 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Atom {
    pub element: String,
    pub position: DVec3,
    /// The author's chain: PDB column 22, mmCIF `auth_asym_id` (else
    /// `label_asym_id`), PSF's segment, GRO's count of chains (`1`, `2`..:
    /// a chain ends where residue numbers start again lower).
    pub chain: String,
    /// The line it was read from (1-based, of the decompressed text).
    pub line: usize,
    /// Its place among the file's coordinate sites (0-based, counting
    /// sites skipped or left out too): the index of its position in each
    /// frame of a trajectory written for this topology.
    pub site: usize,
    /// The atom's name (`CA`, `OW`), trimmed.
    pub name: String,
    /// The residue's name (`LYS`, `HOH`, `SOL`), trimmed.
    pub resname: String,
    /// The residue's number (the author's: PDB columns 23-26, mmCIF
    /// `auth_seq_id`, else `label_seq_id`).
    pub resid: i64,
    /// The residue's insertion code (PDB column 27, mmCIF
    /// `pdbx_PDB_ins_code`), empty when none.
    pub icode: String,
    /// mmCIF's `label_asym_id`; elsewhere the chain.
    pub label_chain: String,
    /// The segment: PDB columns 73-76, PSF's segment; empty elsewhere.
    pub segment: String,
    /// The B-factor (temperature factor; AlphaFold's pLDDT), Å².
    pub beta: f64,
    pub occupancy: f64,
    /// A HETATM record (mmCIF `group_PDB`).
    pub hetero: bool,
    /// PSF's atom type, partial charge (e) and mass (u).
    pub atom_type: String,
    pub charge: f64,
    pub mass: f64,
}

impl Default for Atom {
    fn default() -> Self {
        Atom {
            element: String::new(),
            position: DVec3::ZERO,
            chain: String::new(),
            line: 0,
            site: 0,
            name: String::new(),
            resname: String::new(),
            resid: 0,
            icode: String::new(),
            label_chain: String::new(),
            segment: String::new(),
            beta: 0.0,
            occupancy: 1.0,
            hetero: false,
            atom_type: String::new(),
            charge: 0.0,
            mass: 0.0,
        }
    }
}

/// The atoms of a file, and what was left out and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Molecule {
    /// The path, for messages.
    pub source: String,
    pub atoms: Vec<Atom>,
    /// Sites that are not atoms and were skipped (GRO dummy and virtual
    /// sites), with the first one's line, for the note printed on load.
    pub skipped_sites: Option<(usize, usize)>,
    /// Models after the first that were left out (PDB `MODEL`, mmCIF
    /// `pdbx_PDB_model_num`).
    pub extra_models: usize,
    /// How many coordinate sites a frame of this structure holds (atoms
    /// kept, skipped and left out as alternate locations).
    pub sites: usize,
    /// The periodic box, where the file gives one (GRO's last line).
    pub cell: Option<pbc::Cell>,
    /// Bonds between sites, where the topology lists them (PSF's
    /// `!NBOND`); empty elsewhere (they are then guessed where needed).
    pub bonds: Vec<[usize; 2]>,
}

/// A problem with a molecule file: one line, naming the file and, where
/// there is one, the line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}{}: {message}", .line.map_or(String::new(), |l| format!(":{l}")))]
pub struct MoleculeError {
    pub file: String,
    pub line: Option<usize>,
    pub message: String,
}

/// The formats read, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Pdb,
    Cif,
    Gro,
}

/// The format of a molecule file by its extension (`.pdb`, `.ent`, `.cif`,
/// `.mmcif`, `.gro`, each optionally followed by `.gz`), or `None` for
/// anything else (a scene file).
pub fn format_of(path: &Path) -> Option<Format> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = name.rsplit_once('.')?.1;
    match ext {
        "pdb" | "ent" => Some(Format::Pdb),
        "cif" | "mmcif" => Some(Format::Cif),
        "gro" => Some(Format::Gro),
        _ => None,
    }
}

/// Whether `path` names a molecule file rather than a scene file.
pub fn is_molecule(path: &Path) -> bool {
    format_of(path).is_some()
}

/// The most text a molecule file may hold once decompressed: 1 GiB, ten
/// times the largest mmCIF in the PDB archive. A gzip stream that inflates
/// beyond it (a decompression bomb, or a corrupt length) is an error before
/// it can fill memory.
pub const MAX_TEXT_BYTES: u64 = 1 << 30;

/// The file's text, decompressed when it is gzip (by its magic bytes, so a
/// `.gz` name is not required). A gzip stream cut short is an error naming
/// the last whole line it held.
fn text_of(bytes: Vec<u8>, file: &str) -> Result<String, MoleculeError> {
    let err = |line: Option<usize>, message: String| MoleculeError { file: file.into(), line, message };
    let bytes = if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        let mut decoder = flate2::read::MultiGzDecoder::new(&bytes[..]).take(MAX_TEXT_BYTES + 1);
        if let Err(e) = decoder.read_to_end(&mut out) {
            let lines = out.iter().filter(|&&b| b == b'\n').count();
            let what = if e.kind() == std::io::ErrorKind::UnexpectedEof { "is cut short".to_string() } else { format!("is corrupt ({e})") };
            return Err(err(Some(lines + 1), format!("the gzip stream {what}: its content ends inside this line")));
        }
        if out.len() as u64 > MAX_TEXT_BYTES {
            return Err(err(None, format!("the gzip stream inflates to more than {} MiB, more than any molecule file holds", MAX_TEXT_BYTES >> 20)));
        }
        out
    } else {
        bytes
    };
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        err(Some(line), "not text: a byte that is not UTF-8".into())
    })
}

/// Reads the atoms of a PDB, mmCIF or GRO file (by extension), gzipped or
/// not. Only the first model is read; of each atom site's alternate
/// locations, the first given is kept. An error is one line; a file
/// without atoms is one.
pub fn read(path: &Path) -> Result<Molecule, MoleculeError> {
    let file = path.display().to_string();
    let Some(format) = format_of(path) else {
        return Err(MoleculeError {
            file,
            line: None,
            message: "not a molecule file: expected .pdb, .ent, .cif, .mmcif or .gro, optionally .gz".into(),
        });
    };
    let bytes = std::fs::read(path).map_err(|e| MoleculeError { file: file.clone(), line: None, message: format!("cannot read: {e}") })?;
    parse_bytes(bytes, format, &file)
}

/// [`read`] on a file's bytes, in the given format: `file` names it in
/// errors. The entry point of the fuzz targets (fuzz/).
pub fn parse_bytes(bytes: Vec<u8>, format: Format, file: &str) -> Result<Molecule, MoleculeError> {
    let text = text_of(bytes, file)?;
    let molecule = match format {
        Format::Pdb => pdb::parse(&text, file)?,
        Format::Cif => cif::parse(&text, file)?,
        Format::Gro => gro::parse(&text, file)?,
    };
    if molecule.atoms.is_empty() {
        let last = text.lines().count();
        let what = match format {
            Format::Pdb => "no ATOM or HETATM record",
            Format::Cif => "no _atom_site row",
            Format::Gro => "no atom line",
        };
        return Err(MoleculeError {
            file: file.into(),
            line: Some(last.max(1)),
            message: format!("the file ends here with {what}: no atoms to render"),
        });
    }
    Ok(molecule)
}

/// Parses a coordinate field; the error names the field and its text.
pub(crate) fn number(field: &str, what: &str, file: &str, line: usize) -> Result<f64, MoleculeError> {
    let t = field.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(MoleculeError { file: file.into(), line: Some(line), message: format!("{what} {t:?} is not a number") }),
    }
}

/// An element symbol as the periodic table writes it: `SE` and `se` become
/// `Se`.
pub(crate) fn element_case(symbol: &str) -> String {
    let mut c = symbol.trim().chars();
    match c.next() {
        Some(first) => first.to_ascii_uppercase().to_string() + &c.as_str().to_ascii_lowercase(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_come_from_the_extension_with_or_without_gz() {
        assert_eq!(format_of(Path::new("a/1TII.pdb")), Some(Format::Pdb));
        assert_eq!(format_of(Path::new("3KPR.PDB.GZ")), Some(Format::Pdb));
        assert_eq!(format_of(Path::new("6WG6.cif.gz")), Some(Format::Cif));
        assert_eq!(format_of(Path::new("x.gro")), Some(Format::Gro));
        assert_eq!(format_of(Path::new("scene.ron")), None);
        assert_eq!(format_of(Path::new("gz")), None);
    }

    #[test]
    fn errors_are_one_line_with_file_and_line() {
        let e = MoleculeError { file: "a.pdb".into(), line: Some(12), message: "x coordinate \"abc\" is not a number".into() };
        assert_eq!(e.to_string(), "a.pdb:12: x coordinate \"abc\" is not a number");
        let e = MoleculeError { file: "a.pdb".into(), line: None, message: "cannot read".into() };
        assert_eq!(e.to_string(), "a.pdb: cannot read");
        assert_eq!(element_case("SE"), "Se");
        assert_eq!(element_case(" c"), "C");
    }
}
