//! Hermite RBF terms (the paper's Eq. 9 with φ(r) = r³) and the affine
//! polynomial term that goes with them, as [`PrimitiveKind`]s: the f64
//! mirror of `shaders/include/kinds/hrbf.glsl` and `kinds/affine.glsl`. The fit that produces the
//! weights is `scene/hrbf.rs`; docs/hrbf.md has the derivations in full.
//!
//! One term about its control point c is
//!
//! ```text
//! g(p) = α r³ + β·∇(r³) = α r³ + 3 r β·(p - c),   r = |p - c|.
//! ```
//!
//! Along a ray `p = o + t u` write `x = t - tc` (tc the closest approach),
//! `h` the distance of c from the line and `w` the vector from c to the
//! closest point (`|w| = h`). Then `r = ρ(x) = √(x² + h²)`,
//! `β·(p - c) = c0 + c1 x` with `c0 = β·w`, `c1 = β·u`, and the term is one
//! product of a convex function and an exact quadratic:
//!
//! ```text
//! g = ρ P,   P(x) = α x² + 3 c1 x + α h² + 3 c0
//! g'  = (x/ρ) P + ρ P'
//! g'' = (h/ρ)² (α ρ + 3 c1 x/ρ + 3 ĉ0 h/ρ) + 2 (x/ρ) P' + 2 α ρ,   ĉ0 = β·w/h
//! ```
//!
//! written with the bounded ratios x/ρ and h/ρ (|c0| ≤ |β| h), so that it
//! stays finite as the ray nears the control point. g is C¹; g'' is bounded
//! but jumps at the control point itself (h = 0: g'' = 6α|x| + 6 c1 sign x).
//!
//! - **Quadratic Taylor** takes the exact range of g'' over the interval:
//!   its values at the ends and at the roots of g''' inside. With
//!   `x = h s`, `ρ⁵ g''' / 3 = h⁴ M(s)` where
//!   `M(s) = αh s (2s² + 3)(s² + 1) - 3 ĉ0 s + 3 c1`, a quintic whose
//!   derivative `αh (10 s⁴ + 15 s² + 3) - 3 ĉ0` has at most two real roots
//!   `±s*`, so M is monotone on at most three pieces and each holds at most
//!   one root, found by safeguarded Newton. Real roots lie in
//!   `|s| ≤ max(1, (1.5 (|ĉ0| + |c1|) / |αh|)^¼)`. g'' at the estimate is
//!   widened by `3 (b - a) max(|M(a)|, |M(b)|)` over the final bracket
//!   [a, b], a bound of how far it can be from g'' at the true root, so
//!   that the range is valid however far the steps got.
//! - **Linear Taylor** needs the range of g'; it is bounded (not exactly)
//!   from g' at both ends and the range [m, M] of g'': g' lies below both
//!   `g'(x0) + M τ` and `g'(x1) - m (L - τ)`, and above their mirror images.
//! - **Bottom-up linear**: ρ is convex (tangent below, chord above), P is a
//!   quadratic (convex or concave as α's sign), and the product is Eq. 17's.
//! - **Bottom-up quadratic**: ρ is bounded by quadratics exact at t0 with
//!   curvatures from its own second derivative `h²/ρ³` (least at the far
//!   end; greatest at the least ρ, capped by `1/ρ0` from the tangent of √y
//!   in `y = x² + h²`), times the exact P by Figure 8's product. Near a
//!   control point ρ's curvature grows as 1/h while g'' stays bounded, so
//!   each side's curvature is also capped by `G/2`, G a cheap bound on |g''|
//!   over the interval (from the formula above, term by term).
//! - **RAA**: `y = x² + h²` in affine form, √y by the min-range
//!   linearisation of a concave increasing function, times P.
//! - **Segment tracing**: `|g'| ≤ max|x/ρ| max|P| + max ρ max|P'|` over the
//!   segment (x/ρ is monotone, ρ convex, P' linear: ends and P's vertex).
//! - **Sphere tracing**: `|∇g| ≤ 3|α| r² + 6|β| r`, so over the box where
//!   rays march, `3|α| R² + 6|β| R` with R the farthest corner from c.

use glam::DVec3;

use super::bound::Bound;
use super::bounds::{Lin, Order, Taylor};
use super::kinds::PrimitiveKind;
use super::quad::{self, QuadOptions};
use super::raa::Affine;
use crate::scene::Aabb;

