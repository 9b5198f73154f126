//! Bottom-up quadratic forward bounds (Section 6.2, Figures 8, 9, 11 and 20
//! to 22, Appendices B and C), in f64: the mirror of the `quad_*` functions
//! of `shaders/include/quad.glsl` and the kernels' quadratic bounds
//! (`kernel_compact.glsl`, `kernel_gaussian.glsl`).
//!
//! A quadratic bound on `τ ∈ [0, len]` is a [`Bound`]: lower and upper
//! quadratics sharing the start value `v`. Bounds are built from exact
//! quadratics of `t` (the squared distance along the ray) by sums, scaling,
//! products (Figure 8) and monotone convex functions (Appendix B), and
//! combined across groups by the maximum of Appendix C
//! ([`super::bounds::max_bound`]).
//!
//! `len` is the interval the bound is asked for; an operation that is only
//! valid on a shorter interval shortens it (a validity interval, Section
//! 4.2), and every later operation of the same expression uses the
//! shortened one. The derivations behind each rule are in
//! docs/paper-digest.md, section 5; each is checked here by containment
//! tests and again on the GPU by tests/inclusion.rs.

use super::bound::{Bound, max_bound};
pub use crate::settings::{ExpUpper, QuadSettings, ValidityScope};

/// A bottom-up quadratic bound's rule for exp and its settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadOptions {
    pub exp_upper: ExpUpper,
    pub extension: bool,
    /// With [`ExpUpper::Validity`], Gaussians whose peak along the ray is
    /// below this impose no validity interval (0: every Gaussian does).
    pub validity_floor: f64,
}

/// Product of two forward quadratic bounds on `[0, len]` (Section 6.2,
/// Figure 8). For every pair of one quadratic from each input, the product
/// `P` is a quartic with `P(0) = vf vg`, and `f g` lies between the least
/// and the greatest of the four at every τ. Each `P'` is a cubic: split at
/// its inflection, each piece is convex or concave, so its tangent at the
/// piece's start and its chord bound it (Eq. 17). A line `U0 + s τ` above
/// every piece's upper line (and one below the lower lines), integrated
/// from `vf vg`, gives the product's quadratic bounds.
///
/// The paper extends every piece's line over the whole interval and joins
/// the extremes at 0 and `len` (Figure 8, right). We ask less, which is
/// tighter and, unlike that, continuous as an inflection crosses the
/// interval's end: every first-piece line passes through `(0, P'(0))`, so
/// `U0 = max P'(0)` is exact, and the line need only stay above each
/// first-piece line up to the piece's end and above each second-piece line
/// at `len` (at the split it is above the first piece's line, which is
/// above `P'` there, where the second piece's lines start).
pub fn mul(f: &Bound, g: &Bound, len: f64) -> Bound {
    debug_assert!(f.e_hi == 0.0 && g.e_hi == 0.0, "products take forward bounds");
    let sides = |b: &Bound| [(b.a_lo, b.b_lo), (b.a_hi, b.b_hi)];
    let (mut u0, mut d0) = (f64::NEG_INFINITY, f64::INFINITY);
    for (af, _) in sides(f) {
        for (ag, _) in sides(g) {
            let e0 = f.v * ag + g.v * af;
            u0 = u0.max(e0);
            d0 = d0.min(e0);
        }
    }
    let (mut up_slope, mut down_slope) = (f64::NEG_INFINITY, f64::INFINITY);
    for (af, bf) in sides(f) {
        for (ag, bg) in sides(g) {
            // P'(τ) = e0 + e1 τ + e2 τ² + e3 τ³.
            let e0 = f.v * ag + g.v * af;
            let e1 = 2.0 * (af * ag + bf * g.v + bg * f.v);
            let e2 = 3.0 * (af * bg + ag * bf);
            let e3 = 4.0 * bf * bg;
            let inflection = if e3 != 0.0 { -e2 / (3.0 * e3) } else { -1.0 };
            let split = if inflection > 0.0 && inflection < len { inflection } else { len };
            // The lines of the piece [lo, hi]: tangent at lo, chord.
            let lines = |lo: f64, hi: f64| {
                let tangent = e1 + lo * (2.0 * e2 + 3.0 * lo * e3);
                let chord = e1 + e2 * (lo + hi) + e3 * (lo * lo + lo * hi + hi * hi);
                if e2 + 1.5 * e3 * (lo + hi) >= 0.0 { (chord, tangent) } else { (tangent, chord) }
            };
            let (up, down) = lines(0.0, split);
            if split > 0.0 {
                up_slope = up_slope.max(up + (e0 - u0) / split);
                down_slope = down_slope.min(down + (e0 - d0) / split);
            } else {
                up_slope = up_slope.max(up);
                down_slope = down_slope.min(down);
            }
            // Without a split the second piece is the point len, whose
            // constraint the first piece meets; the GPU computes it anyway.
            let p = e0 + split * (e1 + split * (e2 + split * e3));
            let (up, down) = lines(split, len);
            let inv_len = if len > 0.0 { 1.0 / len } else { 0.0 };
            up_slope = up_slope.max((p + up * (len - split) - u0) * inv_len);
            down_slope = down_slope.min((p + down * (len - split) - d0) * inv_len);
        }
    }
    Bound { v: f.v * g.v, a_lo: d0, b_lo: 0.5 * down_slope, a_hi: u0, b_hi: 0.5 * up_slope, e_hi: 0.0, t_valid: f.t_valid.min(g.t_valid) }
}

