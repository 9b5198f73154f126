//! The shaderc options every kernel is compiled with, shared by the build
//! script's check (shaders/build.rs) and the compilation at run time
//! (src/lib.rs), so that what the build checks is what a program compiles.

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
