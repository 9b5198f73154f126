//! Forward inclusion functions along a ray, in f64: the mirror of
//! `shaders/include/bound.glsl` and the kernels' bounds
//! (`kernel_compact.glsl`, `kernel_gaussian.glsl`), and the oracle their
//! tests compare with.
//!
//! Taylor (Sections 5.1, 6.1) and bottom-up linear (Section 5.2) bounds of
//! one primitive's kernel; the [`Bound`] they make is in `bound.rs`.
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

use super::KernelEval;

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
pub(super) fn compact_derivs(w: f64, inv_r2: f64, a: f64, x: f64) -> (f64, f64, f64) {
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
pub(super) fn kernel_taylor(k: &KernelEval, h2: f64, x0: f64, x1: f64, order: Order, extension: bool) -> Taylor {
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

/// A bottom-up linear bound (Section 5.2): `v + lo τ <= f <= v + hi τ` on
/// `τ ∈ [0, len]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lin {
    pub v: f64,
    pub lo: f64,
    pub hi: f64,
}

/// The bounds of `-f` from those of `f`: the slopes swap.
impl std::ops::Neg for Lin {
    type Output = Lin;

    fn neg(self) -> Lin {
        Lin { v: -self.v, lo: -self.hi, hi: -self.lo }
    }
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
pub(super) fn compact_lin(w: f64, inv_r2: f64, a: f64, x0: f64, len: f64) -> Lin {
    // A negative weight mirrors the kernel of |w|: its bounds swap.
    if w < 0.0 {
        return -compact_lin(-w, inv_r2, a, x0, len);
    }
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
