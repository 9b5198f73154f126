//! Marching rays on the GPU: scene upload, specialised pipelines, tiled
//! dispatches with deadlines.

pub mod frame;
pub mod index;
pub mod light;
pub mod offscreen;
pub mod optics;
pub mod rays;
pub mod tile_build;
pub mod tiles;

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use ash::vk;

use crate::field::inversion::Inversion;
use crate::field::{Field, PrimEval};
use crate::gpu::{Buffer, ComputePipeline, Context, Role, Submitter, TransferStats, Transfers};
use crate::layout::{self, GpuBound, GpuGlobals, GpuLight, GpuMarchState, GpuPrimitive, GpuRay, GpuResult, TexelFormat};
use crate::method::Method;
use crate::scene::{self, Primitive, Scene};
use crate::settings::{QuadSettings, Refinement};
use index::{GridSpec, IndexStats, index_radii};

// SPIR-V of the kernels, built by the isomarch-shaders crate (shaders/):
// the march and the bounds probe, the same walking the spatial index
// (build variants: layout::shader_variants), the indexed march with the
// first-crossing bracket ([`brackets`]), the bracket's kernel walking the
// camera's screen-space lists ([`tiles`]) and that walk without the
// bracket (transparent camera rays), and the spatial index's build.
use isomarch_shaders::Kernel;

/// Which entry point a pipeline runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum EntryPoint {
    March,
    BoundsProbe,
}

/// What a pipeline is specialised to: every setting that changes its
/// specialization constants.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct PipelineKey {
    entry: EntryPoint,
    method: Method,
    shade: bool,
    cull: bool,
    extension: bool,
    transparent: bool,
    secondary: bool,
    any_hit: bool,
    bracket: bool,
    generic: bool,
    refine: Refinement,
    /// Candidates from the camera's tile lists ([`tiles`]).
    tiles: bool,
}

impl PipelineKey {
    /// The pipeline that marches (or probes) with `method` and `options`.
    fn new(entry: EntryPoint, method: Method, options: &MarchOptions) -> PipelineKey {
        PipelineKey {
            entry,
            method,
            shade: options.shade,
            cull: options.cull,
            extension: options.quad.extension,
            transparent: options.transparent,
            secondary: options.secondary,
            any_hit: options.any_hit,
            bracket: options.bracket,
            generic: options.generic,
            refine: options.refine,
            tiles: false,
        }
    }
}

/// Rays per dispatch: big images become many bounded dispatches.
pub const TILE_RAYS: usize = 1 << 16;
const WORKGROUP: usize = 64;
const PUSH_CONSTANT_BYTES: u32 = 16;

/// Loop iterations one invocation may run per dispatch. lavapipe silently
/// ends any invocation after 65535 loop iterations (all loops together), so
/// a march runs in slices that stay below that, resuming from its saved
/// state; on every device this also bounds the length of one dispatch.
const LOOP_BUDGET: usize = 60_000;
/// Slices of a march recorded in one submission at most: a slice after
/// every ray finished costs a dispatch whose invocations return at once.
const SLICES_PER_SUBMIT: u64 = 8;
/// Iterations of the small loops (lights, bisection-tree moves) a turn and a
/// slice may add beyond their passes over the primitives.
const SMALL_LOOPS: usize = 72;

/// Loop iterations of one fold over the primitives: along an interval
/// (a step's bound) and at a point (a value, a normal).
#[derive(Clone, Copy, Debug)]
struct FoldCost {
    interval: usize,
    point: usize,
    /// The per-ray culling once per slice (the flat list only).
    cull: usize,
    /// The look-ahead over empty cells once per turn (the index only).
    skip: usize,
}

impl FoldCost {
    /// Without the index: every primitive, and as many to cull them.
    fn flat(primitives: usize) -> FoldCost {
        FoldCost { interval: primitives, point: primitives, cull: primitives, skip: 0 }
    }

    /// With the camera's tile lists: a walk reads at most its tile's list
    /// of every group (`crowd` entries at most, all groups together), and
    /// the skip to the first support as many.
    fn tiles(grid: &GridSpec, longest: usize, crowd: usize) -> FoldCost {
        let walk = grid.groups * 2 + crowd.min(grid.groups * longest) + grid.everywhere;
        FoldCost { interval: walk, point: walk, cull: 0, skip: walk }
    }

    /// With the index whose longest cell list holds `longest` entries and
    /// whose cells hold at most `crowd`, all groups together.
    fn indexed(grid: &GridSpec, longest: usize, crowd: usize) -> FoldCost {
        FoldCost {
            interval: grid.interval_iterations(longest, crowd),
            point: grid.point_iterations(longest, crowd),
            cull: 0,
            skip: grid.skip_iterations(),
        }
    }
}

/// Loop turns (steps, or bisections of a refinement) per slice. A turn
/// makes at most three folds (bisection: the range, and the field at both
/// ends; transparent: the bound and a crossing's normal; a refinement one
/// or two); once per slice come the culling (a flat fold) and the final
/// normal and shading.
fn slice_steps(cost: FoldCost, lights: usize) -> Result<u32> {
    let fixed = cost.cull + cost.point + 2 + lights + SMALL_LOOPS;
    let per_turn = 3 * cost.interval + cost.skip + lights + SMALL_LOOPS;
    if fixed + per_turn > LOOP_BUDGET {
        bail!(
            "one marching step visits up to {} primitives, more than fit the per-dispatch loop budget ({LOOP_BUDGET} iterations); too many primitives overlap in one place",
            cost.interval
        );
    }
    Ok(((LOOP_BUDGET - fixed) / per_turn) as u32)
}

/// A march's loop turns at most: its steps, and up to 65 turns refining the
/// crossing each step may find.
fn max_turns(max_steps: u32) -> u64 {
    u64::from(max_steps) * 66 + 2
}

#[cfg(test)]
mod tests {
    use super::{FoldCost, LOOP_BUDGET, slice_steps};

    #[test]
    fn slices_fit_the_loop_budget_and_refuse_what_does_not() {
        let cost = FoldCost::flat;
        assert!(slice_steps(cost(64), 4).unwrap() >= 100);
        let most = (1..LOOP_BUDGET).take_while(|&n| slice_steps(cost(n), 4).is_ok()).last().unwrap();
        assert!(most >= 10_000, "{most}");
        assert_eq!(slice_steps(cost(most), 4).unwrap(), 1);
        assert!(format!("{}", slice_steps(cost(most + 1), 4).unwrap_err()).contains("overlap in one place"));
    }
}

/// What the march of a batch of rays produced.
pub struct MarchOutput {
    pub results: Vec<GpuResult>,
    /// Transparent rendering: every ray's crossings in order (at most
    /// `MAX_CROSSINGS` each; `GpuResult::crossings.x` counts them all).
    /// Empty when opaque.
    pub crossings: Vec<Vec<f32>>,
    /// GPU time from timestamp queries, summed over tiles (`None` when the
    /// device has no timestamps).
    pub gpu_ns: Option<f64>,
    /// The shadow and occlusion rays cast from the hits, marched after
    /// them (`light::apply`; their GPU time is not in `gpu_ns`).
    pub light: light::LightStats,
}