/// One HRBF term; `reach` is the largest distance from `center` to the box
/// where rays march (for the global Lipschitz bound).
#[derive(Clone, Copy, Debug)]
pub struct HrbfPrim {
    pub center: DVec3,
    pub alpha: f64,
    pub beta: DVec3,
    pub reach: f64,
}

/// An affine function `gradient · p + offset` (an HRBF's polynomial term,
/// plus the iso value); `reach` as for [`HrbfPrim`], from the origin.
#[derive(Clone, Copy, Debug)]
pub struct AffinePrim {
    pub gradient: DVec3,
    pub offset: f64,
    pub reach: f64,
}

/// The farthest corner of `b` from `c`.
pub fn farthest(b: &Aabb, c: DVec3) -> f64 {
    let d = (b.min - c).abs().max((b.max - c).abs());
    d.length()
}

/// Newton iterations (safeguarded by the bracket) for each root of M.
const ROOT_ITERATIONS: usize = 60;

/// An HRBF term along one ray: see the module documentation.
#[derive(Clone, Copy, Debug)]
struct OnRay {
    alpha: f64,
    h: f64,
    h2: f64,
    x0: f64,
    /// β·w, β·w/h (0 when h = 0), β·u.
    c0: f64,
    c0_hat: f64,
    c1: f64,
}

impl OnRay {
    fn new(p: &HrbfPrim, o: DVec3, u: DVec3, t0: f64) -> OnRay {
        let co = p.center - o;
        let tc = co.dot(u);
        let w = tc * u - co;
        let h2 = w.length_squared();
        let h = h2.sqrt();
        let c0 = p.beta.dot(w);
        OnRay { alpha: p.alpha, h, h2, x0: t0 - tc, c0, c0_hat: if h > 0.0 { c0 / h } else { 0.0 }, c1: p.beta.dot(u) }
    }

    fn p(&self, x: f64) -> f64 {
        self.alpha * x * x + 3.0 * self.c1 * x + self.alpha * self.h2 + 3.0 * self.c0
    }

    fn dp(&self, x: f64) -> f64 {
        2.0 * self.alpha * x + 3.0 * self.c1
    }

    fn rho(&self, x: f64) -> f64 {
        (x * x + self.h2).sqrt()
    }

    /// (ρ, x/ρ, h/ρ); at the control point itself (ρ = 0) the side
    /// `right` says which one-sided limit of x/ρ to take.
    fn angles(&self, x: f64, right: bool) -> (f64, f64, f64) {
        let r = self.rho(x);
        if r > 0.0 { (r, x / r, self.h / r) } else { (0.0, if right { 1.0 } else { -1.0 }, 0.0) }
    }

    fn value(&self, x: f64) -> f64 {
        self.rho(x) * self.p(x)
    }

    fn d1(&self, x: f64) -> f64 {
        let (r, cs, _) = self.angles(x, true);
        cs * self.p(x) + r * self.dp(x)
    }

    /// g'' at x; at the control point, its limit from the side `right`.
    fn d2(&self, x: f64, right: bool) -> f64 {
        let (r, cs, sn) = self.angles(x, right);
        let a = self.alpha;
        sn * sn * (a * r + 3.0 * self.c1 * cs + 3.0 * self.c0_hat * sn) + 2.0 * cs * self.dp(x) + 2.0 * a * r
    }

    /// M(s) and M'(s) (module documentation), `ah = αh`.
    fn m(&self, s: f64) -> (f64, f64) {
        let ah = self.alpha * self.h;
        let s2 = s * s;
        (ah * s * (2.0 * s2 + 3.0) * (s2 + 1.0) - 3.0 * self.c0_hat * s + 3.0 * self.c1, ah * (10.0 * s2 * s2 + 15.0 * s2 + 3.0) - 3.0 * self.c0_hat)
    }