/// The compact kernel `w (a - x²/R²)³` on `x ∈ [x0, x0 + len]`, bottom up
/// as in Figure 11: the exact quadratic `Q = a - x²/R²`, then `Q·Q`, then
/// `(Q·Q)·Q`.
pub(super) fn compact_quad(w: f64, inv_r2: f64, a: f64, x0: f64, len: f64, extension: bool) -> Bound {
    if a <= 0.0 {
        return Bound::zero();
    }
    let l = (a / inv_r2).sqrt();
    let (xa, xb) = (x0.max(-l), (x0 + len).min(l));
    if xa >= xb {
        return Bound::zero();
    }
    if !extension {
        // max(Q, 0)³ on the whole interval.
        let q = Bound::exact(a - x0 * x0 * inv_r2, -2.0 * x0 * inv_r2, -inv_r2);
        let m = max_bound(&q, &Bound::zero(), len, true);
        return mul(&mul(&m, &m, len), &m, len).scaled(w);
    }
    // Section 6.2.1: the bound of the part inside the support...
    let sub = xb - xa;
    let entering = xa > x0;
    let q0 = if entering { 0.0 } else { a - xa * xa * inv_r2 };
    let q = Bound::exact(q0, -2.0 * xa * inv_r2, -inv_r2);
    let mut k = mul(&mul(&q, &q, sub), &q, sub).scaled(w);
    // ...extended to the whole interval (Figure 9, docs/paper-digest.md 5.4).
    if entering {
        // The kernel is 0 on [x0, xa]. In Bézier form on [x0, xb] the new
        // upper bound has control values (0, d1, d2); its piece on [xa, xb]
        // has (B(λ), (1-λ) d1 + λ d2, d2), which dominate the old controls
        // (0, c1, c2) when d2 = c2 and d1 is as below (all >= 0, so it also
        // stays >= 0 before xa). The lower bound is 0.
        let span = xb - x0;
        let lambda = (xa - x0) / span;
        let c1 = k.v + 0.5 * k.a_hi * sub;
        let c2 = k.hi(sub).max(0.0);
        let d1 = ((c1 - lambda * c2) / (1.0 - lambda)).max(0.0);
        k = Bound { a_hi: 2.0 * d1 / span, b_hi: (c2 - 2.0 * d1) / (span * span), ..Bound::zero() };
    }
    if xb < x0 + len {
        // The kernel is 0 on [xb, x0 + len]: raise the upper curvature so
        // the upper bound stays >= 0 there, lower the lower one so it stays
        // <= 0. In y = 1/τ, -U(τ)/τ² = -v y² - a y - b is concave: its
        // maximum over [1/len, 1/τ1] is at the vertex or an end, and at
        // y = 1/τ1 it is <= 0 already (U >= k >= 0 on the support). L(τ)/τ²
        // is convex and <= 0 at y = 1/τ1: only y = 1/len matters.
        let tau1 = xb - x0;
        let y = 1.0 / len;
        let mut raise = -k.v * y * y - k.a_hi * y - k.b_hi;
        if k.v > 0.0 && k.a_hi < 0.0 {
            let vertex = -k.a_hi / (2.0 * k.v);
            if vertex > y && -k.a_hi * tau1 < 2.0 * k.v {
                raise = raise.max(-0.5 * k.a_hi * vertex - k.b_hi);
            }
        }
        k.b_hi += raise.max(0.0);
        k.b_lo -= (k.v * y * y + k.a_lo * y + k.b_lo).max(0.0);
    }
    k
}

/// The slope of the chord of `w e^{-y}` between `y0` and `y1`, accurate
/// when they are close (series of `(e^{-d} - 1)/d`) and finite for any
/// `y >= 0`.
pub fn exp_chord(w: f64, y0: f64, y1: f64) -> f64 {
    let d = y1 - y0;
    if d.abs() < 1e-2 {
        let v = w * (-y0.min(y1)).exp();
        let d = d.abs();
        // Chord slope from the smaller y: e^{-y_min}(e^{-d} - 1)/d.
        v * (-1.0 + d * (0.5 - d * (1.0 / 6.0 - d / 24.0)))
    } else {
        w * ((-y1).exp() - (-y0).exp()) / d
    }
}

