//! The `isomarch` command line: parse, call the library, map errors to an
//! exit code.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};

use isomarch::gpu::{Context, ContextOptions, GpuError, list_devices};
use isomarch::method::{Method, parse_list};
use isomarch::output::{self, Aov, png_bytes, write_atomic};
use isomarch::render::offscreen::{RenderJob, render_frame, render_to_files};
use isomarch::scene::Scene;
use isomarch::bench;
use isomarch::field::quad::{QuadSettings, ValidityScope};

#[derive(Parser)]
#[command(name = "isomarch", version, about = "Ray marching of implicit surfaces on Vulkan compute", long_about = "\
Renders implicit surfaces made of point primitives (compact and Gaussian kernels) and planes, summed within groups and \
combined by max across groups, with the marchers of Aydinlilar & Zanni (2023) running as Vulkan compute shaders. \
Scene files are RON: see docs/scene-format.md.")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Args)]
struct GpuArgs {
    /// Vulkan device: index or name substring from `isomarch info` (default: discrete, then integrated, then CPU).
    #[arg(long)]
    device: Option<String>,
    /// Give up when the GPU has not finished within this many seconds.
    #[arg(long, default_value_t = 600.0, value_name = "SECONDS")]
    timeout: f64,
    /// Enable the Vulkan validation layer (also ISOMARCH_VALIDATION=1).
    #[arg(long)]
    validation: bool,
}

/// A sequence of frames: `-o` is then a pattern such as out/frame_####.png.
#[derive(Args)]
struct BatchArgs {
    /// Render a sequence of frames, in Rust range syntax: 0..100 excludes
    /// 100, 0..=99 includes 99. Each PNG is written whole or not at all;
    /// Ctrl-C stops after the frame in flight.
    #[arg(long, value_name = "RANGE")]
    frames: Option<isomarch::batch::FrameRange>,
    /// Scene time in seconds of a single frame (animated scenes).
    #[arg(long, default_value_t = 0.0, conflicts_with = "frames")]
    time: f64,
    /// Frames per second: frame n is at scene time n / fps.
    #[arg(long, default_value_t = 25.0, requires = "frames")]
    fps: f64,
    /// Render only shard I of N (from 0): the frames whose number modulo N
    /// is I. Default: from SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of
    /// SLURM_ARRAY_TASK_COUNT, or JOB_COMPLETION_INDEX of --shard-count;
    /// else every frame.
    #[arg(long, value_name = "I/N", requires = "frames")]
    shard: Option<String>,
    /// The number of shards of a Kubernetes Indexed Job (its completions).
    #[arg(long, value_name = "N", requires = "frames")]
    shard_count: Option<u64>,
    /// Keep frames already on disk (resume an interrupted batch).
    #[arg(long, requires = "frames")]
    skip_existing: bool,
    /// Per-frame statistics, appended (default: frames.csv beside the frames).
    #[arg(long, value_name = "CSV", requires = "frames")]
    csv: Option<PathBuf>,
}

