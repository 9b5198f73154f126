//! The `isomarch` command line: parse, call the library, map errors to an
//! exit code.
//!
//! Each subcommand has its arguments' struct and one function that runs it.
//! Flags that several subcommands share are one `Args` struct each that
//! checks and applies itself (`MarchArgs` to a scene, `VariantArgs` to the
//! benchmark's variants, `GpuArgs` to the device), and every command that
//! used the GPU ends with [`finish`].

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand, ValueEnum};

use isomarch::bench;
use isomarch::gpu::{Context, ContextOptions, GpuError, list_devices};
use isomarch::method::{Method, parse_list};
use isomarch::molecule::playback::{FramingRule, Stager};
use isomarch::output::{self, Aov, FileFormat, png_bytes, write_atomic};
use isomarch::render::offscreen::{RenderJob, render_frame, render_to_files};
use isomarch::scene::Scene;
use isomarch::settings::{QuadSettings, ValidityScope};

#[derive(Parser)]
#[command(
    name = "isomarch",
    version,
    about = "Ray marching of implicit surfaces on Vulkan compute",
    long_about = "\
Renders implicit surfaces made of point primitives (compact and Gaussian kernels) and planes, summed within groups and \
combined by max across groups, with the marchers of Aydinlilar & Zanni (2023) running as Vulkan compute shaders. \
Scene files are RON: see docs/scene-format.md."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene offscreen to PNG, with optional heatmap, AOVs and statistics.
    Render(RenderArgs),
    /// Open a window that plays the scene's animation in scene time, or a
    /// molecule's trajectory (`view TOPOLOGY TRAJECTORY`, frame n at n/fps s,
    /// looping).
    ///
    /// Controls: drag to orbit, wheel to zoom, Space pause/play, Left/Right
    /// step one frame (1/fps s), + and - double and halve the speed, M next
    /// marcher, H step heatmap, T transparency on/off, S save a screenshot,
    /// Esc quit. The title shows frame time, FPS, marcher, mean steps per
    /// ray, and a trajectory's frame and simulation time. While the view moves,
    /// frames are marched at a lower resolution that fits --preview-ms; at
    /// rest the full-resolution frame is marched in tiles over the preview.
    View(ViewArgs),
    /// List Vulkan devices and the limits that matter.
    Info,
    /// Measure the speed-accuracy trade: every method at each minimum step
    /// and step budget on one seeded ray set, against the f64 reference.
    /// Writes DIR/tradeoff.csv and a plot of time per ray against error
    /// with the Pareto front (DIR/tradeoff.png and .svg).
    Tradeoff(TradeoffArgs),
    /// Compare marchers on the benchmark protocol (docs/benchmark-protocol.md): the same seeded rays for each.
    Bench(BenchArgs),
    /// Write a benchmark scene, e.g. `generate particles --count 1000 --seed 1 -o p.ron`.
    #[command(subcommand)]
    Generate(GenerateCommand),
    /// Write the scene file of a molecule (.pdb, .cif, .gro, gzipped or
    /// not): one Gaussian blob per atom, editable, and rendered exactly as
    /// `render` renders the molecule file itself (docs/molecules.md).
    Scene(SceneArgs),
    /// Measure how time per ray grows with the scene: `generate particles`
    /// scenes of each --counts at a fixed density, every method on the
    /// protocol rays, repeats interleaved. Writes DIR/scaling.md (also
    /// printed), DIR/scaling.csv and a log-log plot (DIR/scaling.png and
    /// .svg).
    Scaling(ScalingArgs),
    /// Merge the per-shard statistics CSVs of `render --frames` (one per
    /// array task) into one CSV for the whole range, in frame order, after
    /// checking that every frame of --frames is listed exactly once (none
    /// missing, none twice, none outside).
    MergeStats(MergeStatsArgs),
    /// Read every frame of a trajectory (or a file of several models) and
    /// print, per frame, its simulation time and the mean position of its
    /// atoms, as CSV; --atoms adds the positions of atoms by their index in
    /// the file (from 0). Checks a trajectory before a long batch, and
    /// compares with other readers (MDAnalysis, VMD).
    Frames(FramesArgs),
}

/// `isomarch frames`.
#[derive(Args)]
struct FramesArgs {
    /// Topology: a molecule file (.pdb, .cif, .gro, optionally .gz) or .psf.
    topology: PathBuf,
    /// Its trajectory (.xtc, .dcd, multi-model .pdb or .cif, multi-frame .gro);
    /// default: the topology's own models or frames.
    trajectory: Option<PathBuf>,
    /// Atoms whose positions to print, by index in the file (0-based,
    /// counting every coordinate site: virtual sites and hydrogens too).
    #[arg(long, value_delimiter = ',', value_name = "I,J,...")]
    atoms: Vec<usize>,
}

/// `isomarch merge-stats`.
#[derive(Args)]
struct MergeStatsArgs {
    /// The frame range that the shards rendered together (as `render --frames`).
    #[arg(long, value_name = "RANGE")]
    frames: isomarch::batch::FrameRange,
    /// The merged CSV, written atomically.
    #[arg(short, long)]
    output: PathBuf,
    /// The per-shard CSVs (`render --csv`).
    #[arg(required = true, value_name = "CSV")]
    inputs: Vec<PathBuf>,
}

/// `isomarch generate`: what to make.
#[derive(Subcommand)]
enum GenerateCommand {
    /// N blobs at a fixed density (one per 1.5^3) in a cube whose side grows
    /// as N^(1/3), seen whole by the scene's camera: a sweep over --count
    /// holds the density fixed while the scene grows. Compact blobs of
    /// support radius 1 at iso 0.5; the choices are documented in
    /// src/generate.rs.
    Particles(ParticlesArgs),
}

