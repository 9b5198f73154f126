//! isomarch: ray marching of implicit surfaces (point primitives with
//! compact and Gaussian kernels, planes; sums within groups, max across
//! groups) on Vulkan compute, after Aydinlilar & Zanni, *Forward inclusion
//! functions for ray-tracing implicit surfaces* (C&G 2023).
//!
//! Data flows one way: scene file → [`scene::Scene`] → GPU buffers and a
//! specialised pipeline ([`render::Renderer`]) → per-ray results →
//! images and statistics ([`output`]). [`field`] is the f64 reference of the
//! same maths, the oracle of the tests and benchmarks.

pub mod batch;
pub mod bench;
pub mod checks;
pub mod field;
pub mod frame_loop;
pub mod generate;
pub mod gpu;
pub mod inputs;
pub mod layout;
pub mod look;
pub mod method;
pub mod molecule;
pub mod movie;
pub mod open;
pub mod output;
pub mod render;
pub mod scaling;
pub mod scene;
pub mod settings;
pub mod stats;
pub mod tradeoff;
/// The compute kernels and where their SPIR-V is kept (`isomarch-shaders`).
pub use isomarch_shaders as shaders;

/// Why `isomarch view` refuses in a build without the `window` feature,
/// and what builds it.
pub const WITHOUT_WINDOW: &str = "this isomarch was built without the window (scripts/render-default.sh builds \
     the quickest one for the first picture): `bash scripts/view.sh SCENE [ARGS]` builds it with the window and opens SCENE";

pub use method::Method;
