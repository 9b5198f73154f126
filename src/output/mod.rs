//! Images and statistics from march results: shaded PNG, step heatmap with a
//! legend, OpenEXR AOVs, JSON statistics, and what plots share ([`plot`]).
//! Files are written atomically.

mod heatmap;
pub mod plot;

use std::io::Cursor;
use std::path::Path;

use anyhow::{Context as _, Result, bail};
use serde::Serialize;

pub use heatmap::{ColorBar, LEGEND_HEIGHT, heatmap_grid, heatmap_image, with_color_bar};

use crate::layout::{FLAG_HIT, FLAG_OUT_OF_STEPS, GpuResult};

/// Writes `bytes` to `path` through a temporary file in the same folder and a
/// rename, so a reader never sees a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let name = path.file_name().with_context(|| format!("{} has no file name", path.display()))?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path)).with_context(|| format!("writing {}", path.display()));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// One rendered image's per-pixel results.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first. Empty where the frame was made on the
    /// GPU and only its image read back (`encoded`).
    pub pixels: Vec<GpuResult>,
    /// The 8-bit sRGB image made on the GPU (render::frame), RGBA
    /// row-major, in place of the pixels' results.
    pub encoded: Option<Vec<u8>>,
}

impl Frame {
    /// Scatters tile-ordered results to pixels (`pixel_of[i]` is ray i's
    /// pixel; `None` marks padding rays).
    pub fn from_results(width: u32, height: u32, results: &[GpuResult], pixel_of: &[Option<u32>]) -> Frame {
        let mut pixels = vec![GpuResult::default(); (width * height) as usize];
        for (r, p) in results.iter().zip(pixel_of) {
            if let Some(p) = p {
                pixels[*p as usize] = *r;
            }
        }
        Frame { width, height, pixels, encoded: None }
    }

    /// A frame made on the GPU: its 8-bit sRGB image alone (opaque).
    pub fn encoded(width: u32, height: u32, rgba: Vec<u8>) -> Frame {
        Frame { width, height, pixels: Vec::new(), encoded: Some(rgba) }
    }

    /// The shaded image, linear colour encoded as sRGB.
    pub fn shaded(&self) -> image::RgbImage {
        if let Some(rgba) = &self.encoded {
            return image::RgbImage::from_fn(self.width, self.height, |x, y| {
                let i = 4 * (y * self.width + x) as usize;
                image::Rgb([rgba[i], rgba[i + 1], rgba[i + 2]])
            });
        }
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let c = self.pixels[(y * self.width + x) as usize].color;
            image::Rgb([srgb(c[0]), srgb(c[1]), srgb(c[2])])
        })
    }

    /// The shaded image over a transparent background: alpha the pixel's
    /// coverage (the fraction of its samples that hit a surface, which
    /// `march_image` leaves in `color[3]`), the colour what the hits saw
    /// (the background's share taken out of the average), sRGB, not
    /// premultiplied.
    pub fn shaded_rgba(&self, background: [f32; 3]) -> image::RgbaImage {
        image::RgbaImage::from_fn(self.width, self.height, |x, y| {
            let c = self.pixels[(y * self.width + x) as usize].color;
            let a = c[3].clamp(0.0, 1.0);
            if a <= 0.0 {
                return image::Rgba([0, 0, 0, 0]);
            }
            let own = |k: usize| srgb((c[k] - (1.0 - a) * background[k]) / a);
            image::Rgba([own(0), own(1), own(2), (a * 255.0).round() as u8])
        })
    }

    pub fn steps(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.counts[0]).collect()
    }
}

/// An sRGB component in [0, 1] in linear light ([`srgb`]'s inverse,
/// before its 8-bit rounding).
pub fn linear_of_srgb(s: f64) -> f64 {
    if s <= 0.04045 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) }
}

/// Linear [0, 1] to 8-bit sRGB.
pub fn srgb(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// A file format, chosen by an output path's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    Png,
    /// OpenEXR, 32-bit float: the linear image (and AOVs).
    Exr,
    Json,
    Csv,
    Ron,
}

impl FileFormat {
    pub const IMAGE: &[FileFormat] = &[FileFormat::Png, FileFormat::Exr];