/// `isomarch generate particles`.
#[derive(Args)]
struct ParticlesArgs {
    /// Number of blobs.
    #[arg(long, value_name = "N")]
    count: usize,
    /// Seed: the same seed and flags write the same bytes.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gaussian blobs (r 0.5, s 2, surface of a lone blob at 0.5) instead of compact ones.
    #[arg(long)]
    gaussian: bool,
    /// Move every centre on a sine (amplitude 0.5, random axis and phase,
    /// period 2 to 4 s): an animated scene.
    #[arg(long)]
    motion: bool,
    /// The scene file to write (.ron), atomically.
    #[arg(short, long)]
    output: PathBuf,
}

/// How a molecule file becomes a scene (docs/molecules.md). These apply
/// to molecule files only (.pdb, .ent, .cif, .mmcif, .gro, each optionally
/// .gz); a scene file given with one is refused.
#[derive(Args)]
struct MoleculeArgs {
    /// Keep hydrogen atoms (left out by default).
    #[arg(long)]
    hydrogens: bool,
    /// Sharpness s of each atom's Gaussian e^(-s d^2/r^2) [default: 2].
    #[arg(long, value_name = "S")]
    sharpness: Option<f64>,
    /// Factor on the van der Waals radii (Bondi 1964) [default: 1].
    #[arg(long, value_name = "K")]
    radius_scale: Option<f64>,
    /// Iso value; with each atom's weight e^s, 1 puts a lone atom's
    /// surface at its radius, more shrinks the surface [default: 1].
    #[arg(long)]
    iso: Option<f64>,
    /// Colour atoms by element (Jmol CPK colours), by chain, or not at all [default: element].
    #[arg(long, value_enum)]
    color: Option<isomarch::molecule::Coloring>,
    /// Turntable: the camera circles the molecule once per SECONDS of
    /// scene time (the viewer plays it; `render --frames` renders it).
    #[arg(long, value_name = "SECONDS")]
    turntable: Option<f64>,
}

impl MoleculeArgs {
    fn options(&self) -> isomarch::molecule::MoleculeOptions {
        let d = isomarch::molecule::MoleculeOptions::default();
        isomarch::molecule::MoleculeOptions {
            hydrogens: self.hydrogens,
            sharpness: self.sharpness.unwrap_or(d.sharpness),
            radius_scale: self.radius_scale.unwrap_or(d.radius_scale),
            iso: self.iso.unwrap_or(d.iso),
            coloring: self.color.unwrap_or(d.coloring),
            turntable: self.turntable,
        }
    }

    /// The flags given, for the refusal of a scene file.
    fn given(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        let flags = [
            (self.hydrogens, "--hydrogens"),
            (self.sharpness.is_some(), "--sharpness"),
            (self.radius_scale.is_some(), "--radius-scale"),
            (self.iso.is_some(), "--iso"),
            (self.color.is_some(), "--color"),
            (self.turntable.is_some(), "--turntable"),
        ];
        for (on, name) in flags {
            if on {
                v.push(name);
            }
        }
        v
    }

    /// The scene file at `path`, refused where molecule flags were given.
    fn scene_file(&self, path: &Path) -> Result<Scene> {
        let given = self.given();
        if !given.is_empty() {
            bail!("{} applies to molecule files (.pdb, .cif, .gro, optionally .gz); {} is a scene file", given.join(", "), path.display());
        }
        Ok(Scene::load(path)?)
    }

    /// The scene of molecule `m` (read from `started` on), its notes and
    /// warnings printed to stderr.
    fn scene_of(&self, m: &isomarch::molecule::Molecule, started: std::time::Instant) -> Result<Scene> {
        let (scene, notes) = isomarch::molecule::build::scene_of(m, &self.options())?;
        for w in &notes.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("{} (read and built in {:.2} s)", notes.summary, started.elapsed().as_secs_f64());
        Ok(scene)
    }
}

/// The flags of a trajectory (or a file of several models).
#[derive(Args)]
struct PlayArgs {
    /// The frame to render, benchmark or write, of a trajectory or a
    /// multi-model file [default: 0].
    #[arg(long, value_name = "N")]
    frame: Option<usize>,
    /// Where a trajectory's camera looks, for every frame: at the first
    /// frame's atoms, or at every frame's (one pass over the trajectory first).
    #[arg(long, value_enum, default_value_t)]
    framing: FramingRule,
}

/// What a command's files hold, as read.
#[allow(clippy::large_enum_variant)] // one per command
enum Opened {
    /// Frames: a trajectory, or a file of several models or frames.
    Frames(Stager),
    /// One molecule, and when its reading started.
    Molecule(isomarch::molecule::Molecule, std::time::Instant),
    /// A scene file (not read yet).
    SceneFile,
}

/// What a command was given to render: one scene, or the frames of a
/// trajectory.
#[allow(clippy::large_enum_variant)] // one per command
enum Input {
    Still(Scene),
    Frames(Stager),
}

impl Input {
    /// Opens `path` (a scene file, a molecule file, or a topology) with
    /// `trajectory`: frames where there is a trajectory or the molecule
    /// file holds more than one model or frame, else one scene.
    fn open(path: &Path, trajectory: Option<&Path>, molecule: &MoleculeArgs, march: &MarchArgs, play: &PlayArgs) -> Result<Input> {
        Ok(match Input::read(path, trajectory, molecule, march, play)? {
            Opened::Frames(stager) => Input::Frames(stager),
            Opened::Molecule(m, started) => {
                let mut scene = molecule.scene_of(&m, started)?;
                march.apply(&mut scene)?;
                Input::Still(scene)
            }
            Opened::SceneFile => Input::Still(march.load(path, molecule)?),
        })
    }