    /// The roots of g''' in `(xa, xb)`, as x, each with the most g'' there
    /// may differ from g'' at the exact root ([`Self::monotone_root`]).
    fn d3_roots(&self, xa: f64, xb: f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        if self.h == 0.0 {
            return out;
        }
        let ah = self.alpha * self.h;
        let (c0, c1) = (self.c0_hat, self.c1);
        if ah == 0.0 {
            if c0 != 0.0 {
                out.push((self.h * c1 / c0, 0.0));
            }
            return out.into_iter().filter(|&(x, _)| x > xa && x < xb).collect();
        }
        let bound = (1.5 * (c0.abs() + c1.abs()) / ah.abs()).powf(0.25).max(1.0);
        let (sa, sb) = ((xa / self.h).max(-bound), (xb / self.h).min(bound));
        if sa >= sb {
            return out;
        }
        let mut cuts = vec![sa];
        let k = 3.0 * c0 / ah;
        if k > 3.0 {
            // 10 y² + 15 y + 3 = K for y = s², without cancellation.
            let y = (2.0 * k - 6.0) / (15.0 + 40f64.sqrt() * (k + 2.625).sqrt());
            let s = y.sqrt();
            cuts.extend([-s, s].into_iter().filter(|&c| c > sa && c < sb));
        }
        cuts.push(sb);
        for pair in cuts.windows(2) {
            if let Some((s, pad)) = self.monotone_root(pair[0], pair[1]) {
                out.push((self.h * s, pad));
            }
        }
        out
    }

    /// The root of M on `[a, b]`, where M is monotone, if it changes sign,
    /// and how far g'' at it may be from g'' at the true root: at most
    /// `sup|g'''| h |s - s*|`, and with `ρ⁵ g''' = 3 h⁴ M`, `ρ >= h` and M
    /// monotone on the final bracket, at most `3 (b - a) max(|M(a)|, |M(b)|)`.
    fn monotone_root(&self, mut a: f64, mut b: f64) -> Option<(f64, f64)> {
        let (mut ma, mut mb) = (self.m(a).0, self.m(b).0);
        if (ma > 0.0) == (mb > 0.0) && ma != 0.0 && mb != 0.0 {
            return None;
        }
        let a_positive = ma > 0.0;
        let mut s = 0.5 * (a + b);
        for _ in 0..ROOT_ITERATIONS {
            let (m, dm) = self.m(s);
            if (m > 0.0) == a_positive {
                a = s;
                ma = m;
            } else {
                b = s;
                mb = m;
            }
            let newton = s - m / dm;
            s = if dm != 0.0 && newton > a && newton < b { newton } else { 0.5 * (a + b) };
            if b - a <= 1e-15 * s.abs().max(1.0) {
                break;
            }
        }
        Some((s, 3.0 * (b - a) * ma.abs().max(mb.abs())))
    }

    /// The exact range of g'' over `[xa, xb]`.
    fn d2_range(&self, xa: f64, xb: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut see = |v: f64| {
            lo = lo.min(v);
            hi = hi.max(v);
        };
        // At an end that is the control point, the limit from inside.
        see(self.d2(xa, true));
        see(self.d2(xb, xb <= xa));
        if self.h == 0.0 && xa < 0.0 && xb > 0.0 {
            see(self.d2(0.0, false));
            see(self.d2(0.0, true));
        }
        for (x, pad) in self.d3_roots(xa, xb) {
            let d = self.d2(x, true);
            see(d - pad);
            see(d + pad);
        }
        (lo, hi)
    }

    /// A range of g' over `[xa, xb]` from its ends and g'''s range.
    fn d1_range(&self, xa: f64, xb: f64) -> (f64, f64) {
        let (ga, gb) = (self.d1(xa), self.d1(xb));
        let len = xb - xa;
        let (m, mm) = self.d2_range(xa, xb);
        d1_range_from(ga, gb, len, m, mm)
    }

    /// Largest |g''| over `[xa, xb]`, cheaply (term by term).
    fn d2_magnitude(&self, xa: f64, xb: f64) -> f64 {
        let a = self.alpha.abs();
        let rho_max = self.rho(xa).max(self.rho(xb));
        // (h/ρ)² |x/ρ| ≤ 2/(3√3).
        a * self.h
            + 3.0 * 0.384_900_179_459_750_5 * self.c1.abs()
            + 3.0 * self.c0_hat.abs()
            + 2.0 * self.dp(xa).abs().max(self.dp(xb).abs())
            + 2.0 * a * rho_max
    }
}

