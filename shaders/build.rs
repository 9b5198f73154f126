//! Compiles `shaders/*.comp` to SPIR-V with shaderc (glslang), for this
//! crate's constants (src/lib.rs).
//!
//! Includes resolve against `shaders/include/` (a kind's file by its path
//! there, `kinds/hrbf.glsl`) and the generated
//! `layout.glsl` and `layout_bindings.glsl` (from `src/layout.rs`, the
//! single source of GPU layouts and descriptor bindings).
//! Warnings are errors; a shader error fails the build with glslang's
//! file:line message. SPIR-V lands in `OUT_DIR`, never in the tree.

use std::path::{Path, PathBuf};

#[path = "../src/layout.rs"]
#[allow(dead_code)]
mod layout;

fn main() {
    if let Err(message) = run() {
        eprintln!("{message}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    // This crate lives in shaders/; the layout it generates GLSL from is
    // the library's (src/layout.rs, the one source of GPU layouts).
    let shaders = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").map_err(|e| e.to_string())?);
    let out = PathBuf::from(std::env::var("OUT_DIR").map_err(|e| e.to_string())?);
    let include_dir = shaders.join("include");
    // The primitive kinds, one file each (shaders/include/kinds.glsl).
    let kinds_dir = include_dir.join("kinds");
    println!("cargo:rerun-if-changed=../src/layout.rs");
    say_which_shaderc();
    // Directories themselves, so that adding a shader file reruns the build.
    println!("cargo:rerun-if-changed={}", shaders.display());
    println!("cargo:rerun-if-changed={}", include_dir.display());
    println!("cargo:rerun-if-changed={}", kinds_dir.display());

    let generated = layout::glsl();
    std::fs::write(out.join("layout.glsl"), &generated).map_err(|e| format!("writing layout.glsl: {e}"))?;
    let bindings = layout::glsl_bindings_file();
    std::fs::write(out.join("layout_bindings.glsl"), &bindings).map_err(|e| format!("writing layout_bindings.glsl: {e}"))?;

    // Every input a shader's SPIR-V depends on, for the cache's key: the
    // includes, the generated layout, the shaderc linked.
    let mut inputs = vec![generated.clone(), bindings.clone(), shaderc_identity()];
    for file in sorted_files(&include_dir, "glsl")?.into_iter().chain(sorted_files(&kinds_dir, "glsl")?) {
        println!("cargo:rerun-if-changed={}", file.display());
        // By name within the include folder: clones elsewhere share the cache.
        inputs.push(file.strip_prefix(&include_dir).unwrap_or(&file).display().to_string());
        inputs.push(std::fs::read_to_string(&file).map_err(|e| format!("reading {}: {e}", file.display()))?);
    }
    let cache = shader_cache(&out);

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
    let optimization = optimization()?;
    let next = std::sync::atomic::AtomicUsize::new(0);
    let times = std::sync::Mutex::new(Vec::new());
    let failures: Vec<String> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2)
            .map(|_| {
                let shared = Shared {
                    generated: &generated,
                    bindings: &bindings,
                    include_dir: &include_dir,
                    out: &out,
                    optimization,
                    inputs: &inputs,
                    cache: cache.as_deref(),
                };
                let (jobs, next, times) = (&jobs, &next, &times);
                scope.spawn(move || {
                    let mut failures = Vec::new();
                    while let Some((file, stem, define)) = jobs.get(next.fetch_add(1, std::sync::atomic::Ordering::Relaxed)) {
                        let started = std::time::Instant::now();
                        if let Err(e) = compile(file, stem, *define, &shared) {
                            failures.push(e);
                        }
                        if let Ok(mut t) = times.lock() {
                            t.push(format!("{stem}\t{:.2}", started.elapsed().as_secs_f64()));
                        }
                    }
                    failures
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap_or_else(|_| vec!["a shader compile thread panicked".into()])).collect()
    });
    // Each shader's compile time, seconds, for whoever asks where the
    // build's minutes go (issue 53): OUT_DIR/shader-times.tsv.
    let mut times = times.into_inner().unwrap_or_default();
    times.sort();
    std::fs::write(out.join("shader-times.tsv"), format!("shader\tseconds\n{}\n", times.join("\n")))
        .map_err(|e| format!("writing shader-times.tsv: {e}"))?;
    if failures.is_empty() { Ok(()) } else { Err(failures.join("\n")) }
}

/// The optimisation shaderc applies: `ISOMARCH_SHADER_OPT=performance`
/// (spirv-opt's performance passes), `zero` (none), or by default the one
/// measured to pay (see the function's body).
fn optimization() -> Result<shaderc::OptimizationLevel, String> {
    println!("cargo:rerun-if-env-changed=ISOMARCH_SHADER_OPT");
    match std::env::var("ISOMARCH_SHADER_OPT").as_deref() {
        Err(_) | Ok("") | Ok("performance") => Ok(shaderc::OptimizationLevel::Performance),
        Ok("zero") => Ok(shaderc::OptimizationLevel::Zero),
        Ok(other) => Err(format!("ISOMARCH_SHADER_OPT={other:?}: expected performance or zero")),
    }
}

/// What every shader's compilation shares: the generated includes, the
/// include folder, the output folder and the optimisation.
struct Shared<'a> {
    generated: &'a str,
    bindings: &'a str,
    include_dir: &'a Path,
    out: &'a Path,
    optimization: shaderc::OptimizationLevel,
    /// What every shader depends on besides its own source ([`key`]).
    inputs: &'a [String],
    cache: Option<&'a Path>,
}

/// Where compiled SPIR-V is kept by the hash of everything it was made
/// from: `shader-cache/` in the profile's folder of the target dir. Every
/// command that builds this crate's build script anew (clippy, whose
/// workspace wrapper changes the hash of local packages' units; maturin,
/// whose features differ; a second clone sharing the target dir) finds the
/// shaders compiled once there instead of spending minutes on them again.
/// `None` where OUT_DIR is not inside a target dir's `build/` folder.
fn shader_cache(out: &Path) -> Option<PathBuf> {
    let build = out.parent()?.parent()?;
    (build.file_name()? == "build").then(|| build.parent().map(|profile| profile.join("shader-cache")))?
}

/// The identity of the shaderc that compiles: a hash of its linked
/// archive's bytes where SHADERC_LIB_DIR names one (each clone merges its
/// own copy of Debian's libraries, alike but for the time it was made),
/// else the crate's.
fn shaderc_identity() -> String {
    use std::hash::{Hash, Hasher};
    let archive = std::env::var_os("SHADERC_LIB_DIR").map(|d| PathBuf::from(d).join("libshaderc_combined.a"));
    match archive.and_then(|a| std::fs::read(a).ok()) {
        Some(bytes) => {
            let mut h = std::collections::hash_map::DefaultHasher::new();
            bytes.hash(&mut h);
            format!("archive of {} bytes, hash {:016x}", bytes.len(), h.finish())
        }
        None => "shaderc-sys built from source".to_string(),
    }
}

/// A 128-bit key (two SipHash passes with different prefixes, hex) of a
/// shader's name and source, its define, the optimisation and the shared
/// inputs.
fn key(stem: &str, source: &str, define: Option<(&str, &str)>, shared: &Shared) -> String {
    use std::hash::{Hash, Hasher};
    let half = |salt: u8| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        salt.hash(&mut h);
        stem.hash(&mut h);
        source.hash(&mut h);
        define.hash(&mut h);
        format!("{:?}", shared.optimization).hash(&mut h);
        shared.inputs.hash(&mut h);
        h.finish()
    };
    format!("{:016x}{:016x}", half(1), half(2))
}