/// How one call marches: the settings that pick a pipeline's
/// specialisation, and the interval growth. A value passed to each
/// [`Renderer::march`] and [`Renderer::probe_bounds`], so that a caller
/// that marches differently once (a benchmark variant, a generation of
/// secondary rays) says so for that call and leaves nothing to restore.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchOptions {
    /// Shade hits (off: only hit distances, normals and counts, as the
    /// benchmarks need).
    pub shade: bool,
    /// Interval growth k for every method; `None`: each method's default.
    pub growth: Option<f64>,
    /// Skip, per ray, the primitives whose support the ray no longer meets
    /// (scenes of at most 64 primitives). Results are identical either way.
    pub cull: bool,
    /// Settings of the bottom-up quadratic bounds.
    pub quad: QuadSettings,
    /// Every crossing along each ray (transparent rendering).
    pub transparent: bool,
    /// Rays that start just past a surface (reflected, refracted): the
    /// side is the field's sign at the start, and the march stops at the
    /// first sign change (entering or leaving).
    pub secondary: bool,
    /// Any-hit rays (shadows, occlusion): the march ends at the first sign
    /// change it brackets or proves, unrefined, and writes only `counts`
    /// (the answer is `FLAG_HIT`) and `crossings` of its result; `hit` and
    /// `color` keep what the buffer held.
    pub any_hit: bool,
    /// March a first crossing only inside its bracket where the scene
    /// allows one (`Scene::bracket_holds`, with the spatial index): from
    /// the first support the ray enters to the first ball in which one
    /// primitive alone reaches iso. Off to measure what it buys.
    pub bracket: bool,
    /// Compile pipelines for any scene: every primitive kind and the max of
    /// groups kept in, instead of only what this scene uses (to measure
    /// what specialisation buys; results are identical).
    pub generic: bool,
    /// How a bracketed crossing is narrowed to the tolerance.
    pub refine: Refinement,
}

impl MarchOptions {
    /// How `scene` asks to be marched: shaded and culled, with its
    /// `marching` growth and quadratic settings, transparent when it has a
    /// `transparency`, primary rays, pipelines specialised to it.
    pub fn for_scene(scene: &Scene) -> MarchOptions {
        MarchOptions {
            shade: true,
            growth: scene.marching.growth,
            cull: true,
            quad: scene.marching.quad,
            transparent: scene.transparency.is_some(),
            secondary: false,
            any_hit: false,
            // ISOMARCH_BRACKET=off measures what the bracket buys (as
            // ISOMARCH_INDEX=off does for the index).
            bracket: env_switch("ISOMARCH_BRACKET").unwrap_or(true),
            generic: false,
            refine: scene.marching.refine,
        }
    }

    /// The interval growth `method` marches with.
    fn growth_of(&self, method: Method) -> f64 {
        self.growth.unwrap_or_else(|| method.default_growth())
    }
}

/// The scene's data on the GPU and one pipeline per method and options
/// used so far.
pub struct Renderer {
    ctx: Arc<Context>,
    scene: Scene,
    globals: Buffer,
    prims: Buffer,
    lights: Buffer,
    rays: Buffer,
    results: Buffer,
    states: Buffer,
    active: Buffer,
    crossings: Buffer,
    /// The spatial index (scenes of more than 64 primitives): its grid,
    /// list starts, entries and build scratch, its build pipeline, and what
    /// the last build made.
    grid: Option<GridSpec>,
    cells: Buffer,
    entries: Buffer,
    scratch: Buffer,
    index_pipeline: Option<ComputePipeline>,
    index_stats: Option<IndexStats>,
    slice_steps: u32,
    pipelines: HashMap<PipelineKey, ComputePipeline>,
    /// The camera's screen-space lists, for the frame they were built for.
    tiles: Option<CameraTiles>,
    /// tiles.comp's pipelines and buffers, made with the first lists the
    /// GPU builds.
    tile_build: Option<tile_build::TileBuild>,
    /// Where the lists are built ([`Renderer::set_tile_builder`]).
    tile_builder: Option<bool>,
    submitter: Submitter,
    /// Uploads into and reads out of the device-local buffers, recorded
    /// into the next submission (gpu::Transfers).
    transfers: Transfers,
    /// Wall-clock nanoseconds spent creating pipelines and compiling their
    /// code ([`Renderer::warm_up`]), apart from every GPU time reported.
    pipeline_ns: f64,
    /// Build the index only when a march needs it ([`Renderer::for_camera`]).
    defer_index: bool,
    /// The index holds the primitives as uploaded.
    index_fresh: bool,
    /// Give up when the GPU is not done by then (given when it is made).
    timeout: Duration,
    /// The kernel and buffers of frames made on the GPU (render::frame),
    /// made with the first.
    look: Option<frame::LookPass>,
    /// Pipelines made and not yet warmed up, with their harmless pushes
    /// ([`Renderer::warm_cold`]).
    cold: Vec<((vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet), [u32; 4])>,
    /// The slices the last GPU frame recorded for its camera rays and its
    /// shadow and occlusion rays (render::frame).
    frame_slices: [u64; 2],
}

/// How long a renderer's GPU work may take unless its maker says
/// ([`Renderer::with_timeout`], [`Renderer::for_camera`]).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(600);

/// The switches the environment may turn off to measure what they buy.
pub const ENV_SWITCHES: [&str; 5] = ["ISOMARCH_INDEX", "ISOMARCH_BRACKET", "ISOMARCH_TILES", frame::GPU_FRAME_SWITCH, TILE_BUILD_SWITCH];

/// `ISOMARCH_TILE_BUILD=on` builds the camera's tile lists on the GPU,
/// `off` on the host (the reference), whatever the device
/// ([`Renderer::gpu_tiles_apply`]).
pub const TILE_BUILD_SWITCH: &str = "ISOMARCH_TILE_BUILD";

/// A switch of [`ENV_SWITCHES`]: on unless set to `off` (or `0`);
/// `Err` names a value that is neither, which [`check_environment`]
/// refuses before any work (elsewhere it leaves the switch on).
fn env_switch(name: &str) -> Result<bool> {
    match std::env::var(name) {
        Err(_) => Ok(true),
        Ok(v) => match v.trim().to_ascii_lowercase().as_str() {
            "on" | "1" | "" => Ok(true),
            "off" | "0" => Ok(false),
            _ => bail!("{name}={v:?}: expected on or off"),
        },
    }
}

/// Checks the environment's switches ([`ENV_SWITCHES`]): a value that is
/// neither on nor off is an error, not silently on.
pub fn check_environment() -> Result<()> {
    for name in ENV_SWITCHES {
        env_switch(name)?;
    }
    Ok(())
}

/// The camera's screen-space lists on the GPU ([`tiles::TileLists`]).
struct CameraTiles {
    starts: Buffer,
    entries: Buffer,
    /// The camera and frame size they were built for, with the scene as
    /// posed then (`None`: stale).
    frame: Option<(scene::Camera, u32, u32)>,
    /// Turns per slice: a walk reads at most the longest list.
    slice_steps: u32,
    stats: TileStats,
}

/// What building the camera's tile lists cost and holds, for statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TileStats {
    /// Time of the build: the GPU's (timestamps, or the submission's wall
    /// time without them) or the host's wall time.
    pub build_ms: f64,
    /// Whether the GPU built them (render::tile_build).
    pub gpu: bool,
    /// Entries in the lists (a primitive is in every tile it may cover).
    pub entries: usize,
    pub longest_list: usize,
    /// 8x8 pixel tiles of the frame.
    pub tiles: usize,
    /// Bytes of the lists' buffers as filled.
    pub bytes: usize,
}

/// A primitive's reach on the GPU (`GpuPrimitive::c.z`) is where its kernel
/// alone is this fraction above iso: f >= 0 there despite f32 rounding.
const REACH_MARGIN: f64 = 1e-3;

/// The primitives in GPU layout, sorted by group.
pub fn gpu_primitives(scene: &Scene) -> Vec<GpuPrimitive> {
    primitives_with_radii(scene, &index::index_radii(scene))
}

