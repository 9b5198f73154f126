//! isomarch's compute kernels, compiled to SPIR-V when a program first
//! needs one and kept on disk for every later run.
//!
//! The build script (shaders/build.rs) checks that every kernel compiles
//! and embeds their GLSL, with a key of everything their SPIR-V depends on.
//! [`Kernel::spirv`] compiles a kernel and optimises it with spirv-opt's
//! passes (`options::PASSES`: the SSA passes function by function, then
//! the inlining, then one cleanup) the first time a process asks for it,
//! or reads the SPIR-V that an earlier run left in the cache
//! ([`cache_dir`]). So a picture pays for the one or two kernels it uses,
//! and only once per machine: the passes spend up to half a minute on a
//! marching kernel on 2 cores, and there are eleven kernels (five of them
//! marching).
//!
//! [`specialise`] applies a pipeline's specialisation constants to a
//! kernel on the host and removes the code they rule out (kept in the
//! cache too), so that drivers and the validation layer read only what
//! the pipeline runs.
//!
//! `ISOMARCH_SHADER_OPT=performance` optimises with shaderc's performance
//! passes instead (`spirv-opt -O`: the same images, about twice the
//! time), `zero` not at all (under a second a kernel, but lavapipe then
//! spends a minute or more making each pipeline: docs/performance.md, "The
//! shaders' build").

mod options;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Instant;

/// One kernel's source as the build script embedded it.
pub(crate) struct KernelSource {
    name: &'static str,
    file: &'static str,
    source: &'static str,
    define: Option<(&'static str, &'static str)>,
    /// The hash of the source, the define, the includes and the shaderc
    /// linked (hex).
    key: &'static str,
}

include!(concat!(env!("OUT_DIR"), "/kernels.rs"));

/// isomarch's compute kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// The march kernel.
    March,
    /// The march walking the spatial index.
    MarchIndexed,
    /// The indexed march with the first-crossing bracket.
    MarchBracket,
    /// The bracket's kernel walking the camera's screen-space lists.
    MarchTiles,
    /// The same walk without the bracket: transparent camera rays.
    MarchTilesCrossings,
    /// The bounds probe (tests of the inclusion functions).
    Bounds,
    /// The bounds probe walking the spatial index.
    BoundsIndexed,
    /// The spatial index's build.
    Index,
    /// A frame's camera rays and image around the march (look.comp).
    Look,
    /// The camera's tile lists built on the GPU (tiles.comp).
    Tiles,
    /// A frame scaled and swizzled into the window's pixels (present.comp).
    Present,
}

impl Kernel {
    /// Every kernel.
    pub const ALL: [Kernel; 11] = [
        Kernel::March,
        Kernel::MarchIndexed,
        Kernel::MarchBracket,
        Kernel::MarchTiles,
        Kernel::MarchTilesCrossings,
        Kernel::Bounds,
        Kernel::BoundsIndexed,
        Kernel::Index,
        Kernel::Look,
        Kernel::Tiles,
        Kernel::Present,
    ];

    /// The kernel's name: its source file's stem and its variant's suffix
    /// (`march_tiles`).
    pub fn name(self) -> &'static str {
        match self {
            Kernel::March => "march",
            Kernel::MarchIndexed => "march_indexed",
            Kernel::MarchBracket => "march_bracket",
            Kernel::MarchTiles => "march_tiles",
            Kernel::MarchTilesCrossings => "march_tiles_crossings",
            Kernel::Bounds => "bounds",
            Kernel::BoundsIndexed => "bounds_indexed",
            Kernel::Index => "index",
            Kernel::Look => "look",
            Kernel::Tiles => "tiles",
            Kernel::Present => "present",
        }
    }

    fn source(self) -> Result<&'static KernelSource, String> {
        SOURCES.iter().find(|s| s.name == self.name()).ok_or_else(|| format!("no kernel {} among the shaders the build script found", self.name()))
    }

    /// The kernel's SPIR-V: compiled on this process's first call, unless
    /// the cache holds it. A second call returns the same words at once.
    pub fn spirv(self) -> Result<&'static [u32], String> {
        static COMPILED: [OnceLock<Result<Vec<u32>, String>>; Kernel::ALL.len()] = [const { OnceLock::new() }; Kernel::ALL.len()];
        let index = Kernel::ALL.iter().position(|&k| k == self).unwrap_or_default();
        COMPILED[index].get_or_init(|| load_or_compile(self.source()?)).as_deref().map_err(Clone::clone)
    }
}

