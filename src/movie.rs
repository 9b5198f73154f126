//! Movies: a batch's frames streamed, as they are rendered, to one movie
//! file. MP4 (H.264) and WebM (VP9) go through ffmpeg, the tool that
//! ChimeraX (`movie encode`), VMD's Movie Maker and PyMOL's
//! `movie.produce` hand their frames to: it is maintained, packaged by
//! every distribution, and its x264 and libvpx are the reference encoders
//! of both formats; no maintained pure-Rust encoder writes H.264. GIF is
//! written by the `image` crate (no external tool). A movie is written
//! under a temporary name beside it and renamed when whole, so a stopped
//! or failed batch leaves neither the movie nor the temporary file.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::Mutex;

use anyhow::{Context as _, Result, bail};

/// A movie's container and codec, from its file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// H.264 in MP4, 4:2:0 (what every player and browser plays).
    Mp4,
    /// VP9 in WebM, 4:2:0.
    Webm,
    /// Animated GIF: 256 colours a frame (the `image` crate's NeuQuant),
    /// looping.
    Gif,
}

impl Container {
    pub const ALL: [Container; 3] = [Container::Mp4, Container::Webm, Container::Gif];

    pub fn extension(self) -> &'static str {
        match self {
            Container::Mp4 => "mp4",
            Container::Webm => "webm",
            Container::Gif => "gif",
        }
    }

    /// The container of `path` by its extension (any case); `None` for a
    /// file that is not a movie.
    pub fn of(path: &Path) -> Option<Container> {
        let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
        Container::ALL.into_iter().find(|c| c.extension() == ext)
    }

    /// ffmpeg's encoder and muxer (`None` for GIF, written here).
    fn ffmpeg(self) -> Option<(&'static str, &'static str)> {
        match self {
            Container::Mp4 => Some(("libx264", "mp4")),
            Container::Webm => Some(("libvpx-vp9", "webm")),
            Container::Gif => None,
        }
    }

    /// The constant rate factor of `quality` for this codec (lower is
    /// better; `None` for GIF, whose loss is its palette).
    pub fn crf(self, quality: Quality) -> Option<u32> {
        let i = quality as usize;
        match self {
            // x264's scale (0 to 51); good is x264's own default, 23.
            Container::Mp4 => Some([12, 15, 18, 23, 26, 30, 35][i]),
            // libvpx-vp9's (0 to 63); good is 31, Google's advice for VP9
            // in constant quality below 720p lines being 32 to 34.
            Container::Webm => Some([15, 20, 25, 31, 36, 42, 50][i]),
            Container::Gif => None,
        }
    }
}

/// A movie's quality, named as ChimeraX's `movie encode quality` names it;
/// each codec maps it to its constant rate factor ([`Container::crf`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Quality {
    Highest,
    Higher,
    High,
    /// A good picture at a modest size (ChimeraX's default).
    #[default]
    Good,
    Medium,
    Fair,
    Low,
}

/// What a movie is: its file, container, frame rate and quality.
#[derive(Clone, Debug, PartialEq)]
pub struct MovieSpec {
    pub path: PathBuf,
    pub container: Container,
    pub fps: f64,
    pub quality: Quality,
}

/// The Debian package that has ffmpeg, named in the error where it is missing.
pub const FFMPEG_PACKAGE: &str = "ffmpeg";

impl MovieSpec {
    /// The movie of `path` when its extension is a movie's ([`check`]ed
    /// for frames of `size`); `None` for any other file.
    pub fn new(path: &Path, fps: f64, quality: Quality, size: (u32, u32)) -> Result<Option<MovieSpec>> {
        let Some(container) = check(path, Some(size))? else { return Ok(None) };
        // As the command line's --fps is checked (checks::fps, which this
        // module below the renderer cannot reach).
        if !(fps.is_finite() && fps > 0.0) {
            bail!("--fps must be positive, got {fps}");
        }
        Ok(Some(MovieSpec { path: path.to_path_buf(), container, fps, quality }))
    }
}

