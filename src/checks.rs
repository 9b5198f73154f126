//! The checks of the values a user gives, each written once: the command
//! line (src/cli/) and the Python package (python/src/lib.rs) call these,
//! so a value is refused with the same one-line message wherever it comes
//! from. Messages name the command-line flag, which the Python docs map to
//! their keyword arguments.

use std::time::Duration;

use anyhow::{Context as _, Result, bail};

use crate::method::{Method, parse_list};

/// `--samples`: rays per pixel.
pub use crate::render::offscreen::check_samples as samples;

/// The largest image side (`--size`), in pixels: the scene file's.
pub use crate::scene::MAX_SIDE;

/// `--size` given as `WxH`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("expected WxH such as 256x256, got {s:?}"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&v| (1..=MAX_SIDE).contains(&v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("expected WxH with each side in 1..={MAX_SIDE}, got {s:?}")),
    }
}

/// An image size given as two numbers (Python's `width`, `height`).
pub fn size(width: u32, height: u32) -> Result<(u32, u32)> {
    if !(1..=MAX_SIDE).contains(&width) || !(1..=MAX_SIDE).contains(&height) {
        bail!("expected a size with each side in 1..={MAX_SIDE}, got {width}x{height}");
    }
    Ok((width, height))
}

/// `--timeout`: how long the GPU may take, in seconds.
pub fn timeout(seconds: f64) -> Result<Duration> {
    if !(seconds.is_finite() && seconds > 0.0) {
        bail!("--timeout must be a positive number of seconds, got {seconds}");
    }
    Ok(Duration::from_secs_f64(seconds))
}

/// `--fps` of `render --frames` and `view`.
pub fn fps(fps: f64) -> Result<f64> {
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps must be positive, got {fps}");
    }
    Ok(fps)
}

/// `--time` of `render` and `view`, and Python's `time`.
pub fn time(time: f64) -> Result<f64> {
    if !time.is_finite() {
        bail!("--time must be a finite number of seconds, got {time}");
    }
    Ok(time)
}

/// `--rays` of `tradeoff`, `bench` and `scaling`.
pub fn rays(rays: usize) -> Result<usize> {
    if rays == 0 {
        bail!("--rays must be at least 1");
    }
    Ok(rays)
}

/// `--methods` of `tradeoff`, `bench` and `scaling`: a comma-separated list.
pub fn methods(list: &str) -> Result<Vec<Method>> {
    parse_list(list).map_err(anyhow::Error::msg).context("--methods")
}

/// One marcher by name (`--method`, Python's `method`).
pub fn method(name: &str) -> Result<Method> {
    name.parse::<Method>().map_err(|e| anyhow::anyhow!("invalid method {name:?}: {e}"))
}

/// `--min-step`, in scene units.
pub fn min_step(s: f64) -> Result<f64> {
    if !(s.is_finite() && s > 0.0) {
        bail!("--min-step must be positive and finite, got {s}");
    }
    Ok(s)
}

/// `--max-steps`: the step budget of a ray.
pub fn max_steps(n: u32) -> Result<u32> {
    if n == 0 {
        bail!("--max-steps must be at least 1");
    }
    Ok(n)
}

/// `--growth`: Algorithm 1's interval growth k.
pub fn growth(k: f64) -> Result<f64> {
    if !(k.is_finite() && k >= 1.0) {
        bail!("--growth must be a finite number >= 1, got {k}");
    }
    Ok(k)
}

/// `--ao`: occlusion rays per shaded hit.
pub fn ao_samples(n: u32) -> Result<u32> {
    let most = crate::scene::MAX_AO_SAMPLES;
    if !(1..=most).contains(&n) {
        bail!("--ao must be 1 to {most} rays per hit, got {n}");
    }
    Ok(n)
}

/// `--ao-distance` (or the distance it falls back to): how far occlusion
/// rays look.
pub fn ao_distance(d: f64) -> Result<f64> {
    if !(d.is_finite() && d > 0.0) {
        bail!("--ao-distance must be positive, got {d}");
    }
    Ok(d)
}

/// `--zoom`: how many times closer the eye moves.
pub fn zoom(f: f64) -> Result<f64> {
    if !(f.is_finite() && f > 0.0) {
        bail!("--zoom must be a positive factor, got {f}");
    }
    Ok(f)
}

