//! `isomarch encode`: numbered frames on disk joined into one movie.

use std::path::PathBuf;
use std::sync::atomic::Ordering;

use anyhow::{Context as _, Result, bail};
use clap::Args;

use isomarch::movie::{MovieSpec, MovieWriter, Quality};

use super::Interrupted;
use super::report::count;

/// `isomarch encode`.
#[derive(Args)]
pub struct EncodeArgs {
    /// The frames' names, as `render --frames -o` wrote them: the run of #
    /// is the frame number (out/frame_####.png).
    pattern: String,
    /// The movie: .mp4 (H.264), .webm (VP9) or .gif, written whole or not
    /// at all.
    #[arg(short, long)]
    output: PathBuf,
    /// The frames to join, in Rust range syntax (0..100, 0..=99); default:
    /// from the lowest number on disk to the highest.
    #[arg(long, value_name = "RANGE")]
    frames: Option<isomarch::batch::FrameRange>,
    /// Frames per second of the movie.
    #[arg(long, default_value_t = 25.0)]
    fps: f64,
    /// The movie's quality, as for `render --quality`.
    #[arg(long, value_enum, default_value_t)]
    quality: Quality,
}

/// `isomarch encode`: checks the movie's encoder and that no frame is
/// missing, then streams the PNGs to the movie in frame order.
pub fn run(args: EncodeArgs) -> Result<()> {
    if isomarch::movie::check(&args.output, None)?.is_none() {
        bail!("-o {}: a movie is .mp4, .webm or .gif", args.output.display());
    }
    let frames = isomarch::batch::frames_on_disk(&args.pattern, args.frames)?;
    let read = |path: &std::path::Path| -> Result<image::RgbImage> {
        let image = image::open(path).with_context(|| format!("reading {}", path.display()))?;
        if image.color().has_alpha() {
            bail!("{}: has an alpha channel (a transparent background), which a movie cannot keep", path.display());
        }
        Ok(image.to_rgb8())
    };
    let first = read(&frames[0].1)?;
    let size = first.dimensions();
    let spec = MovieSpec::new(&args.output, args.fps, args.quality, size)?.context("a movie's extension")?;
    let stop = super::stop_flag("before the next frame")?;
    let mut movie = MovieWriter::create(&spec, size)?;
    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} frames ({per_sec}, {eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message("encoding");
    let mut image = Some(first);
    for (_, path) in &frames {
        if stop.load(Ordering::SeqCst) {
            bar.finish_and_clear();
            drop(movie);
            eprintln!("interrupted: {} not written", spec.path.display());
            return Err(Interrupted.into());
        }
        let frame = match image.take() {
            Some(first) => first,
            None => read(path)?,
        };
        if frame.dimensions() != size {
            bail!("{}: {}x{}, where the first frame is {}x{}", path.display(), frame.width(), frame.height(), size.0, size.1);
        }
        movie.push(&frame)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    movie.finish()?;
    eprintln!("{}: {} at {} fps ({}x{})", spec.path.display(), count(frames.len() as u64, "frame"), spec.fps, size.0, size.1);
    Ok(())
}