#[derive(Args)]
struct MarchArgs {
    /// Marcher: sphere, segment, linear-taylor, quadratic-taylor, linear,
    /// linear-bisection, raa, quadratic, quadratic-relaxed-t0 or
    /// quadratic-relaxed-max (default: the scene's marching.method).
    #[arg(long)]
    method: Option<String>,
    /// Override the scene's minimum step (scene units).
    #[arg(long)]
    min_step: Option<f64>,
    /// Override the scene's step budget per ray.
    #[arg(long)]
    max_steps: Option<u32>,
    /// Interval growth k of Algorithm 1 (next interval = k x last step);
    /// default: the scene's, else 1.5 for segment, 3 for linear-taylor,
    /// 2 for the other methods.
    #[arg(long, value_name = "K")]
    growth: Option<f64>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene offscreen to PNG, with optional heatmap, AOVs and statistics.
    Render {
        /// Scene file (RON).
        scene: PathBuf,
        /// Shaded image (PNG).
        #[arg(short, long)]
        output: PathBuf,
        /// Image size as WxH, overriding the scene's camera.resolution.
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Also write a step-count heatmap PNG with a legend.
        #[arg(long, value_name = "PNG")]
        heatmap: Option<PathBuf>,
        /// Fix the heatmap scale (the paper's Figure 12 uses 75); default: the image's maximum.
        #[arg(long, value_name = "N")]
        steps_max: Option<u32>,
        /// Per-pixel outputs written as 32-bit float OpenEXR.
        #[arg(long, value_enum, value_delimiter = ',')]
        aov: Vec<Aov>,
        /// Where to write the AOVs (default: the output path with .exr).
        #[arg(long, value_name = "EXR")]
        aov_output: Option<PathBuf>,
        /// Write statistics (steps, evaluations, GPU time) as JSON.
        #[arg(long, value_name = "JSON")]
        stats: Option<PathBuf>,
        #[command(flatten)]
        batch: BatchArgs,
        #[command(flatten)]
        march: MarchArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Open a window that plays the scene's animation in scene time.
    ///
    /// Controls: drag to orbit, wheel to zoom, Space pause/play, Left/Right
    /// step one frame (1/fps s), M next marcher, H step heatmap, T
    /// transparency on/off, S save a screenshot, Esc quit. The title shows
    /// frame time, FPS, marcher and mean steps per ray. While the view moves,
    /// frames are marched at a lower resolution that fits --preview-ms; at
    /// rest the full-resolution frame is marched in tiles over the preview.
    View {
        /// Scene file (RON).
        scene: PathBuf,
        /// Window size as WxH (default: the scene's camera.resolution).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// Scene time to start at, seconds.
        #[arg(long, default_value_t = 0.0)]
        time: f64,
        /// Start paused.
        #[arg(long)]
        paused: bool,
        /// Frames per second of Left/Right stepping.
        #[arg(long, default_value_t = 25.0)]
        fps: f64,
        /// Wall time one piece of rendering may take before the window
        /// answers input again, in milliseconds.
        #[arg(long, default_value_t = 80.0, value_name = "MS")]
        preview_ms: f64,
        /// Close after N presented frames (scripted runs and tests).
        #[arg(long, value_name = "N")]
        exit_after: Option<u64>,
        /// At exit, save the last presented image to this PNG.
        #[arg(long, value_name = "PNG")]
        screenshot: Option<PathBuf>,
        /// Folder where S saves screenshots.
        #[arg(long, default_value = ".", value_name = "DIR")]
        screenshot_dir: PathBuf,
        #[command(flatten)]
        march: MarchArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// List Vulkan devices and the limits that matter.
    Info,
    /// Measure the speed-accuracy trade: every method at each minimum step
    /// and step budget on one seeded ray set, against the f64 reference.
    /// Writes DIR/tradeoff.csv and a plot of time per ray against error
    /// with the Pareto front (DIR/tradeoff.png and .svg).
    Tradeoff {
        /// Scene file (RON).
        scene: PathBuf,
        /// Comma-separated marchers (default sphere,segment,linear-taylor,
        /// quadratic-taylor,quadratic; segment,quadratic-taylor with --quick).
        #[arg(long)]
        methods: Option<String>,
        /// Minimum steps to sweep (comma-separated; default 1e-4,1e-3,1e-2,0.1,1).
        #[arg(long, value_delimiter = ',')]
        min_steps: Vec<f64>,
        /// Step budgets to sweep (comma-separated; default 8,32,128,1000,10000).
        #[arg(long = "max-steps-list", value_delimiter = ',')]
        max_steps: Vec<u32>,
        /// Rays (default 16384; 1024 with --quick).
        #[arg(long)]
        rays: Option<usize>,
        /// Seed of the ray set.
        #[arg(long, default_value_t = bench::DEFAULT_SEED)]
        seed: u64,
        /// A small sweep for CI: segment and quadratic-taylor unless
        /// --methods says otherwise, minimum steps 0.01 and 0.1, budgets 32
        /// and 1000, 1024 rays.
        #[arg(long)]
        quick: bool,
        /// Output folder (default: tradeoff-<scene name>).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Compare marchers on the benchmark protocol (docs/benchmark-protocol.md): the same seeded rays for each.
    Bench {
        /// Scene file (RON).
        scene: PathBuf,
        /// Comma-separated marchers; ratios are to the first.
        #[arg(long, default_value = "segment,sphere")]
        methods: String,
        /// Number of rays.
        #[arg(long, default_value_t = bench::DEFAULT_RAYS)]
        rays: usize,
        /// Seed of the ray set.
        #[arg(long, default_value_t = bench::DEFAULT_SEED)]
        seed: u64,
        /// Also write the report as JSON.
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Per-ray support culling (identical results, less work): on, off,
        /// or both to measure it in one run.
        #[arg(long, value_parser = ["on", "off", "both"], default_value = "on")]
        cull: String,
        /// Per-primitive bounds of compact kernels (Section 6.2.1) for the
        /// Taylor and bottom-up quadratic methods: on, off, or both to measure it
        /// in one run (default: the scene's marching.extension).
        #[arg(long, value_parser = ["on", "off", "both"])]
        extension: Option<String>,
        /// Which Gaussians impose validity intervals on `quadratic`:
        /// significant (peak on the ray >= 1e-3 iso), every, or both
        /// (default: the scene's marching.validity).
        #[arg(long, value_parser = ["significant", "every", "both"])]
        validity: Option<String>,
        /// Also run each method with generic pipelines (every primitive kind
        /// and the max of groups compiled in) to measure what specialising
        /// them to the scene buys; rows marked "generic".
        #[arg(long)]
        generic: bool,
        /// Also render the scene's camera view with each method and write
        /// their step heatmaps side by side on one scale (like Figure 10).
        #[arg(long, value_name = "PNG")]
        heatmap_grid: Option<PathBuf>,
        /// Image size of each heatmap panel.
        #[arg(long, value_parser = parse_size, default_value = "256x256")]
        size: (u32, u32),
        /// Top of the shared heatmap scale (default 75, as in the paper).
        #[arg(long, default_value_t = 75)]
        steps_max: u32,
        #[command(flatten)]
        march: MarchArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
}

/// The variants a bench compares: the first is the default (the scene's
/// settings, culling on unless `--cull off`), then each `both` adds the
/// other value of its setting to every variant so far.
fn bench_variants(scene: &Scene, cull: &str, extension: Option<&str>, validity: Option<&str>) -> Vec<bench::Variant> {
    let mut base = bench::Variant { cull: cull != "off", quad: scene.marching.quad, generic: false };
    match extension {
        Some("on") => base.quad.extension = true,
        Some("off") => base.quad.extension = false,
        _ => {}
    }
    match validity {
        Some("significant") => base.quad.validity = ValidityScope::Significant,
        Some("every") => base.quad.validity = ValidityScope::Every,
        _ => {}
    }
    let mut variants = vec![base];
    let mut add = |f: &dyn Fn(bench::Variant) -> bench::Variant| {
        let more: Vec<_> = variants.iter().map(|&v| f(v)).collect();
        variants.extend(more);
    };
    if cull == "both" {
        add(&|v| bench::Variant { cull: !v.cull, ..v });
    }
    if extension == Some("both") {
        add(&|v| bench::Variant { quad: QuadSettings { extension: !v.quad.extension, ..v.quad }, ..v });
    }
    if validity == Some("both") {
        let other = |s| if s == ValidityScope::Every { ValidityScope::Significant } else { ValidityScope::Every };
        add(&|v| bench::Variant { quad: QuadSettings { validity: other(v.quad.validity), ..v.quad }, ..v });
    }
    variants
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WxH such as 256x256, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&v| (1..=16384).contains(&v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("expected WxH with each side in 1..=16384, got {s:?}")),
    }
}

fn load_scene(path: &PathBuf, march: &MarchArgs) -> Result<Scene> {
    let mut scene = Scene::load(path)?;
    if let Some(m) = &march.method {
        scene.marching.method = m.parse::<Method>().map_err(anyhow::Error::msg).context("--method")?;
    }
    if let Some(s) = march.min_step {
        if !(s.is_finite() && s > 0.0) {
            bail!("--min-step must be positive and finite, got {s}");
        }
        scene.marching.min_step = s;
    }
    if let Some(n) = march.max_steps {
        if n == 0 {
            bail!("--max-steps must be at least 1");
        }
        scene.marching.max_steps = n;
    }
    if let Some(k) = march.growth {
        if !(k.is_finite() && k >= 1.0) {
            bail!("--growth must be a finite number >= 1, got {k}");
        }
        scene.marching.growth = Some(k);
    }
    Ok(scene)
}

/// `--timeout`, checked.
fn timeout(gpu: &GpuArgs) -> Result<Duration> {
    if !(gpu.timeout.is_finite() && gpu.timeout > 0.0) {
        bail!("--timeout must be a positive number of seconds, got {}", gpu.timeout);
    }
    Ok(Duration::from_secs_f64(gpu.timeout))
}

fn open(gpu: &GpuArgs) -> Result<(std::sync::Arc<Context>, Duration)> {
    let timeout = timeout(gpu)?;
    let ctx = Context::new(&ContextOptions { validation: gpu.validation, device: gpu.device.clone(), present: None })?;
    Ok((ctx, timeout))
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => {
            for d in list_devices()? {
                println!("{}: {} ({}, Vulkan {})", d.index, d.name, d.kind, d.api_version);
                println!("    max storage buffer:       {} MiB", d.max_storage_buffer_range >> 20);
                println!("    max workgroup invocations: {}", d.max_compute_workgroup_invocations);
                println!("    max workgroup count:      {:?}", d.max_compute_workgroup_count);
                println!("    timestamps:               {} ({} ns/tick)", d.timestamps, d.timestamp_period_ns);
                println!("    memory heaps:             {:?} MiB", d.memory_heaps_mib);
            }
            Ok(())
        }
        Command::Render { scene, output, size, heatmap, steps_max, aov, aov_output, stats, batch, march, gpu } => {
            let scene = load_scene(&scene, &march)?;
            let (width, height) = size.unwrap_or((scene.camera.width, scene.camera.height));
            if let Some(range) = batch.frames {
                if heatmap.is_some() || !aov.is_empty() || stats.is_some() || aov_output.is_some() || steps_max.is_some() {
                    bail!("--frames writes shaded PNGs and a statistics CSV (--csv); --heatmap, --steps-max, --aov, --aov-output and --stats are for single frames");
                }
                if !(batch.fps.is_finite() && batch.fps > 0.0) {
                    bail!("--fps must be positive, got {}", batch.fps);
                }
                let pattern = output.to_string_lossy().into_owned();
                isomarch::batch::frame_path(&pattern, range.start)?;
                let shard = isomarch::batch::Shard::resolve(batch.shard.as_deref(), batch.shard_count, |k| std::env::var(k).ok())?;
                let csv = batch.csv.unwrap_or_else(|| {
                    output.parent().filter(|p| !p.as_os_str().is_empty()).map_or_else(|| PathBuf::from("frames.csv"), |p| p.join("frames.csv"))
                });
                let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
                let flag = std::sync::Arc::clone(&stop);
                ctrlc::set_handler(move || {
                    if flag.swap(true, std::sync::atomic::Ordering::SeqCst) {
                        // A second Ctrl-C: leave now. Files are renamed into
                        // place whole, so none is half-written.
                        std::process::exit(130);
                    }
                    eprintln!("\nstopping after the frame in flight (Ctrl-C again to quit now)");
                })
                .context("installing the Ctrl-C handler")?;
                let (ctx, timeout) = open(&gpu)?;
                let method = scene.marching.method;
                let job = RenderJob::new(scene, method, (width, height), output.clone(), timeout);
                let s = isomarch::batch::run(&ctx, &job, &pattern, range, batch.fps, shard, batch.skip_existing, &csv, &stop)?;
                eprintln!(
                    "{} frames rendered, {} kept from disk (shard {}/{}); statistics in {}",
                    s.rendered,
                    s.skipped,
                    shard.index,
                    shard.count,
                    csv.display()
                );
                save_cache(&ctx);
                check_validation(&ctx)?;
                if s.interrupted {
                    eprintln!("interrupted: rerun with --skip-existing to render the rest");
                    return Err(Interrupted.into());
                }
                return Ok(());
            }
            if !batch.time.is_finite() {
                bail!("--time must be a finite number of seconds, got {}", batch.time);
            }
            let scene = scene.at_time(batch.time);
            let (ctx, timeout) = open(&gpu)?;
            let method = scene.marching.method;
            let job = RenderJob {
                heatmap,
                steps_max,
                aovs: aov,
                aov_output,
                stats,
                ..RenderJob::new(scene, method, (width, height), output, timeout)
            };
            let s = render_to_files(&ctx, &job)?;
            eprintln!(
                "{}: {}x{} with {} on {}: {:.2} steps/ray, {:.1} evals/ray, hit rate {:.3}{}",
                job.output.display(),
                s.width,
                s.height,
                s.method,
                s.device,
                s.march.steps_per_ray,
                s.march.evals_per_ray,
                s.march.hit_rate,
                s.march.gpu_ms.map_or(String::new(), |ms| format!(", GPU {ms:.1} ms"))
            );
            save_cache(&ctx);
            check_validation(&ctx)
        }
        Command::View { scene, size, time, paused, fps, preview_ms, exit_after, screenshot, screenshot_dir, march, gpu } => {
            let scene = load_scene(&scene, &march)?;
            if !(fps.is_finite() && fps > 0.0) {
                bail!("--fps must be positive, got {fps}");
            }
            if !(preview_ms.is_finite() && preview_ms > 0.0) {
                bail!("--preview-ms must be positive, got {preview_ms}");
            }
            if !time.is_finite() {
                bail!("--time must be a finite number of seconds, got {time}");
            }
            let timeout = timeout(&gpu)?;
            let options = isomarch::view::ViewOptions {
                method: scene.marching.method,
                size: size.unwrap_or((scene.camera.width, scene.camera.height)),
                scene,
                time,
                paused,
                fps,
                preview: Duration::from_secs_f64(preview_ms / 1e3),
                exit_after,
                screenshot,
                screenshot_dir,
                device: gpu.device,
                validation: gpu.validation,
                timeout,
            };
            let s = isomarch::view::run(options)?;
            println!(
                "presented {} frames ({} at full resolution) in {:.1} s; last: {}, {:.2} steps/ray",
                s.presented, s.full_frames, s.seconds, s.method, s.steps_per_ray
            );
            match &s.ctx {
                Some(ctx) => {
                    save_cache(ctx);
                    check_validation(ctx)
                }
                None => Ok(()),
            }
        }
        Command::Tradeoff { scene: path, methods, min_steps, max_steps, rays, seed, quick, output, gpu } => {
            let scene = Scene::load(&path)?.at_time(0.0);
            let default = if quick { "segment,quadratic-taylor" } else { "sphere,segment,linear-taylor,quadratic-taylor,quadratic" };
            let methods = parse_list(methods.as_deref().unwrap_or(default)).map_err(anyhow::Error::msg).context("--methods")?;
            let mut sweep = if quick { isomarch::tradeoff::Sweep::quick(methods) } else { isomarch::tradeoff::Sweep::full(methods) };
            if !min_steps.is_empty() {
                if let Some(bad) = min_steps.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
                    bail!("--min-steps must be positive, got {bad}");
                }
                sweep.min_steps = min_steps;
            }
            if !max_steps.is_empty() {
                if max_steps.contains(&0) {
                    bail!("--max-steps-list must be at least 1");
                }
                sweep.max_steps = max_steps;
            }
            if let Some(n) = rays {
                if n == 0 {
                    bail!("--rays must be at least 1");
                }
                sweep.rays = n;
            }
            sweep.seed = seed;
            let stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            let dir = output.unwrap_or_else(|| PathBuf::from(format!("tradeoff-{stem}")));
            let (ctx, timeout) = open(&gpu)?;
            let total = sweep.methods.len() * sweep.min_steps.len() * sweep.max_steps.len();
            let bar = indicatif::ProgressBar::new(total as u64);
            bar.set_style(
                indicatif::ProgressStyle::with_template("tradeoff [{bar:30}] {pos}/{len} settings ({eta} left)")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            let points = isomarch::tradeoff::run(&ctx, &scene, &sweep, timeout, |n| bar.set_position(n as u64))?;
            bar.finish_and_clear();
            write_atomic(&dir.join("tradeoff.csv"), isomarch::tradeoff::csv(&points).as_bytes())?;
            let title = format!("{stem}: time per ray against error, {} rays on {}", sweep.rays, ctx.info.name);
            isomarch::tradeoff::plot(&points, &title, &dir.join("tradeoff.png"), &dir.join("tradeoff.svg"))?;
            eprintln!("{} settings; Pareto front:", points.len());
            for p in points.iter().filter(|p| p.pareto) {
                eprintln!(
                    "  {:<18} min step {:<7} max steps {:<6} {} ns/ray, error {:.2e}, miss rate {:.5}",
                    p.method,
                    p.min_step,
                    p.max_steps,
                    p.ns_per_ray.map_or("n/a".into(), |v| format!("{v:.0}")),
                    p.error,
                    p.miss_rate
                );
            }
            eprintln!("wrote {}/tradeoff.csv, .png, .svg", dir.display());
            save_cache(&ctx);
            check_validation(&ctx)
        }
        Command::Bench { scene, methods, rays, seed, json, cull, extension, validity, generic, heatmap_grid, size, steps_max, march, gpu } => {
            let methods = parse_list(&methods).map_err(anyhow::Error::msg).context("--methods")?;
            if rays == 0 {
                bail!("--rays must be at least 1");
            }
            // An animated scene is measured as posed at time 0.
            let scene = load_scene(&scene, &march)?.at_time(0.0);
            let (ctx, timeout) = open(&gpu)?;
            let mut variants = bench_variants(&scene, &cull, extension.as_deref(), validity.as_deref());
            if generic {
                let more: Vec<_> = variants.iter().map(|&v| bench::Variant { generic: true, ..v }).collect();
                variants.extend(more);
            }
            let report = bench::run(&ctx, &scene, &methods, &variants, rays, seed, timeout)?;
            print!("{}", bench::markdown(&report));
            if let Some(path) = json {
                write_atomic(&path, &serde_json::to_vec_pretty(&report)?)?;
            }
            if let Some(path) = heatmap_grid {
                // The grid shows the first variant's settings.
                let mut scene = scene.clone();
                scene.marching.quad = variants[0].quad;
                let mut panels = Vec::new();
                for &method in &methods {
                    let job = RenderJob::new(scene.clone(), method, size, PathBuf::new(), timeout);
                    let (frame, _) = render_frame(&ctx, &job)?;
                    panels.push((method.to_string(), frame.steps()));
                }
                let grid = output::heatmap_grid(size.0, size.1, &panels, Some(steps_max));
                write_atomic(&path, &png_bytes(&grid)?)?;
            }
            save_cache(&ctx);
            check_validation(&ctx)
        }
    }
}

/// With validation on, any message is a failure worth an exit code.
fn check_validation(ctx: &Context) -> Result<()> {
    let messages = ctx.validation_messages();
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        eprintln!("validation: {m}");
    }
    bail!("{} Vulkan validation message(s)", messages.len())
}

/// A batch stopped by Ctrl-C (exit status 130, as shells expect).
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
struct Interrupted;

/// Keeps compiled pipelines for the next run where the driver allows it; a
/// failure costs only that, so it is a warning.
fn save_cache(ctx: &Context) {
    if let Err(e) = ctx.save_pipeline_cache() {
        eprintln!("warning: pipeline cache not saved: {e:#}");
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<Interrupted>().is_some() => ExitCode::from(130),
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<GpuError>().is_some_and(|g| matches!(g, GpuError::DeadlineExceeded(_))) {
                // The GPU may still run our work: leave now without running
                // exit handlers, which would tear down the driver under it.
                // SAFETY: _exit ends the process at once; nothing runs after.
                unsafe { libc::_exit(3) };
            }
            ExitCode::FAILURE
        }
    }
}
