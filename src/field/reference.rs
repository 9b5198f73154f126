//! The reference root finder: dense f64 sampling plus bisection.
//!
//! Samples are at most `spacing` apart. Where the field is far from the iso
//! value the sampler jumps further, but only by distances that segment
//! tracing's Lipschitz bound proves free of roots, so the result is the same
//! as plain dense sampling at `spacing`, computed in a fraction of the time.
//! Like dense sampling, it cannot see two crossings closer than `spacing`
//! (a tangent ray's double root shows no sign change and is not reported).

use glam::DVec3;

use super::Field;

/// One sign change of `f` along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    pub t: f64,
    /// `true` when `f` goes from `< 0` to `>= 0` (entering the surface).
    pub entering: bool,
}

#[derive(Clone, Copy, Debug)]
pub struct ReferenceOptions {
    /// Largest distance between two samples.
    pub spacing: f64,
    /// Bisection stops when the bracket is shorter than this.
    pub tolerance: f64,
}

impl ReferenceOptions {
    /// Options for a scene whose smallest kernel scale is `min_radius`.
    pub fn for_min_radius(min_radius: f64) -> ReferenceOptions {
        ReferenceOptions { spacing: 1e-4 * min_radius, tolerance: 1e-9 * min_radius }
    }
}

/// Crossings of `f` along `o + t u` for `t ∈ [t0, t1]`, in order. A ray
/// that starts inside (`f(t0) >= 0`) reports an entering crossing at `t0`.
/// With `first_only`, stops after the first.
pub fn crossings(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64, opts: ReferenceOptions, first_only: bool) -> Vec<Crossing> {
    let mut out = Vec::new();
    if !(t0 <= t1) {
        return out;
    }
    let at = |t: f64| field.value(o + t * u);
    let mut t = t0;
    let mut f = at(t);
    let mut inside = f >= 0.0;
    if inside {
        out.push(Crossing { t: t0, entering: true });
        if first_only {
            return out;
        }
    }
    // With a grid, windows of a few cells keep each step's work local.
    let cap = field.grid_cell().map_or(f64::INFINITY, |c| super::grid::REFERENCE_WINDOW_CELLS * c);
    let mut window = (t1 - t0).min(cap);
    while t < t1 {
        let tb = (t + window).min(t1);
        let lambda = field.segment_lipschitz(o, u, t, tb);
        let safe = if lambda > 0.0 { f.abs() / lambda } else { f64::INFINITY };
        let step = safe.min(tb - t).max(opts.spacing);
        let t_next = (t + step).min(t1);
        let f_next = at(t_next);
        if (f_next >= 0.0) != inside {
            let root = bisect(&at, t, t_next, inside, opts.tolerance);
            inside = !inside;
            out.push(Crossing { t: root, entering: inside });
            if first_only {
                return out;
            }
        }
        window = (2.0 * (t_next - t)).max(opts.spacing).min(cap);
        t = t_next;
        f = f_next;
    }
    out
}

/// The first entering crossing, or `None`.
pub fn first_hit(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64, opts: ReferenceOptions) -> Option<f64> {
    crossings(field, o, u, t0, t1, opts, true).first().map(|c| c.t)
}

/// Bisection on `[a, b]` where `at(a) >= 0` equals `a_inside` and `at(b)`
/// has the other sign; returns the midpoint of the final bracket.
pub fn bisect(at: &impl Fn(f64) -> f64, mut a: f64, mut b: f64, a_inside: bool, tolerance: f64) -> f64 {
    while b - a > tolerance {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        if (at(m) >= 0.0) == a_inside {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}
