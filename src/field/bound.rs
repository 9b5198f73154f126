//! The algebra of forward bounds along a ray: the [`Bound`] type, sums,
//! the max of Section 5.2 and Appendix C, and Algorithm 1's roots. The
//! constructions that produce bounds (Taylor and bottom-up linear in
//! `bounds.rs`, bottom-up quadratic in `quad.rs`, revised affine arithmetic
//! in `raa.rs`) build on it; `fold.rs` combines them over the primitives.
//!
//! A bound on `[t0, t1]` is a pair of quadratics in `τ = t - t0`,
//! `lo(τ) = v + a_lo τ + b_lo τ²` and `hi(τ) = v + a_hi τ + b_hi τ²`, both
//! exact at `t0` (forward, Section 4.2) and valid for `τ ∈ [0, t_valid - t0]`.
//! Linear bounds have `b = 0`. One construction relaxes exactness on the
//! upper side (`quadratic-relaxed-t0`, Figure 21 b): its upper bound starts
//! `e_hi >= 0` above `v`; every other bound has `e_hi = 0`.

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

    /// The exact quadratic `v + a τ + b τ²`.
    pub fn exact(v: f64, a: f64, b: f64) -> Bound {
        Bound { v, a_lo: a, b_lo: b, a_hi: a, b_hi: b, e_hi: 0.0, t_valid: f64::INFINITY }
    }

    /// 0 everywhere.
    pub fn zero() -> Bound {
        Bound::exact(0.0, 0.0, 0.0)
    }

    /// Sum of bounds (Eq. 16): coefficients add; valid where both are.
    pub fn add(&self, g: &Bound) -> Bound {
        Bound {
            v: self.v + g.v,
            a_lo: self.a_lo + g.a_lo,
            b_lo: self.b_lo + g.b_lo,
            a_hi: self.a_hi + g.a_hi,
            b_hi: self.b_hi + g.b_hi,
            e_hi: self.e_hi + g.e_hi,
            t_valid: self.t_valid.min(g.t_valid),
        }
    }

    /// `w` times the bound, `w >= 0`.
    pub fn scaled(&self, w: f64) -> Bound {
        Bound {
            v: w * self.v,
            a_lo: w * self.a_lo,
            b_lo: w * self.b_lo,
            a_hi: w * self.a_hi,
            b_hi: w * self.b_hi,
            e_hi: w * self.e_hi,
            t_valid: self.t_valid,
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

/// From outside (`v < 0`): the lower bound's first root, a point where
/// the field is proven >= 0 (infinite where the lower bound stays
/// negative). The GPU's `lower_root`.
pub fn lower_root(b: &Bound) -> f64 {
    if b.v >= 0.0 { 0.0 } else { first_root(-b.v, b.a_lo, b.b_lo) }
}

/// Where the bound on the far side of the field's sign at its start
/// passes `margin` beyond 0: from outside (`v < 0`) where the lower bound
/// reaches `margin`, so the field is proven >= margin; from inside (`v >
/// 0`) where the upper bound falls to `-margin` (transparent marching).
/// Infinite where that bound stays short of it, and on the surface (`v =
/// 0`). The margin puts the point past the field's rounding
/// (`layout::PROVEN_MARGIN`). The GPU's `proven_root`.
pub fn proven_root(b: &Bound, margin: f64) -> f64 {
    if b.v < 0.0 {
        first_root(margin - b.v, b.a_lo, b.b_lo)
    } else if b.v > 0.0 {
        first_root(b.hi(0.0) + margin, -b.a_hi, -b.b_hi)
    } else {
        f64::INFINITY
    }
}

/// For a bound from `t0`: [`proven_root`] where it lies in the validity
/// interval (a crossing is proven by then), else infinite. The GPU's
/// `StepEval::cross`.
pub fn proven_crossing(b: &Bound, t0: f64, margin: f64) -> f64 {
    let r = proven_root(b, margin);
    if r <= b.t_valid - t0 { r } else { f64::INFINITY }
}

/// The margin of a transparent march's proven crossings, as a fraction of
/// iso (see [`proven_root`]); an opaque march's is 0.
pub const PROVEN_MARGIN: f64 = crate::layout::PROVEN_MARGIN as f64;

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
