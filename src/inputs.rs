//! Every reader of input from strangers, by name, from bytes: the entry
//! points the fuzz targets drive (fuzz/, docs/fuzzing.md) and the corpus
//! replay test runs again (tests/fuzz_corpus.rs). The property both hold
//! them to: any input gives a scene or a one-line error, never a panic, an
//! abort, a hang or unbounded memory.

use std::fmt::Display;

use crate::molecule::{self, Format, MoleculeOptions};
use crate::scene::Scene;

/// The fuzz targets: a scene file (RON, through validation), the three
/// molecule formats (read and turned into a scene), and gzip in front of a
/// PDB reader (the bytes after the two magic bytes are fuzzed).
pub const TARGETS: [&str; 5] = ["scene", "pdb", "cif", "gro", "gzip"];

/// What a reader made of the input: the scene's primitive count, or its
/// error as the command line prints it.
pub fn read(target: &str, data: &[u8]) -> Result<usize, String> {
    fn line<E: Display>(e: E) -> String {
        format!("{e:#}")
    }
    let molecule = |format: Format, bytes: Vec<u8>, name: &str| -> Result<usize, String> {
        let m = molecule::parse_bytes(bytes, format, name).map_err(line)?;
        let (scene, _) = molecule::build::scene_of(&m, &MoleculeOptions::default()).map_err(line)?;
        Ok(scene.primitive_count())
    };
    match target {
        "scene" => {
            let text = std::str::from_utf8(data).map_err(|e| format!("fuzz.ron: not UTF-8 text: {e}"))?;
            Ok(Scene::parse(text, "fuzz.ron").map_err(line)?.primitive_count())
        }
        "pdb" => molecule(Format::Pdb, data.to_vec(), "fuzz.pdb"),
        "cif" => molecule(Format::Cif, data.to_vec(), "fuzz.cif"),
        "gro" => molecule(Format::Gro, data.to_vec(), "fuzz.gro"),
        "gzip" => molecule(Format::Pdb, [&[0x1f, 0x8b][..], data].concat(), "fuzz.pdb.gz"),
        _ => panic!("no fuzz target {target:?} (known: {TARGETS:?})"),
    }
}

/// [`read`], checked: panics (which the fuzzer reports as a crash) when the
/// error is not one line. Returns the primitive count where there is one.
pub fn check(target: &str, data: &[u8]) -> Option<usize> {
    match read(target, data) {
        Ok(n) => Some(n),
        Err(e) => {
            assert!(!e.trim().is_empty() && !e.contains('\n'), "{target}: the error is not one line: {e:?}");
            None
        }
    }
}