/// How the kernels are optimised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Optimisation {
    /// shaderc without optimisation, then `options::PASSES`.
    PassList,
    /// shaderc's performance passes (`spirv-opt -O`).
    Performance,
    /// None.
    Zero,
}

impl Optimisation {
    /// The name in a cached kernel's file name.
    fn name(self) -> &'static str {
        match self {
            Optimisation::PassList => "passes",
            Optimisation::Performance => "performance",
            Optimisation::Zero => "zero",
        }
    }
}

/// `options::PASSES` unless `ISOMARCH_SHADER_OPT` says `performance` or
/// `zero`; shaderc's performance passes where the build has no runner for
/// the list (shaderc built from source: shaders/build.rs).
fn optimisation() -> Result<Optimisation, String> {
    let default = if cfg!(isomarch_pass_list) { Optimisation::PassList } else { Optimisation::Performance };
    match std::env::var("ISOMARCH_SHADER_OPT").as_deref() {
        Err(_) | Ok("") => Ok(default),
        Ok("passes") if cfg!(isomarch_pass_list) => Ok(Optimisation::PassList),
        Ok("performance") => Ok(Optimisation::Performance),
        Ok("zero") => Ok(Optimisation::Zero),
        Ok(other) => {
            Err(format!("ISOMARCH_SHADER_OPT={other:?}: expected {}performance or zero", if cfg!(isomarch_pass_list) { "passes, " } else { "" }))
        }
    }
}

/// isomarch's folder in the user's cache folder: `$XDG_CACHE_HOME/isomarch`
/// or `~/.cache/isomarch` on Linux (the pipeline cache lives there too).
pub fn user_cache_dir() -> Option<PathBuf> {
    dirs::cache_dir().map(|d| d.join("isomarch"))
}

/// Where compiled kernels are kept: `ISOMARCH_SHADER_CACHE` where set
/// (empty: nowhere), else `spirv/` in [`user_cache_dir`].
pub fn cache_dir() -> Option<PathBuf> {
    match std::env::var_os("ISOMARCH_SHADER_CACHE") {
        Some(dir) if dir.is_empty() => None,
        Some(dir) => Some(PathBuf::from(dir)),
        None => user_cache_dir().map(|d| d.join("spirv")),
    }
}

/// Reads a kernel's SPIR-V from the cache, or compiles it and writes it
/// there. Processes that want the same kernel at once take turns on a
/// lock file, so that it is compiled once; a cache that cannot be read or
/// written costs only time.
fn load_or_compile(k: &KernelSource) -> Result<Vec<u32>, String> {
    let opt = optimisation()?;
    let Some(dir) = cache_dir().filter(|d| std::fs::create_dir_all(d).is_ok()) else {
        return compile(k, opt, None);
    };
    let path = dir.join(format!("{}-{}-{}.spv", k.name, k.key, opt.name()));
    if let Some(words) = read_spirv(&path) {
        return Ok(words);
    }
    // One lock file per kernel and key: processes compiling different
    // kernels go on side by side.
    let lock = std::fs::File::create(path.with_extension("lock")).ok();
    let _held = lock.as_ref().and_then(|f| f.lock().ok());
    if let Some(words) = read_spirv(&path) {
        return Ok(words);
    }
    let words = compile(k, opt, Some(&dir))?;
    write_spirv(&path, &words);
    Ok(words)
}

