//! What the plots of `tradeoff` and `scaling` share: the font, and drawing
//! one chart into a PNG and an SVG that appear whole or not at all.

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context as _, Result, anyhow};
use plotters::prelude::{BitMapBackend, SVGBackend};

/// Where plots find a font: Debian's DejaVu Sans (package fonts-dejavu-core).
pub const FONT: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";

/// Registers [`FONT`] as plotters' "sans-serif", once per process.
pub fn register_font() -> Result<()> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            let font = std::fs::read(FONT).map_err(|e| format!("reading the plot font {FONT} (Debian: apt-get install fonts-dejavu-core): {e}"))?;
            plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, Box::leak(font.into_boxed_slice()))
                .map_err(|_| format!("{FONT} is not a usable font"))
        })
        .clone()
        .map_err(anyhow::Error::msg)
}

/// Draws one chart of `size` pixels twice, with `draw_png` into `png` and
/// with `draw_svg` into `svg`: each is drawn to a temporary name in the
/// same folder and renamed into place, and nothing is left behind on
/// failure. The bitmap is drawn into memory and encoded with `image` (the
/// encoder every other PNG here uses; plotters' own would build a second
/// version of `image`).
pub fn write_png_svg(
    png: &Path,
    svg: &Path,
    size: (u32, u32),
    draw_png: impl FnOnce(BitMapBackend) -> Result<()>,
    draw_svg: impl FnOnce(SVGBackend) -> Result<()>,
) -> Result<()> {
    register_font()?;
    let temp = |path: &Path, ext: &str| -> Result<std::path::PathBuf> {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let stem = path.file_stem().ok_or_else(|| anyhow!("{} has no file name", path.display()))?;
        Ok(dir.join(format!(".{}.{}.{ext}", stem.to_string_lossy(), std::process::id())))
    };
    let (tmp_png, tmp_svg) = (temp(png, "png")?, temp(svg, "svg")?);
    let mut pixels = vec![0u8; size.0 as usize * size.1 as usize * 3];
    let drawn = draw_png(BitMapBackend::with_buffer(&mut pixels, size))
        .and_then(|()| {
            image::save_buffer_with_format(&tmp_png, &pixels, size.0, size.1, image::ExtendedColorType::Rgb8, image::ImageFormat::Png)
                .with_context(|| format!("writing {}", tmp_png.display()))
        })
        .and_then(|()| draw_svg(SVGBackend::new(&tmp_svg, size)))
        .and_then(|()| std::fs::rename(&tmp_png, png).with_context(|| format!("writing {}", png.display())))
        .and_then(|()| std::fs::rename(&tmp_svg, svg).with_context(|| format!("writing {}", svg.display())));
    if drawn.is_err() {
        let _ = std::fs::remove_file(&tmp_png);
        let _ = std::fs::remove_file(&tmp_svg);
    }
    drawn
}

/// Plotters' errors as anyhow's.
pub fn plot_err<E: std::fmt::Display>(e: E) -> anyhow::Error {
    anyhow!("plotting: {e}")
}

/// A log axis over whole decades: from the decade at or below `min` to the
/// one at or above `max` (each widened by `pad` first, so that no point
/// sits on the frame), and every decade in it, for key points that are
/// each labelled.
pub fn decade_axis(min: f64, max: f64, pad: f64) -> (std::ops::Range<f64>, Vec<f64>) {
    // The ends are decades themselves, computed alike, so both are key points.
    let (k0, k1) = ((min / pad).log10().floor() as i32, (max * pad).log10().ceil() as i32);
    let decades: Vec<f64> = (k0..=k1.max(k0 + 1)).map(|k| 10f64.powi(k)).collect();
    (decades[0]..decades[decades.len() - 1], decades)
}

/// The 2 to 9 multiples of each decade of `decades` inside `range`: light
/// grid lines, unlabelled.
pub fn decade_minors(range: &std::ops::Range<f64>, decades: &[f64]) -> Vec<f64> {
    decades.iter().flat_map(|&d| (2..10).map(move |m| d * f64::from(m))).filter(|v| range.contains(v)).collect()
}

/// How a legend entry is drawn.
#[derive(Clone, Copy, Debug)]
pub enum LegendMark {
    /// A filled dot.
    Dot(plotters::style::RGBAColor),
    /// A line with a ringed dot.
    RingedLine(plotters::style::RGBAColor),
}

/// Draws a legend in its own `area` (beside the chart, so that it covers
/// no data): one row per entry, from the top.
pub fn draw_legend<DB: plotters::prelude::DrawingBackend>(
    area: &plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    entries: &[(String, LegendMark)],
) -> Result<()> {
    use plotters::prelude::*;
    let top = 60;
    for (i, (label, mark)) in entries.iter().enumerate() {
        let y = top + 24 * i as i32;
        match *mark {
            LegendMark::Dot(c) => area.draw(&Circle::new((22, y), 5, c.filled())).map_err(plot_err)?,
            LegendMark::RingedLine(c) => {
                area.draw(&PathElement::new(vec![(10, y), (34, y)], c.stroke_width(2))).map_err(plot_err)?;
                area.draw(&Circle::new((22, y), 7, c.stroke_width(1))).map_err(plot_err)?;
            }
        }
        area.draw(&Text::new(label.clone(), (44, y - 8), ("sans-serif", 15).into_font())).map_err(plot_err)?;
    }
    Ok(())
}

/// A whole number with thousands separators: 100000 -> "100,000".
pub fn thousands(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// A decade's label: 1e-3 ... 1e-1 below 1, then 1, 10, 100, 1,000 ...
pub fn decade_label(v: f64) -> String {
    let k = v.log10().round() as i32;
    if k < 0 { format!("1e{k}") } else { thousands(10usize.pow(k as u32)) }
}