    pub fn extension(self) -> &'static str {
        match self {
            FileFormat::Png => "png",
            FileFormat::Exr => "exr",
            FileFormat::Json => "json",
            FileFormat::Csv => "csv",
            FileFormat::Ron => "ron",
        }
    }

    /// The format of `path`, given to `flag`, from its extension (any
    /// case), which must be one of `allowed`; otherwise a one-line error
    /// naming the flag, the path and the extensions allowed. Commands call
    /// this for every output before any work.
    pub fn of(flag: &str, path: &Path, allowed: &[FileFormat]) -> Result<FileFormat> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        if let Some(f) = allowed.iter().find(|f| ext.as_deref() == Some(f.extension())) {
            if path.is_dir() {
                bail!("{flag} {}: is a folder, not a file: give a file's name (a path inside it, or another)", path.display());
            }
            return Ok(*f);
        }
        let names: Vec<String> = allowed.iter().map(|f| format!(".{}", f.extension())).collect();
        let names = match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
            None => String::new(),
        };
        let got = ext.map_or("a file without an extension".to_string(), |e| format!("a .{e} file"));
        bail!("{flag} {}: cannot write {got}: the format follows the extension, which must be {names}", path.display())
    }
}

/// How the shaded image is written besides its pixels.
#[derive(Clone, Copy, Debug, Default)]
pub struct Look<'a> {
    /// A colour key drawn under it (PNG).
    pub legend: Option<&'a ColorBar>,
    /// A transparent background: the scene's background colour, taken out
    /// of the pixels (RGBA PNG; EXR with A, premultiplied as EXR is).
    pub transparent: Option<[f32; 3]>,
}

/// Encodes the frame's shaded image: 8-bit sRGB PNG, or the linear colour
/// as 32-bit float OpenEXR (channels R, G, B) with any `aovs` beside it,
/// as `look` says.
pub fn shaded_bytes(frame: &Frame, format: FileFormat, aovs: &[Aov], look: Look) -> Result<Vec<u8>> {
    match format {
        FileFormat::Png => match look.transparent {
            Some(_) if look.legend.is_some() => bail!("--legend and --transparent-background cannot be drawn together"),
            Some(bg) => png_bytes(&frame.shaded_rgba(bg)),
            None => png_bytes(&shaded_rgb(frame, look)?),
        },
        FileFormat::Exr => exr_layers(frame, true, aovs, look.transparent),
        other => bail!("an image cannot be written as .{}", other.extension()),
    }
}

/// The frame's shaded image over its background, 8-bit sRGB, with the
/// legend under it where `look` has one: a PNG's pixels, and a movie's
/// frame. A transparent background has no RGB image.
pub fn shaded_rgb(frame: &Frame, look: Look) -> Result<image::RgbImage> {
    if look.transparent.is_some() {
        bail!("a transparent background needs an alpha channel: PNG or EXR");
    }
    Ok(match look.legend {
        Some(bar) => with_color_bar(&frame.shaded(), bar),
        None => frame.shaded(),
    })
}

/// Encodes an image (RGB, or RGBA for a transparent background) as PNG bytes.
pub fn png_bytes<P>(img: &image::ImageBuffer<P, Vec<u8>>) -> Result<Vec<u8>>
where
    P: image::PixelWithColorType<Subpixel = u8>,
{
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).context("encoding PNG")?;
    Ok(out.into_inner())
}

/// Per-pixel outputs that `--aov` can write to OpenEXR.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Aov {
    /// Hit distance along the ray (channel Z; infinity where the ray misses).
    Depth,
    /// Marching steps (channel steps).
    Steps,
    /// Outward unit normal (channels normal.X, normal.Y, normal.Z; 0 on misses).
    Normal,
    /// Loop turns of the march: steps and refinement evaluations, one fold each (channel turns).
    Turns,
    /// List positions the march's folds visited, admitted or not (channel visits): where the time goes, pixel by pixel.
    Visits,
}

/// A 32-bit float OpenEXR file with the chosen AOVs.
pub fn exr_bytes(frame: &Frame, aovs: &[Aov]) -> Result<Vec<u8>> {
    if aovs.is_empty() {
        bail!("no AOV chosen");
    }
    exr_layers(frame, false, aovs, None)
}

