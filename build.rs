//! Compiles `shaders/*.comp` to SPIR-V with shaderc (glslang).
//!
//! Includes resolve against `shaders/include/` (a kind's file by its path
//! there, `kinds/hrbf.glsl`) and the generated
//! `layout.glsl` and `layout_bindings.glsl` (from `src/layout.rs`, the
//! single source of GPU layouts and descriptor bindings).
//! Warnings are errors; a shader error fails the build with glslang's
//! file:line message. SPIR-V lands in `OUT_DIR`, never in the tree.

use std::path::{Path, PathBuf};

#[path = "src/layout.rs"]
#[allow(dead_code)]
mod layout;

fn main() {
    if let Err(message) = run() {
        eprintln!("{message}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").map_err(|e| e.to_string())?);
    let out = PathBuf::from(std::env::var("OUT_DIR").map_err(|e| e.to_string())?);
    let shaders = root.join("shaders");
    let include_dir = shaders.join("include");
    // The primitive kinds, one file each (shaders/include/kinds.glsl).
    let kinds_dir = include_dir.join("kinds");
    println!("cargo:rerun-if-changed=src/layout.rs");
    say_which_shaderc();
    // Directories themselves, so that adding a shader file reruns the build.
    println!("cargo:rerun-if-changed={}", shaders.display());
    println!("cargo:rerun-if-changed={}", include_dir.display());
    println!("cargo:rerun-if-changed={}", kinds_dir.display());

    let generated = layout::glsl();
    std::fs::write(out.join("layout.glsl"), &generated).map_err(|e| format!("writing layout.glsl: {e}"))?;
    let bindings = layout::glsl_bindings_file();
    std::fs::write(out.join("layout_bindings.glsl"), &bindings).map_err(|e| format!("writing layout_bindings.glsl: {e}"))?;

    for file in sorted_files(&include_dir, "glsl")?.into_iter().chain(sorted_files(&kinds_dir, "glsl")?) {
        println!("cargo:rerun-if-changed={}", file.display());
    }

    // Every shader, and once more per build variant of
    // layout::shader_variants: (source, output stem, macro).
    let mut jobs = Vec::new();
    for file in sorted_files(&shaders, "comp")? {
        println!("cargo:rerun-if-changed={}", file.display());
        let stem = file.file_stem().and_then(|s| s.to_str()).ok_or("shader name is not UTF-8")?.to_string();
        for (macro_name, value, suffix) in layout::shader_variants(&stem) {
            jobs.push((file.clone(), format!("{stem}{suffix}"), Some((macro_name, value))));
        }
        jobs.push((file, stem, None));
    }
    // Two threads taking jobs from one queue, heaviest first: spirv-opt
    // spends most of a minute on each marching kernel, so the two go to
    // different threads and the small shaders fill in behind them. On a
    // fresh build this script is the last long job, so its balance is the
    // first build's wall time.
    // Heaviest first (their SPIR-V today: march_indexed 890 kB, march 480,
    // bounds_indexed 390, bounds 200, index 12); unknown shaders last.
    const HEAVIEST_FIRST: [&str; 2] = ["march", "bounds"];
    jobs.sort_by_key(|(file, _, define)| {
        let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        (HEAVIEST_FIRST.iter().position(|&h| h == stem).unwrap_or(HEAVIEST_FIRST.len()), define.is_none())
    });
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2)
            .map(|_| {
                let (jobs, next, generated, bindings, include_dir, out) = (&jobs, &next, &generated, &bindings, &include_dir, &out);
                scope.spawn(move || {
                    let mut failures = Vec::new();
                    while let Some((file, stem, define)) = jobs.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed)) {
                        if let Err(e) = compile(file, stem, *define, generated, bindings, include_dir, out) {
                            failures.push(e);
                        }
                    }
                    failures
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap_or_else(|_| vec!["a shader compile thread panicked".into()])).collect()
    });
    if failures.is_empty() { Ok(()) } else { Err(failures.join("\n")) }
}

/// Compiles one shader to `OUT_DIR/{stem}.spv`, with `define` set.
fn compile(
    file: &Path,
    stem: &str,
    define: Option<(&str, &str)>,
    generated: &str,
    bindings: &str,
    include_dir: &Path,
    out: &Path,
) -> Result<(), String> {
    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let mut options = shaderc::CompileOptions::new().map_err(|e| format!("shaderc options: {e}"))?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_source_language(shaderc::SourceLanguage::GLSL);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_warnings_as_errors();
    if let Some((name, value)) = define {
        options.add_macro_definition(name, Some(value));
    }
    let (generated, bindings, include_root) = (generated.to_string(), bindings.to_string(), include_dir.to_path_buf());
    options.set_include_callback(move |name, _kind, _from, _depth| {
        if name == "layout.glsl" {
            return Ok(shaderc::ResolvedInclude { resolved_name: "layout.glsl (generated from src/layout.rs)".into(), content: generated.clone() });
        }
        if name == "layout_bindings.glsl" {
            return Ok(shaderc::ResolvedInclude {
                resolved_name: "layout_bindings.glsl (generated from src/layout.rs)".into(),
                content: bindings.clone(),
            });
        }
        let path = include_root.join(name);
        std::fs::read_to_string(&path)
            .map(|content| shaderc::ResolvedInclude { resolved_name: path.display().to_string(), content })
            .map_err(|e| format!("cannot include {}: {e}", path.display()))
    });
    let source = std::fs::read_to_string(file).map_err(|e| format!("reading {}: {e}", file.display()))?;
    let name = file.display().to_string();
    let artifact = compiler
        .compile_into_spirv(&source, shaderc::ShaderKind::Compute, &name, "main", Some(&options))
        .map_err(|e| format!("shader compilation failed ({stem}):\n{e}"))?;
    std::fs::write(out.join(format!("{stem}.spv")), artifact.as_binary_u8()).map_err(|e| format!("writing {stem}.spv: {e}"))
}

/// Says in the build's output which shaderc compiles the shaders: Debian's
/// static libraries, merged by scripts/env.sh into the folder that
/// SHADERC_LIB_DIR names (.cargo/config.toml), or, where that folder holds
/// no archive, the one shaderc-sys built from source (the fallback).
fn say_which_shaderc() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    let archive = std::env::var_os("SHADERC_LIB_DIR").map(|d| PathBuf::from(d).join("libshaderc_combined.a")).filter(|a| a.is_file());
    match archive {
        Some(a) => println!("cargo:warning=shaderc: linked from the system's static libraries ({})", a.display()),
        None => println!(
            "cargo:warning=shaderc: built from source (about 8 minutes once): no libshaderc_combined.a where SHADERC_LIB_DIR points; scripts/env.sh merges Debian's there"
        ),
    }
}

fn sorted_files(dir: &Path, extension: &str) -> Result<Vec<PathBuf>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("reading {}: {e}", dir.display()))?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == extension))
        .collect();
    files.sort();
    Ok(files)
}