/// [`gpu_primitives`] with the scene's `index::index_radii` at hand.
fn primitives_with_radii(scene: &Scene, radii: &[Option<f64>]) -> Vec<GpuPrimitive> {
    let mut radii = radii.iter().copied();
    let mut colors = scene.colors.iter().flatten().map(|&c| pack_color(c));
    let mut out = Vec::with_capacity(scene.primitive_count());
    for (gi, group) in scene.groups.iter().enumerate() {
        for p in group {
            let e = PrimEval::new(p, &scene.bounds);
            let v4 = |v: glam::DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
            let radius = radii.next().flatten().unwrap_or(0.0);
            let (a, kind) = match *p {
                Primitive::Point { center, kernel } => {
                    let kind = match kernel {
                        scene::Kernel::Compact { .. } => layout::PRIM_COMPACT_POINT,
                        scene::Kernel::Gaussian { .. } => layout::PRIM_GAUSSIAN_POINT,
                    };
                    (v4(center, radius), kind)
                }
                Primitive::Plane { normal, offset, .. } => (v4(normal, offset), layout::PRIM_COMPACT_PLANE),
                Primitive::Hrbf { center, alpha, .. } => (v4(center, alpha), layout::PRIM_HRBF),
                Primitive::Affine { gradient, offset } => (v4(gradient, offset), layout::PRIM_AFFINE),
            };
            let (b, c0, reach) = match (e.kernel(), *p) {
                (Some(k), _) => {
                    ([k.scale as f32, k.inv as f32, k.weight as f32, k.peak_distance as f32], k.peak_slope, k.reach(scene.iso * (1.0 + REACH_MARGIN)))
                }
                (None, Primitive::Hrbf { beta, .. }) => (v4(beta, 0.0), 0.0, 0.0),
                (None, _) => ([0.0; 4], 0.0, 0.0),
            };
            let c = [c0 as f32, radius as f32, reach as f32, 0.0];
            out.push(GpuPrimitive { a, b, c, ids: [kind, gi as u32, colors.next().unwrap_or(0), 0] });
        }
    }
    out
}

/// A linear RGB colour as `GpuPrimitive::ids.z`: 8 bits a channel, red
/// lowest (GLSL's `unpackUnorm4x8`).
fn pack_color(c: glam::DVec3) -> u32 {
    let q = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u32;
    q(c.x) | q(c.y) << 8 | q(c.z) << 16
}

fn globals(scene: &Scene, growth: f64, quad: QuadSettings, grid: Option<&GridSpec>) -> GpuGlobals {
    let validity_floor = quad.validity_floor(scene.iso);
    let rgb = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
    let field = Field::new(scene);
    GpuGlobals {
        march: [scene.iso as f32, scene.marching.min_step as f32, scene.refine_tolerance() as f32, field.lipschitz() as f32],
        sizes: [scene.primitive_count() as u32, scene.groups.len() as u32, scene.lights.len() as u32, scene.marching.max_steps],
        tuning: [
            growth as f32,
            validity_floor as f32,
            grid.map_or(0.0, |g| g.window as f32),
            f32::from(u8::from(grid.is_some_and(|g| g.skips_empty_cells(scene.iso)))),
        ],
        background: rgb(scene.background),
        surface: {
            let mut s = rgb(scene.surface);
            s[3] = if scene.colors.is_some() { 1.0 } else { 0.0 };
            s
        },
        ambient: rgb(scene.ambient),
        material: scene.transparency.map_or([0.0; 4], |t| [t.absorption.x as f32, t.absorption.y as f32, t.absorption.z as f32, t.opacity as f32]),
        grid: grid.map_or([0.0; 4], |g| [g.origin.x as f32, g.origin.y as f32, g.origin.z as f32, g.cell as f32]),
        grid_dims: grid.map_or([0; 4], |g| [g.dims[0], g.dims[1], g.dims[2], g.lists_per_group as u32]),
        inversion: Inversion::of_field(&field).map_or([0.0; 4], |i| [i.r_ref as f32, i.s as f32, i.ln_w as f32, i.ln_floor as f32]),
    }
}

/// Whether `method` marches `scene`'s first crossings with their bracket
/// (`march_bracket.spv`, shaders/include/fold.glsl):
/// with the spatial index, where the bracket holds
/// ([`Scene::bracket_holds`]), for opaque and
/// any-hit rays (not transparent or secondary ones) of Algorithm 1's
/// methods (not the bisection baselines), unless `options.bracket` is off.
pub fn brackets(scene: &Scene, method: Method, options: &MarchOptions) -> bool {
    options.bracket && scene.bracket_holds() && !options.transparent && !options.secondary && !method.bisects()
}

/// Specialization constants for `scene` marched by `method`.
/// Per-ray support culling keeps one bit per primitive.
pub const CULL_MAX_PRIMITIVES: usize = 64;

fn specialization(scene: &Scene, method: Method, key: &PipelineKey, indexed: bool) -> Vec<(u32, u32)> {
    let has = |pred: fn(&Primitive) -> bool| u32::from(key.generic || scene.primitives().any(pred));
    let values = [
        ("SC_METHOD", method.shader_id()),
        ("SC_HAS_COMPACT_POINT", has(|p| matches!(p, Primitive::Point { kernel: scene::Kernel::Compact { .. }, .. }))),
        ("SC_HAS_GAUSSIAN_POINT", has(|p| matches!(p, Primitive::Point { kernel: scene::Kernel::Gaussian { .. }, .. }))),
        ("SC_HAS_COMPACT_PLANE", has(|p| matches!(p, Primitive::Plane { .. }))),
        ("SC_HAS_HRBF", has(|p| matches!(p, Primitive::Hrbf { .. }))),
        ("SC_HAS_AFFINE", has(|p| matches!(p, Primitive::Affine { .. }))),
        ("SC_MULTI_GROUP", u32::from(key.generic || scene.groups.len() > 1)),
        ("SC_SHADE", u32::from(key.shade)),
        ("SC_CULL", u32::from(key.cull && !indexed && scene.primitive_count() <= CULL_MAX_PRIMITIVES && !scene.max_needs_every_group())),
        ("SC_EXTENSION", u32::from(key.extension)),
        ("SC_TRANSPARENT", u32::from(key.transparent)),
        ("SC_SECONDARY", u32::from(key.secondary)),
        ("SC_ANY_HIT", u32::from(key.any_hit)),
        ("SC_REFINE", key.refine.shader_id()),
    ];
    values
        .iter()
        .map(|(name, v)| {
            let id = layout::SPEC_CONSTANTS.iter().find(|(_, n)| n == name).map(|(id, _)| *id);
            (id.expect("every specialization constant is declared in layout.rs"), *v)
        })
        .collect()
}

/// The primitives' buffer: a storage buffer for the index build, texels
/// for the march (`layout::BINDINGS`), filled by `transfers`' next
/// submission.
fn primitive_buffer(ctx: &Arc<Context>, transfers: &mut Transfers, prims: &[GpuPrimitive]) -> Result<Buffer> {
    let b = Buffer::texels(ctx, "primitives", size_of_val(prims) as u64, TexelFormat::Rgba32Uint, true)?;
    transfers.upload(&b, 0, prims)?;
    Ok(b)
}

/// The spatial index's buffers for `grid` (one-word stand-ins without).
fn index_buffers(ctx: &Arc<Context>, grid: Option<&GridSpec>) -> Result<[Buffer; 3]> {
    let words = grid.map_or([1; 3], |g| g.buffer_words());
    Ok([
        Buffer::texels(ctx, "index lists", 4 * words[0] as u64, TexelFormat::R32Uint, true)?,
        Buffer::texels(ctx, "index entries", 4 * words[1] as u64, TexelFormat::R32Uint, false)?,
        Buffer::device(ctx, "index scratch", 4 * words[2] as u64)?,
    ])
}