/// `--fov`: the vertical field of view, degrees.
pub fn fov(deg: f64) -> Result<f64> {
    if !(deg.is_finite() && deg > 0.0 && deg < 180.0) {
        bail!("--fov must be between 0 and 180 degrees, got {deg}");
    }
    Ok(deg)
}

/// `--ortho HEIGHT`: the view's height in scene units.
pub fn ortho(height: f64) -> Result<f64> {
    if !(height.is_finite() && height > 0.0) {
        bail!("--ortho takes the view's height in scene units, a positive number, got {height}");
    }
    Ok(height)
}

/// `--clip near:D,far:D` (either or both): distances from the eye's plane.
pub fn clip(text: &str) -> Result<(Option<f64>, Option<f64>)> {
    let bad = || anyhow::anyhow!("--clip takes near:D, far:D or near:D,far:D (distances along the view), got {text:?}");
    let (mut near, mut far) = (None, None);
    for part in text.split(',') {
        let (key, value) = part.split_once(':').ok_or_else(bad)?;
        let d: f64 = value.trim().parse().ok().filter(|d: &f64| d.is_finite()).ok_or_else(bad)?;
        match key.trim() {
            "near" if near.is_none() => near = Some(d),
            "far" if far.is_none() => far = Some(d),
            _ => return Err(bad()),
        }
    }
    if let (Some(n), Some(f)) = (near, far)
        && n >= f
    {
        bail!("--clip: near ({n}) must be closer than far ({f})");
    }
    Ok((near, far))
}

/// `--background`: a CSS colour name (`white`, `black`, `navy`), `#rrggbb`
/// (both sRGB, as published) or three linear RGB numbers `r,g,b` in [0, 1];
/// linear RGB, as the scene's `background` holds it.
pub fn background(text: &str) -> Result<[f64; 3]> {
    color("--background", text)
}

/// A colour given to `flag`: a CSS name, `#rrggbb` (sRGB) or linear
/// `r,g,b` in [0, 1]; linear RGB.
pub fn color(flag: &str, text: &str) -> Result<[f64; 3]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() == 3
        && let Ok(v) = parts.iter().map(|p| p.parse::<f64>()).collect::<Result<Vec<f64>, _>>()
    {
        if v.iter().any(|c| !(c.is_finite() && (0.0..=1.0).contains(c))) {
            bail!("{flag} r,g,b takes linear values in [0, 1], got {text:?}");
        }
        return Ok([v[0], v[1], v[2]]);
    }
    let Ok(c) = csscolorparser::parse(text) else {
        bail!("{flag} {text:?} is no colour: give a name (white, black, navy), #rrggbb, or linear r,g,b in [0, 1]");
    };
    Ok([c.r, c.g, c.b].map(|s| crate::output::linear_of_srgb(f64::from(s))))
}

/// `--preview-ms` of `view`.
pub fn preview(ms: f64) -> Result<Duration> {
    if !(ms.is_finite() && ms > 0.0) {
        bail!("--preview-ms must be positive, got {ms}");
    }
    Ok(Duration::from_secs_f64(ms / 1e3))
}

#[cfg(test)]
mod tests {
    #[test]
    fn sizes_parse_within_their_bounds() {
        assert_eq!(super::parse_size("64x32"), Ok((64, 32)));
        assert_eq!(super::parse_size("16384X1"), Ok((16384, 1)));
        for bad in ["0x4", "4x16385", "4", "ax4", "4x-1"] {
            assert!(super::parse_size(bad).is_err(), "{bad}");
        }
        assert!(super::size(0, 4).is_err() && super::size(4, 16385).is_err());
        assert_eq!(super::size(16384, 1).unwrap(), (16384, 1));
    }

    #[test]
    fn scalars_refuse_what_cannot_run() {
        assert!(super::timeout(0.0).is_err() && super::timeout(f64::NAN).is_err() && super::timeout(f64::INFINITY).is_err());
        assert!(super::fps(-1.0).is_err() && super::time(f64::NAN).is_err() && super::rays(0).is_err());
        assert!(super::min_step(0.0).is_err() && super::max_steps(0).is_err() && super::growth(0.99).is_err());
        assert!(super::ao_samples(0).is_err() && super::ao_samples(1025).is_err() && super::ao_distance(0.0).is_err());
        assert!(super::preview(0.0).is_err() && super::methods(" , ").is_err() && super::method("spehre").is_err());
        assert_eq!(super::growth(1.0).unwrap(), 1.0);
        assert_eq!(super::ao_samples(1024).unwrap(), 1024);
    }
}
