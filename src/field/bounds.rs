//! Forward inclusion functions along a ray, in f64: the mirror of
//! `shaders/include/inclusion.glsl`, and the oracle its tests compare with.
//!
//! A bound on `[t0, t1]` is a pair of quadratics in `τ = t - t0`,
//! `lo(τ) = v + a_lo τ + b_lo τ²` and `hi(τ) = v + a_hi τ + b_hi τ²`, both
//! exact at `t0` (forward, Section 4.2) and valid for `τ ∈ [0, t_valid - t0]`.
//! Linear bounds have `b = 0`. One construction relaxes exactness on the
//! upper side (`quadratic-relaxed-t0`, Figure 21 b): its upper bound starts
//! `e_hi >= 0` above `v`; every other bound has `e_hi = 0`.
//!
//! Per primitive, the kernel is a function of `x = t - tc` (tc the closest
//! approach) with `q = x² + h²`; its derivatives' ranges over an interval
//! come from their values at the ends and at the roots of the next
//! derivative inside it (Appendix A, Eq. 23):
//!
//! ```text
//! compact, Q = a - x²/R², a = 1 - h²/R², support |x| < l = R√a:
//!   k' = -6w x Q²/R²              extrema at x = ±l/√5
//!   k'' = -6w Q (a - 5x²/R²)/R²   extrema at x = 0, ±l√(3/5)
//! Gaussian, k = A e^{-αx²}, α = s/r², A = w e^{-αh²}:
//!   k' = -2αx k                   extrema at x = ±1/√(2α)
//!   k'' = 2α(2αx² - 1) k          extrema at x = 0, ±√(3/(2α))
//! ```
//!
//! Outside the compact support every derivative is 0, and since the
//! kernel is C² the values at ±l (0) cover that part of the interval.

use glam::DVec3;

use super::quad::{QuadOptions, QuadSettings, field_quadratic};
use super::{Field, KernelEval, PrimEval, point_on_ray};
use crate::method::Method;

/// A forward bound on `[t0, t_valid]`; see the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    pub v: f64,
    pub a_lo: f64,
    pub b_lo: f64,
    pub a_hi: f64,
    pub b_hi: f64,
    /// How far the upper bound starts above `v` (0 for forward bounds).
    pub e_hi: f64,
    pub t_valid: f64,
}

impl Bound {
    pub fn lo(&self, tau: f64) -> f64 {
        self.v + tau * (self.a_lo + self.b_lo * tau)
    }
    pub fn hi(&self, tau: f64) -> f64 {
        self.v + self.e_hi + tau * (self.a_hi + self.b_hi * tau)
    }
}

/// Which derivative's range a Taylor bound needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Linear Taylor (Eq. 13-15): the range of f'.
    Linear,
    /// Quadratic Taylor (Eq. 19): f'(t0) and the range of f''.
    Quadratic,
}

/// One primitive along the ray: the value and first derivative at `t0` and
/// the range of the `order`'s derivative over `[t0, t1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Taylor {
    pub value: f64,
    pub slope: f64,
    pub min: f64,
    pub max: f64,
}

/// Kernel derivatives `(k, k', k'')` at `x` for a kernel written in `x`.
fn compact_derivs(w: f64, inv_r2: f64, a: f64, x: f64) -> (f64, f64, f64) {
    let q = a - x * x * inv_r2;
    if q <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    (w * q * q * q, -6.0 * w * x * q * q * inv_r2, -6.0 * w * q * (a - 5.0 * x * x * inv_r2) * inv_r2)
}

fn gaussian_derivs(amp: f64, alpha: f64, x: f64) -> (f64, f64, f64) {
    let k = amp * (-alpha * x * x).exp();
    (k, -2.0 * alpha * x * k, 2.0 * alpha * (2.0 * alpha * x * x - 1.0) * k)
}