/// g' lies below `ga + M τ` and `gb - m (len - τ)` (and above the mirror
/// images) for τ in [0, len], where g'' ∈ [m, M]: the extremes of those
/// envelopes.
fn d1_range_from(ga: f64, gb: f64, len: f64, m: f64, mm: f64) -> (f64, f64) {
    let (lo_end, hi_end) = (ga.min(gb), ga.max(gb));
    if len <= 0.0 || mm - m <= 0.0 {
        return (lo_end, hi_end);
    }
    // Upper: the lines cross at τ* where ga + M τ = gb - m (len - τ).
    let tau_hi = ((gb - ga - m * len) / (mm - m)).clamp(0.0, len);
    let hi = if mm < 0.0 {
        ga
    } else if m > 0.0 {
        gb
    } else {
        ga + mm * tau_hi
    };
    let tau_lo = ((mm * len - (gb - ga)) / (mm - m)).clamp(0.0, len);
    let lo = if m > 0.0 {
        ga
    } else if mm < 0.0 {
        gb
    } else {
        ga + m * tau_lo
    };
    (lo.min(lo_end), hi.max(hi_end))
}

impl PrimitiveKind for HrbfPrim {
    fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        let d = p - self.center;
        let r = d.length();
        let bd = self.beta.dot(d);
        let grad = if r > 0.0 { 3.0 * self.alpha * r * d + 3.0 * bd * d / r + 3.0 * r * self.beta } else { DVec3::ZERO };
        (self.alpha * r * r * r + 3.0 * r * bd, grad)
    }

    fn value(&self, p: DVec3) -> f64 {
        let d = p - self.center;
        let r = d.length();
        self.alpha * r * r * r + 3.0 * r * self.beta.dot(d)
    }

    fn lipschitz(&self) -> f64 {
        3.0 * self.alpha.abs() * self.reach * self.reach + 6.0 * self.beta.length() * self.reach
    }

    fn segment_slope(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> f64 {
        let g = OnRay::new(self, o, u, ta);
        let (xa, xb) = (g.x0, g.x0 + (tb - ta));
        let (ra, ca, _) = g.angles(xa, true);
        let (rb, cb, _) = g.angles(xb, false);
        let mut p_max = g.p(xa).abs().max(g.p(xb).abs());
        if g.alpha != 0.0 {
            let vertex = -1.5 * g.c1 / g.alpha;
            if vertex > xa && vertex < xb {
                p_max = p_max.max(g.p(vertex).abs());
            }
        }
        ca.abs().max(cb.abs()) * p_max + ra.max(rb) * g.dp(xa).abs().max(g.dp(xb).abs())
    }

    fn taylor(&self, o: DVec3, u: DVec3, t0: f64, t1: f64, order: Order, _extension: bool) -> Taylor {
        let g = OnRay::new(self, o, u, t0);
        let (xa, xb) = (g.x0, g.x0 + (t1 - t0));
        let (min, max) = match order {
            Order::Linear => g.d1_range(xa, xb),
            Order::Quadratic => g.d2_range(xa, xb),
        };
        Taylor { value: g.value(xa), slope: g.d1(xa), min, max }
    }

    fn linear(&self, o: DVec3, u: DVec3, t0: f64, len: f64) -> Lin {
        let g = OnRay::new(self, o, u, t0);
        let (x0, x1) = (g.x0, g.x0 + len);
        let (r0, r1) = (g.rho(x0), g.rho(x1));
        // ρ is convex: the tangent (a subgradient at the control point)
        // below, the chord above.
        let tangent = if r0 > 0.0 { x0 / r0 } else { 1.0 };
        let rho = Lin { v: r0, lo: tangent, hi: if len > 0.0 { (r1 - r0) / len } else { tangent } };
        // P is a quadratic: tangent and chord, by the sign of α.
        let (p_tangent, p_chord) = (g.dp(x0), g.dp(x0) + g.alpha * len);
        let p = Lin { v: g.p(x0), lo: p_tangent.min(p_chord), hi: p_tangent.max(p_chord) };
        rho.mul(p, len)
    }

    fn quadratic(&self, o: DVec3, u: DVec3, t0: f64, len: &mut f64, _opts: QuadOptions) -> Bound {
        let g = OnRay::new(self, o, u, t0);
        let (x0, x1) = (g.x0, g.x0 + *len);
        let (r0, r1) = (g.rho(x0), g.rho(x1));
        let rho_max = r0.max(r1);
        let rho_min = if x0 <= 0.0 && x1 >= 0.0 { g.h } else { r0.min(r1) };
        let slope = if r0 > 0.0 { x0 / r0 } else { 1.0 };
        let curv_lo = if rho_max > 0.0 { g.h2 / (rho_max * rho_max * rho_max) } else { 0.0 };
        let curv_hi = if r0 == 0.0 {
            0.0 // h = 0 and x0 = 0: ρ = τ exactly
        } else if rho_min > 0.0 {
            (g.h2 / (rho_min * rho_min * rho_min)).min(1.0 / r0)
        } else {
            1.0 / r0
        };
        let rho = Bound { v: r0, a_lo: slope, b_lo: 0.5 * curv_lo, a_hi: slope, b_hi: 0.5 * curv_hi, e_hi: 0.0, t_valid: f64::INFINITY };
        let p = Bound::exact(g.p(x0), g.dp(x0), g.alpha);
        let mut b = quad::mul(&rho, &p, *len);
        // Near the control point ρ's curvature grows as 1/h while g'' stays
        // bounded: cap each side by the Taylor bound of |g''| ≤ G.
        let cap = 0.5 * g.d2_magnitude(x0, x1);
        b.b_hi = b.b_hi.min(cap);
        b.b_lo = b.b_lo.max(-cap);
        b
    }

    fn raa(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> Affine {
        let g = OnRay::new(self, o, u, ta);
        let (xa, xb) = (g.x0, g.x0 + (tb - ta));
        let x = Affine { x0: 0.5 * (xa + xb), x1: 0.5 * (xb - xa), e: 0.0 };
        let y = x * x + Affine { x0: g.h2, x1: 0.0, e: 0.0 };
        let rho = sqrt_affine(y, g.h2);
        let p = y.scale(g.alpha) + x.scale(3.0 * g.c1) + Affine { x0: 3.0 * g.c0, x1: 0.0, e: 0.0 };
        rho * p
    }
}

/// √y by min-range linearisation on the range of y, which is at least
/// `y_min >= 0`: √ is concave and increasing, so with the least slope
/// `s = 1/(2√hi)`, `√y - s y` increases over the range.
pub fn sqrt_affine(y: Affine, y_min: f64) -> Affine {
    let (lo, hi) = y.range();
    let hi = hi.max(y_min);
    let lo = lo.max(y_min).min(hi);
    if hi <= 0.0 {
        return Affine::ZERO;
    }
    let s = 0.5 / hi.sqrt();
    let (top, bottom) = (hi.sqrt() - s * hi, lo.sqrt() - s * lo);
    Affine { x0: s * y.x0 + 0.5 * (top + bottom), x1: s * y.x1, e: s * y.e + 0.5 * (top - bottom) }
}

impl PrimitiveKind for AffinePrim {
    fn value_gradient(&self, p: DVec3) -> (f64, DVec3) {
        (self.value(p), self.gradient)
    }

    fn value(&self, p: DVec3) -> f64 {
        self.gradient.dot(p) + self.offset
    }

    fn lipschitz(&self) -> f64 {
        self.gradient.length()
    }

    fn segment_slope(&self, _o: DVec3, u: DVec3, _ta: f64, _tb: f64) -> f64 {
        self.gradient.dot(u).abs()
    }

    fn taylor(&self, o: DVec3, u: DVec3, t0: f64, _t1: f64, order: Order, _extension: bool) -> Taylor {
        let slope = self.gradient.dot(u);
        let d = if order == Order::Linear { slope } else { 0.0 };
        Taylor { value: self.value(o + t0 * u), slope, min: d, max: d }
    }

    fn linear(&self, o: DVec3, u: DVec3, t0: f64, _len: f64) -> Lin {
        let slope = self.gradient.dot(u);
        Lin { v: self.value(o + t0 * u), lo: slope, hi: slope }
    }

    fn quadratic(&self, o: DVec3, u: DVec3, t0: f64, _len: &mut f64, _opts: QuadOptions) -> Bound {
        Bound::exact(self.value(o + t0 * u), self.gradient.dot(u), 0.0)
    }

    fn raa(&self, o: DVec3, u: DVec3, ta: f64, tb: f64) -> Affine {
        let tm = 0.5 * (ta + tb);
        Affine { x0: self.value(o + tm * u), x1: self.gradient.dot(u) * 0.5 * (tb - ta), e: 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn random_term(rng: &mut Pcg64Mcg) -> HrbfPrim {
        let mut v = || DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let (center, beta) = (v(), 0.5 * v());
        HrbfPrim { center, alpha: rng.random_range(-1.0..1.0), beta, reach: 10.0 }
    }

    /// Rays at every distance from the control point, down to through it.
    fn random_ray(rng: &mut Pcg64Mcg, p: &HrbfPrim) -> (DVec3, DVec3, f64, f64) {
        let u = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize();
        let side = u.any_orthonormal_vector() * 10f64.powf(rng.random_range(-6.0..0.5)) * f64::from(rng.random_range(0..6).min(1));
        let o = p.center + side - 3.0 * u;
        let t0 = rng.random_range(0.0..5.0);
        (o, u, t0, t0 + rng.random_range(0.0..3.0) * rng.random::<f64>())
    }

    #[test]
    fn derivatives_along_the_ray_match_finite_differences() {
        let mut rng = Pcg64Mcg::seed_from_u64(1);
        for _ in 0..500 {
            let p = random_term(&mut rng);
            let (o, u, t0, _) = random_ray(&mut rng, &p);
            let g = OnRay::new(&p, o, u, t0);
            let f = |t: f64| p.value(o + t * u);
            let e = 1e-4;
            assert!((g.value(g.x0) - f(t0)).abs() < 1e-12 * (1.0 + f(t0).abs()));
            if g.rho(g.x0) < 1e-2 {
                continue; // g'' jumps at the control point
            }
            let d1 = (f(t0 + e) - f(t0 - e)) / (2.0 * e);
            let d2 = (f(t0 + e) - 2.0 * f(t0) + f(t0 - e)) / (e * e);
            assert!((g.d1(g.x0) - d1).abs() < 1e-6 * (1.0 + d1.abs()), "g' {} vs {d1}", g.d1(g.x0));
            assert!((g.d2(g.x0, true) - d2).abs() < 1e-4 * (1.0 + d2.abs()), "g'' {} vs {d2}", g.d2(g.x0, true));
            let (_, grad) = p.value_gradient(o + t0 * u);
            assert!((grad.dot(u) - d1).abs() < 1e-6 * (1.0 + d1.abs()));
        }
    }

    /// Every bound contains dense samples of the term, and the Taylor
    /// ranges are the sampled ranges (exact, not just valid).
    #[test]
    fn bounds_contain_the_term_and_the_second_derivative_range_is_exact() {
        let mut rng = Pcg64Mcg::seed_from_u64(2);
        let opts = QuadOptions { exp_upper: crate::settings::ExpUpper::Validity, extension: true, validity_floor: 0.0 };
        for _ in 0..1500 {
            let p = random_term(&mut rng);
            let (o, u, t0, t1) = random_ray(&mut rng, &p);
            let f = |t: f64| p.value(o + t * u);
            let len = t1 - t0;
            let scale = 1.0 + (0..=20).map(|i| f(t0 + len * f64::from(i) / 20.0).abs()).fold(0.0, f64::max);
            let mut l = len;
            let quad = p.quadratic(o, u, t0, &mut l, opts);
            assert_eq!(l, len);
            let lin = p.linear(o, u, t0, len);
            let (lo, hi) = p.raa(o, u, t0, t1).range();
            let k2 = p.taylor(o, u, t0, t1, Order::Quadratic, false);
            let k1 = p.taylor(o, u, t0, t1, Order::Linear, false);
            assert!((quad.v - f(t0)).abs() < 1e-12 * scale && (lin.v - f(t0)).abs() < 1e-12 * scale);
            let (mut d2lo, mut d2hi) = (f64::INFINITY, f64::NEG_INFINITY);
            let g = OnRay::new(&p, o, u, t0);
            for i in 0..=400 {
                let tau = len * f64::from(i) / 400.0;
                let v = f(t0 + tau);
                let tol = 1e-9 * scale;
                assert!(v >= quad.lo(tau) - tol && v <= quad.hi(tau) + tol, "quadratic {quad:?} misses {v} at τ={tau}");
                assert!(v >= lin.v + lin.lo * tau - tol && v <= lin.v + lin.hi * tau + tol, "linear {lin:?} misses {v} at τ={tau}");
                assert!(v >= lo - tol && v <= hi + tol, "RAA [{lo}, {hi}] misses {v}");
                for (k, order) in [(k2, 2), (k1, 1)] {
                    let (m, mm) = (k.min, k.max);
                    let taylor = |c: f64| if order == 2 { k.value + k.slope * tau + 0.5 * c * tau * tau } else { k.value + c * tau };
                    assert!(v >= taylor(m) - tol && v <= taylor(mm) + tol, "Taylor {order} [{m}, {mm}] misses {v} at τ={tau}");
                }
                let d = g.d2(g.x0 + tau, true);
                d2lo = d2lo.min(d);
                d2hi = d2hi.max(d);
            }
            // Exactness: the range is the sampled one, up to the sampling
            // step (g'' is smooth away from the control point).
            let width = (k2.max - k2.min).max(1e-9);
            assert!(k2.min <= d2lo + 1e-9 * width && k2.max >= d2hi - 1e-9 * width, "range [{}, {}] misses sampled [{d2lo}, {d2hi}]", k2.min, k2.max);
            if g.h > 1e-2 {
                assert!(
                    k2.min >= d2lo - 0.01 * width && k2.max <= d2hi + 0.01 * width,
                    "range [{}, {}] wider than sampled [{d2lo}, {d2hi}]",
                    k2.min,
                    k2.max
                );
            }
        }
    }

    #[test]
    fn segment_and_global_slopes_bound_the_derivative() {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        for _ in 0..500 {
            let p = random_term(&mut rng);
            let (o, u, t0, t1) = random_ray(&mut rng, &p);
            let lambda = p.segment_slope(o, u, t0, t1);
            let reach = farthest(&Aabb { min: o.min(o + t1 * u), max: o.max(o + t1 * u) }, p.center);
            let global = HrbfPrim { reach, ..p }.lipschitz();
            for i in 0..=100 {
                let t = t0 + (t1 - t0) * f64::from(i) / 100.0;
                let (_, grad) = p.value_gradient(o + t * u);
                let d = grad.dot(u).abs();
                assert!(d <= lambda * (1.0 + 1e-9) + 1e-12, "|g'| = {d} > λ = {lambda}");
                assert!(grad.length() <= global * (1.0 + 1e-9) + 1e-12);
            }
        }
    }

    #[test]
    fn a_ray_through_the_control_point_gets_finite_exact_bounds() {
        let p = HrbfPrim { center: DVec3::ZERO, alpha: 0.7, beta: DVec3::new(0.3, -0.2, 0.5), reach: 5.0 };
        let opts = QuadOptions { exp_upper: crate::settings::ExpUpper::Validity, extension: true, validity_floor: 0.0 };
        for (t0, t1) in [(1.0, 3.0), (3.0, 4.0), (0.0, 3.0), (2.0, 3.0), (3.0, 3.0)] {
            let (o, u) = (DVec3::new(0.0, 0.0, -3.0), DVec3::Z);
            let k = p.taylor(o, u, t0, t1, Order::Quadratic, false);
            // h = 0: g'' = 6α|x| + 6 c1 sign x, c1 = β_z; at x = 0 the
            // limit from inside the interval.
            let g2 = |x: f64, right: bool| 6.0 * 0.7 * x.abs() + 3.0 * if x > 0.0 || (x == 0.0 && right) { 1.0 } else { -1.0 };
            let (xa, xb) = (t0 - 3.0, t1 - 3.0);
            let ends = [g2(xa, true), g2(xb, xb <= xa)];
            let mut want = [ends[0].min(ends[1]), ends[0].max(ends[1])];
            if xa < 0.0 && xb > 0.0 {
                want = [want[0].min(-3.0), want[1].max(3.0)];
            }
            let err = (k.min - want[0]).abs().max((k.max - want[1]).abs());
            assert!(err < 1e-12, "[{t0}, {t1}]: [{}, {}] vs {want:?}", k.min, k.max);
            let mut l = t1 - t0;
            let b = p.quadratic(o, u, t0, &mut l, opts);
            for x in [b.v, b.a_lo, b.b_lo, b.a_hi, b.b_hi] {
                assert!(x.is_finite());
            }
        }
    }
}
