//! Benchmark scenes made up on demand: `isomarch generate particles`.
//!
//! **Particles.** N blobs with centres uniform (seeded) in a cube centred on
//! the origin whose side is `SPACING · N^(1/3)`, so the number density
//! (one blob per `SPACING³`) stays the same whatever N: a sweep over N
//! changes the size of the scene, not what a ray meets per unit length. The
//! protocol rays (`isomarch bench`) cross the whole box, whose side grows as
//! N^(1/3), so their hit rate grows with N.
//!
//! - Compact blobs (the default): `Compact(radius: 1)`, iso 0.5, one blob
//!   per 1.5³ (a mean spacing of 1.5; 1.6 left the protocol's hit rate at
//!   N = 100 within a point of 50% on some seeds, 1.5 gives 53 to 54%). A
//!   lone blob's surface is a sphere of radius `sqrt(1 - 0.5^(1/3)) ≈
//!   0.454`; most blobs stand alone and close pairs merge.
//! - `--gaussian`: `Gaussian(r: 0.5, s: 2)` with the default weight
//!   `iso·e^2`, which puts a lone blob's surface at 0.5, next to the
//!   compact blob's 0.454. Beyond its surface this kernel falls faster than
//!   the compact one (at 0.75 from the centre, half the spacing, it is 0.08
//!   iso against 0.17 iso), so the two scenes merge about as much and hit
//!   about as often (`r = radius` would put the surface at 1 and fuse
//!   every blob at this density into one mass).
//! - `--motion`: each centre moves as `Sine(axis, amplitude 0.5, period,
//!   phase)` with a random unit axis, a period uniform in [2, 4] s and a
//!   phase uniform in [0, 2π).
//!
//! The file sets explicit `bounds`: the cube of centres grown by a blob's
//! reach (its support; for a Gaussian where it falls below 1e-3 iso, as the
//! loader measures it) plus the motion's amplitude, so the box the rays
//! and the spatial index use stays the same over the animation. The camera
//! looks at the centre from a diagonal, far enough for its 45° field of
//! view to hold the box's bounding sphere. `marching` is quadratic-taylor
//! with a minimum step of 0.01 (1e-2 of the support radius) and at most
//! 1000 steps.
//!
//! Same options, same seed: the same bytes (numbers are written rounded to six
//! decimals from a seeded PCG).

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Result, bail};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::scene::Kernel;

/// The iso value of every generated scene.
pub const ISO: f64 = 0.5;
/// Support radius R of the compact blobs.
pub const RADIUS: f64 = 1.0;
/// Mean distance between neighbouring centres: the cube holds one blob per
/// `SPACING³`.
pub const SPACING: f64 = 1.5;
/// A Gaussian blob: `Gaussian(r: GAUSSIAN_R, s: GAUSSIAN_S)`, default weight.
pub const GAUSSIAN_R: f64 = 0.5 * RADIUS;
pub const GAUSSIAN_S: f64 = 2.0;
/// `--motion`: amplitude of each centre's sine, and its period range (s).
pub const MOTION_AMPLITUDE: f64 = 0.5 * RADIUS;
pub const MOTION_PERIOD: (f64, f64) = (2.0, 4.0);
/// Minimum step of the generated marching settings: 1e-2 of R.
pub const MIN_STEP: f64 = 1e-2 * RADIUS;
/// The camera's vertical field of view, degrees.
pub const FOV_Y: f64 = 45.0;

/// What `generate particles` makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Particles {
    pub count: usize,
    pub seed: u64,
    /// Gaussian blobs instead of compact ones.
    pub gaussian: bool,
    /// A sine motion on every centre.
    pub motion: bool,
}

impl Particles {
    /// The side of the cube that holds the centres.
    pub fn side(&self) -> f64 {
        SPACING * (self.count as f64).cbrt()
    }

    /// The kernel of every blob (the Gaussian's weight resolved as the
    /// loader does: `iso·e^s`).
    pub fn kernel(&self) -> Kernel {
        if self.gaussian {
            Kernel::Gaussian { r: GAUSSIAN_R, s: GAUSSIAN_S, weight: ISO * GAUSSIAN_S.exp() }
        } else {
            Kernel::Compact { radius: RADIUS, weight: 1.0 }
        }
    }

    /// Half the side of the explicit bounds: half the cube, a blob's reach
    /// and the motion's amplitude, rounded up to the six decimals written.
    pub fn bounds_half_side(&self) -> f64 {
        let motion = if self.motion { MOTION_AMPLITUDE } else { 0.0 };
        let reach = 0.5 * self.side() + self.kernel().cutoff(ISO) + motion;
        // Centres are rounded to 1e-6 when written: a margin of two more.
        ((reach * 1e6).ceil() + 2.0) / 1e6
    }

