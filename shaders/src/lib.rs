//! The SPIR-V of isomarch's compute shaders, built by this crate's build
//! script from `shaders/*.comp` (and once per build variant of
//! `isomarch::layout::shader_variants`).

macro_rules! spirv {
    ($name:literal) => {
        include_bytes!(concat!(env!("OUT_DIR"), "/", $name, ".spv"))
    };
}

/// The march kernel.
pub const MARCH: &[u8] = spirv!("march");
/// The bounds probe (tests of the inclusion functions).
pub const BOUNDS: &[u8] = spirv!("bounds");
/// The march walking the spatial index.
pub const MARCH_INDEXED: &[u8] = spirv!("march_indexed");
/// The bounds probe walking the spatial index.
pub const BOUNDS_INDEXED: &[u8] = spirv!("bounds_indexed");
/// The indexed march with the first-crossing bracket.
pub const MARCH_BRACKET: &[u8] = spirv!("march_bracket");
/// The bracket's kernel walking the camera's screen-space lists.
pub const MARCH_TILES: &[u8] = spirv!("march_tiles");
/// The same walk without the bracket: transparent camera rays.
pub const MARCH_TILES_CROSSINGS: &[u8] = spirv!("march_tiles_crossings");
/// The spatial index's build.
pub const INDEX: &[u8] = spirv!("index");
