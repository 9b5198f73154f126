//! Replays the fuzz corpus (fuzz/corpus/TARGET/) and every crash the fuzzer
//! found (fuzz/regressions/TARGET/, each fixed) through the readers, as the
//! fuzz targets run them (isomarch::inputs::check): each input gives a
//! scene or a one-line error, never a panic. Fast: no GPU, a few thousand
//! small files.

use std::path::Path;

use isomarch::inputs::{TARGETS, check};

fn files(dir: &Path) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut files: Vec<_> = entries.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    files.sort();
    files
}

/// The targets in which the fuzzer found crashes (docs/fuzzing.md's table),
/// each kept in fuzz/regressions/TARGET/: a folder moved or emptied would
/// otherwise read as no crash to replay.
const CRASHES_FOUND: &[&str] = &["gro", "xtc"];

#[test]
fn every_corpus_input_and_every_crash_found_gives_a_scene_or_one_line_error() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    for target in CRASHES_FOUND {
        assert!(
            !files(&root.join("regressions").join(target)).is_empty(),
            "fuzz/regressions/{target} is missing or empty: its crash is not replayed"
        );
    }
    for entry in std::fs::read_dir(root.join("regressions")).expect("fuzz/regressions") {
        let name = entry.unwrap().file_name().into_string().unwrap();
        assert!(TARGETS.contains(&name.as_str()), "fuzz/regressions/{name} is no fuzz target's: its inputs are not replayed");
    }
    let mut replayed = 0;
    for target in TARGETS {
        let corpus = files(&root.join("corpus").join(target));
        assert!(!corpus.is_empty(), "fuzz/corpus/{target} is empty: the replay would check nothing");
        let mut scenes = 0;
        for file in corpus.iter().chain(&files(&root.join("regressions").join(target))) {
            let data = std::fs::read(file).unwrap();
            let outcome = std::panic::catch_unwind(|| check(target, &data));
            match outcome {
                Ok(n) => scenes += usize::from(n.is_some()),
                Err(_) => panic!("{target}: {} panics the reader (see the message above)", file.display()),
            }
            replayed += 1;
        }
        // The seeds are real files: the corpus is not all garbage.
        assert!(scenes > 0, "{target}: no corpus input gives a scene");
    }
    eprintln!("replayed {replayed} inputs");
}
