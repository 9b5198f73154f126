//! Step-count heatmaps with a legend (the paper's Figure 12 style).

use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage};

/// Rows below a heatmap for its colour bar and scale.
pub const LEGEND_HEIGHT: u32 = 26;
const BAR_TOP: u32 = 4;
const BAR_HEIGHT: u32 = 8;
const TEXT_TOP: u32 = 15;

fn color(fraction: f64) -> Rgb<u8> {
    let c = colorous::VIRIDIS.eval_continuous(fraction.clamp(0.0, 1.0));
    Rgb([c.r, c.g, c.b])
}

/// Draws `text` with an 8x8 bitmap font, left edge at `x`.
fn draw_text(img: &mut RgbImage, x: i64, y: u32, text: &str) {
    for (i, ch) in text.chars().enumerate() {
        let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                let px = x + 8 * i as i64 + col;
                let py = y + row as u32;
                if bits >> col & 1 == 1 && px >= 0 && (px as u32) < img.width() && py < img.height() {
                    img.put_pixel(px as u32, py, Rgb([235, 235, 235]));
                }
            }
        }
    }
}

/// Steps per pixel mapped through viridis on `[0, steps_max]` (values above
/// clamp to the top colour), with a colour bar and its scale underneath.
/// Without `steps_max` the scale is the image's own maximum.
pub fn heatmap_image(width: u32, height: u32, steps: &[u32], steps_max: Option<u32>) -> RgbImage {
    let max = steps_max.unwrap_or_else(|| steps.iter().copied().max().unwrap_or(1)).max(1);
    let mut img = RgbImage::from_pixel(width, height + LEGEND_HEIGHT, Rgb([20, 20, 24]));
    for y in 0..height {
        for x in 0..width {
            let s = steps[(y * width + x) as usize];
            img.put_pixel(x, y, color(f64::from(s) / f64::from(max)));
        }
    }
    let top = format!("{}{max}", if steps_max.is_some() { ">=" } else { "" });
    draw_color_bar(&mut img, height, color, "0", &top, "steps");
    img
}

/// Draws a colour bar in the `LEGEND_HEIGHT` rows from `top` down: the
/// colours of `color` on [0, 1] left to right, `low` under its left end,
/// `high` under its right end and `label` between them where it fits.
pub fn draw_color_bar(img: &mut RgbImage, top: u32, color: impl Fn(f64) -> Rgb<u8>, low: &str, high: &str, label: &str) {
    let width = img.width();
    let margin = 2u32.min(width / 4);
    let bar = width.saturating_sub(2 * margin).max(1);
    for x in 0..bar {
        let c = color(f64::from(x) / f64::from(bar.saturating_sub(1).max(1)));
        for y in 0..BAR_HEIGHT {
            img.put_pixel(margin + x, top + BAR_TOP + y, c);
        }
    }
    draw_text(img, i64::from(margin), top + TEXT_TOP, low);
    let right = i64::from(margin + bar) - 8 * high.len() as i64;
    draw_text(img, right, top + TEXT_TOP, high);
    let mid = i64::from(width / 2) - 4 * label.len() as i64;
    if mid > i64::from(margin) + 8 * low.len() as i64 + 4 && mid + 8 * label.len() as i64 + 4 < right {
        draw_text(img, mid, top + TEXT_TOP, label);
    }
}

/// A colour key under an image: the colours along its bar, the values at
/// its ends and what they are (`--legend`).
#[derive(Clone, Debug, PartialEq)]
pub struct ColorBar {
    /// The bar's colours, sRGB, from its low end to its high end, sampled
    /// evenly (nearest sample drawn).
    pub colors: Vec<[u8; 3]>,
    pub low: String,
    pub high: String,
    pub label: String,
}

/// `img` with `bar` drawn in `LEGEND_HEIGHT` rows added under it.
pub fn with_color_bar(img: &RgbImage, bar: &ColorBar) -> RgbImage {
    let mut out = RgbImage::from_pixel(img.width(), img.height() + LEGEND_HEIGHT, Rgb([20, 20, 24]));
    image::imageops::replace(&mut out, img, 0, 0);
    let n = bar.colors.len().max(1);
    let color = |f: f64| Rgb(bar.colors.get(((f * (n - 1) as f64).round() as usize).min(n - 1)).copied().unwrap_or([0, 0, 0]));
    draw_color_bar(&mut out, img.height(), color, &bar.low, &bar.high, &bar.label);
    out
}

/// Step heatmaps of several methods side by side on one shared scale, each
/// titled with its name and mean steps (the paper's Figure 10 layout).
/// `panels` holds `(title, steps)` for `width` x `height` images.
pub fn heatmap_grid(width: u32, height: u32, panels: &[(String, Vec<u32>)], steps_max: Option<u32>) -> RgbImage {
    let max = steps_max.unwrap_or_else(|| panels.iter().flat_map(|(_, s)| s.iter().copied()).max().unwrap_or(1));
    const TITLE: u32 = 12;
    let gap = 4;
    let cell_w = width + gap;
    let mut grid = RgbImage::from_pixel(cell_w * panels.len() as u32, height + LEGEND_HEIGHT + TITLE, Rgb([20, 20, 24]));
    for (i, (title, steps)) in panels.iter().enumerate() {
        let panel = heatmap_image(width, height, steps, Some(max));
        let x0 = i as u32 * cell_w;
        image::imageops::replace(&mut grid, &panel, i64::from(x0), i64::from(TITLE));
        let mean = steps.iter().map(|&s| f64::from(s)).sum::<f64>() / steps.len().max(1) as f64;
        draw_text(&mut grid, i64::from(x0) + 2, 2, &format!("{title} {mean:.1}"));
    }
    grid
}