    /// The scene file's text, or a one-line error for `count` 0.
    pub fn ron(&self) -> Result<String> {
        if self.count == 0 {
            bail!("--count must be at least 1");
        }
        let mut rng = Pcg64Mcg::seed_from_u64(self.seed);
        let half = 0.5 * self.side();
        let b = self.bounds_half_side();
        // The box's bounding sphere fills the 45° view, with 5% to spare.
        let distance = 1.05 * 3f64.sqrt() * b / (0.5 * FOV_Y.to_radians()).sin();
        let eye = DVec3::splat(distance / 3f64.sqrt());
        let kernel =
            if self.gaussian { format!("Gaussian(r: {}, s: {})", f(GAUSSIAN_R), f(GAUSSIAN_S)) } else { format!("Compact(radius: {})", f(RADIUS)) };
        let mut s = String::new();
        let what = if self.gaussian { "Gaussian" } else { "compact" };
        let flags = format!("{}{}", if self.gaussian { " --gaussian" } else { "" }, if self.motion { " --motion" } else { "" });
        // Writing to a String cannot fail.
        let _ = writeln!(s, "// Generated by `isomarch generate particles --count {} --seed {}{flags}` (src/generate.rs).", self.count, self.seed);
        let _ = writeln!(s, "// {} {what} blobs, centres uniform in a cube of side {} (one per {SPACING}^3), iso {ISO}.", self.count, f(self.side()));
        if self.motion {
            let _ = writeln!(
                s,
                "// Each centre moves along a random axis by {MOTION_AMPLITUDE} sin(2 pi t / period + phase), period in [{}, {}] s.",
                MOTION_PERIOD.0, MOTION_PERIOD.1
            );
        }
        let _ = writeln!(s, "Scene(");
        let _ = writeln!(s, "    camera: (");
        let _ = writeln!(s, "        eye: {},", v(eye));
        let _ = writeln!(s, "        target: (0.0, 0.0, 0.0),");
        let _ = writeln!(s, "        fov_y: {},", f(FOV_Y));
        let _ = writeln!(s, "        resolution: (512, 512),");
        let _ = writeln!(s, "    ),");
        let _ = writeln!(s, "    lights: [");
        let _ = writeln!(s, "        (direction: (0.4, 0.8, 0.45), intensity: 0.85),");
        let _ = writeln!(s, "        (direction: (-0.6, 0.3, -0.2), color: (0.5, 0.6, 0.9), intensity: 0.35),");
        let _ = writeln!(s, "    ],");
        let _ = writeln!(s, "    iso: {},", f(ISO));
        let _ = writeln!(s, "    marching: (method: \"quadratic-taylor\", min_step: {}, max_steps: 1000),", f(MIN_STEP));
        let _ = writeln!(s, "    bounds: Some((min: {}, max: {})),", v(DVec3::splat(-b)), v(DVec3::splat(b)));
        let _ = writeln!(s, "    groups: [");
        let _ = writeln!(s, "        (primitives: [");
        for _ in 0..self.count {
            let c = DVec3::new(rng.random_range(-half..half), rng.random_range(-half..half), rng.random_range(-half..half));
            let _ = write!(s, "            Point(center: {}, kernel: {kernel}", v(c));
            if self.motion {
                // Uniform on the sphere: z uniform in [-1, 1], angle uniform.
                let z: f64 = rng.random_range(-1.0..=1.0);
                let phi: f64 = rng.random_range(0.0..TAU);
                let r = (1.0 - z * z).max(0.0).sqrt();
                let axis = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                let period = rng.random_range(MOTION_PERIOD.0..MOTION_PERIOD.1);
                let phase = rng.random_range(0.0..TAU);
                let _ = write!(
                    s,
                    ", motion: Some(Sine(axis: {}, amplitude: {}, period: {}, phase: {}))",
                    v(axis),
                    f(MOTION_AMPLITUDE),
                    f(period),
                    f(phase)
                );
            }
            let _ = writeln!(s, "),");
        }
        let _ = writeln!(s, "        ]),");
        let _ = writeln!(s, "    ],");
        let _ = writeln!(s, ")");
        Ok(s)
    }

    /// Writes the scene to `path` (a `.ron` file) atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron")) {
            bail!("-o {}: a scene file must end in .ron", path.display());
        }
        let text = self.ron()?;
        crate::output::write_atomic(path, text.as_bytes())
    }

    /// The one line `generate` prints.
    pub fn summary(&self, path: &Path) -> String {
        format!(
            "{}: {} {} blobs in a cube of side {:.3}{}, seed {}",
            path.display(),
            self.count,
            if self.gaussian { "Gaussian" } else { "compact" },
            self.side(),
            if self.motion { ", moving" } else { "" },
            self.seed
        )
    }
}

/// A number rounded to six decimals, trailing zeros dropped (one kept after
/// the point, as RON floats need), no negative zero.
fn f(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0');
    let s = if s.ends_with('.') { format!("{s}0") } else { s.to_string() };
    if s == "-0.0" { "0.0".into() } else { s }
}

fn v(p: DVec3) -> String {
    format!("({}, {}, {})", f(p.x), f(p.y), f(p.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_six_decimals_and_no_negative_zero() {
        assert_eq!(f(1.0), "1.0");
        assert_eq!(f(-0.0000001), "0.0");
        assert_eq!(f(-1.25), "-1.25");
        assert_eq!(f(2.0000004), "2.0");
        assert_eq!(f(0.1234567), "0.123457");
    }

    #[test]
    fn the_cube_grows_as_the_cube_root_of_the_count() {
        let p = |count| Particles { count, seed: 1, gaussian: false, motion: false };
        assert!((p(1000).side() - 10.0 * SPACING).abs() < 1e-9);
        assert!((p(8000).side() / p(1000).side() - 2.0).abs() < 1e-9);
    }
}
