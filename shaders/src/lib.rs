//! isomarch's compute kernels, compiled to SPIR-V when a program first
//! needs one and kept on disk for every later run.
//!
//! The build script (shaders/build.rs) checks that every kernel compiles
//! and embeds their GLSL, with a key of everything their SPIR-V depends on.
//! [`Kernel::spirv`] compiles a kernel with shaderc's performance passes
//! the first time a process asks for it, or reads the SPIR-V that an
//! earlier run left in the cache ([`cache_dir`]). So a picture pays for the
//! one or two kernels it uses, and only once per machine: spirv-opt spends
//! about a minute on a marching kernel on 2 cores, and there are eleven (five of them marching).
//!
//! `ISOMARCH_SHADER_OPT=zero` compiles without optimisation (under a second
//! a kernel, but lavapipe then spends a minute or more making each
//! pipeline: docs/performance.md, "The shaders' build").

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

/// How the kernels are optimised: shaderc's performance passes unless
/// `ISOMARCH_SHADER_OPT=zero`.
fn optimisation() -> Result<(shaderc::OptimizationLevel, &'static str), String> {
    match std::env::var("ISOMARCH_SHADER_OPT").as_deref() {
        Err(_) | Ok("") | Ok("performance") => Ok((shaderc::OptimizationLevel::Performance, "performance")),
        Ok("zero") => Ok((shaderc::OptimizationLevel::Zero, "zero")),
        Ok(other) => Err(format!("ISOMARCH_SHADER_OPT={other:?}: expected performance or zero")),
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
    let (level, level_name) = optimisation()?;
    let Some(dir) = cache_dir().filter(|d| std::fs::create_dir_all(d).is_ok()) else {
        return compile(k, level, None);
    };
    let path = dir.join(format!("{}-{}-{level_name}.spv", k.name, k.key));
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
    let words = compile(k, level, Some(&dir))?;
    // Written under a temporary name, then renamed: a reader never sees
    // half a file.
    let tmp = dir.join(format!(".{}.{}.tmp", k.name, std::process::id()));
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        f.write_all(&bytes)
    });
    if written.is_err() || std::fs::rename(&tmp, &path).is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    Ok(words)
}

/// A cached kernel's words, where the file holds SPIR-V (its magic number
/// first, a whole number of words).
fn read_spirv(path: &Path) -> Option<Vec<u32>> {
    let bytes = std::fs::read(path).ok()?;
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    (bytes.len() % 4 == 0 && words.len() > 5 && words[0] == 0x0723_0203).then_some(words)
}

/// Compiles a kernel with shaderc, saying so on stderr where it is to be
/// kept (the user waits for it once).
fn compile(k: &KernelSource, level: shaderc::OptimizationLevel, kept_in: Option<&Path>) -> Result<Vec<u32>, String> {
    let started = Instant::now();
    if let Some(dir) = kept_in {
        eprintln!("isomarch: compiling the {} kernel, once (kept in {})", k.name, dir.display());
    }
    let compiler = shaderc::Compiler::new().map_err(|e| format!("shaderc: {e}"))?;
    let options = options::options(level, k.define, |name| INCLUDES.iter().find(|(n, _)| *n == name).map(|(_, text)| text.to_string()))?;
    let artifact = compiler
        .compile_into_spirv(k.source, shaderc::ShaderKind::Compute, k.file, "main", Some(&options))
        .map_err(|e| format!("compiling the {} kernel: {e}", k.name))?;
    if kept_in.is_some() {
        eprintln!("isomarch: compiled the {} kernel in {:.1} s", k.name, started.elapsed().as_secs_f64());
    }
    Ok(artifact.as_binary().to_vec())
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
