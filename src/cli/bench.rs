//! `isomarch bench`: marchers compared on the benchmark protocol.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};

use isomarch::bench;
use isomarch::checks;
use isomarch::method::Method;
use isomarch::open::Input;
use isomarch::output::{self, FileFormat, png_bytes, write_atomic};
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::scene::Scene;
use isomarch::settings::{QuadSettings, ValidityScope};

use super::args::{GpuArgs, PlayArgs, SceneFlags};
use super::finish;

/// `isomarch bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Scene file (RON) or molecule file (.pdb, .cif, .gro, optionally .gz),
    /// or a trajectory's topology (those, or .psf).
    scene: PathBuf,
    /// Trajectory of the topology: benchmark one frame (--frame).
    trajectory: Option<PathBuf>,
    #[command(flatten)]
    play: PlayArgs,
    /// Comma-separated marchers; ratios are to the first.
    #[arg(long, default_value = "segment,sphere")]
    methods: String,
    /// Number of rays.
    #[arg(long, default_value_t = bench::DEFAULT_RAYS)]
    rays: usize,
    /// Seed of the ray set.
    #[arg(long, default_value_t = bench::DEFAULT_SEED)]
    seed: u64,
    /// Instead of the protocol's rays, a seeded sample of `--rays` of the
    /// scene camera's pixel rays, without repeats: the rays a rendered
    /// frame marches. The frame is the scene's resolution, or WxH when
    /// given (`--camera-rays 750x750`). The camera is the scene's, or the
    /// one `--camera FILE` gives.
    #[arg(long, value_parser = checks::parse_size, value_name = "WxH", num_args = 0..=1)]
    camera_rays: Option<Option<(u32, u32)>>,
    /// Run the whole list of methods this many times, interleaved, and
    /// report each time as the median over repeats with its range, and
    /// each time ratio as the median of the ratios within each repeat
    /// (GPU times move by 10-30% between runs on a shared CPU).
    #[arg(long, default_value_t = 1, value_name = "N")]
    repeat: usize,
    /// Also write the report as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    #[command(flatten)]
    variants: VariantArgs,
    /// Also render the scene's camera view with each method and write
    /// their step heatmaps side by side on one scale (like Figure 10).
    #[arg(long, value_name = "PNG")]
    heatmap_grid: Option<PathBuf>,
    /// Image size of each heatmap panel, and of the frame loop's frames.
    #[arg(long, value_parser = checks::parse_size, default_value = "256x256")]
    size: (u32, u32),
    /// Top of the shared heatmap scale (default 75, as in the paper).
    #[arg(long, default_value_t = 75)]
    steps_max: u32,
    /// Benchmark the any-hit query of shadows and ambient occlusion: from
    /// the f64 reference's first hit of each ray, the scene's shadow and
    /// occlusion rays (--shadows, --ao N; both, with 8 occlusion rays,
    /// when the scene and the flags ask for neither), marched by every
    /// method and compared with the reference's answers ray by ray.
    #[arg(long)]
    any_hit: bool,
    /// The frame loop instead of the protocol: N frames rendered offscreen
    /// along a window's path (a still scene turned about the view's
    /// vertical axis, 360 degrees over the N frames; a trajectory's frames
    /// in order), at --size with the first of --methods, each image made
    /// whole (rays, march, lights, samples, look) and none written. Prints
    /// wall and GPU milliseconds per frame, frames per second, and the
    /// bytes read back and uploaded and the fences waited per frame
    /// (medians); --json writes every frame's figures.
    #[arg(long, value_name = "N", conflicts_with_all = ["heatmap_grid", "any_hit", "repeat"])]
    frames: Option<usize>,
    /// Rays per pixel of the frame loop's frames (anti-aliasing, as
    /// render's --samples; default: the scene's).
    #[arg(long, value_name = "N", requires = "frames")]
    samples: Option<u32>,
    #[command(flatten)]
    flags: SceneFlags,
}

/// A setting that `bench` runs one way, or both ways to measure it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Switch {
    On,
    Off,
    Both,
}

impl Switch {
    /// The one value asked for; `None` for both.
    fn only(self) -> Option<bool> {
        match self {
            Switch::On => Some(true),
            Switch::Off => Some(false),
            Switch::Both => None,
        }
    }
}

