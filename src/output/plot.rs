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
/// failure.
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
        // The bitmap backend picks its format from the extension.
        Ok(dir.join(format!(".{}.{}.{ext}", stem.to_string_lossy(), std::process::id())))
    };
    let (tmp_png, tmp_svg) = (temp(png, "png")?, temp(svg, "svg")?);
    let drawn = draw_png(BitMapBackend::new(&tmp_png, size))
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
