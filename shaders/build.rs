//! Prepares `shaders/*.comp` for compilation at run time (src/lib.rs):
//! generates `layout.glsl` and `layout_bindings.glsl` from `src/layout.rs`
//! (the single source of GPU layouts and descriptor bindings), checks that
//! every kernel compiles, and writes `OUT_DIR/kernels.rs`, which embeds
//! every source and include with the key its SPIR-V is cached under.
//!
//! The check compiles without optimisation (a fraction of a second a
//! kernel), so a shader error still fails the build with glslang's
//! file:line message, warnings included. The optimised SPIR-V is made when
//! a program first needs a kernel: spirv-opt's passes (options::PASSES)
//! spend 10 to 27 s on each marching kernel on 2 cores, and a picture
//! needs one or two of the ten (docs/performance.md, "The shaders'
//! build"). It also compiles shaders/cpp/optimize.cpp, which runs those
//! passes (build_pass_runner).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[path = "../src/layout.rs"]
#[allow(dead_code)]
mod layout;
#[path = "src/options.rs"]
mod options;

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
    build_pass_runner()?;
    // Directories themselves, so that adding a shader file reruns the build.
    println!("cargo:rerun-if-changed={}", shaders.display());
    println!("cargo:rerun-if-changed={}", include_dir.display());
    println!("cargo:rerun-if-changed={}", kinds_dir.display());

    // The includes, by their name within the include folder (a kind's by
    // its path there, `kinds/hrbf.glsl`), then the two generated ones.
    let mut includes: Vec<(String, PathBuf)> = Vec::new();
    for file in sorted_files(&include_dir, "glsl")?.into_iter().chain(sorted_files(&kinds_dir, "glsl")?) {
        println!("cargo:rerun-if-changed={}", file.display());
        let name = file.strip_prefix(&include_dir).unwrap_or(&file).display().to_string();
        includes.push((name, file));
    }
    for (name, text) in [
        ("layout.glsl", layout::glsl()),
        ("layout_bindings.glsl", layout::glsl_bindings_file()),
        ("look_bindings.glsl", layout::glsl_look_bindings_file()),
        ("tiles_bindings.glsl", layout::glsl_tiles_bindings_file()),
    ] {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|e| format!("writing {name}: {e}"))?;
        includes.push((name.to_string(), path));
    }
    let mut contents = Vec::new();
    for (name, path) in &includes {
        contents.push((name.clone(), std::fs::read_to_string(path).map_err(|e| format!("reading {}: {e}", path.display()))?));
    }
    // What every kernel's SPIR-V depends on besides its own source and
    // define: the includes (by name, so that clones share the cache), the
    // shaderc linked and the spirv-opt passes (options::PASSES).
    let shared_key = {
        let mut inputs = vec![shaderc_identity(), options::PASSES.join(" ")];
        for (name, text) in &contents {
            inputs.push(name.clone());
            inputs.push(text.clone());
        }
        inputs
    };

    // Every shader, and once more per build variant of
    // layout::shader_variants.
    let mut kernels = Vec::new();
    for file in sorted_files(&shaders, "comp")? {
        println!("cargo:rerun-if-changed={}", file.display());
        let stem = file.file_stem().and_then(|s| s.to_str()).ok_or("shader name is not UTF-8")?.to_string();
        let source = std::fs::read_to_string(&file).map_err(|e| format!("reading {}: {e}", file.display()))?;
        kernels.push(Kernel { name: stem.clone(), file: file.clone(), source: source.clone(), define: None });
        for (macro_name, value, suffix) in layout::shader_variants(&stem) {
            kernels.push(Kernel { name: format!("{stem}{suffix}"), file: file.clone(), source: source.clone(), define: Some((macro_name, value)) });
        }
    }

    // The check: every kernel compiles, warnings as errors.
    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let failures: Vec<String> = kernels.iter().filter_map(|k| check(&compiler, k, &contents).err()).collect();
    if !failures.is_empty() {
        return Err(failures.join("\n"));
    }

    // kernels.rs: the includes and the kernels, embedded by include_str!
    // (so that rustc rebuilds this crate when one changes).
    let mut rs = format!(
        "// Generated by shaders/build.rs.\n\n/// The shaderc (and its SPIRV-Tools) linked.\npub(crate) static SHADERC: &str = {:?};\n\n/// The includes: (name, text).\npub(crate) static INCLUDES: &[(&str, &str)] = &[\n",
        shaderc_identity()
    );
    for (name, path) in &includes {
        let _ = writeln!(rs, "    ({name:?}, include_str!({:?})),", path.display().to_string());
    }
    rs.push_str("];\n\n/// The kernels, in the order of `Kernel::ALL`.\npub(crate) static SOURCES: &[KernelSource] = &[\n");
    for k in &kernels {
        let define = match k.define {
            Some((name, value)) => format!("Some(({name:?}, {value:?}))"),
            None => "None".into(),
        };
        let _ = writeln!(
            rs,
            "    KernelSource {{ name: {:?}, file: {:?}, source: include_str!({:?}), define: {define}, key: {:?} }},",
            k.name,
            k.file.file_name().and_then(|n| n.to_str()).unwrap_or_default(),
            k.file.display().to_string(),
            key(k, &shared_key),
        );
    }
    rs.push_str("];\n");
    std::fs::write(out.join("kernels.rs"), rs).map_err(|e| format!("writing kernels.rs: {e}"))
}