/// Checks that `path`, when its extension is a movie's, can be written
/// from frames of `size` (where already known): H.264 and VP9 in 4:2:0
/// need even sizes, GIF at most 65535 pixels a side, and MP4 and WebM
/// ffmpeg with the codec's encoder. Commands run it before any frame is
/// rendered (and before any input is read, where they can); each refusal
/// is one line, a missing ffmpeg's naming its Debian package.
pub fn check(path: &Path, size: Option<(u32, u32)>) -> Result<Option<Container>> {
    let Some(container) = Container::of(path) else { return Ok(None) };
    if path.is_dir() {
        bail!("-o {}: is a folder, not a file: give the movie's name", path.display());
    }
    match (container, size) {
        (Container::Gif, Some((width, height))) if width > u32::from(u16::MAX) || height > u32::from(u16::MAX) => {
            bail!("-o {}: a GIF is at most 65535 pixels wide and high; this one would be {width}x{height}", path.display());
        }
        (Container::Mp4 | Container::Webm, Some((width, height))) if width % 2 != 0 || height % 2 != 0 => bail!(
            "-o {}: {} in 4:2:0 needs an even width and height, and the frames are {width}x{height}: give an even --size (e.g. {}x{})",
            path.display(),
            container.codec_name(),
            width + width % 2,
            height + height % 2
        ),
        _ => {}
    }
    check_encoder(path, container)?;
    Ok(Some(container))
}

impl Container {
    fn codec_name(self) -> &'static str {
        match self {
            Container::Mp4 => "H.264",
            Container::Webm => "VP9",
            Container::Gif => "GIF",
        }
    }
}

/// ffmpeg runs and has `container`'s encoder; else one line naming the
/// Debian package.
fn check_encoder(path: &Path, container: Container) -> Result<()> {
    let Some((encoder, _)) = container.ffmpeg() else { return Ok(()) };
    let out = match Command::new("ffmpeg").args(["-hide_banner", "-encoders"]).stdin(Stdio::null()).stderr(Stdio::null()).output() {
        Ok(out) => out,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "-o {}: writing .{} needs ffmpeg, which is not installed (Debian: apt-get install {FFMPEG_PACKAGE}); or write .gif, or numbered PNGs (-o out/frame_####.png)",
            path.display(),
            container.extension()
        ),
        Err(e) => bail!("-o {}: running ffmpeg: {e}", path.display()),
    };
    let listed = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() || !listed.split_whitespace().any(|w| w == encoder) {
        bail!(
            "-o {}: this ffmpeg has no {encoder} encoder, which {} needs (Debian's {FFMPEG_PACKAGE} package has it)",
            path.display(),
            container.codec_name()
        );
    }
    Ok(())
}

/// The temporary files of movies being written and the encoders writing
/// them, for [`abandon_all`].
static LIVE: Mutex<Vec<(PathBuf, Option<u32>)>> = Mutex::new(Vec::new());

/// Stops every encoder this process started and removes the temporary
/// files of the movies not yet whole: what a second Ctrl-C runs before the
/// process leaves at once.
pub fn abandon_all() {
    let Ok(mut live) = LIVE.lock() else { return };
    for (tmp, pid) in live.drain(..) {
        if let Some(pid) = pid {
            // SAFETY: kill(2) on a child this process started and has not
            // reaped (it is reaped only after it leaves LIVE).
            unsafe { libc::kill(pid as i32, libc::SIGKILL) };
        }
        let _ = std::fs::remove_file(tmp);
    }
}

fn forget(tmp: &Path) {
    if let Ok(mut live) = LIVE.lock() {
        live.retain(|(p, _)| p != tmp);
    }
}

/// Where the frames go.
enum Encoder {
    /// ffmpeg reading raw RGB frames on its standard input; its standard
    /// error is gathered on a thread, for the message if it fails.
    Ffmpeg {
        child: Child,
        stdin: Option<ChildStdin>,
        stderr: Option<std::thread::JoinHandle<String>>,
    },
    Gif(Box<gif::Encoder<std::io::BufWriter<std::fs::File>>>),
}

/// A movie being written: frames in order ([`MovieWriter::push`]), then
/// [`MovieWriter::finish`], which renames it into place. Dropped unfinished
/// (an error, a stop), it stops the encoder and removes its temporary file.
pub struct MovieWriter {
    spec: MovieSpec,
    size: (u32, u32),
    tmp: PathBuf,
    encoder: Option<Encoder>,
    frames: u64,
}