/// `--validity`: one `ValidityScope`, or both to compare them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ValidityChoice {
    Significant,
    Every,
    Both,
}

impl ValidityChoice {
    /// The one scope asked for; `None` for both.
    fn only(self) -> Option<ValidityScope> {
        match self {
            ValidityChoice::Significant => Some(ValidityScope::Significant),
            ValidityChoice::Every => Some(ValidityScope::Every),
            ValidityChoice::Both => None,
        }
    }
}

/// The settings a bench compares, each on, off or both.
#[derive(Args)]
pub struct VariantArgs {
    /// Per-ray support culling (identical results, less work): on, off,
    /// or both to measure it in one run.
    #[arg(long, value_enum, default_value_t = Switch::On)]
    cull: Switch,
    /// Per-primitive bounds of compact kernels (Section 6.2.1) for the
    /// Taylor and bottom-up quadratic methods: on, off, or both to measure it
    /// in one run (default: the scene's marching.extension).
    #[arg(long, value_enum)]
    extension: Option<Switch>,
    /// Which Gaussians impose validity intervals on `quadratic`:
    /// significant (peak on the ray >= 1e-3 iso), every, or both
    /// (default: the scene's marching.validity).
    #[arg(long, value_enum)]
    validity: Option<ValidityChoice>,
    /// Also run each method with generic pipelines (every primitive kind
    /// and the max of groups compiled in) to measure what specialising
    /// them to the scene buys; rows marked "generic".
    #[arg(long)]
    generic: bool,
}

impl VariantArgs {
    /// The variants a bench compares: the first is the default (the
    /// scene's settings with what was asked for, culling on unless `--cull
    /// off`), then each `both`, and `--generic`, adds the other value of
    /// its setting to every variant so far.
    fn variants(&self, scene: &Scene) -> Vec<bench::Variant> {
        let mut base = bench::Variant { cull: self.cull.only().unwrap_or(true), quad: scene.marching.quad, generic: false };
        if let Some(on) = self.extension.and_then(Switch::only) {
            base.quad.extension = on;
        }
        if let Some(scope) = self.validity.and_then(ValidityChoice::only) {
            base.quad.validity = scope;
        }
        let mut variants = vec![base];
        let mut add = |f: &dyn Fn(bench::Variant) -> bench::Variant| {
            let more: Vec<_> = variants.iter().map(|&v| f(v)).collect();
            variants.extend(more);
        };
        if self.cull == Switch::Both {
            add(&|v| bench::Variant { cull: !v.cull, ..v });
        }
        if self.extension == Some(Switch::Both) {
            add(&|v| bench::Variant { quad: QuadSettings { extension: !v.quad.extension, ..v.quad }, ..v });
        }
        if self.validity == Some(ValidityChoice::Both) {
            let other = |s| if s == ValidityScope::Every { ValidityScope::Significant } else { ValidityScope::Every };
            add(&|v| bench::Variant { quad: QuadSettings { validity: other(v.quad.validity), ..v.quad }, ..v });
        }
        if self.generic {
            add(&|v| bench::Variant { generic: true, ..v });
        }
        variants
    }
}

/// What `bench` will measure, every value checked, before the device is
/// opened.
struct Plan {
    scene: Scene,
    methods: Vec<Method>,
    variants: Vec<bench::Variant>,
    rays: usize,
    seed: u64,
    repeats: usize,
    camera: Option<(u32, u32)>,
    any_hit: bool,
    json: Option<PathBuf>,
    heatmap_grid: Option<(PathBuf, (u32, u32), u32)>,
    gpu: GpuArgs,
}