    /// What `path` (and `trajectory`) holds, each file read once.
    fn read(path: &Path, trajectory: Option<&Path>, molecule: &MoleculeArgs, march: &MarchArgs, play: &PlayArgs) -> Result<Opened> {
        let started = std::time::Instant::now();
        let psf = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psf"));
        // A PSF alone goes to the trajectory reader, which says why not.
        if trajectory.is_none() && !psf {
            let single = if isomarch::molecule::is_molecule(path) {
                let m = isomarch::molecule::read(path)?;
                if m.extra_models > 0 { None } else { Some(Opened::Molecule(m, started)) }
            } else {
                Some(Opened::SceneFile)
            };
            if let Some(single) = single {
                if let Some(k) = play.frame.filter(|&k| k > 0) {
                    bail!("--frame {k}: {} holds one frame (frame 0)", path.display());
                }
                if play.framing != FramingRule::First {
                    bail!("--framing applies to trajectories and files of several models; {} holds one", path.display());
                }
                return Ok(single);
            }
        }
        let t = isomarch::molecule::trajectory::open(path, trajectory)?;
        let frames = t.len();
        let overrides = march.clone();
        let mut stager = Stager::new(t, molecule.options(), play.framing)?.with_adjust(Box::new(move |s| overrides.apply(s)));
        let (_, time, notes) = stager.text(0)?;
        for w in &notes.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("{}", notes.summary);
        eprintln!(
            "{}: {frames} frame{}{}",
            stager.trajectory.source,
            if frames == 1 { "" } else { "s" },
            time.map_or(String::new(), |t| format!(", the first at {} ps", isomarch::molecule::trajectory::ps(t)))
        );
        Ok(Opened::Frames(stager))
    }

    /// The scene of frame `frame` (0 where not given).
    fn scene(&mut self, frame: Option<usize>) -> Result<Scene> {
        match self {
            Input::Still(scene) => Ok(scene.clone()),
            Input::Frames(stager) => Ok(stager.scene(frame.unwrap_or(0))?.0),
        }
    }
}

/// `isomarch scene`.
#[derive(Args)]
struct SceneArgs {
    /// Molecule file (.pdb, .ent, .cif, .mmcif, .gro; optionally .gz), or
    /// a trajectory's topology (those, or .psf).
    molecule: PathBuf,
    /// Trajectory of the topology (.xtc, .dcd, multi-model .pdb or .cif,
    /// multi-frame .gro): write the scene of one frame (--frame).
    trajectory: Option<PathBuf>,
    #[command(flatten)]
    play: PlayArgs,
    /// The scene file to write (.ron), atomically.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    molecule_args: MoleculeArgs,
}

/// The device flags of every command that uses the GPU.
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

/// A command's device, opened without a window, and its `--timeout`.
struct Session {
    ctx: Arc<Context>,
    timeout: Duration,
}

impl GpuArgs {
    /// `--timeout`, checked.
    fn timeout(&self) -> Result<Duration> {
        if !(self.timeout.is_finite() && self.timeout > 0.0) {
            bail!("--timeout must be a positive number of seconds, got {}", self.timeout);
        }
        Ok(Duration::from_secs_f64(self.timeout))
    }

    /// Opens the device for a command that renders offscreen; end with
    /// [`finish`].
    fn open(&self) -> Result<Session> {
        let timeout = self.timeout()?;
        let ctx = Context::new(&ContextOptions { validation: self.validation, device: self.device.clone(), present: None })?;
        Ok(Session { ctx, timeout })
    }
}

/// The marching flags of `render`, `view` and `bench`: overrides of the
/// scene file's `marching` section.
#[derive(Args, Clone)]
struct MarchArgs {
    /// Marcher (default: the scene's marching.method).
    #[arg(long, value_enum)]
    method: Option<Method>,
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
    /// How a crossing is narrowed to the refinement tolerance (default:
    /// the scene's marching.refine, else inclusion: the inclusion methods
    /// fold their own bound over the bracket, the others use secant;
    /// secant and bisection reproduce the figures measured before).
    #[arg(long, value_enum)]
    refine: Option<isomarch::settings::Refinement>,
    /// Shadows: from every shaded hit, a ray towards each light, marched
    /// with the same method until the surface crosses it (opaque scenes).
    #[arg(long)]
    shadows: bool,
    /// Ambient occlusion: N cosine-weighted rays over the hemisphere of
    /// every shaded hit, each looking --ao-distance far (opaque scenes).
    #[arg(long, value_name = "N")]
    ao: Option<u32>,
    /// How far occlusion rays look (scene units) [default: the scene's
    /// ao.distance, else 4 x the smallest primitive radius].
    #[arg(long, value_name = "D", requires = "ao")]
    ao_distance: Option<f64>,
    /// March the first crossing only, as if the scene had no
    /// `transparency` section (so that the opaque-only bisection
    /// baselines can run on a transparent or refractive scene).
    #[arg(long)]
    opaque: bool,
}

impl MarchArgs {
    /// No overrides.
    fn none() -> MarchArgs {
        MarchArgs {
            method: None,
            min_step: None,
            max_steps: None,
            growth: None,
            refine: None,
            opaque: false,
            shadows: false,
            ao: None,
            ao_distance: None,
        }
    }

    /// Loads the scene file at `path` with these overrides.
    fn load(&self, path: &Path, molecule: &MoleculeArgs) -> Result<Scene> {
        let mut scene = molecule.scene_file(path)?;
        self.apply(&mut scene)?;
        Ok(scene)
    }