/// Compiles one shader to `OUT_DIR/{stem}.spv`, with `define` set.
fn compile(file: &Path, stem: &str, define: Option<(&str, &str)>, shared: &Shared) -> Result<(), String> {
    let Shared { generated, bindings, include_dir, out, optimization, .. } = *shared;
    let source = std::fs::read_to_string(file).map_err(|e| format!("reading {}: {e}", file.display()))?;
    let target = out.join(format!("{stem}.spv"));
    let cached = shared.cache.map(|c| c.join(format!("{}.spv", key(stem, &source, define, shared))));
    if let Some(c) = &cached
        && std::fs::copy(c, &target).is_ok()
    {
        return Ok(());
    }
    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let mut options = shaderc::CompileOptions::new().map_err(|e| format!("shaderc options: {e}"))?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_source_language(shaderc::SourceLanguage::GLSL);
    options.set_optimization_level(optimization);
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
    let name = file.display().to_string();
    let artifact = compiler
        .compile_into_spirv(&source, shaderc::ShaderKind::Compute, &name, "main", Some(&options))
        .map_err(|e| format!("shader compilation failed ({stem}):\n{e}"))?;
    std::fs::write(&target, artifact.as_binary_u8()).map_err(|e| format!("writing {stem}.spv: {e}"))?;
    // Into the cache under a temporary name, then renamed: a reader never
    // sees half a file. A cache that cannot be written costs only time.
    if let Some(c) = cached
        && let Some(dir) = c.parent()
        && std::fs::create_dir_all(dir).is_ok()
    {
        let tmp = dir.join(format!(".{stem}.{}.tmp", std::process::id()));
        if std::fs::write(&tmp, artifact.as_binary_u8()).is_ok() && std::fs::rename(&tmp, &c).is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
    }
    Ok(())
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