impl TryFrom<BenchArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(args: BenchArgs) -> Result<Plan> {
        let methods = checks::methods(&args.methods)?;
        let rays = checks::rays(args.rays)?;
        if let Some(path) = &args.json {
            FileFormat::of("--json", path, &[FileFormat::Json])?;
        }
        if let Some(path) = &args.heatmap_grid {
            FileFormat::of("--heatmap-grid", path, &[FileFormat::Png])?;
        }
        // An animated scene is measured as posed at time 0.
        let scene = args.flags.open(&args.scene, args.trajectory.as_deref(), &args.play)?.scene(args.play.frame)?.at_time(0.0);
        let variants = args.variants.variants(&scene);
        let camera = args.camera_rays.map(|size| size.unwrap_or((scene.camera.width, scene.camera.height)));
        let plan = Plan {
            scene,
            methods,
            variants,
            rays,
            seed: args.seed,
            repeats: args.repeat,
            camera,
            any_hit: args.any_hit,
            json: args.json,
            heatmap_grid: args.heatmap_grid.map(|path| (path, args.size, args.steps_max)),
            gpu: args.flags.gpu,
        };
        plan.protocol().check()?;
        Ok(plan)
    }
}

impl Plan {
    /// The library's benchmark plan.
    fn protocol(&self) -> bench::Plan<'_> {
        bench::Plan {
            methods: &self.methods,
            variants: &self.variants,
            rays: self.rays,
            seed: self.seed,
            repeats: self.repeats,
            camera: self.camera,
            any_hit: self.any_hit,
        }
    }
}

/// `bench --frames N`: the frame loop (isomarch::frame_loop).
fn run_loop(args: BenchArgs, count: usize) -> Result<()> {
    let methods = checks::methods(&args.methods)?;
    let samples = args.samples.map(isomarch::render::offscreen::check_samples).transpose()?;
    if let Some(path) = &args.json {
        FileFormat::of("--json", path, &[FileFormat::Json])?;
    }
    if count == 0 {
        anyhow::bail!("--frames takes at least one frame");
    }
    let input = args.flags.open(&args.scene, args.trajectory.as_deref(), &args.play)?;
    let (scene, stager) = match input {
        Input::Still(scene, _) => (scene, None),
        Input::Frames(mut stager) => (stager.scene(0)?.0, Some(stager)),
    };
    let gpu = args.flags.gpu.open()?;
    let mut job = RenderJob::new(scene.at_time(0.0), methods[0], args.size, PathBuf::new(), gpu.timeout);
    if let Some(n) = samples {
        job.samples = n;
    }
    let bar = indicatif::ProgressBar::new(count as u64);
    let report = isomarch::frame_loop::run(&gpu.ctx, &job, stager, count, |k| bar.set_position(k as u64))?;
    bar.finish_and_clear();
    println!("{}", report.summary());
    if let Some(path) = &args.json {
        write_atomic(path, &serde_json::to_vec_pretty(&report)?)?;
    }
    finish(&gpu.ctx)
}

pub fn run(args: BenchArgs) -> Result<()> {
    if let Some(count) = args.frames {
        return run_loop(args, count);
    }
    let plan = Plan::try_from(args)?;
    let gpu = plan.gpu.open()?;
    let report = bench::run(&gpu.ctx, &plan.scene, &plan.protocol(), gpu.timeout)?;
    print!("{}", bench::markdown(&report));
    if let Some(path) = &plan.json {
        write_atomic(path, &serde_json::to_vec_pretty(&report)?)?;
    }
    if let Some((path, size, steps_max)) = &plan.heatmap_grid {
        // The grid shows the first variant's settings.
        let mut scene = plan.scene.clone();
        scene.marching.quad = plan.variants[0].quad;
        let mut panels = Vec::new();
        for &method in &plan.methods {
            let job = RenderJob::new(scene.clone(), method, *size, PathBuf::new(), gpu.timeout);
            let (frame, _) = render_frame(&gpu.ctx, &job)?;
            panels.push((method.to_string(), frame.steps()));
        }
        let grid = output::heatmap_grid(size.0, size.1, &panels, Some(*steps_max));
        write_atomic(path, &png_bytes(&grid)?)?;
    }
    finish(&gpu.ctx)
}

/// `--camera-rays` as parsed: absent, without a size, or WxH.
#[cfg(test)]
pub type CameraRays = Option<Option<(u32, u32)>>;

#[cfg(test)]
impl BenchArgs {
    /// The view flags' camera file and bench's frame of camera rays, as
    /// parsed.
    pub fn camera_frame(&self) -> (Option<&std::path::Path>, CameraRays) {
        (self.flags.view.camera.as_deref(), self.camera_rays)
    }
}
