//! The `isomarch` command line: the commands, their arguments and what
//! each runs. Flags that several commands share are one `Args` struct each
//! (args.rs) that turns itself into library values; each command's file
//! holds its arguments and the function that runs it, which checks every
//! value (through `isomarch::checks`, as Python does) before any GPU work;
//! the summary lines are report.rs's. Every command that used the GPU ends
//! with [`finish`].

mod args;
mod bench;
mod encode;
mod frames;
mod generate;
mod info;
mod merge_stats;
mod render;
mod report;
mod scaling;
mod scene;
mod tradeoff;
mod view;

use anyhow::{Result, bail};
use clap::{Parser, Subcommand};

use isomarch::gpu::Context;

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
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
#[allow(clippy::large_enum_variant)] // parsed once per run
enum Command {
    /// Render a scene offscreen to PNG, with optional heatmap, AOVs and statistics.
    Render(render::RenderArgs),
    /// Open a window that plays the scene's animation in scene time, or a
    /// molecule's trajectory (`view TOPOLOGY TRAJECTORY`, frame n at n/fps s,
    /// looping).
    ///
    /// Controls: drag to orbit, wheel to zoom, Space pause/play, Left/Right
    /// step one frame (1/fps s), + and - double and halve the speed, M next
    /// marcher, H step heatmap, T transparency on/off, S save a screenshot,
    /// C save the camera (for render --camera), Esc quit. The title shows frame time, FPS, marcher, mean steps per
    /// ray, and a trajectory's frame and simulation time. While the view moves,
    /// frames are marched at a lower resolution that fits --preview-ms; at
    /// rest the full-resolution frame is marched in tiles over the preview.
    View(view::ViewArgs),
    /// List Vulkan devices and the limits that matter.
    Info,
    /// Measure the speed-accuracy trade: every method at each minimum step
    /// and step budget on one seeded ray set, against the f64 reference.
    /// Writes DIR/tradeoff.csv and a plot of time per ray against error
    /// with the Pareto front (DIR/tradeoff.png and .svg).
    Tradeoff(tradeoff::TradeoffArgs),
    /// Compare marchers on the benchmark protocol (docs/benchmark-protocol.md): the same seeded rays for each.
    Bench(bench::BenchArgs),
    /// Write a benchmark scene, e.g. `generate particles --count 1000 --seed 1 -o p.ron`.
    #[command(subcommand)]
    Generate(generate::GenerateCommand),
    /// Write the scene file of a molecule (.pdb, .cif, .gro, gzipped or
    /// not): one Gaussian blob per atom, editable, and rendered exactly as
    /// `render` renders the molecule file itself (docs/molecules.md).
    Scene(scene::SceneArgs),
    /// Measure how time per ray grows with the scene: `generate particles`
    /// scenes of each --counts at a fixed density, every method on the
    /// protocol rays, repeats interleaved. Writes DIR/scaling.md (also
    /// printed), DIR/scaling.csv and a log-log plot (DIR/scaling.png and
    /// .svg).
    Scaling(scaling::ScalingArgs),
    /// Merge the per-shard statistics CSVs of `render --frames` (one per
    /// array task) into one CSV for the whole range, in frame order, after
    /// checking that every frame of --frames is listed exactly once (none
    /// missing, none twice, none outside).
    MergeStats(merge_stats::MergeStatsArgs),
    /// Join numbered frames that shards wrote (`render --frames -o
    /// out/frame_####.png` in a SLURM array or an Indexed Job) into one
    /// movie (.mp4, .webm, .gif), in frame order: every frame of --frames,
    /// else from the lowest number on disk to the highest; a gap is refused
    /// in one line naming the first missing frame.
    Encode(encode::EncodeArgs),
    /// Read every frame of a trajectory (or a file of several models) and
    /// print, per frame, its simulation time and the mean position of its
    /// atoms, as CSV; --atoms adds the positions of atoms by their index in
    /// the file (from 0). Checks a trajectory before a long batch, and
    /// compares with other readers (MDAnalysis, VMD).
    Frames(frames::FramesArgs),
}