/// `words` with its specialisation constants `(constant_id, value)` made
/// constants and the code they rule out removed (`options::SPECIALISE`),
/// or `None` where this build has no runner for spirv-opt's passes (the
/// caller then hands the values to the driver). The module that comes
/// back has no specialisation constants left, so the driver and the
/// validation layer read only what the pipeline runs: the layer otherwise
/// validates the whole module again for each specialisation, and lavapipe
/// translates all of it before removing what the constants rule out.
/// Kept in the cache's `specialised/` folder ([`cache_dir`]), as the
/// kernels are, so a later process (or run) reads it back.
pub fn specialise(words: &[u32], constants: &[(u32, u32)]) -> Result<Option<Vec<u32>>, String> {
    use std::hash::{Hash, Hasher};
    if !can_specialise() {
        return Ok(None);
    }
    let half = |salt: u8| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (salt, SHADERC, options::SPECIALISE, words, constants).hash(&mut h);
        h.finish()
    };
    let dir = cache_dir().map(|d| d.join("specialised")).filter(|d| std::fs::create_dir_all(d).is_ok());
    let path = dir.as_ref().map(|d| d.join(format!("{:016x}{:016x}.spv", half(1), half(2))));
    if let Some(words) = path.as_deref().and_then(read_spirv) {
        return Ok(Some(words));
    }
    // The values as bits, whatever each constant's type; the kernel is not
    // validated again, the module that comes out is.
    let specialised = run_passes(words, constants, options::SPECIALISE)?;
    if let Some(path) = &path {
        write_spirv(path, &specialised);
    }
    Ok(Some(specialised))
}

/// Whether this build can specialise on the host ([`specialise`] returns
/// `None` where it cannot: shaderc built from source).
pub fn can_specialise() -> bool {
    cfg!(isomarch_pass_list)
}

/// Writes `words` to `path` under a temporary name, then renames it, so
/// that a reader never sees half a file; a cache that cannot be written
/// costs only time.
fn write_spirv(path: &Path, words: &[u32]) {
    let Some(dir) = path.parent() else { return };
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("kernel");
    // A name of this process and write: threads may write the same file.
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let write = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    // The clock's nanoseconds too: machines sharing a cache folder (a
    // cluster's home) may run processes of the same id.
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.{nanos}.{write}.tmp", std::process::id()));
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        f.write_all(&bytes)
    });
    if written.is_err() || std::fs::rename(&tmp, path).is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
}

/// A cached kernel's words, where the file holds SPIR-V (its magic number
/// first, a whole number of words).
fn read_spirv(path: &Path) -> Option<Vec<u32>> {
    let bytes = std::fs::read(path).ok()?;
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    (bytes.len() % 4 == 0 && words.len() > 5 && words[0] == 0x0723_0203).then_some(words)
}

/// Compiles a kernel with shaderc (and optimises it), saying so on stderr
/// where it is to be kept (the user waits for it once).
fn compile(k: &KernelSource, opt: Optimisation, kept_in: Option<&Path>) -> Result<Vec<u32>, String> {
    let started = Instant::now();
    if let Some(dir) = kept_in {
        eprintln!("isomarch: compiling the {} kernel, once (kept in {})", k.name, dir.display());
    }
    let level = match opt {
        Optimisation::Performance => shaderc::OptimizationLevel::Performance,
        Optimisation::PassList | Optimisation::Zero => shaderc::OptimizationLevel::Zero,
    };
    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let options = options::options(level, k.define, |name| INCLUDES.iter().find(|(n, _)| *n == name).map(|(_, text)| text.to_string()))?;
    let artifact = compiler
        .compile_into_spirv(k.source, shaderc::ShaderKind::Compute, k.file, "main", Some(&options))
        .map_err(|e| format!("compiling the {} kernel: {e}", k.name))?;
    let words = match opt {
        Optimisation::PassList => {
            run_passes(artifact.as_binary(), &[], options::PASSES).map_err(|e| format!("optimising the {} kernel: {e}", k.name))?
        }
        Optimisation::Performance | Optimisation::Zero => artifact.as_binary().to_vec(),
    };
    if kept_in.is_some() {
        eprintln!("isomarch: compiled the {} kernel in {:.1} s", k.name, started.elapsed().as_secs_f64());
    }
    Ok(words)
}

