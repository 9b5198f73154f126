//! Images and statistics from march results: shaded PNG, step heatmap with a
//! legend, OpenEXR AOVs, JSON statistics, and what plots share ([`plot`]).
//! Files are written atomically.

mod heatmap;
pub mod plot;

use std::io::Cursor;
use std::path::Path;

use anyhow::{Context as _, Result, bail};
use serde::Serialize;

pub use heatmap::{LEGEND_HEIGHT, heatmap_grid, heatmap_image};

use crate::layout::{FLAG_HIT, FLAG_OUT_OF_STEPS, GpuResult};

/// Writes `bytes` to `path` through a temporary file in the same folder and a
/// rename, so a reader never sees a half-written file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let name = path.file_name().with_context(|| format!("{} has no file name", path.display()))?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = std::fs::write(&tmp, bytes)
        .and_then(|()| std::fs::rename(&tmp, path))
        .with_context(|| format!("writing {}", path.display()));
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
    /// Row-major, top row first.
    pub pixels: Vec<GpuResult>,
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
        Frame { width, height, pixels }
    }

    /// The shaded image, linear colour encoded as sRGB.
    pub fn shaded(&self) -> image::RgbImage {
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            let c = self.pixels[(y * self.width + x) as usize].color;
            image::Rgb([srgb(c[0]), srgb(c[1]), srgb(c[2])])
        })
    }

    pub fn steps(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.counts[0]).collect()
    }
}

/// Linear [0, 1] to 8-bit sRGB.
pub fn srgb(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Encodes an image as PNG bytes.
pub fn png_bytes(img: &image::RgbImage) -> Result<Vec<u8>> {
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
}

/// A 32-bit float OpenEXR file with the chosen AOVs.
pub fn exr_bytes(frame: &Frame, aovs: &[Aov]) -> Result<Vec<u8>> {
    use exr::prelude::*;
    if aovs.is_empty() {
        bail!("no AOV chosen");
    }
    let channel = |name: &str, f: &dyn Fn(&GpuResult) -> f32| {
        AnyChannel::new(name, FlatSamples::F32(frame.pixels.iter().map(f).collect()))
    };
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for aov in aovs {
        match aov {
            Aov::Depth => channels.push(channel("Z", &|p| if p.counts[3] & FLAG_HIT != 0 { p.hit[3] } else { f32::INFINITY })),
            Aov::Steps => channels.push(channel("steps", &|p| p.counts[0] as f32)),
            Aov::Normal => {
                for (i, axis) in ["X", "Y", "Z"].iter().enumerate() {
                    channels.push(channel(&format!("normal.{axis}"), &|p| p.hit[i]));
                }
            }
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
}

impl MarchStats {
    /// Statistics of `results` (callers leave out padding rays).
    pub fn of<'a>(results: impl IntoIterator<Item = &'a GpuResult>, gpu_ns: Option<f64>) -> MarchStats {
        let mut s = MarchStats::default();
        let (mut hits, mut steps, mut evals, mut refine, mut oos) = (0u64, 0u64, 0u64, 0u64, 0u64);
        for r in results {
            s.rays += 1;
            steps += u64::from(r.counts[0]);
            evals += u64::from(r.counts[1]);
            refine += u64::from(r.counts[2]);
            hits += u64::from(r.counts[3] & FLAG_HIT != 0);
            oos += u64::from(r.counts[3] & FLAG_OUT_OF_STEPS != 0);
            s.max_steps_taken = s.max_steps_taken.max(r.counts[0]);
        }
        let n = s.rays.max(1) as f64;
        s.hit_rate = hits as f64 / n;
        s.steps_per_ray = steps as f64 / n;
        s.evals_per_ray = evals as f64 / n;
        s.refine_per_ray = refine as f64 / n;
        s.out_of_steps_rate = oos as f64 / n;
        s.gpu_ms = gpu_ns.map(|ns| ns * 1e-6);
        s.ns_per_ray = gpu_ns.map(|ns| ns / n);
        s
    }
}