impl Renderer {
    /// Uploads `scene`, with the spatial index when it has more than 64
    /// primitives (unless the environment sets `ISOMARCH_INDEX=off`, to
    /// measure what the index buys). Fails with a one-line error when it
    /// does not fit.
    /// The GPU gives up after [`DEFAULT_TIMEOUT`].
    pub fn new(ctx: &Arc<Context>, scene: &Scene) -> Result<Renderer> {
        Renderer::with_timeout(ctx, scene, DEFAULT_TIMEOUT)
    }

    /// [`Renderer::new`] whose GPU work gives up after `timeout`.
    pub fn with_timeout(ctx: &Arc<Context>, scene: &Scene, timeout: Duration) -> Result<Renderer> {
        let indexed = env_switch("ISOMARCH_INDEX").unwrap_or(true);
        let mut renderer = Renderer::with_index_deferred(ctx, scene, indexed, timeout)?;
        renderer.ensure_index()?;
        Ok(renderer)
    }

    /// [`Renderer::new`] with the spatial index or without it (every
    /// primitive in every step, as far as the loop budget allows).
    pub fn with_index(ctx: &Arc<Context>, scene: &Scene, indexed: bool) -> Result<Renderer> {
        let mut renderer = Renderer::with_index_deferred(ctx, scene, indexed, DEFAULT_TIMEOUT)?;
        renderer.ensure_index()?;
        Ok(renderer)
    }

    /// [`Renderer::with_index`] without building the index (nor sizing a
    /// flat march's slices: [`Renderer::ensure_index`] does both).
    fn with_index_deferred(ctx: &Arc<Context>, scene: &Scene, indexed: bool, timeout: Duration) -> Result<Renderer> {
        let limit = ctx.info.max_storage_buffer_range / size_of::<GpuPrimitive>() as u64;
        if scene.primitive_count() as u64 > limit {
            bail!(
                "{}: groups: {} primitives, but {} holds at most {limit} in one storage buffer",
                scene.source,
                scene.primitive_count(),
                ctx.info.name
            );
        }
        let radii = index::index_radii(scene);
        let grid = GridSpec::with_radii(scene, &radii).filter(|_| indexed);
        if let Some(g) = &grid {
            index::check_fits(g, &ctx.info, &scene.source)?;
        }
        if grid.is_some() && scene.primitive_count() > index::MAX_INDEXED_PRIMITIVES {
            bail!(
                "{}: groups: {} primitives, more than the {} one dispatch of the index build covers",
                scene.source,
                scene.primitive_count(),
                index::MAX_INDEXED_PRIMITIVES
            );
        }
        let [cells, entries, scratch] = index_buffers(ctx, grid.as_ref())?;
        let prims = primitives_with_radii(scene, &radii);
        let lights: Vec<GpuLight> = scene
            .lights
            .iter()
            .map(|l| GpuLight {
                dir: [l.direction.x as f32, l.direction.y as f32, l.direction.z as f32, 0.0],
                color: [l.color.x as f32, l.color.y as f32, l.color.z as f32, 0.0],
            })
            .collect();
        let mut transfers = Transfers::new(ctx);
        let renderer = Renderer {
            globals: Buffer::uniform(ctx, "globals", &[globals(scene, 2.0, scene.marching.quad, grid.as_ref())])?,
            prims: primitive_buffer(ctx, &mut transfers, &prims)?,
            lights: Buffer::with_data(ctx, "lights", &lights)?,
            rays: Buffer::device(ctx, "rays", (TILE_RAYS * size_of::<GpuRay>()) as u64)?,
            results: Buffer::device(ctx, "results", (TILE_RAYS * size_of::<GpuResult>()) as u64)?,
            states: Buffer::device(ctx, "march states", (TILE_RAYS * size_of::<GpuMarchState>()) as u64)?,
            active: Buffer::device(ctx, "active ray count", 16)?,
            crossings: Buffer::device(ctx, "crossings", (TILE_RAYS * layout::MAX_CROSSINGS as usize * size_of::<f32>()) as u64)?,
            transfers,
            grid,
            cells,
            entries,
            scratch,
            index_pipeline: None,
            index_stats: None,
            slice_steps: 0,
            pipelines: HashMap::new(),
            tiles: None,
            tile_build: None,
            tile_builder: None,
            submitter: Submitter::new(ctx)?,
            pipeline_ns: 0.0,
            defer_index: false,
            index_fresh: false,
            ctx: Arc::clone(ctx),
            scene: scene.clone(),
            timeout,
            look: None,
            cold: Vec::new(),
            frame_slices: [0; 2],
        };
        Ok(renderer)
    }

    /// [`Renderer::new`] for frames of camera rays: the spatial index is
    /// built when a march needs it, not when the camera's tile lists serve
    /// every ray of the frame (no shadows, occlusion or secondary rays),
    /// and then again only after the scene moved.
    pub fn for_camera(ctx: &Arc<Context>, scene: &Scene, timeout: Duration) -> Result<Renderer> {
        let indexed = env_switch("ISOMARCH_INDEX").unwrap_or(true);
        let mut renderer = Renderer::with_index_deferred(ctx, scene, indexed, timeout)?;
        // Only scenes the lists may serve wait for a march to need the index.
        renderer.defer_index = scene.bracket_holds();
        if !renderer.defer_index {
            renderer.ensure_index()?;
        }
        Ok(renderer)
    }

    /// Builds the index now unless it holds the primitives as uploaded.
    fn ensure_index(&mut self) -> Result<()> {
        if self.index_fresh { Ok(()) } else { self.build_index() }
    }

    /// What the last build of the spatial index made (`None` without one).
    pub fn index_stats(&self) -> Option<IndexStats> {
        self.index_stats.filter(|_| self.index_fresh)
    }