#[cfg(isomarch_pass_list)]
unsafe extern "C" {
    /// shaders/cpp/optimize.cpp.
    fn isomarch_spirv_optimize(
        words: *const u32,
        count: usize,
        ids: *const u32,
        values: *const u32,
        constants: usize,
        flags: *const *const std::ffi::c_char,
        flag_count: usize,
        context: *mut std::ffi::c_void,
        sink: unsafe extern "C" fn(*mut std::ffi::c_void, *const u32, usize),
        report: unsafe extern "C" fn(*mut std::ffi::c_void, *const std::ffi::c_char),
    ) -> std::ffi::c_int;
}

/// Runs spirv-opt's `passes` (command-line flags) over `words` with the
/// SPIRV-Tools inside the linked shaderc. Without `constants`, `words`
/// (a kernel shaderc compiled) is validated first; with them (ids and
/// 32-bit patterns, as Vulkan's specialisation info gives them), they are
/// set before the passes, and the result is validated instead.
#[cfg(isomarch_pass_list)]
fn run_passes(words: &[u32], constants: &[(u32, u32)], passes: &[&str]) -> Result<Vec<u32>, String> {
    use std::ffi::{CStr, CString, c_char, c_void};
    /// What the optimizer hands back: the module's words and its messages.
    #[derive(Default)]
    struct Out {
        words: Vec<u32>,
        messages: Vec<String>,
    }
    unsafe extern "C" fn sink(context: *mut c_void, words: *const u32, count: usize) {
        // SAFETY: `context` is the `Out` below, alive for the call; the
        // optimizer's result holds `count` words at `words`.
        unsafe { (*context.cast::<Out>()).words.extend_from_slice(std::slice::from_raw_parts(words, count)) }
    }
    unsafe extern "C" fn report(context: *mut c_void, text: *const c_char) {
        // SAFETY: as in `sink`; the message is a NUL-terminated string.
        unsafe { (*context.cast::<Out>()).messages.push(CStr::from_ptr(text).to_string_lossy().into_owned()) }
    }
    let flags: Vec<CString> = passes.iter().map(|p| CString::new(*p).map_err(|e| e.to_string())).collect::<Result<_, _>>()?;
    let pointers: Vec<*const c_char> = flags.iter().map(|f| f.as_ptr()).collect();
    let (ids, values): (Vec<u32>, Vec<u32>) = constants.iter().copied().unzip();
    let mut out = Out::default();
    // SAFETY: every pointer is valid for the call and its length (`ids`
    // and `values` hold `constants.len()` words each); the callbacks only
    // reach `out` through `context`.
    let status = unsafe {
        isomarch_spirv_optimize(
            words.as_ptr(),
            words.len(),
            ids.as_ptr(),
            values.as_ptr(),
            ids.len(),
            pointers.as_ptr(),
            pointers.len(),
            (&raw mut out).cast(),
            sink,
            report,
        )
    };
    match status {
        0 if !out.words.is_empty() => Ok(out.words),
        1 => Err(format!("spirv-opt does not know one of the passes {}", passes.join(" "))),
        4 => Err(format!("the specialised module is not valid SPIR-V: {}", out.messages.join("; "))),
        _ => Err(format!("spirv-opt failed (status {status}): {}", out.messages.join("; "))),
    }
}