/// A 32-bit float OpenEXR file: the linear shaded colour (R, G, B) if
/// `rgb`, then the AOVs.
fn exr_layers(frame: &Frame, rgb: bool, aovs: &[Aov], transparent: Option<[f32; 3]>) -> Result<Vec<u8>> {
    use exr::prelude::*;
    let channel = |name: &str, f: &dyn Fn(&GpuResult) -> f32| AnyChannel::new(name, FlatSamples::F32(frame.pixels.iter().map(f).collect()));
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    if rgb {
        match transparent {
            None => {
                for (i, name) in ["R", "G", "B"].iter().enumerate() {
                    channels.push(channel(name, &|p| p.color[i]));
                }
            }
            // Premultiplied: what the hits add over nothing.
            Some(bg) => {
                for (i, name) in ["R", "G", "B"].iter().enumerate() {
                    channels.push(channel(name, &|p| p.color[i] - (1.0 - p.color[3]) * bg[i]));
                }
                channels.push(channel("A", &|p| p.color[3]));
            }
        }
    }
    for aov in aovs {
        match aov {
            Aov::Depth => channels.push(channel("Z", &|p| if p.counts[3] & FLAG_HIT != 0 { p.hit[3] } else { f32::INFINITY })),
            Aov::Steps => channels.push(channel("steps", &|p| p.counts[0] as f32)),
            Aov::Normal => {
                for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
                    channels.push(channel(&format!("normal.{axis}"), &|p| p.hit[i]));
                }
            }
            Aov::Turns => channels.push(channel("turns", &|p| p.crossings[2] as f32)),
            Aov::Visits => channels.push(channel("visits", &|p| p.crossings[1] as f32)),
        }
    }
    let layer = Layer::new(
        (frame.width as usize, frame.height as usize),
        LayerAttributes::named("isomarch"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let mut out = Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).context("encoding OpenEXR")?;
    Ok(out.into_inner())
}

/// Averages over a batch of march results (misses included, like the paper).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct MarchStats {
    pub rays: usize,
    pub hit_rate: f64,
    pub steps_per_ray: f64,
    pub evals_per_ray: f64,
    pub refine_per_ray: f64,
    /// Fraction of rays that ran out of steps.
    pub out_of_steps_rate: f64,
    pub max_steps_taken: u32,
    pub gpu_ms: Option<f64>,
    pub ns_per_ray: Option<f64>,
    /// Loop turns of the march per ray: steps, and evaluations of a
    /// crossing's refinement (one fold each).
    pub turns_per_ray: f64,
    /// List positions the folds visited per ray (entries of the spatial
    /// index's lists, or culled primitives), yielding an evaluation or not.
    pub visits_per_ray: f64,
    /// GPU time per kernel evaluation (`ns_per_ray / evals_per_ray`), the
    /// figure to hold against what the driver's arithmetic costs.
    pub ns_per_eval: Option<f64>,
    /// GPU time per loop turn.
    pub ns_per_turn: Option<f64>,
    /// The shadow and occlusion rays cast from the hits (`null` when none
    /// was cast): their steps apart from the camera rays' above, and their
    /// GPU time apart from `gpu_ms`.
    pub any_hit: Option<AnyHitStats>,
}

/// The shadow and occlusion rays of a frame (`render::light`), in `render
/// --stats` and the batch CSV.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AnyHitStats {
    pub shadow_rays: u64,
    pub shadow_steps_per_ray: f64,
    pub ao_rays: u64,
    pub ao_steps_per_ray: f64,
    /// GPU time of their march, apart from the camera rays' `gpu_ms`.
    pub gpu_ms: Option<f64>,
}

impl MarchStats {
    /// Statistics of `results` (callers leave out padding rays).
    pub fn of<'a>(results: impl IntoIterator<Item = &'a GpuResult>, gpu_ns: Option<f64>) -> MarchStats {
        let mut s = MarchStats::default();
        let (mut hits, mut steps, mut evals, mut refine, mut oos) = (0u64, 0u64, 0u64, 0u64, 0u64);
        let (mut visits, mut turns) = (0u64, 0u64);
        for r in results {
            s.rays += 1;
            steps += u64::from(r.counts[0]);
            evals += u64::from(r.counts[1]);
            refine += u64::from(r.counts[2]);
            hits += u64::from(r.counts[3] & FLAG_HIT != 0);
            oos += u64::from(r.counts[3] & FLAG_OUT_OF_STEPS != 0);
            s.max_steps_taken = s.max_steps_taken.max(r.counts[0]);
            visits += u64::from(r.crossings[1]);
            turns += u64::from(r.crossings[2]);
        }
        let n = s.rays.max(1) as f64;
        s.hit_rate = hits as f64 / n;
        s.steps_per_ray = steps as f64 / n;
        s.evals_per_ray = evals as f64 / n;
        s.refine_per_ray = refine as f64 / n;
        s.out_of_steps_rate = oos as f64 / n;
        s.gpu_ms = gpu_ns.map(|ns| ns * 1e-6);
        s.ns_per_ray = gpu_ns.map(|ns| ns / n);
        s.turns_per_ray = turns as f64 / n;
        s.visits_per_ray = visits as f64 / n;
        s.ns_per_eval = gpu_ns.filter(|_| evals > 0).map(|ns| ns / evals as f64);
        s.ns_per_turn = gpu_ns.filter(|_| turns > 0).map(|ns| ns / turns as f64);
        s
    }
}
