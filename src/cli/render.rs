//! `isomarch render`: one frame, or a batch of frames (`--frames`).

use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};
use clap::Args;

use isomarch::checks;
use isomarch::molecule::playback::Stager;
use isomarch::open::Input;
use isomarch::output::{Aov, ColorBar, FileFormat};
use isomarch::render::offscreen::{Effects, RenderJob, render_to_files};
use isomarch::scene::Scene;

use super::args::{GpuArgs, PlayArgs, SceneFlags};
use super::report::{self, count, method_note};
use super::{Interrupted, finish};

/// A sequence of frames: `-o` is then a pattern such as out/frame_####.png.
#[derive(Args)]
pub struct BatchArgs {
    /// Render a sequence of frames, in Rust range syntax: 0..100 excludes
    /// 100, 0..=99 includes 99. Each PNG is written whole or not at all;
    /// Ctrl-C (or SIGTERM, as from scancel) stops after the frame in flight.
    /// With -o movie.mp4 (H.264), .webm (VP9) or .gif, the frames go to one
    /// movie as they are rendered (MP4 and WebM through ffmpeg), written
    /// whole or not at all.
    #[arg(long, value_name = "RANGE")]
    frames: Option<isomarch::batch::FrameRange>,
    /// Scene time in seconds of a single frame (animated scenes).
    #[arg(long, default_value_t = 0.0, conflicts_with = "frames")]
    time: f64,
    /// Frames per second: frame n is at scene time n / fps, and a movie
    /// plays at this rate.
    #[arg(long, default_value_t = 25.0, requires = "frames")]
    fps: f64,
    /// A movie's quality (-o .mp4 or .webm): each codec's constant rate
    /// factor, from highest (largest file) to low; good is H.264's CRF 23
    /// and VP9's 31.
    #[arg(long, value_enum, default_value_t, requires = "frames")]
    quality: isomarch::movie::Quality,
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
    /// Per-frame statistics, appended (default: frames.csv beside the
    /// frames); a movie's are written whole with it (default: the movie's
    /// name and .csv, e.g. adk.mp4.csv).
    #[arg(long, value_name = "CSV", requires = "frames")]
    csv: Option<PathBuf>,
}

/// `isomarch render`.
#[derive(Args)]
pub struct RenderArgs {
    /// Scene file (RON) or molecule file (.pdb, .cif, .gro, optionally .gz),
    /// or a trajectory's topology (those, or .psf).
    scene: PathBuf,
    /// Trajectory of the topology (.xtc, .dcd, multi-model .pdb or .cif,
    /// multi-frame .gro). With --frames, frame n of the batch is frame n
    /// of the trajectory (a file of several models alone plays its models).
    trajectory: Option<PathBuf>,
    #[command(flatten)]
    play: PlayArgs,
    /// Shaded image: PNG, or the linear image as 32-bit float OpenEXR
    /// (.exr; with --aov and no --aov-output, the AOVs go in the same file);
    /// with --frames, a pattern (out/frame_####.png) or a movie (.mp4,
    /// .webm, .gif). The format follows the extension; any other is refused.
    #[arg(short, long)]
    output: PathBuf,
    /// Image size as WxH, overriding the scene's camera.resolution.
    #[arg(long, value_parser = checks::parse_size)]
    size: Option<(u32, u32)>,
    /// Depth cueing: blend hits toward the background from START to END,
    /// fractions of the scene's depth range along the view [default
    /// without a value: 0.5:1, ChimeraX's].
    #[arg(long, value_name = "START:END", num_args = 0..=1, default_missing_value = "0.5:1")]
    depth_cue: Option<String>,
    /// Outlines: a line WIDTH pixels wide where the depth between nearby
    /// pixels jumps (and where the surface meets the background)
    /// [default without a value: 1].
    #[arg(long, value_name = "WIDTH", num_args = 0..=1, default_missing_value = "1")]
    outline: Option<u32>,
    /// The outlines' colour: a name, #rrggbb or linear r,g,b [default: black].
    #[arg(long, value_name = "COLOR")]
    outline_color: Option<String>,
    /// The depth jump that draws an outline, a fraction of the scene's
    /// depth range [default: 0.03, ChimeraX's depthJump].
    #[arg(long, value_name = "F")]
    outline_jump: Option<f64>,
    /// Write the background transparent: PNG with an alpha channel (EXR
    /// with A), alpha the pixel's coverage, anti-aliasing included.
    #[arg(long)]
    transparent_background: bool,
    /// Draw the colour bar of a colouring by value (--color bfactor,
    /// occupancy, --color-values) with its range under the image.
    #[arg(long)]
    legend: bool,
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
    /// Anti-aliasing: N rays per pixel at sub-pixel positions (a Latin
    /// hypercube in each pixel, so a straight vertical or horizontal edge
    /// is covered within 1/N; jittered and deterministic), their colours
    /// averaged in linear light. Steps in the heatmap and statistics count
    /// every ray; depth and normal AOVs are the first sample's.
    /// [default: the scene's camera.samples, else 1]
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
    #[command(flatten)]
    batch: BatchArgs,
    #[command(flatten)]
    flags: SceneFlags,
}