#[cfg(not(isomarch_pass_list))]
fn run_passes(_words: &[u32], _constants: &[(u32, u32)], _passes: &[&str]) -> Result<Vec<u32>, String> {
    Err("this build has no runner for spirv-opt's passes (shaderc built from source: shaders/build.rs)".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kernel_has_a_source_and_every_source_a_kernel() {
        for k in Kernel::ALL {
            assert!(k.source().is_ok(), "{k:?}");
        }
        for s in SOURCES {
            assert!(Kernel::ALL.iter().any(|k| k.name() == s.name), "{} has no Kernel", s.name);
        }
        assert_eq!(SOURCES.len(), Kernel::ALL.len());
    }

    /// The pass list runs where the build made its runner (the index
    /// kernel: a second or so), and a flag it does not know is refused.
    #[test]
    #[cfg(isomarch_pass_list)]
    fn the_pass_list_optimises_a_kernel_and_refuses_an_unknown_pass() {
        let words = compile(Kernel::Index.source().unwrap(), Optimisation::PassList, None).unwrap();
        assert_eq!(words[0], 0x0723_0203);
        let zero = compile(Kernel::Index.source().unwrap(), Optimisation::Zero, None).unwrap();
        assert!(words.len() < zero.len(), "{} words optimised, {} not", words.len(), zero.len());
        assert!(run_passes(&zero, &[], &["--no-such-pass"]).unwrap_err().contains("--no-such-pass"));
    }

    /// A module's instructions, each its words (opcode and length first).
    fn instructions(words: &[u32]) -> Vec<&[u32]> {
        let mut at = 5;
        let mut found = Vec::new();
        while at < words.len() {
            let len = ((words[at] >> 16) as usize).max(1);
            found.push(&words[at..(at + len).min(words.len())]);
            at += len;
        }
        found
    }

    /// The opcodes of a module's instructions.
    fn opcodes(words: &[u32]) -> Vec<u32> {
        instructions(words).iter().map(|i| i[0] & 0xffff).collect()
    }

    /// Specialising the look kernel on each of its passes leaves no
    /// specialisation constant (OpSpecConstant* are opcodes 48 to 52) and
    /// a smaller module for each, different passes different modules.
    #[test]
    #[cfg(isomarch_pass_list)]
    fn specialising_freezes_every_constant_and_removes_the_passes_not_taken() {
        let words = Kernel::Look.spirv().unwrap();
        // OpDecorate (71) of SpecId (1): the constants' ids.
        let ids: Vec<u32> = instructions(words).iter().filter(|i| i[0] & 0xffff == 71 && i.len() > 3 && i[2] == 1).map(|i| i[3]).collect();
        assert!(!ids.is_empty(), "the look kernel has no specialisation constant");
        assert!(opcodes(words).iter().any(|op| (48..=52).contains(op)));
        let mut modules = Vec::new();
        for pass in 0..3 {
            let constants: Vec<(u32, u32)> = ids.iter().map(|&id| (id, pass)).collect();
            let out = specialise(words, &constants).unwrap().expect("a pass-list build specialises");
            assert_eq!(out[0], 0x0723_0203);
            assert!(!opcodes(&out).iter().any(|op| (48..=52).contains(op)), "pass {pass}: a specialisation constant is left");
            assert!(out.len() < words.len(), "pass {pass}: {} words specialised, {} not", out.len(), words.len());
            modules.push(out);
        }
        assert!(modules[0] != modules[1] && modules[1] != modules[2], "two passes gave the same module");
    }

    #[test]
    fn a_cached_kernel_is_read_back_whole_and_a_damaged_one_refused() {
        let dir = std::env::temp_dir().join(format!("isomarch-spirv-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.spv");
        let words = [0x0723_0203u32, 0x0001_0500, 0, 10, 0, 7];
        std::fs::write(&good, words.iter().flat_map(|w| w.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
        assert_eq!(read_spirv(&good).as_deref(), Some(&words[..]));
        let cut = dir.join("cut.spv");
        std::fs::write(&cut, &std::fs::read(&good).unwrap()[..22]).unwrap();
        assert_eq!(read_spirv(&cut), None);
        let text = dir.join("text.spv");
        std::fs::write(&text, b"not SPIR-V at all, twenty-four b").unwrap();
        assert_eq!(read_spirv(&text), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