    /// Checks the overrides and writes them into `scene`'s marching
    /// settings.
    fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(m) = self.method {
            scene.marching.method = m;
        }
        if let Some(s) = self.min_step {
            if !(s.is_finite() && s > 0.0) {
                bail!("--min-step must be positive and finite, got {s}");
            }
            scene.marching.min_step = s;
        }
        if let Some(n) = self.max_steps {
            if n == 0 {
                bail!("--max-steps must be at least 1");
            }
            scene.marching.max_steps = n;
        }
        if let Some(k) = self.growth {
            if !(k.is_finite() && k >= 1.0) {
                bail!("--growth must be a finite number >= 1, got {k}");
            }
            scene.marching.growth = Some(k);
        }
        if let Some(r) = self.refine {
            scene.marching.refine = r;
        }
        if self.opaque {
            scene.transparency = None;
        }
        if self.shadows {
            scene.shadows = true;
        }
        if let Some(n) = self.ao {
            let most = isomarch::scene::MAX_AO_SAMPLES;
            if !(1..=most).contains(&n) {
                bail!("--ao must be 1 to {most} rays per hit, got {n}");
            }
            let distance = self.ao_distance.or(scene.ao.map(|a| a.distance)).unwrap_or_else(|| scene.default_ao_distance());
            if !(distance.is_finite() && distance > 0.0) {
                bail!("--ao-distance must be positive, got {distance}");
            }
            scene.ao = Some(isomarch::scene::Ao { samples: n, distance });
        }
        Ok(())
    }
}

