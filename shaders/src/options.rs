//! The shaderc options every kernel is compiled with, shared by the build
//! script's check (shaders/build.rs) and the compilation at run time
//! (src/lib.rs), so that what the build checks is what a program compiles;
//! and the spirv-opt passes the kernels are optimised with.

/// The spirv-opt passes (their command-line flags) that optimise a kernel
/// compiled without optimisation: the SSA passes function by function
/// first, while each function is small, then the inlining of everything
/// into the entry point, then one cleanup of the inlined function. It
/// makes the same images as shaderc's performance passes (`spirv-opt -O`,
/// which inlines first and runs its SSA passes, some twice, on the one
/// giant function) in about half their time; what it costs on lavapipe is
/// measured in docs/performance.md, "The shaders' build". The build script
/// hashes this list into every kernel's cache key.
pub const PASSES: &[&str] = &[
    // Function by function.
    "--strip-debug",
    "--wrap-opkill",
    "--eliminate-dead-branches",
    "--merge-return",
    "--eliminate-local-single-block",
    "--eliminate-local-single-store",
    "--scalar-replacement=100",
    "--convert-local-access-chains",
    "--eliminate-local-single-block",
    "--eliminate-local-single-store",
    "--ssa-rewrite",
    "--eliminate-dead-code-aggressive",
    "--ccp",
    "--simplify-instructions",
    "--eliminate-dead-code-aggressive",
    // Everything into the entry point.
    "--inline-entry-points-exhaustive",
    "--eliminate-dead-functions",
    // The cleanup: what the inlining put in memory (arguments, results,
    // structs passed by reference) back into SSA form, once.
    "--private-to-local",
    "--eliminate-local-single-store",
    "--scalar-replacement=100",
    "--convert-local-access-chains",
    "--eliminate-local-single-block",
    "--eliminate-local-single-store",
    "--ssa-rewrite",
    "--eliminate-dead-code-aggressive",
    "--ccp",
    "--eliminate-dead-branches",
    "--redundancy-elimination",
    "--simplify-instructions",
    "--vector-dce",
    "--if-conversion",
    "--eliminate-dead-code-aggressive",
    "--merge-blocks",
    "--simplify-instructions",
];

/// The passes that specialise an optimised kernel for one pipeline, after
/// its constants' values are set (as bits: shaders/cpp/optimize.cpp): the constants frozen and folded, then
/// the branches they decide and the code only those branches used
/// removed. (The build script includes this file, and does not use it.)
#[allow(dead_code)]
pub const SPECIALISE: &[&str] =
    &["--freeze-spec-const", "--fold-spec-const-op-composite", "--eliminate-dead-branches", "--eliminate-dead-code-aggressive"];

/// Vulkan 1.2 SPIR-V from GLSL at `level`, warnings as errors, `define` set,
/// and each include resolved by its name through `lookup`.
pub fn options<'a>(
    level: shaderc::OptimizationLevel,
    define: Option<(&str, &str)>,
    lookup: impl Fn(&str) -> Option<String> + 'a,
) -> Result<shaderc::CompileOptions<'a>, String> {
    let mut options = shaderc::CompileOptions::new().map_err(|e| format!("shaderc options: {e}"))?;
    options.set_target_env(shaderc::TargetEnv::Vulkan, shaderc::EnvVersion::Vulkan1_2 as u32);
    options.set_source_language(shaderc::SourceLanguage::GLSL);
    options.set_optimization_level(level);
    options.set_warnings_as_errors();
    if let Some((name, value)) = define {
        options.add_macro_definition(name, Some(value));
    }
    options.set_include_callback(move |name, _kind, _from, _depth| {
        lookup(name)
            .map(|content| shaderc::ResolvedInclude { resolved_name: name.to_string(), content })
            .ok_or_else(|| format!("cannot include {name}: neither in shaders/include nor generated from src/layout.rs"))
    });
    Ok(options)
}
