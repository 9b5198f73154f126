//! Compiles `shaders/*.comp` to SPIR-V with shaderc (glslang).
//!
//! Includes resolve against `shaders/include/` and the generated
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
    println!("cargo:rerun-if-changed=src/layout.rs");
    // Directories themselves, so that adding a shader file reruns the build.
    println!("cargo:rerun-if-changed={}", shaders.display());
    println!("cargo:rerun-if-changed={}", include_dir.display());

    let generated = layout::glsl();
    std::fs::write(out.join("layout.glsl"), &generated).map_err(|e| format!("writing layout.glsl: {e}"))?;
    let bindings = layout::glsl_bindings_file();
    std::fs::write(out.join("layout_bindings.glsl"), &bindings).map_err(|e| format!("writing layout_bindings.glsl: {e}"))?;

    for file in sorted_files(&include_dir, "glsl")? {
        println!("cargo:rerun-if-changed={}", file.display());
    }

    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let mut options = shaderc::CompileOptions::new().map_err(|e| format!("shaderc options: {e}"))?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_source_language(shaderc::SourceLanguage::GLSL);
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_warnings_as_errors();
    let include_root = include_dir.clone();
    options.set_include_callback(move |name, _kind, _from, _depth| {
        if name == "layout.glsl" {
            return Ok(shaderc::ResolvedInclude {
                resolved_name: "layout.glsl (generated from src/layout.rs)".into(),
                content: generated.clone(),
            });
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

    let mut failures = Vec::new();
    for file in sorted_files(&shaders, "comp")? {
        println!("cargo:rerun-if-changed={}", file.display());
        let source = std::fs::read_to_string(&file).map_err(|e| format!("reading {}: {e}", file.display()))?;
        let name = file.display().to_string();
        match compiler.compile_into_spirv(&source, shaderc::ShaderKind::Compute, &name, "main", Some(&options)) {
            Ok(artifact) => {
                let stem = file.file_stem().and_then(|s| s.to_str()).ok_or("shader name is not UTF-8")?;
                std::fs::write(out.join(format!("{stem}.spv")), artifact.as_binary_u8())
                    .map_err(|e| format!("writing {stem}.spv: {e}"))?;
            }
            Err(e) => failures.push(format!("shader compilation failed:\n{e}")),
        }
    }
    if failures.is_empty() { Ok(()) } else { Err(failures.join("\n")) }
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
