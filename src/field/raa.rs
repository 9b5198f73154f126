//! Revised affine arithmetic along a ray (the paper's [FPC10] baseline;
//! Fryazinov, Pasko & Comninos 2010), in f64: the mirror of
//! `shaders/include/raa.glsl` (and of the kernels' RAA bounds in
//! `kernel_compact.glsl` and the kinds' in `kinds/`).
//!
//! On `[a, b]`, `t = tm + tr ε` with `ε ∈ [-1, 1]`. Every quantity is
//! `x0 + x1 ε ± e`: a centre, one linear term in the ray parameter and one
//! accumulated error. Products fold the quadratic term into the error
//! (`ε² ∈ [0, 1]`, centred at ½); `e^{-y}` uses the min-range linearisation
//! of a decreasing convex function. Compact supports are handled by
//! clipping: a support that covers `[a, b]` keeps the affine form in the
//! ray's ε, a partial one contributes its range united with 0.

use super::KernelEval;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    pub x0: f64,
    pub x1: f64,
    pub e: f64,
}

impl Affine {
    pub const ZERO: Affine = Affine { x0: 0.0, x1: 0.0, e: 0.0 };

    pub fn scale(self, c: f64) -> Affine {
        Affine { x0: c * self.x0, x1: c * self.x1, e: c.abs() * self.e }
    }
    pub fn range(&self) -> (f64, f64) {
        let r = self.x1.abs() + self.e;
        (self.x0 - r, self.x0 + r)
    }
    fn from_range(lo: f64, hi: f64) -> Affine {
        Affine { x0: 0.5 * (lo + hi), x1: 0.0, e: 0.5 * (hi - lo) }
    }
}

/// Sums of affine forms: their terms and their errors add.
impl std::ops::Add for Affine {
    type Output = Affine;
    fn add(self, o: Affine) -> Affine {
        Affine { x0: self.x0 + o.x0, x1: self.x1 + o.x1, e: self.e + o.e }
    }
}

/// Products: the quadratic term of ε² splits into its mean (1/2) and
/// an error of 1/2, plus the cross terms with the errors.
impl std::ops::Mul for Affine {
    type Output = Affine;
    fn mul(self, y: Affine) -> Affine {
        Affine {
            x0: self.x0 * y.x0 + 0.5 * self.x1 * y.x1,
            x1: self.x0 * y.x1 + y.x0 * self.x1,
            e: 0.5 * (self.x1 * y.x1).abs() + (self.x0.abs() + self.x1.abs()) * y.e + (y.x0.abs() + y.x1.abs()) * self.e + self.e * y.e,
        }
    }
}

/// `w (a - x²/R²)³` for `x = x0 + x1 ε` on the clipped support.
fn compact_poly(w: f64, inv_r2: f64, a: f64, x: Affine) -> Affine {
    let q = (x * x).scale(-inv_r2) + Affine { x0: a, x1: 0.0, e: 0.0 };
    (q * q * q).scale(w)
}

/// The compact kernel in x on `x ∈ [xa, xb]` (x = t - tc, so dx/dt = 1).
pub(super) fn compact_raa(k: &KernelEval, inv_r2: f64, h2: f64, xa: f64, xb: f64) -> Affine {
    let a = 1.0 - h2 * inv_r2;
    if a <= 0.0 {
        return Affine::ZERO;
    }
    let l = (a / inv_r2).sqrt();
    let (ca, cb) = (xa.max(-l), xb.min(l));
    if ca >= cb {
        return Affine::ZERO;
    }
    let x = Affine { x0: 0.5 * (ca + cb), x1: 0.5 * (cb - ca), e: 0.0 };
    let p = compact_poly(k.weight, inv_r2, a, x);
    if ca == xa && cb == xb {
        return p;
    }
    let (lo, hi) = p.range();
    Affine::from_range(lo.min(0.0), hi.max(0.0))
}

/// `e^{-y}` by min-range linearisation on the range of `y`, which is at
/// least `y_min` (the true minimum of y along the ray).
pub fn exp_neg(y: Affine, y_min: f64) -> Affine {
    let (lo, hi) = y.range();
    let lo = lo.max(y_min).min(hi);
    // Slope of least magnitude on [lo, hi]: φ'(hi). φ(y) - s y decreases.
    let s = -(-hi).exp();
    let (top, bottom) = ((-lo).exp() - s * lo, (-hi).exp() - s * hi);
    let zeta = 0.5 * (top + bottom);
    let delta = 0.5 * (top - bottom);
    Affine { x0: s * y.x0 + zeta, x1: s * y.x1, e: s.abs() * y.e + delta }
}
