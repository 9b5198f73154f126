//! Every reader of input from strangers, by name, from bytes: the entry
//! points the fuzz targets drive (fuzz/, docs/fuzzing.md) and the corpus
//! replay test runs again (tests/fuzz_corpus.rs). The property both hold
//! them to: any input gives a scene or a one-line error, never a panic, an
//! abort, a hang or unbounded memory.

use std::fmt::Display;

use crate::molecule::{self, Format, MoleculeOptions};
use crate::scene::Scene;

/// The fuzz targets: a scene file (RON, through validation), the three
/// molecule formats (read and turned into a scene), gzip in front of a
/// PDB reader (the bytes after the two magic bytes are fuzzed), PSF
/// topologies, and XTC and DCD trajectories (every frame read).
pub const TARGETS: [&str; 8] = ["scene", "pdb", "cif", "gro", "gzip", "psf", "xtc", "dcd"];

/// Reads every frame of the trajectory `data` as a file of extension
/// `ext` (the readers seek in files): the frame count.
fn trajectory(data: &[u8], ext: &str) -> Result<usize, String> {
    use std::sync::atomic::{AtomicU64, Ordering};

    use crate::molecule::trajectory::{Frames, dcd::DcdFrames, xtc::XtcFrames};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let path = std::env::temp_dir().join(format!("isomarch-input-{}-{}.{ext}", std::process::id(), NEXT.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&path, data).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    let read = || -> Result<usize, crate::molecule::MoleculeError> {
        let mut frames: Box<dyn Frames> = match ext {
            "xtc" => Box::new(XtcFrames::open(&path, None)?),
            _ => Box::new(DcdFrames::open(&path, None)?),
        };
        for k in 0..frames.len() {
            frames.read(k)?;
        }
        Ok(frames.len())
    };
    let out = read().map_err(|e| e.to_string());
    let _ = std::fs::remove_file(&path);
    out
}

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
        "psf" => {
            let text = std::str::from_utf8(data).map_err(|e| format!("fuzz.psf: not UTF-8 text: {e}"))?;
            Ok(crate::molecule::psf::parse(text, "fuzz.psf").map_err(line)?.atoms.len())
        }
        "xtc" | "dcd" => trajectory(data, target),
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