/// The range of `g` over `[x0, x1]` from the ends and the interior candidates.
fn range(g: impl Fn(f64) -> f64, x0: f64, x1: f64, candidates: &[f64]) -> (f64, f64) {
    let (mut lo, mut hi) = (g(x0).min(g(x1)), g(x0).max(g(x1)));
    for &c in candidates {
        if c > x0 && c < x1 {
            let v = g(c);
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (lo, hi)
}

/// A kernel as a function of `x` along the ray: `q = x² + h2`. With
/// `extension`, a compact support entered after `x0` gets the per-primitive
/// bound of Section 6.2.1: see [`entering_taylor`].
fn kernel_taylor(k: &KernelEval, h2: f64, x0: f64, x1: f64, order: Order, extension: bool) -> Taylor {
    let pick = |d: (f64, f64, f64)| if order == Order::Linear { d.1 } else { d.2 };
    if k.gaussian {
        let alpha = k.inv;
        let amp = k.weight * (-alpha * h2).exp();
        let (value, slope, _) = gaussian_derivs(amp, alpha, x0);
        let c1 = 1.0 / (2.0 * alpha).sqrt();
        let c2 = (1.5 / alpha).sqrt();
        let cands: &[f64] = if order == Order::Linear { &[-c1, c1] } else { &[0.0, -c2, c2] };
        let (min, max) = range(|x| pick(gaussian_derivs(amp, alpha, x)), x0, x1, cands);
        Taylor { value, slope, min, max }
    } else {
        let a = 1.0 - h2 * k.inv;
        if a <= 0.0 {
            return Taylor::default();
        }
        let l = a.sqrt() * k.scale;
        let (xa, xb) = (x0.max(-l), x1.min(l));
        if xa >= xb {
            return Taylor::default();
        }
        let (value, slope, _) = compact_derivs(k.weight, k.inv, a, x0);
        let c1 = l / 5f64.sqrt();
        let c2 = l * 0.6f64.sqrt();
        let cands: &[f64] = if order == Order::Linear { &[-c1, c1] } else { &[0.0, -c2, c2] };
        let (min, max) = range(|x| pick(compact_derivs(k.weight, k.inv, a, x)), xa, xb, cands);
        if extension && xa > x0 {
            return entering_taylor(max, (xb - xa) / (xb - x0), order);
        }
        Taylor { value, slope, min, max }
    }
}

/// Section 6.2.1 for the Taylor forms: a compact support entered at `xa`
/// after the interval's start. The kernel and its first two derivatives
/// vanish at the entry (it is C²), so on the support part the Taylor bound
/// from the entry is `M s` (linear) or `M s²/2` (quadratic), `s` measured
/// from the entry and `M >= 0` the largest f′ or f″ there. Moved to start
/// at `x0` as in Figure 9 (the middle control point is 0), it becomes
/// `M r τ` or `M r² τ²/2` with `r = (xb - xa)/(xb - x0)`: above the kernel
/// up to the exit `xb`, and above its 0 before the entry and after the exit.
/// The kernel is >= 0, so the lower bound is 0.
fn entering_taylor(max: f64, r: f64, order: Order) -> Taylor {
    let scale = if order == Order::Linear { r } else { r * r };
    Taylor { value: 0.0, slope: 0.0, min: 0.0, max: max.max(0.0) * scale }
}

impl PrimEval {
    /// Taylor data of this primitive along `o + t u` on `[t0, t1]`; with
    /// `extension`, the per-primitive bound of a compact point entered
    /// late (Section 6.2.1).
    pub fn taylor(&self, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Taylor {
        match *self {
            PrimEval::Point { center, kernel } => {
                let (h2, x0) = point_on_ray(center, o, u, t0);
                kernel_taylor(&kernel, h2, x0, x0 + (t1 - t0), order, extension)
            }
            PrimEval::Plane { normal, offset, kernel } => {
                // Signed distance s = s0 + σ t: the kernel of s with h = 0,
                // derivatives in t scaled by σ and σ².
                let sigma = normal.dot(u);
                let s0 = normal.dot(o + t0 * u) - offset;
                let s1 = normal.dot(o + t1 * u) - offset;
                let (lo, hi) = (s0.min(s1), s0.max(s1));
                let mut k = kernel_taylor(&kernel, 0.0, lo, hi, order, false);
                // kernel_taylor evaluated value/slope at `lo`; redo them at s0.
                let (value, slope, _) = compact_derivs(kernel.weight, kernel.inv, 1.0, s0);
                k.value = value;
                k.slope = slope * sigma;
                let scale = if order == Order::Linear { sigma } else { sigma * sigma };
                let (a, b) = (k.min * scale, k.max * scale);
                k.min = a.min(b);
                k.max = a.max(b);
                k
            }
        }
    }
}

/// The Taylor bound of one group (a sum): per-primitive ranges add.
pub fn group_taylor(group: &[PrimEval], o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Bound {
    let mut s = Taylor::default();
    for p in group {
        let k = p.taylor(o, u, t0, t1, order, extension);
        s.value += k.value;
        s.slope += k.slope;
        s.min += k.min;
        s.max += k.max;
    }
    match order {
        // Eq. 13-15: asymmetric slopes from the range of f'.
        Order::Linear => Bound { v: s.value, a_lo: s.min, b_lo: 0.0, a_hi: s.max, b_hi: 0.0, e_hi: 0.0, t_valid: t1 },
        // Eq. 19: f(t0) + f'(t0) τ + ½ f''_{min/max} τ².
        Order::Quadratic => {
            Bound { v: s.value, a_lo: s.slope, b_lo: 0.5 * s.min, a_hi: s.slope, b_hi: 0.5 * s.max, e_hi: 0.0, t_valid: t1 }
        }
    }
}

/// The max of two forward bounds over `[t0, t0 + len]` (Section 5.2 for
/// linear bounds, Appendix C for quadratic ones). Lower: the input with the
/// larger start value. Upper: for linear inputs the chord to the larger end
/// value; for quadratic ones the Bézier control polygon whose points are the
/// larger of the inputs' control points (valid since Bernstein weights are
/// non-negative, and exact at t0 for forward inputs; a relaxed start
/// `e_hi` is carried as the larger start of the upper bounds).
pub fn max_bound(f: &Bound, g: &Bound, len: f64, quadratic: bool) -> Bound {
    let v = f.v.max(g.v);
    let lower = if f.v > g.v || (f.v == g.v && f.lo(len) >= g.lo(len)) { f } else { g };
    let start = f.hi(0.0).max(g.hi(0.0));
    let end = f.hi(len).max(g.hi(len));
    let (a_hi, b_hi) = if len <= 0.0 {
        (f.a_hi.max(g.a_hi), f.b_hi.max(g.b_hi))
    } else if quadratic {
        let mid = (f.hi(0.0) + 0.5 * f.a_hi * len).max(g.hi(0.0) + 0.5 * g.a_hi * len);
        (2.0 * (mid - start) / len, (start - 2.0 * mid + end) / (len * len))
    } else {
        ((end - start) / len, 0.0)
    };
    Bound { v, a_lo: lower.a_lo, b_lo: lower.b_lo, a_hi, b_hi, e_hi: start - v, t_valid: f.t_valid.min(g.t_valid) }
}

/// The Taylor bound of the whole field minus iso: per group, then the max
/// of groups (the paper's mixed methods on a max scene, Table 3).
pub fn field_taylor(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, extension: bool) -> Bound {
    max_of_groups(field, t1 - t0, order == Order::Quadratic, |g| group_taylor(g, o, u, t0, t1, order, extension))
}

/// `f = max over groups - iso` from each group's bound: the bottom-up max
/// (quadratic or linear upper bound) of `group_bound` over the groups.
fn max_of_groups(field: &Field, len: f64, quadratic: bool, group_bound: impl Fn(&[PrimEval]) -> Bound) -> Bound {
    let mut groups = field.groups.iter().map(|g| group_bound(g));
    let first = groups.next().expect("a field has at least one group");
    let mut b = groups.fold(first, |prev, b| max_bound(&prev, &b, len, quadratic));
    b.v -= field.iso;
    b
}

/// The first `τ > 0` where `-g + A τ + B τ² = 0`, for `g >= 0`; infinity
/// when there is none. Written without cancellation: the small root is
/// `2g / (A + √D)`, and for `A < 0 < B` the far root `(√D - A) / 2B`.
pub fn first_root(g: f64, a: f64, b: f64) -> f64 {
    let d = a * a + 4.0 * b * g;
    if d < 0.0 {
        return f64::INFINITY;
    }
    let sd = d.sqrt();
    if a >= 0.0 {
        return if a + sd > 0.0 { 2.0 * g / (a + sd) } else { f64::INFINITY };
    }
    if b <= 0.0 {
        return f64::INFINITY;
    }
    (sd - a) / (2.0 * b)
}

/// Where a march from `t0` may step: the first root of the upper bound when
/// outside (`v < 0`), of the lower bound when inside (Algorithm 1). A
/// relaxed upper bound that starts at or above 0 allows no step.
pub fn next_root(b: &Bound) -> f64 {
    if b.v > 0.0 {
        first_root(b.v, -b.a_lo, -b.b_lo)
    } else {
        // On the surface (v = 0) either side may follow: no step.
        let start = b.hi(0.0);
        if start >= 0.0 { 0.0 } else { first_root(-start, b.a_hi, b.b_hi) }
    }
}

/// A bottom-up linear bound (Section 5.2): `v + lo τ <= f <= v + hi τ` on
/// `τ ∈ [0, len]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lin {
    pub v: f64,
    pub lo: f64,
    pub hi: f64,
}

impl Lin {
    /// Product (Section 5.2): the four corner products of the input lines
    /// are quadratics sharing the start value; each is bounded by its
    /// tangent at 0 and its chord (Eq. 17, which is which depends on the
    /// sign of its curvature), and the extreme slopes bound them all.
    pub fn mul(self, g: Lin, len: f64) -> Lin {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for m in [self.lo, self.hi] {
            for n in [g.lo, g.hi] {
                let c1 = self.v * n + g.v * m;
                let chord = c1 + m * n * len;
                lo = lo.min(c1).min(chord);
                hi = hi.max(c1).max(chord);
            }
        }
        Lin { v: self.v * g.v, lo, hi }
    }

    /// `w e^{-y}` of this bound (decreasing, convex): upper from the lower
    /// input line through the chord of `e^{-y}` over its range, lower from
    /// the upper input line through the tangent at `v` (Eq. 17).
    pub fn exp_neg(self, w: f64, len: f64) -> Lin {
        let v = w * (-self.v).exp();
        let dy = self.lo * len;
        let chord = if dy.abs() > 1e-12 { w * ((-(self.v + dy)).exp() - (-self.v).exp()) / dy } else { -v };
        Lin { v, lo: -v * self.hi, hi: chord * self.lo }
    }

    pub fn at_hi(&self, tau: f64) -> f64 {
        self.v + self.hi * tau
    }
}

/// The compact kernel `w (a - x²/R²)³` on `x ∈ [x0, x0 + len]` built bottom
/// up (Figure 11): the exact concave quadratic Q (tangent above, chord
/// below), then Q·Q·Q, on the part of the interval inside the support; then
/// extended to the whole interval, where the kernel is 0 outside:
/// entering late, the line from 0 at x0 through the clipped upper bound's
/// end value (lower: 0, the kernel is non-negative); leaving early, the
/// upper slope raised to `-v/len` so the line stays >= 0 past the exit
/// (the lower line already ends <= 0 at the exit and decreases).
fn compact_lin(w: f64, inv_r2: f64, a: f64, x0: f64, len: f64) -> Lin {
    let zero = Lin { v: 0.0, lo: 0.0, hi: 0.0 };
    if a <= 0.0 {
        return zero;
    }
    let l = (a / inv_r2).sqrt();
    let (xa, xb) = (x0.max(-l), (x0 + len).min(l));
    if xa >= xb {
        return zero;
    }
    let sub = xb - xa;
    let q0 = a - xa * xa * inv_r2;
    let q = Lin { v: q0, lo: -(2.0 * xa + sub) * inv_r2, hi: -2.0 * xa * inv_r2 };
    let k = q.mul(q, sub).mul(q, sub);
    let mut k = Lin { v: w * k.v, lo: w * k.lo, hi: w * k.hi };
    if xa > x0 {
        // Entering: the kernel is 0 on [x0, xa].
        let end = k.at_hi(sub).max(0.0);
        k = Lin { v: 0.0, lo: 0.0, hi: end / (xb - x0) };
    }
    if xb < x0 + len && len > 0.0 {
        // Leaving: the kernel is 0 on [xb, x0 + len].
        k.hi = k.hi.max(-k.v / len);
    }
    k
}

impl PrimEval {
    /// Bottom-up linear bound of this primitive along `o + t u` on
    /// `[t0, t0 + len]`.
    pub fn linear(&self, o: DVec3, u: DVec3, t0: f64, len: f64) -> Lin {
        match *self {
            PrimEval::Point { center, kernel } => {
                let (h2, x0) = point_on_ray(center, o, u, t0);
                if kernel.gaussian {
                    // y = α(x² + h²) is convex: tangent below, chord above.
                    let y = Lin { v: kernel.inv * (x0 * x0 + h2), lo: 2.0 * kernel.inv * x0, hi: kernel.inv * (2.0 * x0 + len) };
                    // Far from t0 the chord of e^{-y} over the lower line's
                    // range can exceed any float; but |f'| never exceeds
                    // the kernel's Lipschitz constant, so by the mean value
                    // theorem slopes can be clamped to it (also tighter).
                    let k = y.exp_neg(kernel.weight, len);
                    Lin { v: k.v, lo: k.lo.max(-kernel.peak_slope), hi: k.hi.min(kernel.peak_slope) }
                } else {
                    compact_lin(kernel.weight, kernel.inv, 1.0 - h2 * kernel.inv, x0, len)
                }
            }
            PrimEval::Plane { normal, offset, kernel } => {
                // q = s², s = s0 + σ t: the compact kernel in x = s/σ with
                // 1/R'² = σ²/R² and h = 0.
                let sigma = normal.dot(u);
                let s0 = normal.dot(o + t0 * u) - offset;
                if sigma.abs() < 1e-9 {
                    return Lin { v: kernel.value(s0 * s0), lo: 0.0, hi: 0.0 };
                }
                compact_lin(kernel.weight, kernel.inv * sigma * sigma, 1.0, s0 / sigma, len)
            }
        }
    }
}

/// Bottom-up linear bound of the field minus iso: sums within groups, the
/// linear max across groups.
pub fn field_linear(field: &Field, o: DVec3, u: DVec3, t0: f64, t1: f64) -> Bound {
    let len = t1 - t0;
    max_of_groups(field, len, false, |g| {
        let s = g.iter().fold(Lin { v: 0.0, lo: 0.0, hi: 0.0 }, |s, p| {
            let k = p.linear(o, u, t0, len);
            Lin { v: s.v + k.v, lo: s.lo + k.lo, hi: s.hi + k.hi }
        });
        Bound { v: s.v, a_lo: s.lo, b_lo: 0.0, a_hi: s.hi, b_hi: 0.0, e_hi: 0.0, t_valid: t1 }
    })
}

/// The forward bound of `method` for the field minus iso on `[t0, t1]`
/// (`t_valid` may be shorter); `None` for the methods without one (sphere,
/// segment, revised affine arithmetic). `quad`: see [`QuadSettings`].
pub fn field_bound(field: &Field, method: Method, quad: QuadSettings, o: DVec3, u: DVec3, t0: f64, t1: f64) -> Option<Bound> {
    Some(match method {
        Method::LinearTaylor => field_taylor(field, o, u, t0, t1, Order::Linear, quad.extension),
        Method::QuadraticTaylor => field_taylor(field, o, u, t0, t1, Order::Quadratic, quad.extension),
        Method::Linear | Method::LinearBisection => field_linear(field, o, u, t0, t1),
        Method::Quadratic | Method::QuadraticRelaxedT0 | Method::QuadraticRelaxedMax => {
            let exp_upper = method.exp_upper().expect("a bottom-up quadratic method");
            let validity_floor = quad.validity_floor(field.iso);
            field_quadratic(field, o, u, t0, t1, QuadOptions { exp_upper, extension: quad.extension, validity_floor })
        }
        Method::Sphere | Method::Segment | Method::Raa => return None,
    })
}