impl MovieWriter {
    /// Starts the movie of frames `size` pixels large.
    pub fn create(spec: &MovieSpec, size: (u32, u32)) -> Result<MovieWriter> {
        let path = &spec.path;
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let name = path.file_name().with_context(|| format!("{} has no file name", path.display()))?;
        let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
        LIVE.lock().map_err(|_| anyhow::anyhow!("the movie registry's lock is poisoned"))?.push((tmp.clone(), None));
        // From here the writer owns the temporary file: dropped, it removes it.
        let mut writer = MovieWriter { spec: spec.clone(), size, tmp, encoder: None, frames: 0 };
        writer.encoder = Some(match spec.container.ffmpeg() {
            Some((codec, muxer)) => writer.spawn_ffmpeg(codec, muxer)?,
            None => {
                let file = std::fs::File::create(&writer.tmp).with_context(|| format!("creating {}", writer.tmp.display()))?;
                let (w, h) = (u16::try_from(size.0)?, u16::try_from(size.1)?);
                let mut gif = gif::Encoder::new(std::io::BufWriter::new(file), w, h, &[]).context("writing the GIF's header")?;
                gif.set_repeat(gif::Repeat::Infinite).context("writing the GIF's header")?;
                Encoder::Gif(Box::new(gif))
            }
        });
        Ok(writer)
    }

