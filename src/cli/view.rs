//! `isomarch view`: the window.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use isomarch::checks;
#[cfg(feature = "window")]
use isomarch::{open::Input, output::FileFormat};

#[cfg(feature = "window")]
use crate::view::ViewOptions;

use super::args::{PlayArgs, SceneFlags};
#[cfg(feature = "window")]
use super::{
    finish,
    report::{self, method_note},
};

/// `isomarch view`.
#[derive(Args)]
#[cfg_attr(not(feature = "window"), allow(dead_code))]
pub struct ViewArgs {
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
    #[arg(long, value_parser = checks::parse_size)]
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
    flags: SceneFlags,
}

/// What `view` will show, every value checked, before the window opens.
#[cfg(feature = "window")]
impl TryFrom<ViewArgs> for ViewOptions {
    type Error = anyhow::Error;

    fn try_from(args: ViewArgs) -> Result<ViewOptions> {
        let input = args.flags.open(&args.scene, args.trajectory.as_deref(), &args.play)?;
        if (args.every_frame || args.loops.is_some()) && matches!(input, Input::Still(..)) {
            bail!("--every-frame and --loops play a trajectory; {} holds one frame", args.scene.display());
        }
        if args.loops == Some(0) {
            bail!("--loops must be at least 1");
        }
        let (scene, frames) = match input {
            Input::Still(scene, _) => (scene, None),
            Input::Frames(mut stager) => {
                let start = args.play.frame.unwrap_or(0);
                let (scene, _) = stager.scene(start)?;
                (scene, Some(crate::view::Playback { stager, start, every_frame: args.every_frame, loops: args.loops }))
            }
        };
        let fps = checks::fps(args.fps)?;
        let preview = checks::preview(args.preview_ms)?;
        let time = checks::time(args.time)?;
        if let Some(path) = &args.screenshot {
            FileFormat::of("--screenshot", path, &[FileFormat::Png])?;
        }
        let timeout = args.flags.gpu.timeout()?;
        let samples = checks::samples(args.samples.unwrap_or(scene.camera.samples))?;
        Ok(ViewOptions {
            method: scene.marching.method,
            size: args.size.unwrap_or((scene.camera.width, scene.camera.height)),
            scene,
            frames,
            time,
            paused: args.paused,
            fps,
            preview,
            exit_after: args.exit_after,
            samples,
            screenshot: args.screenshot,
            screenshot_dir: args.screenshot_dir,
            device: args.flags.gpu.device,
            validation: args.flags.gpu.validation,
            timeout,
        })
    }
}

#[cfg(not(feature = "window"))]
pub fn run(_args: ViewArgs) -> Result<()> {
    bail!("{}", isomarch::WITHOUT_WINDOW)
}

#[cfg(feature = "window")]
pub fn run(args: ViewArgs) -> Result<()> {
    let options = ViewOptions::try_from(args)?;
    method_note(&options.scene, options.method);
    let s = crate::view::run(options)?;
    report::view(&s);
    // No context: the window closed before the device was opened.
    s.ctx.as_deref().map_or(Ok(()), finish)
}