/// What `render` will do, every value checked, before the device is
/// opened.
#[allow(clippy::large_enum_variant)] // one per run
enum Plan {
    /// One frame and its outputs.
    Still { job: RenderJob, gpu: GpuArgs },
    /// A batch of frames (`--frames`).
    Batch(Batch),
}

/// `render --frames`: a batch of PNGs, or a movie, and their statistics CSV.
struct Batch {
    job: RenderJob,
    stager: Option<Stager>,
    to: BatchOutput,
    range: isomarch::batch::FrameRange,
    fps: f64,
    shard: isomarch::batch::Shard,
    csv: PathBuf,
    gpu: GpuArgs,
}

/// Where `render --frames` writes.
enum BatchOutput {
    Files { pattern: String, skip_existing: bool },
    Movie(isomarch::movie::MovieSpec),
}

impl TryFrom<RenderArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(args: RenderArgs) -> Result<Plan> {
        // The look's flags are checked before any file is read, and so is
        // a movie's encoder (and its size, where given).
        let effects = effects(&args)?;
        if args.batch.frames.is_some() {
            isomarch::movie::check(&args.output, args.size)?;
        }
        let mut input = args.flags.open(&args.scene, args.trajectory.as_deref(), &args.play)?;
        let legend = match args.legend {
            false => None,
            true => match input.legend()? {
                Some(legend) => Some(legend.color_bar()),
                None => bail!("--legend draws the key of a colouring by value: give --color bfactor, occupancy or --color-values"),
            },
        };
        if let (Some(range), Some(k)) = (args.batch.frames, args.play.frame) {
            bail!("--frame {k} renders one frame; --frames {}..{} renders a batch: give one of them", range.start, range.end);
        }
        if let Some(range) = args.batch.frames {
            let (scene, stager) = match input {
                Input::Still(scene, _) => (scene, None),
                Input::Frames(mut stager) => {
                    // Every frame asked for must exist before any is rendered;
                    // the message names the first that does not.
                    let first_missing = range.start.max(stager.len() as u64) as usize;
                    if first_missing < range.end as usize {
                        stager.check_frame(first_missing).with_context(|| format!("--frames {}..{}", range.start, range.end))?;
                    }
                    (stager.scene(range.start as usize)?.0, Some(stager))
                }
            };
            return Ok(Plan::Batch(Batch::new(args, range, scene, stager, legend, effects)?));
        }
        let scene = input.scene(args.play.frame)?;
        let size = args.size.unwrap_or((scene.camera.width, scene.camera.height));
        let scene = scene.at_time(checks::time(args.batch.time)?);
        let method = scene.marching.method;
        let job = RenderJob {
            heatmap: args.heatmap,
            steps_max: args.steps_max,
            aovs: args.aov,
            aov_output: args.aov_output,
            stats: args.stats,
            legend,
            transparent_background: args.transparent_background,
            effects,
            samples: checks::samples(args.samples.unwrap_or(scene.camera.samples))?,
            // Only the files are written: the image alone where it will do.
            results: false,
            ..RenderJob::new(scene, method, size, args.output, args.flags.gpu.timeout()?)
        };
        // Every output's format from its extension, before any work.
        job.outputs()?;
        isomarch::render::light::check_method(&job.scene, job.method)?;
        Ok(Plan::Still { job, gpu: args.flags.gpu })
    }
}