    /// ffmpeg's arguments for this movie: raw sRGB frames in, converted to
    /// Y'CbCr 4:2:0 with the BT.709 matrix in limited range and tagged so
    /// (sRGB's primaries are BT.709's, and players read the tags).
    fn ffmpeg_args(&self, codec: &str, muxer: &str) -> Vec<String> {
        let (w, h) = self.size;
        let crf = self.spec.container.crf(self.spec.quality).unwrap_or(23);
        let mut args: Vec<String> = [
            "-hide_banner",
            "-nostdin",
            "-nostats",
            "-loglevel",
            "error",
            "-y",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-video_size",
            &format!("{w}x{h}"),
            "-framerate",
            &format!("{}", self.spec.fps),
            "-i",
            "pipe:0",
            "-an",
            "-vf",
            "scale=out_color_matrix=bt709:out_range=tv,format=yuv420p",
            "-c:v",
            codec,
            "-crf",
            &crf.to_string(),
            "-colorspace",
            "bt709",
            "-color_primaries",
            "bt709",
            "-color_trc",
            "iec61966-2-1",
            "-color_range",
            "tv",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        match self.spec.container {
            // The index at the front, so that a browser plays while it loads.
            Container::Mp4 => args.extend(["-preset", "medium", "-movflags", "+faststart"].map(String::from)),
            // Constant quality: VP9's CRF applies only with no bitrate cap.
            Container::Webm => args.extend(["-b:v", "0", "-row-mt", "1"].map(String::from)),
            Container::Gif => {}
        }
        // Byte-for-byte the same movie from the same frames: no encoder
        // version or creation time written.
        args.extend(["-fflags", "+bitexact", "-flags:v", "+bitexact", "-f", muxer].map(String::from));
        args.push(self.tmp.to_string_lossy().into_owned());
        args
    }

    fn spawn_ffmpeg(&self, codec: &str, muxer: &str) -> Result<Encoder> {
        use std::os::unix::process::CommandExt as _;
        let mut child = Command::new("ffmpeg")
            .args(self.ffmpeg_args(codec, muxer))
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            // A process group of its own: a Ctrl-C at the terminal reaches
            // isomarch, which stops it, not ffmpeg, which would end the
            // movie early as if it were whole.
            .process_group(0)
            .spawn()
            .with_context(|| format!("starting ffmpeg (Debian: apt-get install {FFMPEG_PACKAGE})"))?;
        if let Ok(mut live) = LIVE.lock()
            && let Some(entry) = live.iter_mut().find(|(p, _)| *p == self.tmp)
        {
            entry.1 = Some(child.id());
        }
        let stdin = child.stdin.take();
        let stderr = child.stderr.take().map(|mut err| {
            std::thread::spawn(move || {
                let mut text = String::new();
                let _ = std::io::Read::read_to_string(&mut err, &mut text);
                text
            })
        });
        Ok(Encoder::Ffmpeg { child, stdin, stderr })
    }

    /// The frames pushed so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Appends a frame, which must be the movie's size.
    pub fn push(&mut self, frame: &image::RgbImage) -> Result<()> {
        if frame.dimensions() != self.size {
            bail!("a {}x{} frame in a {}x{} movie", frame.width(), frame.height(), self.size.0, self.size.1);
        }
        match self.encoder.as_mut() {
            Some(Encoder::Ffmpeg { stdin: Some(stdin), .. }) => {
                block_sigpipe();
                if let Err(e) = stdin.write_all(frame.as_raw()) {
                    // ffmpeg has gone: its own words say why.
                    let why = self.ffmpeg_failure();
                    bail!("writing frame {} of {} to ffmpeg: {}", self.frames, self.spec.path.display(), why.unwrap_or_else(|| e.to_string()));
                }
            }
            Some(Encoder::Gif(gif)) => {
                let (palette, indices) = gif_palette(frame);
                let frame = gif::Frame {
                    width: self.size.0 as u16,
                    height: self.size.1 as u16,
                    buffer: std::borrow::Cow::Owned(indices),
                    palette: Some(palette),
                    delay: gif_delay(self.spec.fps),
                    ..gif::Frame::default()
                };
                gif.write_frame(&frame).with_context(|| format!("writing frame {} of {}", self.frames, self.spec.path.display()))?;
            }
            _ => bail!("the movie {} is already closed", self.spec.path.display()),
        }
        self.frames += 1;
        Ok(())
    }

    /// Waits for ffmpeg to end (its input closed) and returns its error
    /// output's last line when it failed.
    fn ffmpeg_failure(&mut self) -> Option<String> {
        let Some(Encoder::Ffmpeg { child, stdin, stderr }) = self.encoder.as_mut() else { return None };
        drop(stdin.take());
        let status = child.wait().ok();
        let text = stderr.take().and_then(|h| h.join().ok()).unwrap_or_default();
        if status.is_some_and(|s| s.success()) {
            return None;
        }
        let last = text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message").trim().to_string();
        Some(format!("ffmpeg failed ({}): {last}", status.map_or("not waited for".to_string(), |s| s.to_string())))
    }

    /// Ends the movie: closes the encoder's input, waits for it, and
    /// renames the file into place. A movie of no frames is refused.
    pub fn finish(mut self) -> Result<PathBuf> {
        if self.frames == 0 {
            bail!("{}: no frame to write", self.spec.path.display());
        }
        match self.encoder.take() {
            Some(Encoder::Gif(gif)) => {
                let out = gif.into_inner().context("ending the GIF")?;
                out.into_inner().map_err(|e| e.into_error()).and_then(|f| f.sync_all()).with_context(|| format!("writing {}", self.tmp.display()))?;
            }
            Some(ffmpeg @ Encoder::Ffmpeg { .. }) => {
                self.encoder = Some(ffmpeg);
                if let Some(why) = self.ffmpeg_failure() {
                    bail!("writing {}: {why}", self.spec.path.display());
                }
                self.encoder = None;
            }
            None => bail!("the movie {} is already closed", self.spec.path.display()),
        }
        std::fs::rename(&self.tmp, &self.spec.path).with_context(|| format!("writing {}", self.spec.path.display()))?;
        forget(&self.tmp);
        Ok(self.spec.path.clone())
    }
}

impl Drop for MovieWriter {
    /// An unfinished movie: its encoder stopped, its temporary file removed.
    fn drop(&mut self) {
        if let Some(Encoder::Ffmpeg { mut child, stdin, stderr }) = self.encoder.take() {
            drop(stdin);
            let _ = child.kill();
            let _ = child.wait();
            drop(stderr.map(|h| h.join()));
        }
        let _ = std::fs::remove_file(&self.tmp);
        forget(&self.tmp);
    }
}

/// NeuQuant's sampling factor for GIF palettes: 1 learns from every pixel
/// (the slowest), 30 from one in 30; 10 is the gif crate's advice.
pub const GIF_SPEED: i32 = 10;

/// A GIF frame's palette and pixels: the frame's own colours where they
/// are at most 256, else 256 colours that NeuQuant learns from it; every
/// pixel takes the palette colour nearest to it (squared RGB distance,
/// the first of equals), found exactly.
fn gif_palette(frame: &image::RgbImage) -> (Vec<u8>, Vec<u8>) {
    let pixels = frame.as_raw();
    let mut colours: Vec<[u8; 3]> = pixels.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    colours.sort_unstable();
    colours.dedup();
    let palette: Vec<[u8; 3]> = if colours.len() <= 256 {
        colours
    } else {
        let rgba: Vec<u8> = pixels.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect();
        color_quant::NeuQuant::new(GIF_SPEED, 256, &rgba).color_map_rgb().chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
    };
    let mut memo = std::collections::HashMap::new();
    let indices = pixels
        .chunks_exact(3)
        .map(|c| {
            let c = [c[0], c[1], c[2]];
            *memo.entry(c).or_insert_with(|| nearest(&palette, c))
        })
        .collect();
    (palette.concat(), indices)
}

/// The index of the colour of `palette` nearest to `c` (squared RGB
/// distance; the first of equals).
pub fn nearest(palette: &[[u8; 3]], c: [u8; 3]) -> u8 {
    let d2 = |p: &[u8; 3]| (0..3).map(|i| (i32::from(p[i]) - i32::from(c[i])).pow(2)).sum::<i32>();
    palette.iter().enumerate().min_by_key(|(_, p)| d2(p)).map_or(0, |(i, _)| i as u8)
}

/// A GIF frame's delay at `fps`, in hundredths of a second (GIF's unit):
/// 25 fps (4) and 50 fps (2) are exact, others rounded to the nearest.
fn gif_delay(fps: f64) -> u16 {
    (100.0 / fps).round().clamp(1.0, f64::from(u16::MAX)) as u16
}

/// Writes to ffmpeg's closed input then fail with EPIPE on this thread
/// instead of raising SIGPIPE, which the binary leaves at its default
/// (ending the process, and with it the clean-up of the temporary file).
fn block_sigpipe() {
    // SAFETY: a signal mask of the calling thread only, from a set built
    // by sigemptyset/sigaddset.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, libc::SIGPIPE);
        libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containers_follow_the_extension() {
        assert_eq!(Container::of(Path::new("a/adk.MP4")), Some(Container::Mp4));
        assert_eq!(Container::of(Path::new("adk.webm")), Some(Container::Webm));
        assert_eq!(Container::of(Path::new("adk.gif")), Some(Container::Gif));
        assert_eq!(Container::of(Path::new("out/frame_####.png")), None);
        assert_eq!(Container::Mp4.crf(Quality::default()), Some(23));
    }

    #[test]
    fn gif_delays_are_hundredths() {
        assert_eq!(gif_delay(25.0), 4);
        assert_eq!(gif_delay(50.0), 2);
        assert_eq!(gif_delay(30.0), 3);
        assert_eq!(gif_delay(1000.0), 1);
    }

    #[test]
    fn gif_pixels_take_the_nearest_palette_colour() {
        // A few colours: the palette is the frame's own, every pixel exact.
        let few = image::RgbImage::from_fn(16, 16, |x, _| image::Rgb([(x * 16) as u8, 0, 0]));
        let (palette, indices) = gif_palette(&few);
        assert_eq!(palette.len(), 16 * 3);
        for (i, p) in few.pixels().enumerate() {
            let k = usize::from(indices[i]);
            assert_eq!(&palette[3 * k..3 * k + 3], &p.0);
        }
        // Many: 256 colours, each pixel its nearest.
        let many = image::RgbImage::from_fn(64, 64, |x, y| image::Rgb([(x * 4) as u8, (y * 4) as u8, ((x + y) * 2) as u8]));
        let (palette, indices) = gif_palette(&many);
        let palette: Vec<[u8; 3]> = palette.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert_eq!(palette.len(), 256);
        for (i, p) in many.pixels().enumerate() {
            assert_eq!(indices[i], nearest(&palette, p.0));
        }
    }
}