    /// Builds the spatial index on the GPU from the primitives uploaded
    /// (seven dispatches of index.comp in one submission), reads back the
    /// longest list, and sizes the march's slices to it. Without an index,
    /// only the slices.
    fn build_index(&mut self) -> Result<()> {
        self.index_fresh = true;
        let Some(grid) = self.grid else {
            self.slice_steps = slice_steps(FoldCost::flat(self.scene.primitive_count()), self.scene.lights.len())
                .map_err(|e| anyhow::anyhow!("{}: groups: {e}", self.scene.source))?;
            return Ok(());
        };
        self.globals.write(0, &[globals(&self.scene, 2.0, self.scene.marching.quad, Some(&grid))])?;
        if self.index_pipeline.is_none() {
            let started = Instant::now();
            let p = ComputePipeline::new(&self.ctx, Kernel::Index.spirv().map_err(anyhow::Error::msg)?, layout::BINDINGS, PUSH_CONSTANT_BYTES, &[])?;
            p.bind(&self.bound_buffers())?;
            self.warm_up((p.pipeline, p.layout, p.set))?;
            self.index_pipeline = Some(p);
            self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
        }
        let p = self.index_pipeline.as_ref().expect("created above");
        let (pipeline, layout, set) = (p.pipeline, p.layout, p.set);
        let n = self.scene.primitive_count() as u32;
        let (lists, blocks) = (grid.lists() as u32, grid.blocks() as u32);
        // (invocations, pass) in order; see index.comp.
        let passes = [(lists + 1, 0u32), (n, 1), (blocks, 2), (1, 3), (blocks, 4), (n, 5), (lists, 6)];
        let deadline = Instant::now() + self.timeout;
        let longest = self.transfers.fetch::<u32>(&self.scratch, 0, 1)?;
        let entries = self.transfers.fetch::<u32>(&self.cells, grid.lists(), 1)?;
        self.warm_cold()?;
        let ns = self.submitter.run_with(deadline, self.timeout, &mut self.transfers, |d, cmd| {
            // SAFETY: the pipeline and its set are alive and bound to the
            // renderer's buffers, sized for this grid.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
                for (i, (count, pass)) in passes.into_iter().enumerate() {
                    if i > 0 {
                        crate::gpu::memory_barrier(
                            d,
                            cmd,
                            (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
                            (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE),
                        );
                    }
                    d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::cast_slice(&[count, pass, 0u32, 0u32]));
                    d.cmd_dispatch(cmd, (count as usize).div_ceil(WORKGROUP) as u32, 1, 1);
                }
            }
        })?;
        let longest = self.transfers.take::<u32>(longest)?[0] as usize;
        let entries = self.transfers.take::<u32>(entries)?[0] as usize;
        if entries > grid.entry_capacity {
            bail!("the spatial index holds {entries} entries, more than the {} it was sized for", grid.entry_capacity);
        }
        // With several groups a walk reads every group's list of a cell:
        // bounded by the most primitives any cell may hold (host-side).
        let crowd = if grid.groups > 1 { grid.crowd(&self.scene, &index_radii(&self.scene)) } else { longest };
        self.slice_steps = slice_steps(FoldCost::indexed(&grid, longest, crowd), self.scene.lights.len())
            .map_err(|e| anyhow::anyhow!("{}: groups: {e}", self.scene.source))?;
        let bytes: usize = grid.buffer_words().iter().sum::<usize>() * 4;
        self.index_stats = Some(IndexStats {
            build_ns: ns.unwrap_or(f64::NAN),
            entries,
            longest_list: longest,
            bytes_per_primitive: bytes as f64 / f64::from(n.max(1)),
            cells: grid.lists_per_group - 1,
            cell_size: grid.cell,
        });
        Ok(())
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Replaces the scene by the same scene posed at another time (its
    /// primitives moved, its camera and bounds changed): only the primitive
    /// data is uploaded again, and the pipelines are kept.
    pub fn set_scene(&mut self, scene: &Scene) -> Result<()> {
        let same_shape = scene.groups.len() == self.scene.groups.len()
            && scene
                .groups
                .iter()
                .zip(&self.scene.groups)
                .all(|(a, b)| a.len() == b.len() && a.iter().zip(b).all(|(p, q)| std::mem::discriminant(p) == std::mem::discriminant(q)));
        if !same_shape {
            bail!("set_scene takes the same scene at another time; {} has different primitives", scene.source);
        }
        let radii = index::index_radii(scene);
        let grid = GridSpec::with_radii(scene, &radii).filter(|_| self.grid.is_some());
        if let Some(g) = &grid {
            index::check_fits(g, &self.ctx.info, &scene.source)?;
        }
        // Another box, other buffer sizes: new buffers first (nothing is
        // replaced if one fails), then every pipeline bound to them.
        let resized = grid.map(|g| g.buffer_words()) != self.grid.map(|g| g.buffer_words());
        let buffers = if resized { Some(index_buffers(&self.ctx, grid.as_ref())?) } else { None };
        self.transfers.upload(&self.prims, 0, &primitives_with_radii(scene, &radii))?;
        self.scene = scene.clone();
        self.grid = grid;
        // The primitives moved: the lists are another frame's.
        if let Some(t) = &mut self.tiles {
            t.frame = None;
        }
        if let Some([cells, entries, scratch]) = buffers {
            (self.cells, self.entries, self.scratch) = (cells, entries, scratch);
            self.rebind()?;
        }
        self.index_fresh = false;
        if self.defer_index && self.grid.is_some() { Ok(()) } else { self.build_index() }
    }

    /// Overwrites the primitive buffer with raw GPU records, as many as the
    /// scene has: for tests of what the shaders make of records no scene
    /// produces (a primitive kind they do not know).
    pub fn upload_raw_primitives(&mut self, prims: &[GpuPrimitive]) -> Result<()> {
        if prims.len() != self.scene.primitive_count() {
            bail!("{} raw primitives for a scene of {}", prims.len(), self.scene.primitive_count());
        }
        self.transfers.upload(&self.prims, 0, prims)
    }

    /// Binds every pipeline to the buffers as they are now (after some
    /// were replaced by larger ones).
    fn rebind(&self) -> Result<()> {
        for (key, p) in &self.pipelines {
            p.bind(&self.buffers_for(key.tiles)?)?;
        }
        if let Some(p) = &self.index_pipeline {
            p.bind(&self.bound_buffers())?;
        }
        if let Some(look) = &self.look {
            look.bind(&self.rays, &self.results, &self.active, &self.lights)?;
        }
        Ok(())
    }

    /// The buffers of a pipeline that walks the camera's tile lists
    /// (`tiles`) or not: [`Renderer::bound_buffers`], with the lists where
    /// the march reads its lists (`cell_texels`, `entry_texels`).
    fn buffers_for(&self, tiles: bool) -> Result<[&Buffer; layout::BINDINGS.len()]> {
        let mut b = self.bound_buffers();
        if tiles {
            let t = self.tiles.as_ref().ok_or_else(|| anyhow::anyhow!("a tile pipeline without tile lists"))?;
            b[12] = &t.starts;
            b[13] = &t.entries;
        }
        Ok(b)
    }

    /// The buffers behind `layout::BINDINGS`, in binding order (the array's
    /// length is the table's, so a binding added there fails to compile
    /// until it has its buffer here).
    fn bound_buffers(&self) -> [&Buffer; layout::BINDINGS.len()] {
        [
            &self.globals,
            &self.prims,
            &self.lights,
            &self.rays,
            &self.results,
            &self.states,
            &self.active,
            &self.crossings,
            &self.cells,
            &self.entries,
            &self.scratch,
            &self.prims,
            &self.cells,
            &self.entries,
        ]
    }

    fn pipeline(
        &mut self,
        entry: EntryPoint,
        method: Method,
        options: &MarchOptions,
        tiles: bool,
    ) -> Result<(vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet)> {
        let key = PipelineKey { tiles, ..PipelineKey::new(entry, method, options) };
        if !self.pipelines.contains_key(&key) {
            let started = Instant::now();
            let spec = specialization(&self.scene, method, &key, self.grid.is_some());
            let kernel = match entry {
                EntryPoint::March if tiles && brackets(&self.scene, method, options) => Kernel::MarchTiles,
                EntryPoint::March if tiles => Kernel::MarchTilesCrossings,
                EntryPoint::March if self.grid.is_some() && brackets(&self.scene, method, options) => Kernel::MarchBracket,
                EntryPoint::March if self.grid.is_some() => Kernel::MarchIndexed,
                EntryPoint::March => Kernel::March,
                EntryPoint::BoundsProbe if self.grid.is_some() => Kernel::BoundsIndexed,
                EntryPoint::BoundsProbe => Kernel::Bounds,
            };
            let spirv = kernel.spirv().map_err(anyhow::Error::msg)?;
            let p = ComputePipeline::new(&self.ctx, spirv, layout::BINDINGS, PUSH_CONSTANT_BYTES, &spec)?;
            p.bind(&self.buffers_for(tiles)?)?;
            self.warm_up((p.pipeline, p.layout, p.set))?;
            self.pipelines.insert(key, p);
            self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
        }
        let p = &self.pipelines[&key];
        Ok((p.pipeline, p.layout, p.set))
    }

    /// Wall-clock milliseconds this renderer has spent creating pipelines
    /// and compiling their code, which no GPU time includes.
    pub fn pipeline_ms(&self) -> f64 {
        self.pipeline_ns * 1e-6
    }

    /// Runs a new pipeline once over no rays (one workgroup whose
    /// invocations all return at once): drivers that compile a pipeline's
    /// code on its first dispatch (lavapipe builds its LLVM variant then)
    /// compile it here, so that the timed dispatches measure the march and
    /// not the compiler. Every kernel returns first thing when its
    /// invocation is past `push[0]`, the count.
    fn warm_up(&mut self, handles: (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet)) -> Result<()> {
        self.warm_up_with(handles, [0u32, 1, self.slice_steps, 0])
    }

    /// [`Renderer::warm_up`] with push constants under which no invocation
    /// reads or writes a buffer. The warm-up waits for the next submission
    /// ([`Renderer::warm_cold`]): pipelines made together warm up in one.
    fn warm_up_with(&mut self, handles: (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet), push: [u32; 4]) -> Result<()> {
        self.cold.push((handles, push));
        Ok(())
    }

    /// Warms up every pipeline made since the last call, in one submission
    /// of its own (no transfers: those wait for the work they belong to),
    /// its time counted with the pipelines' ([`Renderer::pipeline_ms`]).
    /// Called before every submission that dispatches.
    fn warm_cold(&mut self) -> Result<()> {
        if self.cold.is_empty() {
            return Ok(());
        }
        let started = Instant::now();
        let cold = std::mem::take(&mut self.cold);
        let deadline = Instant::now() + self.timeout;
        self.submitter.run(deadline, self.timeout, |d, cmd| {
            for &(handles, push) in &cold {
                // SAFETY: as in `dispatch`; no invocation reads or writes a
                // buffer.
                unsafe {
                    crate::gpu::bind_compute(d, cmd, handles, &push);
                    d.cmd_dispatch(cmd, 1, 1, 1);
                }
            }
        })?;
        self.transfers.stats.submits += 1;
        self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
        Ok(())
    }

    /// Records one dispatch per push constants (`push[0]` rays each) in
    /// one submission, each after the previous one's writes, with the
    /// transfers staged for it. With `count_active` the active-ray counter
    /// is zeroed before each dispatch, so that after the last it holds the
    /// rays that dispatch left unfinished.
    fn dispatch(
        &mut self,
        (pipeline, layout, set): (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet),
        deadline: Instant,
        pushes: &[[u32; 4]],
        count_active: bool,
    ) -> Result<Option<f64>> {
        self.warm_cold()?;
        let active = self.active.handle;
        self.submitter.run_with(deadline, self.timeout, &mut self.transfers, |d, cmd| {
            // SAFETY: the pipeline, its layout and set are alive and bound
            // to buffers sized for a full tile; the counter is one of them.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, pipeline);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, layout, 0, &[set], &[]);
                for (i, push) in pushes.iter().enumerate() {
                    if i > 0 {
                        // The next slice reads what the last one wrote,
                        // and the counter's reset waits for its count.
                        crate::gpu::memory_barrier(
                            d,
                            cmd,
                            (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE),
                            (
                                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                                vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE,
                            ),
                        );
                    }
                    if count_active {
                        d.cmd_fill_buffer(cmd, active, 0, 16, 0);
                        crate::gpu::memory_barrier(
                            d,
                            cmd,
                            (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE),
                            (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE),
                        );
                    }
                    d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, bytemuck::cast_slice(push));
                    d.cmd_dispatch(cmd, (push[0] as usize).div_ceil(WORKGROUP) as u32, 1, 1);
                }
            }
        })
    }

    /// What crossed between host and GPU so far, and the submissions
    /// waited for (`render --stats`).
    pub fn transfer_stats(&self) -> TransferStats {
        self.transfers.stats
    }

    /// Each of the renderer's buffers by name, with the role it was made
    /// for (the rule of `gpu::Role`, checked by the tests).
    pub fn buffer_roles(&self) -> Vec<(&'static str, Role, vk::MemoryPropertyFlags)> {
        let mut buffers = vec![
            ("globals", &self.globals),
            ("primitives", &self.prims),
            ("lights", &self.lights),
            ("rays", &self.rays),
            ("results", &self.results),
            ("march states", &self.states),
            ("active ray count", &self.active),
            ("crossings", &self.crossings),
            ("index lists", &self.cells),
            ("index entries", &self.entries),
            ("index scratch", &self.scratch),
        ];
        if let Some(t) = &self.tiles {
            buffers.push(("tile list starts", &t.starts));
            buffers.push(("tile list entries", &t.entries));
        }
        buffers.into_iter().map(|(name, b)| (name, b.role(), b.memory_properties())).collect()
    }

    /// What `method` with `options` evaluates of the field for each query,
    /// a ray with `t0` in `o.w` and `t1` in `d.w`: its forward bound, RAA's
    /// range, sphere tracing's value and gradient at t0, segment tracing's
    /// value and Lipschitz bound (see [`GpuBound`]).
    pub fn probe_bounds(&mut self, method: Method, options: MarchOptions, queries: &[GpuRay]) -> Result<Vec<GpuBound>> {
        // One probe is one fold, not sliced: with the index, only as long
        // as a step's interval, so that it stays within the loop budget.
        if let Some(g) = &self.grid
            && let Some(q) = queries.iter().find(|q| f64::from(q.d[3] - q.o[3]) > g.window)
        {
            bail!("a probe query over [{}, {}] is longer than a step's {} with the spatial index", q.o[3], q.d[3], g.window);
        }
        self.ensure_index()?;
        let deadline = Instant::now() + self.timeout;
        let handles = self.pipeline(EntryPoint::BoundsProbe, method, &options, false)?;
        self.globals.write(0, &[globals(&self.scene, options.growth_of(method), options.quad, self.grid.as_ref())])?;
        let mut out = Vec::with_capacity(queries.len());
        for tile in queries.chunks(TILE_RAYS) {
            self.transfers.upload(&self.rays, 0, tile)?;
            let bounds = self.transfers.fetch::<GpuBound>(&self.results, 0, tile.len())?;
            self.dispatch(handles, deadline, &[[tile.len() as u32, 0, 0, 0]], false)?;
            out.extend(self.transfers.take::<GpuBound>(bounds)?);
        }
        Ok(out)
    }

    /// Marches `rays` with `method` and `options`, one tile per submission,
    /// each tile in slices until every ray is done, all within
    /// `self.timeout`. `progress` gets the number of rays done after each
    /// tile.
    pub fn march(&mut self, method: Method, options: MarchOptions, rays: &[GpuRay], progress: impl FnMut(usize)) -> Result<MarchOutput> {
        self.march_with(method, options, rays, None, progress)
    }

    /// [`Renderer::march`] for camera rays of the frame the renderer's
    /// tile lists were built for ([`Renderer::prepare_camera`]), in tile
    /// order from ray `first_ray` (a multiple of 64: whole tiles): through
    /// the lists where they were built for this method, else the grid.
    pub fn march_camera(&mut self, method: Method, options: MarchOptions, rays: &[GpuRay], first_ray: usize) -> Result<MarchOutput> {
        if !self.through_tiles(method, &options) {
            return self.march(method, options, rays, |_| {});
        }
        anyhow::ensure!(first_ray.is_multiple_of(WORKGROUP), "camera rays from ray {first_ray}: not a whole tile");
        self.march_with(method, options, rays, Some(first_ray), |_| {})
    }

    /// Whether camera rays of the frame prepared ([`Renderer::prepare_camera`])
    /// marched by `method` with `options` walk its tile lists: they were
    /// built, and they apply ([`Renderer::tiles_apply`]).
    fn through_tiles(&self, method: Method, options: &MarchOptions) -> bool {
        self.tiles.as_ref().is_some_and(|t| t.frame.is_some()) && self.tiles_apply(method, options)
    }

    /// Whether camera rays marched by `method` with `options` take their
    /// candidates from tile lists: with the index, where every primitive
    /// is a point kernel of non-negative weight (the first-crossing
    /// bracket holds: molecules, particles), for every method but the
    /// bisection baselines, opaque (the bracket's kernel) or transparent
    /// (every crossing), unless `ISOMARCH_TILES=off`. A dielectric scene's
    /// camera rays are traced through the grid (`optics::trace`). Every
    /// method they serve was measured faster through them, or as fast
    /// (docs/performance.md, "Tile lists"). Where the lists do not fit a
    /// dispatch's loop budget ([`Renderer::prepare_camera`]), the grid.
    pub fn tiles_apply(&self, method: Method, options: &MarchOptions) -> bool {
        self.grid.is_some()
            && !options.any_hit
            && !options.secondary
            && !method.bisects()
            && self.scene.bracket_holds()
            && self.scene.transparency.is_none_or(|t| t.ior.is_none())
            && env_switch("ISOMARCH_TILES").unwrap_or(true)
    }

    /// Builds the tile lists of `camera`'s `width` x `height` frame of the
    /// scene as posed now (kept until the scene or the frame changes) when
    /// camera rays marched by `method` with `options` would use them.
    /// Returns whether they did.
    /// Marks the tile lists as built for no camera.
    fn forget_tiles(&mut self) {
        if let Some(t) = self.tiles.as_mut() {
            t.frame = None;
        }
    }

    pub fn prepare_camera(&mut self, method: Method, options: &MarchOptions, camera: &scene::Camera, width: u32, height: u32) -> Result<bool> {
        // The lists bin what each tile's rays meet through the eye: a
        // perspective camera's only (an orthographic one walks the grid).
        if !self.tiles_apply(method, options) {
            return Ok(false);
        }
        if camera.projection != scene::Projection::Perspective {
            // Lists of an earlier camera must not serve this one.
            self.forget_tiles();
            return Ok(false);
        }
        let frame = (camera.clone(), width, height);
        if self.tiles.as_ref().is_some_and(|t| t.frame.as_ref() == Some(&frame)) {
            return Ok(true);
        }
        let grid = self.grid.expect("tiles apply with the index only");
        let built = if self.gpu_tiles_apply(width, height) {
            self.build_tiles_on_gpu(grid.groups as u32, camera, width, height)?
        } else {
            self.build_tiles_on_host(grid.groups as u32, camera, width, height)?
        };
        let Ok(steps) = slice_steps(FoldCost::tiles(&grid, built.longest, built.crowd), self.scene.lights.len()) else {
            // A list longer than a dispatch's loop budget: the grid (and
            // no earlier camera's lists).
            self.forget_tiles();
            return Ok(false);
        };
        let t = self.tiles.as_mut().expect("the builds make them");
        t.frame = Some(frame);
        t.slice_steps = steps;
        Ok(true)
    }

    /// Whether the camera's lists of a `width` x `height` frame are built
    /// on the GPU ([`tile_build`]): where the device can and is not a
    /// CPU's driver, unless [`Renderer::set_tile_builder`] or
    /// `ISOMARCH_TILE_BUILD=on|off` says otherwise; frames of at most 65,535 tiles (a
    /// primitive's loop over its tiles stays below lavapipe's cap).
    pub fn gpu_tiles_apply(&self, width: u32, height: u32) -> bool {
        let tiles = u64::from(width.div_ceil(rays::PIXEL_TILE)) * u64::from(height.div_ceil(rays::PIXEL_TILE));
        // A CPU's driver (lavapipe) runs the GPU's build on the host's
        // cores, slower than the host's own build (docs/performance.md,
        // "Tile lists built on the GPU"): there the host builds them, unless
        // asked otherwise.
        let asked = std::env::var_os(TILE_BUILD_SWITCH).map(|_| env_switch(TILE_BUILD_SWITCH).unwrap_or(true));
        let wanted = self.tile_builder.or(asked).unwrap_or(!self.ctx.info.is_cpu());
        tile_build::supported(&self.ctx) && tiles <= 65_535 && wanted
    }

    /// Builds the camera's tile lists on the GPU (`Some(true)`), on the
    /// host (`Some(false)`), or where [`Renderer::gpu_tiles_apply`] rules
    /// (`None`, the default; `ISOMARCH_TILE_BUILD=on|off` overrides it).
    pub fn set_tile_builder(&mut self, gpu: Option<bool>) {
        if self.tile_builder != gpu {
            self.tile_builder = gpu;
            self.forget_tiles();
        }
    }

    /// Makes sure the lists' buffers hold `lists` lists and `entries`
    /// entries, growing them (to powers of two) where not.
    fn ensure_tile_buffers(&mut self, lists: u64, entries: u64) -> Result<()> {
        let fits = self.tiles.as_ref().is_some_and(|t| t.starts.size >= 4 * (lists + 1) && t.entries.size >= 8 * entries.max(1));
        if !fits {
            let (starts, entries) = tile_build::list_buffers(&self.ctx, lists, entries)?;
            let steps = self.tiles.as_ref().map_or(1, |t| t.slice_steps);
            self.tiles = Some(CameraTiles { starts, entries, frame: None, slice_steps: steps, stats: TileStats::default() });
            self.rebind()?;
        }
        Ok(())
    }

    /// The host's build ([`tiles::TileLists::build`], in f64), uploaded.
    fn build_tiles_on_host(&mut self, groups: u32, camera: &scene::Camera, width: u32, height: u32) -> Result<tile_build::Built> {
        let started = Instant::now();
        let prims = primitives_with_radii(&self.scene, &index::index_radii(&self.scene));
        let lists = tiles::TileLists::build(&prims, groups, camera, width, height);
        let build_ms = started.elapsed().as_secs_f64() * 1e3;
        self.ensure_tile_buffers(lists.starts.len() as u64 - 1, lists.entries.len() as u64)?;
        let t = self.tiles.as_mut().expect("made above");
        self.transfers.upload(&t.starts, 0, &lists.starts)?;
        self.transfers.upload(&t.entries, 0, &lists.entries)?;
        t.stats = TileStats {
            build_ms,
            gpu: false,
            entries: lists.entries.len(),
            longest_list: lists.longest,
            tiles: (lists.tiles_x * lists.tiles_y) as usize,
            bytes: lists.bytes(),
        };
        Ok(tile_build::Built { entries: lists.entries.len(), longest: lists.longest, crowd: lists.crowd })
    }

    /// The GPU's build ([`tile_build`]): one submission, made again in
    /// larger buffers where the entries outgrew them.
    fn build_tiles_on_gpu(&mut self, groups: u32, camera: &scene::Camera, width: u32, height: u32) -> Result<tile_build::Built> {
        let primitives = self.scene.primitive_count() as u64;
        let tiles = u64::from(width.div_ceil(rays::PIXEL_TILE)) * u64::from(height.div_ceil(rays::PIXEL_TILE));
        let lists = tiles * u64::from(groups);
        // A first guess of the entries: four tiles a primitive.
        let mut capacity = self.tile_build.as_ref().map_or(4 * primitives + lists, |b| b.capacity).max(1 << 16);
        // The GPU's time of every try (timestamps), or the wall time.
        let (mut gpu_ns, started) = (Some(0.0), Instant::now());
        for _ in 0..4 {
            if self.tile_build.as_ref().is_none_or(|b| !b.fits(primitives, capacity)) {
                let started = Instant::now();
                self.tile_build = None;
                self.tile_build = Some(tile_build::TileBuild::new(&self.ctx, primitives, capacity)?);
                self.pipeline_ns += started.elapsed().as_secs_f64() * 1e9;
            }
            self.ensure_tile_buffers(lists, capacity)?;
            self.warm_cold()?;
            let t = self.tiles.as_ref().expect("made above");
            let build = self.tile_build.as_mut().expect("made above");
            let (built, ns) = build.build(
                &mut self.submitter,
                &mut self.transfers,
                (&self.prims, &t.starts, &t.entries),
                (primitives as u32, groups),
                camera,
                (width, height),
                self.timeout,
            )?;
            gpu_ns = gpu_ns.zip(ns).map(|(a, b)| a + b);
            if built.entries as u64 > build.capacity {
                // Too many entries for the buffers (the build stopped once
                // it knew): again, in larger ones.
                capacity = (built.entries as u64 + built.entries as u64 / 8).next_power_of_two();
                continue;
            }
            let wall_ms = started.elapsed().as_secs_f64() * 1e3;
            let t = self.tiles.as_mut().expect("made above");
            t.stats = TileStats {
                build_ms: gpu_ns.map_or(wall_ms, |ns| ns * 1e-6),
                gpu: true,
                entries: built.entries,
                longest_list: built.longest,
                tiles: tiles as usize,
                bytes: 4 * (lists as usize + 1) + 8 * built.entries,
            };
            return Ok(built);
        }
        bail!("the tile lists' entries kept outgrowing their buffers ({capacity} entries)")
    }

    /// The camera's tile lists as the GPU holds them (read back: for
    /// tests and checks), or `None` without lists for the current camera.
    pub fn camera_tile_lists(&mut self) -> Result<Option<tiles::TileLists>> {
        let Some(t) = self.tiles.as_ref() else { return Ok(None) };
        let Some((_, width, height)) = t.frame.clone() else { return Ok(None) };
        let groups = self.grid.map_or(1, |g| g.groups as u32);
        let (tiles_x, tiles_y) = (width.div_ceil(rays::PIXEL_TILE), height.div_ceil(rays::PIXEL_TILE));
        let lists = (tiles_x * tiles_y * groups) as usize;
        let starts = self.transfers.fetch::<u32>(&t.starts, 0, lists + 1)?;
        let total = t.stats.entries;
        let entries = self.transfers.fetch::<[u32; 2]>(&t.entries, 0, total.max(1))?;
        self.submitter.run_with(Instant::now() + self.timeout, self.timeout, &mut self.transfers, |_, _| {})?;
        let starts: Vec<u32> = self.transfers.take(starts)?;
        let mut entries: Vec<[u32; 2]> = self.transfers.take(entries)?;
        entries.truncate(total);
        Ok(Some(tiles::TileLists::from_parts(width, height, groups, starts, entries)))
    }

    /// The primitives as the GPU holds them (centre and clip radius in
    /// `a`, group in `ids.y`).
    pub fn primitives(&self) -> Vec<GpuPrimitive> {
        gpu_primitives(&self.scene)
    }

    /// What the last build of the camera's tile lists made.
    pub fn tile_stats(&self) -> Option<TileStats> {
        self.tiles.as_ref().map(|t| t.stats)
    }

    /// What every march does before its first dispatch: the index built
    /// unless the camera's tile lists serve it (`tiles`), the globals for
    /// `method`, the method checked against the scene and the options.
    /// Returns the pipeline, the turns of a slice and the most slices a
    /// ray may take (every slice but a ray's last takes `slice_steps`
    /// turns).
    fn march_setup(
        &mut self,
        method: Method,
        options: &MarchOptions,
        tiles: bool,
    ) -> Result<((vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet), u32, u64)> {
        // The pipeline first: it warms up with the index's build.
        let handles = self.pipeline(EntryPoint::March, method, options, tiles)?;
        if !tiles {
            self.ensure_index()?;
        }
        let slice_steps = match (tiles, &self.tiles) {
            (true, Some(t)) => t.slice_steps,
            _ => self.slice_steps,
        };
        self.globals.write(0, &[globals(&self.scene, options.growth_of(method), options.quad, self.grid.as_ref())])?;
        if method.inverts() {
            Inversion::of_field(&Field::new(&self.scene)).map_err(|e| anyhow::anyhow!("{}: {e}", self.scene.source))?;
        }
        if (options.transparent || options.secondary || options.any_hit) && matches!(method, Method::LinearBisection | Method::Raa) {
            bail!(
                "{method} marches opaque scenes only: its bisection looks for a first entering crossing; use an Algorithm 1 method for transparency, reflection and refraction"
            );
        }
        Ok((handles, slice_steps, max_turns(self.scene.marching.max_steps) / u64::from(slice_steps) + 2))
    }

    /// The march: camera rays from ray `camera_from` through the tile
    /// lists when given, else through the grid or the flat list.
    fn march_with(
        &mut self,
        method: Method,
        options: MarchOptions,
        rays: &[GpuRay],
        camera_from: Option<usize>,
        mut progress: impl FnMut(usize),
    ) -> Result<MarchOutput> {
        let deadline = Instant::now() + self.timeout;
        let (handles, slice_steps, max_slices) = self.march_setup(method, &options, camera_from.is_some())?;
        let mut results = Vec::with_capacity(rays.len());
        let mut crossings = Vec::new();
        let mut gpu_ns = Some(0.0);
        let max = layout::MAX_CROSSINGS as usize;
        for (chunk, tile) in rays.chunks(TILE_RAYS).enumerate() {
            let first_tile = camera_from.map_or(0, |from| (from + chunk * TILE_RAYS) / WORKGROUP) as u32;
            self.transfers.upload(&self.rays, 0, tile)?;
            // Slices in submissions of 1, 2, 4... (at most SLICES_PER_SUBMIT):
            // most tiles end in their first slice, and a long march waits
            // on a fence a few times rather than once a slice. Each
            // submission reads back the counter and the results, which the
            // last one holds.
            let (mut slice, mut batch) = (0u64, 1u64);
            let (tile_results, all) = loop {
                if slice > max_slices {
                    bail!("rays still marching after {slice} slices of {slice_steps} turns: a marcher ignores its step budget");
                }
                let pushes: Vec<[u32; 4]> = (slice..slice + batch).map(|s| [tile.len() as u32, u32::from(s == 0), slice_steps, first_tile]).collect();
                let active = self.transfers.fetch::<u32>(&self.active, 0, 1)?;
                let results = self.transfers.fetch::<GpuResult>(&self.results, 0, tile.len())?;
                let crossed = if options.transparent { Some(self.transfers.fetch::<f32>(&self.crossings, 0, tile.len() * max)?) } else { None };
                let ns = self.dispatch(handles, deadline, &pushes, true)?;
                gpu_ns = gpu_ns.zip(ns).map(|(a, b)| a + b);
                slice += batch;
                batch = (batch * 2).min(SLICES_PER_SUBMIT);
                if self.transfers.take::<u32>(active)?[0] == 0 {
                    let all = crossed.map(|c| self.transfers.take::<f32>(c)).transpose()?;
                    break (self.transfers.take::<GpuResult>(results)?, all);
                }
            };
            if let Some(all) = all {
                for (r, ts) in tile_results.iter().zip(all.chunks(max)) {
                    crossings.push(ts[..(r.crossings[0] as usize).min(max)].to_vec());
                }
            }
            results.extend(tile_results);
            progress(results.len());
        }
        Ok(MarchOutput { results, crossings, gpu_ns, light: light::LightStats::default() })
    }
}