struct Kernel {
    name: String,
    file: PathBuf,
    source: String,
    define: Option<(&'static str, &'static str)>,
}

/// Compiles a kernel without optimisation and throws the SPIR-V away.
fn check(compiler: &shaderc::Compiler, k: &Kernel, includes: &[(String, String)]) -> Result<(), String> {
    let options =
        options::options(shaderc::OptimizationLevel::Zero, k.define, |name| includes.iter().find(|(n, _)| n == name).map(|(_, text)| text.clone()))?;
    compiler
        .compile_into_spirv(&k.source, shaderc::ShaderKind::Compute, &k.file.display().to_string(), "main", Some(&options))
        .map(|_| ())
        .map_err(|e| format!("shader compilation failed ({}):\n{e}", k.name))
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
/// kernel's name, source and define and the shared inputs. The run time
/// adds the optimisation to it.
fn key(k: &Kernel, shared: &[String]) -> String {
    use std::hash::{Hash, Hasher};
    let half = |salt: u8| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        salt.hash(&mut h);
        k.name.hash(&mut h);
        k.source.hash(&mut h);
        k.define.hash(&mut h);
        shared.hash(&mut h);
        h.finish()
    };
    format!("{:016x}{:016x}", half(1), half(2))
}

/// Compiles shaders/cpp/optimize.cpp, which runs options::PASSES with
/// SPIRV-Tools' optimizer, where shaderc is linked from Debian's archive
/// (which holds SPIRV-Tools) and SPIRV-Tools' header is installed (package
/// spirv-tools, from scripts/env.sh), and says so to the crate
/// (`cfg(isomarch_pass_list)`). Elsewhere (shaderc built from source, whose
/// SPIRV-Tools may differ from the system's header) the kernels keep
/// shaderc's performance passes.
fn build_pass_runner() -> Result<(), String> {
    println!("cargo::rustc-check-cfg=cfg(isomarch_pass_list)");
    println!("cargo:rerun-if-changed=cpp/optimize.cpp");
    let archive = std::env::var_os("SHADERC_LIB_DIR").map(|d| PathBuf::from(d).join("libshaderc_combined.a")).is_some_and(|a| a.is_file());
    let header = Path::new("/usr/include/spirv-tools/optimizer.hpp");
    println!("cargo:rerun-if-changed={}", header.display());
    if !archive || !header.is_file() {
        return Ok(());
    }
    // No C++ runtime named: the merged archive holds libstdc++ (see
    // isomarch_shaderc_archive in scripts/env.sh).
    cc::Build::new()
        .cpp(true)
        .cpp_link_stdlib(None)
        .std("c++17")
        .file("cpp/optimize.cpp")
        .try_compile("isomarch_spirv_opt")
        .map_err(|e| format!("compiling shaders/cpp/optimize.cpp: {e}"))?;
    println!("cargo:rustc-cfg=isomarch_pass_list");
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