/// The end of every command that used the GPU: keeps the compiled pipelines
/// for the next run where the driver allows it (a failure costs only that,
/// so it is a warning), then, with validation on, fails on any message.
pub fn finish(ctx: &Context) -> Result<()> {
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
pub struct Interrupted;

/// A flag that Ctrl-C, SIGTERM and SIGHUP (scancel, a pod's deletion, a
/// closed terminal) raise, for a batch to stop between frames so that no
/// temporary file is left; `what` says what stops ("after the frame in
/// flight"). A second signal leaves at once: files are renamed into place
/// whole, so none is half-written, and a movie's encoder is stopped and
/// its temporary file removed.
pub fn stop_flag(what: &'static str) -> Result<std::sync::Arc<std::sync::atomic::AtomicBool>> {
    use anyhow::Context as _;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = std::sync::Arc::clone(&stop);
    ctrlc::set_handler(move || {
        if flag.swap(true, std::sync::atomic::Ordering::SeqCst) {
            isomarch::movie::abandon_all();
            std::process::exit(130);
        }
        eprintln!("\nstopping {what} (Ctrl-C again to quit now)");
    })
    .context("installing the signal handler")?;
    Ok(stop)
}

pub fn run(cli: Cli) -> Result<()> {
    isomarch::render::check_environment()?;
    match cli.command {
        Command::Info => info::run(),
        Command::Render(args) => render::run(args),
        Command::View(args) => view::run(args),
        Command::Tradeoff(args) => tradeoff::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Generate(command) => generate::run(command),
        Command::Scene(args) => scene::run(args),
        Command::Scaling(args) => scaling::run(args),
        Command::MergeStats(args) => merge_stats::run(args),
        Command::Frames(args) => frames::run(args),
        Command::Encode(args) => encode::run(args),
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use clap::CommandFactory;

    use super::Cli;

    /// Every argument of one command (its flattened groups included) has
    /// its own id, long name and short name: two with one name (bench's
    /// `--camera [WxH]` and the view flags' `--camera FILE`) parse as
    /// whichever clap meets first, and the other cannot be given at all.
    /// clap's own checks (`Command::debug_assert`) find this, but only where
    /// clap is built with debug assertions, which the release-mode tests
    /// are not; so the names are also compared here, in every build.
    fn assert_names_unique(cmd: &clap::Command, path: &str) {
        let path = format!("{path} {}", cmd.get_name());
        let mut ids = HashMap::new();
        let mut longs = HashMap::new();
        let mut shorts = HashMap::new();
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            if let Some(before) = ids.insert(id.to_string(), id.to_string()) {
                panic!("{path}: two arguments have the id {before}");
            }
            for long in arg.get_long().into_iter().chain(arg.get_all_aliases().into_iter().flatten()) {
                if let Some(other) = longs.insert(long.to_string(), id.to_string()) {
                    panic!("{path}: --{long} names both {other} and {id}");
                }
            }
            for short in arg.get_short().into_iter().chain(arg.get_all_short_aliases().into_iter().flatten()) {
                if let Some(other) = shorts.insert(short, id.to_string()) {
                    panic!("{path}: -{short} names both {other} and {id}");
                }
            }
        }
        for sub in cmd.get_subcommands() {
            assert_names_unique(sub, &path);
        }
    }

    /// The whole command line passes clap's checks of its definition
    /// (duplicate names, conflicts and requirements that name no argument,
    /// positional order), and no command gives one name to two arguments.
    #[test]
    fn the_command_line_is_well_formed() {
        Cli::command().debug_assert();
        assert_names_unique(&Cli::command(), "");
    }

    /// `bench --camera FILE` is the view flag (docs/commands.md), and bench's
    /// sample of the camera's rays is `--camera-rays [WxH]`.
    #[test]
    fn bench_takes_a_camera_file_and_a_frame_of_camera_rays() {
        use clap::Parser;
        let cli = Cli::try_parse_from(["isomarch", "bench", "scenes/fig10.ron", "--camera", "cam.ron", "--camera-rays", "64x48"]).unwrap();
        let super::Command::Bench(args) = cli.command else { panic!("not bench") };
        assert_eq!(args.camera_frame(), (Some(std::path::Path::new("cam.ron")), Some(Some((64, 48)))));
        let cli = Cli::try_parse_from(["isomarch", "bench", "scenes/fig10.ron", "--camera-rays"]).unwrap();
        let super::Command::Bench(args) = cli.command else { panic!("not bench") };
        assert_eq!(args.camera_frame(), (None, Some(None)));
    }
}