impl Batch {
    fn new(
        args: RenderArgs,
        range: isomarch::batch::FrameRange,
        scene: Scene,
        stager: Option<Stager>,
        legend: Option<ColorBar>,
        effects: Effects,
    ) -> Result<Batch> {
        let size = args.size.unwrap_or((scene.camera.width, scene.camera.height));
        let RenderArgs { output, batch, .. } = args;
        if args.heatmap.is_some() || !args.aov.is_empty() || args.stats.is_some() || args.aov_output.is_some() || args.steps_max.is_some() {
            bail!(
                "--frames writes shaded PNGs and a statistics CSV (--csv); --heatmap, --steps-max, --aov, --aov-output and --stats are for single frames"
            );
        }
        let fps = checks::fps(batch.fps)?;
        let shard = isomarch::batch::Shard::resolve(batch.shard.as_deref(), batch.shard_count, |k| std::env::var(k).ok())?;
        let movie = isomarch::movie::Container::of(&output).is_some();
        let csv = batch.csv.unwrap_or_else(|| match movie {
            true => {
                let mut name = output.clone().into_os_string();
                name.push(".csv");
                PathBuf::from(name)
            }
            false => output.parent().filter(|p| !p.as_os_str().is_empty()).map_or_else(|| PathBuf::from("frames.csv"), |p| p.join("frames.csv")),
        });
        FileFormat::of("--csv", &csv, &[FileFormat::Csv])?;
        let method = scene.marching.method;
        let job = RenderJob {
            samples: checks::samples(args.samples.unwrap_or(scene.camera.samples))?,
            legend,
            transparent_background: args.transparent_background,
            effects,
            results: false,
            ..RenderJob::new(scene, method, size, output.clone(), args.flags.gpu.timeout()?)
        };
        let to = if movie {
            let flag = |given: bool, name: &str| match given {
                true => bail!(
                    "-o {}: a movie is written whole by one process, so {name} does not apply: render numbered PNGs (-o out/frame_####.png) and join them with `isomarch encode`",
                    output.display()
                ),
                false => Ok(()),
            };
            flag(batch.skip_existing, "--skip-existing")?;
            flag(shard != isomarch::batch::Shard::ALL, "a shard (--shard, a SLURM array or an Indexed Job)")?;
            if job.transparent_background {
                bail!("-o {}: a movie has no transparent background: write PNGs (-o out/frame_####.png)", output.display());
            }
            if csv == output {
                bail!("--csv {}: is the movie itself", csv.display());
            }
            let size = isomarch::batch::movie_frame_size(&job);
            let spec = isomarch::movie::MovieSpec::new(&output, fps, batch.quality, size)?.context("a movie's extension")?;
            BatchOutput::Movie(spec)
        } else {
            let pattern = output.to_string_lossy().into_owned();
            isomarch::batch::frame_path(&pattern, range.start)?;
            // The pattern's format, and a legend only on PNG with a background,
            // as a single frame's outputs are checked.
            job.outputs()?;
            BatchOutput::Files { pattern, skip_existing: batch.skip_existing }
        };
        isomarch::render::light::check_method(&job.scene, job.method)?;
        Ok(Batch { job, stager, to, range, fps, shard, csv, gpu: args.flags.gpu })
    }

    fn run(self) -> Result<()> {
        let Batch { job, stager, to, range, fps, shard, csv, gpu } = self;
        let stop = super::stop_flag("after the frame in flight")?;
        let gpu = gpu.open()?;
        method_note(&job.scene, job.method);
        let sink = match &to {
            BatchOutput::Files { pattern, skip_existing } => isomarch::batch::Sink::Files { pattern, skip_existing: *skip_existing },
            BatchOutput::Movie(spec) => isomarch::batch::Sink::Movie(spec),
        };
        let s = isomarch::batch::run(&gpu.ctx, &job, stager, sink, range, fps, shard, &csv, &stop)?;
        match &to {
            BatchOutput::Movie(spec) if !s.interrupted => eprintln!(
                "{}: {} at {} fps ({}x{}); statistics in {}",
                spec.path.display(),
                count(s.rendered, "frame"),
                spec.fps,
                isomarch::batch::movie_frame_size(&job).0,
                isomarch::batch::movie_frame_size(&job).1,
                csv.display()
            ),
            BatchOutput::Movie(_) => {}
            BatchOutput::Files { .. } => eprintln!(
                "{} rendered, {} kept from disk (shard {}/{}); statistics in {}",
                count(s.rendered, "frame"),
                s.skipped,
                shard.index,
                shard.count,
                csv.display()
            ),
        }
        finish(&gpu.ctx)?;
        if s.interrupted {
            match to {
                BatchOutput::Movie(spec) => eprintln!("interrupted: {} not written", spec.path.display()),
                BatchOutput::Files { .. } => eprintln!("interrupted: rerun with --skip-existing to render the rest"),
            }
            return Err(Interrupted.into());
        }
        Ok(())
    }
}

/// Depth cueing and outlines from the flags, checked.
fn effects(args: &RenderArgs) -> Result<Effects> {
    let color = args.outline_color.as_deref().map(|c| checks::color("--outline-color", c)).transpose()?;
    Effects::from_choices(args.depth_cue.as_deref(), args.outline, color, args.outline_jump)
}

pub fn run(args: RenderArgs) -> Result<()> {
    match Plan::try_from(args)? {
        Plan::Still { job, gpu } => {
            method_note(&job.scene, job.method);
            let gpu = gpu.open()?;
            let s = render_to_files(&gpu.ctx, &job)?;
            report::render(&job, &s);
            finish(&gpu.ctx)
        }
        Plan::Batch(batch) => batch.run(),
    }
}