/// A sequence of frames: `-o` is then a pattern such as out/frame_####.png.
#[derive(Args)]
struct BatchArgs {
    /// Render a sequence of frames, in Rust range syntax: 0..100 excludes
    /// 100, 0..=99 includes 99. Each PNG is written whole or not at all;
    /// Ctrl-C (or SIGTERM, as from scancel) stops after the frame in flight.
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

/// `isomarch render`.
#[derive(Args)]
struct RenderArgs {
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
    /// (.exr; with --aov and no --aov-output, the AOVs go in the same file).
    /// The format follows the extension; any other is refused.
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
    molecule: MoleculeArgs,
    #[command(flatten)]
    march: MarchArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `isomarch view`.
#[derive(Args)]
struct ViewArgs {
    /// Scene file (RON) or molecule file (.pdb, .cif, .gro, optionally .gz),
    /// or a trajectory's topology (those, or .psf).
    scene: PathBuf,
    /// Trajectory of the topology (.xtc, .dcd, multi-model .pdb or .cif,
    /// multi-frame .gro), played at --fps frames per second of scene time.
    trajectory: Option<PathBuf>,
    #[command(flatten)]
    play: PlayArgs,
    /// Play every frame of a trajectory in turn, one per presented image,
    /// as fast as they render (scene time then moves one frame per image).
    #[arg(long)]
    every_frame: bool,
    /// Close after playing a trajectory through this many times.
    #[arg(long, value_name = "N")]
    loops: Option<u64>,
    /// Anti-aliasing: once the view rests, march the frame again at N
    /// sub-pixel positions and show the passes' mean as they land (as
    /// `render --samples N` computes it); any motion starts again
    /// [default: the scene's camera.samples, else 1].
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
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
    molecule: MoleculeArgs,
    #[command(flatten)]
    march: MarchArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `isomarch tradeoff`.
#[derive(Args)]
struct TradeoffArgs {
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
    /// Sweep the any-hit query of shadows and ambient occlusion instead:
    /// the scene's shadow and occlusion rays (both, with 8 occlusion rays,
    /// when it asks for neither) cast from the f64 reference's hits of the
    /// protocol rays, as `bench --any-hit` casts them; an answer that
    /// disagrees with the reference's counts as an error of 1.
    #[arg(long)]
    any_hit: bool,
    /// Output folder (default: tradeoff-<scene name>, with -any-hit).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Draw the plot again from the folder's tradeoff.csv, without
    /// marching (for a sweep measured earlier).
    #[arg(long)]
    replot: bool,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `isomarch scaling`.
#[derive(Args)]
struct ScalingArgs {
    /// Comma-separated numbers of blobs, one scene each.
    #[arg(long, default_value = isomarch::scaling::DEFAULT_COUNTS, value_name = "N,N,...")]
    counts: String,
    /// Comma-separated marchers.
    #[arg(long, default_value = isomarch::scaling::DEFAULT_METHODS)]
    methods: String,
    /// Protocol rays per scene.
    #[arg(long, default_value_t = isomarch::scaling::DEFAULT_RAYS)]
    rays: usize,
    /// Timed marches of each scene and method; their order alternates
    /// between repeats.
    #[arg(long, default_value_t = isomarch::scaling::DEFAULT_REPEAT, value_name = "R")]
    repeat: usize,
    /// Seed of the scenes, as `generate particles --seed`.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seed of the protocol rays, the same for every count.
    #[arg(long, default_value_t = bench::DEFAULT_SEED)]
    ray_seed: u64,
    /// Gaussian blobs, as `generate particles --gaussian`.
    #[arg(long)]
    gaussian: bool,
    /// Output folder.
    #[arg(short, long, default_value = "scaling", value_name = "DIR")]
    output: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `isomarch bench`.
#[derive(Args)]
struct BenchArgs {
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
    /// given (`--camera 750x750`).
    #[arg(long, value_parser = parse_size, value_name = "WxH", num_args = 0..=1)]
    camera: Option<Option<(u32, u32)>>,
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
    /// Image size of each heatmap panel.
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
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
    #[command(flatten)]
    molecule: MoleculeArgs,
    #[command(flatten)]
    march: MarchArgs,
    #[command(flatten)]
    gpu: GpuArgs,
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
struct VariantArgs {
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

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WxH such as 256x256, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&v| (1..=16384).contains(&v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("expected WxH with each side in 1..=16384, got {s:?}")),
    }
}

/// A line on stderr where the method chosen is known to be slow on the
/// scene, so that a surprising frame time comes with its reason.
fn method_note(scene: &Scene, method: Method) {
    if method == Method::Sphere && scene.has_gaussians() {
        eprintln!(
            "note: sphere tracing steps by one global Lipschitz bound, which Gaussian kernels (molecules) make small: expect many steps per ray; quadratic-taylor (the default) takes far fewer"
        );
    }
}

/// `n` and a noun, plural unless `n` is 1: "1 frame", "6 frames".
fn count(n: u64, noun: &str) -> String {
    if n == 1 { format!("1 {noun}") } else { format!("{n} {noun}s") }
}

// Checks of flags that two subcommands declare, each with its own help.

/// `--fps` of `render --frames` and `view`.
fn check_fps(fps: f64) -> Result<f64> {
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps must be positive, got {fps}");
    }
    Ok(fps)
}

/// `--time` of `render` and `view`.
fn check_time(time: f64) -> Result<f64> {
    if !time.is_finite() {
        bail!("--time must be a finite number of seconds, got {time}");
    }
    Ok(time)
}

/// `--rays` of `tradeoff`, `bench` and `scaling`.
fn check_rays(rays: usize) -> Result<usize> {
    if rays == 0 {
        bail!("--rays must be at least 1");
    }
    Ok(rays)
}

/// `--methods` of `tradeoff`, `bench` and `scaling`: a comma-separated list.
fn parse_methods(list: &str) -> Result<Vec<Method>> {
    parse_list(list).map_err(anyhow::Error::msg).context("--methods")
}

fn info() -> Result<()> {
    for d in list_devices()? {
        println!("{}: {} ({}, Vulkan {})", d.index, d.name, d.kind, d.api_version);
        println!("    max storage buffer:       {} MiB", d.max_storage_buffer_range >> 20);
        println!("    max texel buffer:         {} texels", d.max_texel_buffer_elements);
        println!("    max workgroup invocations: {}", d.max_compute_workgroup_invocations);
        println!("    max workgroup count:      {:?}", d.max_compute_workgroup_count);
        println!("    timestamps:               {} ({} ns/tick)", d.timestamps, d.timestamp_period_ns);
        println!("    memory heaps:             {:?} MiB", d.memory_heaps_mib);
    }
    Ok(())
}

fn render(args: RenderArgs) -> Result<()> {
    let mut input = Input::open(&args.scene, args.trajectory.as_deref(), &args.molecule, &args.march, &args.play)?;
    if let (Some(range), Some(k)) = (args.batch.frames, args.play.frame) {
        bail!("--frame {k} renders one frame; --frames {}..{} renders a batch: give one of them", range.start, range.end);
    }
    if let Some(range) = args.batch.frames {
        let (scene, stager) = match input {
            Input::Still(scene) => (scene, None),
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
        let size = args.size.unwrap_or((scene.camera.width, scene.camera.height));
        return render_frames(args, range, scene, stager, size);
    }
    let scene = input.scene(args.play.frame)?;
    let size = args.size.unwrap_or((scene.camera.width, scene.camera.height));
    let scene = scene.at_time(check_time(args.batch.time)?);
    let method = scene.marching.method;
    method_note(&scene, method);
    let job = RenderJob {
        heatmap: args.heatmap,
        steps_max: args.steps_max,
        aovs: args.aov,
        aov_output: args.aov_output,
        stats: args.stats,
        samples: isomarch::render::offscreen::check_samples(args.samples.unwrap_or(scene.camera.samples))?,
        ..RenderJob::new(scene, method, size, args.output, args.gpu.timeout()?)
    };
    // Every output's format from its extension, before any work.
    job.outputs()?;
    let gpu = args.gpu.open()?;
    let s = render_to_files(&gpu.ctx, &job)?;
    eprintln!(
        "{}: {}x{}{} with {} on {}: {:.2} steps/ray, {:.1} evals/ray, {:.2} turns/ray, {:.1} visits/eval, hit rate {:.3}{}; pipelines built in {:.1} ms (outside GPU time)",
        job.output.display(),
        s.width,
        s.height,
        if s.samples > 1 { format!(", {} samples per pixel,", s.samples) } else { String::new() },
        s.method,
        s.device,
        s.march.steps_per_ray,
        s.march.evals_per_ray,
        s.march.turns_per_ray,
        s.march.visits_per_ray / s.march.evals_per_ray.max(1e-9),
        s.march.hit_rate,
        s.march.gpu_ms.map_or(String::new(), |ms| format!(
            ", GPU {ms:.1} ms ({}, {})",
            s.march.ns_per_eval.map_or("n/a".into(), |v| format!("{v:.1} ns/eval")),
            s.march.ns_per_turn.map_or("n/a".into(), |v| format!("{v:.1} ns/turn"))
        )),
        s.pipeline_ms
    );
    if let Some(a) = s.march.any_hit {
        eprintln!(
            "  and {} shadow rays ({:.2} steps/ray), {} occlusion rays ({:.2} steps/ray){}",
            a.shadow_rays,
            a.shadow_steps_per_ray,
            a.ao_rays,
            a.ao_steps_per_ray,
            a.gpu_ms.map_or(String::new(), |ms| format!(", GPU {ms:.1} ms"))
        );
    }
    finish(&gpu.ctx)
}

/// `render --frames`: a batch of PNGs and their statistics CSV.
fn render_frames(args: RenderArgs, range: isomarch::batch::FrameRange, scene: Scene, stager: Option<Stager>, size: (u32, u32)) -> Result<()> {
    let RenderArgs { output, batch, .. } = args;
    if args.heatmap.is_some() || !args.aov.is_empty() || args.stats.is_some() || args.aov_output.is_some() || args.steps_max.is_some() {
        bail!(
            "--frames writes shaded PNGs and a statistics CSV (--csv); --heatmap, --steps-max, --aov, --aov-output and --stats are for single frames"
        );
    }
    let fps = check_fps(batch.fps)?;
    let pattern = output.to_string_lossy().into_owned();
    isomarch::batch::frame_path(&pattern, range.start)?;
    FileFormat::of("-o", &output, FileFormat::IMAGE)?;
    let shard = isomarch::batch::Shard::resolve(batch.shard.as_deref(), batch.shard_count, |k| std::env::var(k).ok())?;
    let csv = batch.csv.unwrap_or_else(|| {
        output.parent().filter(|p| !p.as_os_str().is_empty()).map_or_else(|| PathBuf::from("frames.csv"), |p| p.join("frames.csv"))
    });
    FileFormat::of("--csv", &csv, &[FileFormat::Csv])?;
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    // Ctrl-C, and SIGTERM and SIGHUP (scancel, a pod's deletion, a closed
    // terminal): stop between frames, so that no temporary file is left.
    ctrlc::set_handler(move || {
        if flag.swap(true, std::sync::atomic::Ordering::SeqCst) {
            // A second signal: leave now. Files are renamed into
            // place whole, so none is half-written.
            std::process::exit(130);
        }
        eprintln!("\nstopping after the frame in flight (Ctrl-C again to quit now)");
    })
    .context("installing the signal handler")?;
    let gpu = args.gpu.open()?;
    let method = scene.marching.method;
    method_note(&scene, method);
    let job = RenderJob {
        samples: isomarch::render::offscreen::check_samples(args.samples.unwrap_or(scene.camera.samples))?,
        ..RenderJob::new(scene, method, size, output.clone(), gpu.timeout)
    };
    let s = isomarch::batch::run(&gpu.ctx, &job, stager, &pattern, range, fps, shard, batch.skip_existing, &csv, &stop)?;
    eprintln!(
        "{} rendered, {} kept from disk (shard {}/{}); statistics in {}",
        count(s.rendered, "frame"),
        s.skipped,
        shard.index,
        shard.count,
        csv.display()
    );
    finish(&gpu.ctx)?;
    if s.interrupted {
        eprintln!("interrupted: rerun with --skip-existing to render the rest");
        return Err(Interrupted.into());
    }
    Ok(())
}

fn view(args: ViewArgs) -> Result<()> {
    let input = Input::open(&args.scene, args.trajectory.as_deref(), &args.molecule, &args.march, &args.play)?;
    if (args.every_frame || args.loops.is_some()) && matches!(input, Input::Still(_)) {
        bail!("--every-frame and --loops play a trajectory; {} holds one frame", args.scene.display());
    }
    if args.loops == Some(0) {
        bail!("--loops must be at least 1");
    }
    let (scene, frames) = match input {
        Input::Still(scene) => (scene, None),
        Input::Frames(mut stager) => {
            let start = args.play.frame.unwrap_or(0);
            let (scene, _) = stager.scene(start)?;
            (scene, Some(isomarch::view::Playback { stager, start, every_frame: args.every_frame, loops: args.loops }))
        }
    };
    method_note(&scene, scene.marching.method);
    let fps = check_fps(args.fps)?;
    if !(args.preview_ms.is_finite() && args.preview_ms > 0.0) {
        bail!("--preview-ms must be positive, got {}", args.preview_ms);
    }
    let time = check_time(args.time)?;
    if let Some(path) = &args.screenshot {
        FileFormat::of("--screenshot", path, &[FileFormat::Png])?;
    }
    let timeout = args.gpu.timeout()?;
    let samples = isomarch::render::offscreen::check_samples(args.samples.unwrap_or(scene.camera.samples))?;
    let options = isomarch::view::ViewOptions {
        method: scene.marching.method,
        size: args.size.unwrap_or((scene.camera.width, scene.camera.height)),
        scene,
        frames,
        time,
        paused: args.paused,
        fps,
        preview: Duration::from_secs_f64(args.preview_ms / 1e3),
        exit_after: args.exit_after,
        samples,
        screenshot: args.screenshot,
        screenshot_dir: args.screenshot_dir,
        device: args.gpu.device,
        validation: args.gpu.validation,
        timeout,
    };
    let s = isomarch::view::run(options)?;
    println!(
        "presented {} ({} at full resolution) in {:.1} s; last: {}, {:.2} steps/ray",
        count(s.presented, "frame"),
        s.full_frames,
        s.seconds,
        s.method,
        s.steps_per_ray
    );
    if let Some(p) = &s.playback {
        println!(
            "trajectory: {} frames shown ({:.2} per second), {} decoded in {:.1} ms each on the decoder thread, marching {:.1} ms per shown frame; peak RSS {}, RSS at the end {}",
            p.shown,
            p.shown as f64 / s.seconds.max(1e-9),
            p.decoded,
            p.decode_ms / p.decoded.max(1) as f64,
            p.march_ms / p.shown.max(1) as f64,
            isomarch::stats::peak_rss_mib().map_or("n/a".into(), |m| format!("{m:.1} MiB")),
            isomarch::stats::rss_mib().map_or("n/a".into(), |m| format!("{m:.1} MiB"))
        );
    }
    // No context: the window closed before the device was opened.
    s.ctx.as_deref().map_or(Ok(()), finish)
}

fn tradeoff(args: TradeoffArgs) -> Result<()> {
    let TradeoffArgs { scene: path, methods, min_steps, max_steps, rays, seed, quick, any_hit, output, replot, gpu } = args;
    let mut stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    if any_hit {
        stem.push_str("-any-hit");
    }
    let dir = output.unwrap_or_else(|| PathBuf::from(format!("tradeoff-{stem}")));
    if replot {
        let csv = dir.join("tradeoff.csv");
        let text = std::fs::read_to_string(&csv).with_context(|| format!("reading {}", csv.display()))?;
        let points = isomarch::tradeoff::read_csv(&text).with_context(|| csv.display().to_string())?;
        let title = format!("{stem}: time per ray against error (replotted from tradeoff.csv)");
        isomarch::tradeoff::plot(&points, &title, &dir.join("tradeoff.png"), &dir.join("tradeoff.svg"))?;
        eprintln!("wrote {}/tradeoff.png, .svg from its tradeoff.csv", dir.display());
        return Ok(());
    }
    if isomarch::molecule::is_molecule(&path) || path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psf")) {
        bail!(
            "{}: tradeoff takes a scene file (.ron), not a molecule; `isomarch scene {} -o scene.ron` writes the molecule's",
            path.display(),
            path.display()
        );
    }
    let scene = Scene::load(&path)?.at_time(0.0);
    let default = if quick { "segment,quadratic-taylor" } else { "sphere,segment,linear-taylor,quadratic-taylor,quadratic" };
    let methods = parse_methods(methods.as_deref().unwrap_or(default))?;
    let mut sweep = if quick { isomarch::tradeoff::Sweep::quick(methods) } else { isomarch::tradeoff::Sweep::full(methods) };
    if !min_steps.is_empty() {
        sweep.min_steps = min_steps;
    }
    if !max_steps.is_empty() {
        sweep.max_steps = max_steps;
    }
    if let Some(n) = rays {
        sweep.rays = n;
    }
    sweep.seed = seed;
    sweep.any_hit = any_hit;
    sweep.check()?;
    let gpu = gpu.open()?;
    let total = sweep.methods.len() * sweep.min_steps.len() * sweep.max_steps.len();
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("tradeoff [{bar:30}] {pos}/{len} settings ({eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let points = isomarch::tradeoff::run(&gpu.ctx, &scene, &sweep, gpu.timeout, |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    write_atomic(&dir.join("tradeoff.csv"), isomarch::tradeoff::csv(&points).as_bytes())?;
    let title = format!("{stem}: time per ray against error, {} rays on {}", sweep.rays, gpu.ctx.info.name);
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
    finish(&gpu.ctx)
}

fn generate(command: GenerateCommand) -> Result<()> {
    match command {
        GenerateCommand::Particles(args) => {
            FileFormat::of("-o", &args.output, &[FileFormat::Ron])?;
            let p = isomarch::generate::Particles { count: args.count, seed: args.seed, gaussian: args.gaussian, motion: args.motion };
            p.write(&args.output)?;
            println!("{}", p.summary(&args.output));
            Ok(())
        }
    }
}

/// `isomarch scene`: a molecule's scene file.
fn scene(args: SceneArgs) -> Result<()> {
    if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron")) {
        bail!("-o {}: a scene file must end in .ron", args.output.display());
    }
    let opened = Input::read(&args.molecule, args.trajectory.as_deref(), &args.molecule_args, &MarchArgs::none(), &args.play)?;
    let (text, source) = match opened {
        Opened::Frames(mut stager) => {
            let k = args.play.frame.unwrap_or(0);
            (stager.text(k)?.0, stager.trajectory.topology.source.clone())
        }
        Opened::SceneFile => bail!("{}: not a molecule file: expected .pdb, .ent, .cif, .mmcif or .gro, optionally .gz", args.molecule.display()),
        Opened::Molecule(m, _) => {
            let (text, notes) = isomarch::molecule::build::scene_text(&m, &args.molecule_args.options())?;
            for w in &notes.warnings {
                eprintln!("warning: {w}");
            }
            eprintln!("{}", notes.summary);
            (text, m.source)
        }
    };
    // The text must load as the molecule renders: check before writing.
    Scene::parse(&text, &source)?;
    write_atomic(&args.output, text.as_bytes())?;
    println!("wrote {}", args.output.display());
    Ok(())
}

/// `isomarch frames`: every frame's time and mean position, as CSV on
/// stdout.
fn frames(args: FramesArgs) -> Result<()> {
    use std::io::Write as _;
    let mut t = isomarch::molecule::trajectory::open(&args.topology, args.trajectory.as_deref())?;
    let sites = t.topology.sites;
    if let Some(&i) = args.atoms.iter().find(|&&i| i >= sites) {
        bail!("--atoms {i}: the topology has {sites} atoms (0 to {})", sites - 1);
    }
    let mut out = std::io::stdout().lock();
    let mut header = "frame,time_ps,atoms,mean_x,mean_y,mean_z".to_string();
    for i in &args.atoms {
        header.push_str(&format!(",x{i},y{i},z{i}"));
    }
    writeln!(out, "{header}")?;
    for k in 0..t.len() {
        let f = t.frames.read(k)?;
        let present: Vec<glam::DVec3> = f.positions.iter().copied().filter(|p| p.is_finite()).collect();
        let mean = present.iter().fold(glam::DVec3::ZERO, |a, &p| a + p) / present.len().max(1) as f64;
        let mut row =
            format!("{k},{},{},{:.6},{:.6},{:.6}", f.time_ps.map_or(String::new(), |t| format!("{t:.6}")), present.len(), mean.x, mean.y, mean.z);
        for &i in &args.atoms {
            let p = f.positions[i];
            row.push_str(&format!(",{:.6},{:.6},{:.6}", p.x, p.y, p.z));
        }
        writeln!(out, "{row}")?;
    }
    eprintln!("{}: {} of {sites} atoms", t.source, count(t.len() as u64, "frame"));
    Ok(())
}

/// `isomarch merge-stats`: the shards' statistics CSVs as one.
fn merge_stats(args: MergeStatsArgs) -> Result<()> {
    FileFormat::of("-o", &args.output, &[FileFormat::Csv])?;
    let frames = isomarch::batch::merge::merge_files(&args.inputs, args.frames, &args.output)?;
    println!("{frames} frames from {} file(s) in {}", args.inputs.len(), args.output.display());
    Ok(())
}

fn scaling(args: ScalingArgs) -> Result<()> {
    let ScalingArgs { counts, methods, rays, repeat, seed, ray_seed, gaussian, output, gpu } = args;
    let sweep = isomarch::scaling::Sweep {
        counts: isomarch::scaling::parse_counts(&counts)?,
        methods: parse_methods(&methods)?,
        rays: check_rays(rays)?,
        repeat,
        seed,
        ray_seed,
        gaussian,
    };
    sweep.check()?;
    let gpu = gpu.open()?;
    let report = isomarch::scaling::run(&gpu.ctx, &sweep, gpu.timeout, command_line(), true)?;
    report.write(&output)?;
    print!("{}", report.markdown());
    eprintln!("wrote {}/scaling.md, .csv, .png, .svg", output.display());
    finish(&gpu.ctx)
}

/// This process's command line as a shell would take it back, the program
/// named `isomarch`.
fn command_line() -> String {
    let quote = |a: String| {
        if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./,=:+@%".contains(c)) {
            a
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    std::iter::once("isomarch".to_string()).chain(std::env::args().skip(1).map(quote)).collect::<Vec<_>>().join(" ")
}

fn bench(args: BenchArgs) -> Result<()> {
    let methods = parse_methods(&args.methods)?;
    let rays = check_rays(args.rays)?;
    if let Some(path) = &args.json {
        FileFormat::of("--json", path, &[FileFormat::Json])?;
    }
    if let Some(path) = &args.heatmap_grid {
        FileFormat::of("--heatmap-grid", path, &[FileFormat::Png])?;
    }
    // An animated scene is measured as posed at time 0.
    let scene = Input::open(&args.scene, args.trajectory.as_deref(), &args.molecule, &args.march, &args.play)?.scene(args.play.frame)?.at_time(0.0);
    let variants = args.variants.variants(&scene);
    let camera = args.camera.map(|size| size.unwrap_or((scene.camera.width, scene.camera.height)));
    let plan = bench::Plan { methods: &methods, variants: &variants, rays, seed: args.seed, repeats: args.repeat, camera, any_hit: args.any_hit };
    plan.check()?;
    let gpu = args.gpu.open()?;
    let report = bench::run(&gpu.ctx, &scene, &plan, gpu.timeout)?;
    print!("{}", bench::markdown(&report));
    if let Some(path) = args.json {
        write_atomic(&path, &serde_json::to_vec_pretty(&report)?)?;
    }
    if let Some(path) = args.heatmap_grid {
        // The grid shows the first variant's settings.
        let mut scene = scene.clone();
        scene.marching.quad = variants[0].quad;
        let mut panels = Vec::new();
        for &method in &methods {
            let job = RenderJob::new(scene.clone(), method, args.size, PathBuf::new(), gpu.timeout);
            let (frame, _) = render_frame(&gpu.ctx, &job)?;
            panels.push((method.to_string(), frame.steps()));
        }
        let grid = output::heatmap_grid(args.size.0, args.size.1, &panels, Some(args.steps_max));
        write_atomic(&path, &png_bytes(&grid)?)?;
    }
    finish(&gpu.ctx)
}

/// The end of every command that used the GPU: keeps the compiled pipelines
/// for the next run where the driver allows it (a failure costs only that,
/// so it is a warning), then, with validation on, fails on any message.
fn finish(ctx: &Context) -> Result<()> {
    if let Err(e) = ctx.save_pipeline_cache() {
        eprintln!("warning: pipeline cache not saved: {e:#}");
    }
    let messages = ctx.validation_messages();
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        eprintln!("validation: {m}");
    }
    bail!("{} Vulkan validation message(s)", messages.len())
}

/// A batch stopped by Ctrl-C or SIGTERM (exit status 130, as shells expect).
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
struct Interrupted;

fn run(cli: Cli) -> Result<()> {
    isomarch::render::check_environment()?;
    match cli.command {
        Command::Info => info(),
        Command::Render(args) => render(args),
        Command::View(args) => view(args),
        Command::Tradeoff(args) => tradeoff(args),
        Command::Bench(args) => bench(args),
        Command::Generate(command) => generate(command),
        Command::Scene(args) => scene(args),
        Command::Scaling(args) => scaling(args),
        Command::MergeStats(args) => merge_stats(args),
        Command::Frames(args) => frames(args),
    }
}

fn main() -> ExitCode {
    // A closed pipe (`isomarch frames ... | head`) ends the process quietly,
    // as it ends command-line tools written in C: Rust ignores SIGPIPE, so
    // each write would fail with "Broken pipe" and print! would panic.
    // SAFETY: the first thing main does, before any other thread exists.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_DFL) };
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