/// The Gaussian `w e^{-y}`, `y = α (x² + h²)` on `x ∈ [x0, x0 + len]`
/// (Appendix B): `e^{-y}` is decreasing and convex, so its tangent at
/// `y(t0)` is a lower bound everywhere (composed with the exact quadratic
/// y, slope `-v y'`), and a chord through `y(t0)` an upper bound wherever
/// y stays within the chord's ends, which needs `y(t0)` to be an end of
/// y's range: see [`ExpUpper`] for the case where it is not. May shorten
/// `len`.
pub(super) fn gaussian_quad(w: f64, alpha: f64, h2: f64, x0: f64, len: &mut f64, rule: ExpUpper, validity_floor: f64) -> Bound {
    let y = |x: f64| alpha * (x * x + h2);
    let (y0, y1, c) = (y(x0), 2.0 * alpha * x0, alpha);
    let v = w * (-y0).exp();
    let mut b = Bound { v, a_lo: -v * y1, b_lo: -v * c, a_hi: 0.0, b_hi: 0.0, e_hi: 0.0, t_valid: f64::INFINITY };
    let y_end = y(x0 + *len);
    let straddles = x0 < 0.0 && y_end > y0;
    let slope = if !straddles {
        // y(t0) is the least value (x0 >= 0) or the largest: the chord to
        // the other extreme of y on the interval.
        let other = if x0 >= 0.0 { y_end } else { y((x0 + *len).min(0.0)) };
        exp_chord(w, y0, other)
    } else {
        let y_min = alpha * h2;
        let faint = w * (-y_min).exp() < validity_floor;
        match if rule == ExpUpper::Validity && faint { ExpUpper::RelaxedMax } else { rule } {
            ExpUpper::Validity => {
                // Up to the point symmetric to t0 about the closest
                // approach, y(t0) is the largest value.
                *len = -2.0 * x0;
                exp_chord(w, y0, y_min)
            }
            ExpUpper::RelaxedT0 => {
                // The chord over [y_min, y_end] lies above w e^{-y(t0)} by
                // (y0 - y_min)(S - chord(y_min, y0)).
                let s = exp_chord(w, y_min, y_end);
                b.e_hi = ((y0 - y_min) * (s - exp_chord(w, y_min, y0))).max(0.0);
                s
            }
            ExpUpper::RelaxedMax => {
                // The chord S from y0 to y_end holds for y >= y0; below y0
                // its deficit is convex in y, 0 at y0 and
                // D = (y0 - y_min)(S - chord(y_min, y0)) at y_min, so at
                // most D (y0 - y)/(y0 - y_min) <= D·2α|x0|τ/(α x0²).
                let s = exp_chord(w, y0, y_end);
                b.a_hi = 2.0 * alpha * x0.abs() * (s - exp_chord(w, y_min, y0)).max(0.0);
                s
            }
        }
    };
    b.a_hi += slope * y1;
    b.b_hi = slope * c;
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// Dense samples of `f` on `[0, len]` lie within the bound.
    fn contains(b: &Bound, len: f64, f: impl Fn(f64) -> f64) -> f64 {
        let scale = 1.0 + b.v.abs();
        (0..=400)
            .map(|i| {
                let tau = len * f64::from(i) / 400.0;
                let y = f(tau);
                (b.lo(tau) - y).max(y - b.hi(tau)).max(0.0) / scale
            })
            .fold(0.0, f64::max)
    }

    fn random_quadratic(rng: &mut Pcg64Mcg) -> (f64, f64, f64) {
        (rng.random_range(-2.0..2.0), rng.random_range(-3.0..3.0), rng.random_range(-2.0..2.0))
    }

    #[test]
    fn products_of_quadratic_bounds_contain_the_product() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        for _ in 0..3000 {
            let len = rng.random_range(0.0..3.0);
            // Two functions, each a quadratic plus a bounded wiggle, and
            // bounds that contain them.
            let (p, q) = (random_quadratic(&mut rng), random_quadratic(&mut rng));
            let (wp, wq) = (rng.random_range(0.0..0.5), rng.random_range(0.0..0.5));
            let f = |t: f64| p.0 + p.1 * t + p.2 * t * t + wp * (3.0 * t).sin() * t * t / (1.0 + t * t);
            let g = |t: f64| q.0 + q.1 * t + q.2 * t * t - wq * (5.0 * t).cos().abs() * t * t / (1.0 + t * t);
            let fb = Bound { b_lo: p.2 - wp, b_hi: p.2 + wp, ..Bound::exact(p.0, p.1, p.2) };
            let gb = Bound { b_lo: q.2 - wq, b_hi: q.2, ..Bound::exact(q.0, q.1, q.2) };
            assert!(contains(&fb, len, f) < 1e-12 && contains(&gb, len, g) < 1e-12);
            let m = mul(&fb, &gb, len);
            assert_eq!(m.v, p.0 * q.0);
            let out = contains(&m, len, |t| f(t) * g(t));
            assert!(out < 1e-9, "product bound {m:?} misses f g by {out} on [0, {len}]");
        }
    }

    #[test]
    fn exp_chord_matches_the_difference_quotient() {
        for (y0, y1) in [(0.3f64, 0.31f64), (2.0, 1.995), (0.0, 5.0), (40.0, 1.0), (1.0, 1.0)] {
            let direct = if y0 == y1 { -(-y0).exp() } else { ((-y1).exp() - (-y0).exp()) / (y1 - y0) };
            let c = exp_chord(2.0, y0, y1);
            assert!((c - 2.0 * direct).abs() <= 1e-9 * direct.abs().max(1e-300), "{y0} {y1}: {c} vs {}", 2.0 * direct);
        }
    }

    #[test]
    fn kernel_bounds_contain_the_kernel_for_every_rule() {
        let mut rng = Pcg64Mcg::seed_from_u64(2);
        let rules = [ExpUpper::Validity, ExpUpper::RelaxedT0, ExpUpper::RelaxedMax];
        let (mut kept, mut n) = (0.0, 0);
        for i in 0..4000 {
            let x0 = rng.random_range(-3.0..3.0);
            let len0 = rng.random_range(0.0..5.0);
            let h2 = rng.random_range(0.0..2.0);
            // Gaussian.
            let (w, alpha) = (rng.random_range(0.1..3.0), rng.random_range(0.1..4.0));
            for rule in rules {
                let mut len = len0;
                let b = gaussian_quad(w, alpha, h2, x0, &mut len, rule, 0.0);
                let k = |tau: f64| w * (-alpha * ((x0 + tau) * (x0 + tau) + h2)).exp();
                assert!((b.v - k(0.0)).abs() < 1e-14 && b.e_hi >= 0.0);
                assert!(rule == ExpUpper::RelaxedT0 || b.e_hi == 0.0, "{rule:?} must be exact at t0");
                let out = contains(&b, len, k);
                assert!(out < 1e-12, "{rule:?} x0={x0} len={len} h2={h2}: Gaussian bound misses by {out}");
                if rule == ExpUpper::Validity && len0 > 0.0 {
                    kept += len / len0;
                    n += 1;
                }
            }
            // Compact, with and without the extension.
            let inv_r2 = 1.0 / rng.random_range(0.5f64..2.5).powi(2);
            let a = 1.0 - h2 * inv_r2;
            for extension in [true, false] {
                let b = compact_quad(1.5, inv_r2, a, x0, len0, extension);
                let k = |tau: f64| {
                    let q = a - (x0 + tau) * (x0 + tau) * inv_r2;
                    if q > 0.0 { 1.5 * q * q * q } else { 0.0 }
                };
                assert!((b.v - k(0.0)).abs() < 1e-12, "case {i}: not exact at t0");
                let out = contains(&b, len0, k);
                assert!(out < 1e-10, "case {i} extension={extension} x0={x0} len={len0} a={a}: compact bound misses by {out}");
            }
        }
        assert!(kept / f64::from(n) > 0.5, "validity intervals kept {}", kept / f64::from(n));
    }

    #[test]
    fn faint_gaussians_keep_the_interval_and_stay_valid() {
        // The ray passes the centre at x = 0, 2 units away: the peak on the
        // ray is w e^{-α h²} = 2 e^{-4}.
        let (w, alpha, h2, x0) = (2.0f64, 1.0f64, 4.0f64, -1.0f64);
        let peak = w * (-alpha * h2).exp();
        let k = |tau: f64| w * (-alpha * ((x0 + tau) * (x0 + tau) + h2)).exp();
        let mut len = 5.0;
        let cut = gaussian_quad(w, alpha, h2, x0, &mut len, ExpUpper::Validity, 0.5 * peak);
        assert_eq!(len, 2.0, "a significant Gaussian cuts the interval at the point symmetric to t0");
        assert!(contains(&cut, len, k) < 1e-12);
        let mut len = 5.0;
        let faint = gaussian_quad(w, alpha, h2, x0, &mut len, ExpUpper::Validity, 2.0 * peak);
        assert_eq!(len, 5.0, "a faint Gaussian keeps the whole interval");
        assert!(faint.e_hi == 0.0 && contains(&faint, len, k) < 1e-12);
    }
}
