// Forward inclusion functions along a ray (Sections 4-6): the bounds of
// one primitive, one function per kind, and the algebra that combines
// bounds (sums, products, max, roots); traverse.glsl folds them over the
// primitives. Mirrors src/field/bounds.rs, quad.rs and raa.rs, whose
// comments carry the derivations.
//
// A Bound on [t0, t1] is lo(τ) = v + a_lo τ + b_lo τ² and
// hi(τ) = v + e_hi + a_hi τ + b_hi τ², τ = t - t0, exact at t0 (forward)
// except for quadratic-relaxed-t0, whose upper bound starts e_hi >= 0 above.
#ifndef INCLUSION_GLSL
#define INCLUSION_GLSL

#include "field.glsl"

const float INFINITY = 3.0e38;

struct Bound {
    float v;
    float a_lo, b_lo;
    float a_hi, b_hi;
    float e_hi;
};

float bound_hi(Bound b, float tau) {
    return b.v + b.e_hi + tau * (b.a_hi + b.b_hi * tau);
}

struct Taylor {
    float value, slope, lo, hi;
};

// (k, k', k'') of the compact kernel w (a - x²/R²)³ at x; inv_r2 = 1/R².
vec3 compact_derivs(float w, float inv_r2, float a, float x) {
    float q = a - x * x * inv_r2;
    if (q <= 0.0) return vec3(0.0);
    return vec3(w * q * q * q, -6.0 * w * x * q * q * inv_r2, -6.0 * w * q * (a - 5.0 * x * x * inv_r2) * inv_r2);
}

// (k, k', k'') of the Gaussian amp e^{-α x²} at x.
vec3 gaussian_derivs(float amp, float alpha, float x) {
    float k = amp * exp(-alpha * x * x);
    return vec3(k, -2.0 * alpha * x * k, 2.0 * alpha * (2.0 * alpha * x * x - 1.0) * k);
}

// Range of k' (QUADRATIC false) or k'' (true) over [x0, x1]: ends plus the
// roots of the next derivative inside (Appendix A, Eq. 23). Branch-free for
// SIMD lanes: each root is clamped into the interval, which adds at worst
// an end point already counted, and only the needed derivative is computed.

// Quadratic Taylor's terms of the compact kernel w (a - s)³, s = x²/R²,
// on [x0, x1]: k'' = -6 w/R² (a - s)(a - 5 s) is a quadratic in s, whose
// range over the interval's range of s (clipped to the support, s <= a)
// is that of its ends and its vertex s = 3a/5 (x = ±√(3/5) l, as in
// compact_taylor): three products, and no square root but the entry's.
Taylor compact_taylor_quadratic(float w, float inv_r2, float radius, float h2, float x0, float x1, bool EXTEND) {
    Taylor k = Taylor(0.0, 0.0, 0.0, 0.0);
    float a = 1.0 - h2 * inv_r2;
    float xn = clamp(0.0, x0, x1);    // the interval's point nearest the closest approach
    float s_lo = xn * xn * inv_r2;
    if (!(s_lo < a)) return k;        // the support misses the interval: only this test
    g_evals += 1u;
    float s0 = x0 * x0 * inv_r2;
    float q0 = max(a - s0, 0.0);
    k.value = w * q0 * q0 * q0;
    k.slope = -6.0 * w * x0 * q0 * q0 * inv_r2;
    float s_hi = min(max(s0, x1 * x1 * inv_r2), a);
    float s_m = clamp(0.6 * a, s_lo, s_hi);
    float c = -6.0 * w * inv_r2;
    float d_lo = c * (a - s_lo) * (a - 5.0 * s_lo);
    float d_hi = c * (a - s_hi) * (a - 5.0 * s_hi);
    float d_m = c * (a - s_m) * (a - 5.0 * s_m);
    k.lo = min(min(d_lo, d_hi), d_m);
    k.hi = max(max(d_lo, d_hi), d_m);
    if (EXTEND && x0 < 0.0 && s0 > a) {
        // Entered after x0, at xa = -l (compact_taylor's EXTEND).
        float l = sqrt(a) * radius;
        float xb = min(x1, l);
        float r = (xb + l) / (xb - x0);
        k = Taylor(0.0, 0.0, 0.0, max(k.hi, 0.0) * r * r);
    }
    return k;
}

// k' or k'' of the compact kernel w (a - x²/R²)³ at x inside the support.
float compact_deriv(float w, float inv_r2, float a, float x, bool QUADRATIC) {
    float q = max(a - x * x * inv_r2, 0.0);
    return QUADRATIC ? -6.0 * w * q * (a - 5.0 * x * x * inv_r2) * inv_r2 : -6.0 * w * x * q * q * inv_r2;
}

// EXTEND: a support entered after x0 gets the per-primitive bound of
// Section 6.2.1 (entering_taylor in src/field/bounds.rs): the Taylor bound
// from the entry, where the kernel and two derivatives vanish, moved to
// start at x0; scale r or r², r = (xb - xa)/(xb - x0); lower bound 0.
Taylor compact_taylor(float w, float inv_r2, float radius, float h2, float x0, float x1, bool QUADRATIC, bool EXTEND) {
    if (QUADRATIC) return compact_taylor_quadratic(w, inv_r2, radius, h2, x0, x1, EXTEND);
    Taylor k = Taylor(0.0, 0.0, 0.0, 0.0);
    float a = 1.0 - h2 * inv_r2;
    if (a <= 0.0) return k;
    float l = sqrt(a) * radius;
    float xa = max(x0, -l);
    float xb = min(x1, l);
    if (xa >= xb) return k;       // the support misses the interval: only this test
    g_evals += 1u;
    float q0 = max(a - x0 * x0 * inv_r2, 0.0);
    k.value = w * q0 * q0 * q0;
    k.slope = -6.0 * w * x0 * q0 * q0 * inv_r2;
    float da = compact_deriv(w, inv_r2, a, xa, QUADRATIC);
    float db = compact_deriv(w, inv_r2, a, xb, QUADRATIC);
    float c = l * (QUADRATIC ? 0.7745966692 : 0.4472135955);   // √(3/5) or 1/√5
    float dm = compact_deriv(w, inv_r2, a, clamp(-c, xa, xb), QUADRATIC);
    float dp = compact_deriv(w, inv_r2, a, clamp(c, xa, xb), QUADRATIC);
    float d0 = QUADRATIC ? compact_deriv(w, inv_r2, a, clamp(0.0, xa, xb), true) : da;
    k.lo = min(min(min(da, db), min(dm, dp)), d0);
    k.hi = max(max(max(da, db), max(dm, dp)), d0);
    if (EXTEND && xa > x0) {
        float r = (xb - xa) / (xb - x0);
        k = Taylor(0.0, 0.0, 0.0, max(k.hi, 0.0) * (QUADRATIC ? r * r : r));
    }
    return k;
}

// k' or k'' of the Gaussian amp e^{-α x²} at x.
float gaussian_deriv(float amp, float alpha, float x, bool QUADRATIC) {
    float k = amp * exp(-alpha * x * x);
    return QUADRATIC ? 2.0 * alpha * (2.0 * alpha * x * x - 1.0) * k : -2.0 * alpha * x * k;
}

// The Gaussian's k' and k'' have their extrema in closed form: k'' is
// least at 0 (-2α amp) and greatest at ±√(1.5/α) (4α amp e^{-3/2}); k' =
// -2αx k is least at 1/√(2α) and greatest at -1/√(2α) (∓√(2α) amp
// e^{-1/2}). An extremum inside [x0, x1] adds its value, so the range
// costs the ends' exponentials and no more.
Taylor gaussian_taylor(float w, float alpha, float h2, float x0, float x1, bool QUADRATIC) {
    g_evals += 1u;
    float amp = w * exp(-alpha * h2);
    vec3 v0 = gaussian_derivs(amp, alpha, x0);
    float d0 = QUADRATIC ? v0.z : v0.y;
    float d1 = gaussian_deriv(amp, alpha, x1, QUADRATIC);
    float lo = min(d0, d1);
    float hi = max(d0, d1);
    if (QUADRATIC) {
        float c = sqrt(1.5 / alpha);
        if (x0 <= 0.0 && x1 >= 0.0) lo = min(lo, -2.0 * alpha * amp);
        if ((x0 <= c && x1 >= c) || (x0 <= -c && x1 >= -c)) hi = max(hi, 4.0 * alpha * amp * 0.22313016);   // e^{-3/2}
    } else {
        float c = inversesqrt(2.0 * alpha);
        float peak = sqrt(2.0 * alpha) * amp * 0.60653066;   // e^{-1/2}
        if (x0 <= c && x1 >= c) lo = min(lo, -peak);
        if (x0 <= -c && x1 >= -c) hi = max(hi, peak);
    }
    return Taylor(v0.x, v0.y, lo, hi);
}

// One primitive's Taylor data along o + t u on [t0, t1], per kind.
Taylor compact_point_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_taylor(pr.b.z, pr.b.y, pr.b.x, g.x, g.y, g.y + (t1 - t0), QUADRATIC, SC_EXTENSION != 0u);
}

Taylor gaussian_point_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return gaussian_taylor(pr.b.z, pr.b.y, g.x, g.y, g.y + (t1 - t0), QUADRATIC);
}

// Signed distance s = s0 + σ t: the kernel of s with h = 0, derivatives in
// t scaled by σ and σ².
Taylor compact_plane_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    vec2 s = plane_on_ray(pr, o, u, t0);
    float s0 = s.x;
    float sigma = s.y;
    float s1 = plane_on_ray(pr, o, u, t1).x;
    Taylor k = compact_taylor(pr.b.z, pr.b.y, pr.b.x, 0.0, min(s0, s1), max(s0, s1), QUADRATIC, false);
    vec3 d0 = compact_derivs(pr.b.z, pr.b.y, 1.0, s0);
    float scale = QUADRATIC ? sigma * sigma : sigma;
    float lo = k.lo * scale;
    float hi = k.hi * scale;
    return Taylor(d0.x, d0.y * sigma, min(lo, hi), max(lo, hi));
}

// Max of two forward bounds on [0, len] (Section 5.2, Appendix C): lower is
// the input with the larger start value; upper is the chord to the larger
// end (linear) or the Bézier polygon of the larger control points (quadratic).
Bound max_bound(Bound f, Bound g, float len, bool QUADRATIC) {
    Bound r;
    r.v = max(f.v, g.v);
    float f_end_lo = f.v + len * (f.a_lo + f.b_lo * len);
    float g_end_lo = g.v + len * (g.a_lo + g.b_lo * len);
    bool take_f = f.v > g.v || (f.v == g.v && f_end_lo >= g_end_lo);
    r.a_lo = take_f ? f.a_lo : g.a_lo;
    r.b_lo = take_f ? f.b_lo : g.b_lo;
    float f_start = f.v + f.e_hi;
    float g_start = g.v + g.e_hi;
    float start = max(f_start, g_start);
    r.e_hi = start - r.v;
    float end = max(bound_hi(f, len), bound_hi(g, len));
    if (len <= 0.0) {
        r.a_hi = max(f.a_hi, g.a_hi);
        r.b_hi = max(f.b_hi, g.b_hi);
    } else if (QUADRATIC) {
        float mid = max(f_start + 0.5 * f.a_hi * len, g_start + 0.5 * g.a_hi * len);
        r.a_hi = 2.0 * (mid - start) / len;
        r.b_hi = (start - 2.0 * mid + end) / (len * len);
    } else {
        r.a_hi = (end - start) / len;
        r.b_hi = 0.0;
    }
    return r;
}

// Bottom-up linear bounds (Section 5.2): v + lo τ <= f <= v + hi τ on
// [0, len]. Mirrors `Lin` in src/field/bounds.rs.
struct Lin {
    float v, lo, hi;
};

// Product: the four corner products of the input lines, each bounded by
// its tangent at 0 and its chord (Eq. 17); the extreme slopes bound all.
Lin lin_mul(Lin f, Lin g, float len) {
    float lo = 3.0e38;
    float hi = -3.0e38;
    for (int i = 0; i < 2; ++i) {
        float m = i == 0 ? f.lo : f.hi;
        for (int j = 0; j < 2; ++j) {
            float n = j == 0 ? g.lo : g.hi;
            float c1 = f.v * n + g.v * m;
            float chord = c1 + m * n * len;
            lo = min(lo, min(c1, chord));
            hi = max(hi, max(c1, chord));
        }
    }
    return Lin(f.v * g.v, lo, hi);
}

// w e^{-y}: decreasing and convex; upper through the chord over the lower
// input line's range, lower through the tangent at v.
Lin lin_exp_neg(Lin y, float w, float len) {
    float v = w * exp(-y.v);
    float dy = y.lo * len;
    // exp of at most 88 keeps the chord finite in f32; larger arguments
    // only make the upper slope larger (the caller clamps it anyway).
    float chord = abs(dy) > 1e-12 ? w * (exp(min(-(y.v + dy), 88.0)) - exp(-y.v)) / dy : -v;
    return Lin(v, -v * y.hi, chord * y.lo);
}

// Compact kernel w (a - x²/R²)³ on [x0, x0 + len], bottom up (Figure 11) on
// the part inside the support, then extended over the whole interval.
Lin compact_lin(float w_signed, float inv_r2, float a, float x0, float len) {
    Lin zero = Lin(0.0, 0.0, 0.0);
    if (a <= 0.0) return zero;
    // A negative weight mirrors the kernel of |w|: its bounds swap (below).
    float w = abs(w_signed);
    float l = sqrt(a / inv_r2);
    float xa = max(x0, -l);
    float xb = min(x0 + len, l);
    if (xa >= xb) return zero;      // the support misses the interval: only this test
    g_evals += 1u;
    float sub = xb - xa;
    Lin q = Lin(a - xa * xa * inv_r2, -(2.0 * xa + sub) * inv_r2, -2.0 * xa * inv_r2);
    Lin k = lin_mul(lin_mul(q, q, sub), q, sub);
    k = Lin(w * k.v, w * k.lo, w * k.hi);
    if (xa > x0) {
        float end = max(k.v + k.hi * sub, 0.0);
        k = Lin(0.0, 0.0, end / (xb - x0));
    }
    if (xb < x0 + len && len > 0.0) k.hi = max(k.hi, -k.v / len);
    return w_signed < 0.0 ? Lin(-k.v, -k.hi, -k.lo) : k;
}

// One primitive's bottom-up linear bound on [t0, t0 + len], per kind.
Lin compact_point_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_lin(pr.b.z, pr.b.y, 1.0 - g.x * pr.b.y, g.y, len);
}

Lin gaussian_point_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    float h2 = g.x;
    float x0 = g.y;
    g_evals += 1u;
    float alpha = pr.b.y;
    Lin y = Lin(alpha * (x0 * x0 + h2), 2.0 * alpha * x0, alpha * (2.0 * x0 + len));
    // Slopes clamped to the kernel's Lipschitz constant (mean value
    // theorem): the chord of e^{-y} can overflow far from t0.
    // A negative weight mirrors the kernel of |w|: its bounds swap.
    Lin k = lin_exp_neg(y, abs(pr.b.z), len);
    k = Lin(k.v, max(k.lo, -pr.c.x), min(k.hi, pr.c.x));
    return pr.b.z < 0.0 ? Lin(-k.v, -k.hi, -k.lo) : k;
}

Lin compact_plane_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    vec2 s = plane_on_ray(pr, o, u, t0);
    if (abs(s.y) < 1e-9) return Lin(slab_value(pr, s.x), 0.0, 0.0);
    return compact_lin(pr.b.z, pr.b.y * s.y * s.y, 1.0, s.x / s.y, len);
}

// Revised affine arithmetic (the paper's [FPC10] baseline), mirrored
// from src/field/raa.rs: on [a, b], t = tm + tr ε; a quantity is
// x0 + x1 ε ± e (vec3(x0, x1, e)).
vec3 aa_mul(vec3 x, vec3 y) {
    return vec3(x.x * y.x + 0.5 * x.y * y.y,
                x.x * y.y + y.x * x.y,
                0.5 * abs(x.y * y.y) + (abs(x.x) + abs(x.y)) * y.z + (abs(y.x) + abs(y.y)) * x.z + x.z * y.z);
}

vec3 aa_scale(vec3 x, float c) {
    return vec3(c * x.x, c * x.y, abs(c) * x.z);
}

vec2 aa_range(vec3 x) {
    float r = abs(x.y) + x.z;
    return vec2(x.x - r, x.x + r);
}

// Compact kernel w (a - x²/R²)³ on x in [xa, xb]: affine in the ray's ε
// where the support covers the interval, else its range united with 0.
vec3 compact_raa(float w, float inv_r2, float h2, float xa, float xb) {
    float a = 1.0 - h2 * inv_r2;
    if (a <= 0.0) return vec3(0.0);
    float l = sqrt(a / inv_r2);
    float ca = max(xa, -l);
    float cb = min(xb, l);
    if (ca >= cb) return vec3(0.0);
    g_evals += 1u;
    vec3 x = vec3(0.5 * (ca + cb), 0.5 * (cb - ca), 0.0);
    vec3 q = aa_scale(aa_mul(x, x), -inv_r2) + vec3(a, 0.0, 0.0);
    vec3 p = aa_scale(aa_mul(aa_mul(q, q), q), w);
    if (ca == xa && cb == xb) return p;
    vec2 r = aa_range(p);
    float lo = min(r.x, 0.0);
    float hi = max(r.y, 0.0);
    return vec3(0.5 * (lo + hi), 0.0, 0.5 * (hi - lo));
}

// e^{-y} by min-range linearisation; y is at least y_min.
vec3 aa_exp_neg(vec3 y, float y_min) {
    vec2 r = aa_range(y);
    float hi = r.y;
    float lo = min(max(r.x, y_min), hi);
    float s = -exp(-hi);
    float top = exp(-lo) - s * lo;
    float bottom = exp(-hi) - s * hi;
    return vec3(s * y.x + 0.5 * (top + bottom), s * y.y, abs(s) * y.z + 0.5 * (top - bottom));
}

// One primitive in revised affine arithmetic on [ta, tb], per kind.
vec3 compact_point_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    vec2 g = point_on_ray(pr, o, u, ta);
    return compact_raa(pr.b.z, pr.b.y, g.x, g.y, g.y + (tb - ta));
}

vec3 gaussian_point_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    vec2 g = point_on_ray(pr, o, u, ta);
    float h2 = g.x;
    float xa = g.y;
    float xb = xa + (tb - ta);
    g_evals += 1u;
    vec3 x = vec3(0.5 * (xa + xb), 0.5 * (xb - xa), 0.0);
    vec3 y = aa_scale(aa_mul(x, x) + vec3(h2, 0.0, 0.0), pr.b.y);
    return aa_scale(aa_exp_neg(y, pr.b.y * h2), pr.b.z);
}

vec3 compact_plane_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    vec2 s = plane_on_ray(pr, o, u, ta);
    float sa = s.x;
    float sigma = s.y;
    if (abs(sigma) < 1e-9) return vec3(slab_value(pr, sa), 0.0, 0.0);
    float sb = plane_on_ray(pr, o, u, tb).x;
    // x = s / σ = sa / σ + (t - ta) runs with t whatever σ's sign.
    return compact_raa(pr.b.z, pr.b.y * sigma * sigma, 0.0, sa / sigma, sb / sigma);
}

// Bottom-up quadratic bounds (Section 6.2), mirrored from
// src/field/quad.rs, whose comments carry the derivations.
Bound quad_exact(float v, float a, float b) {
    return Bound(v, a, b, a, b, 0.0);
}

Bound quad_add(Bound f, Bound g) {
    return Bound(f.v + g.v, f.a_lo + g.a_lo, f.b_lo + g.b_lo, f.a_hi + g.a_hi, f.b_hi + g.b_hi, f.e_hi + g.e_hi);
}

Bound quad_scale(Bound f, float w) {
    return Bound(w * f.v, w * f.a_lo, w * f.b_lo, w * f.a_hi, w * f.b_hi, w * f.e_hi);
}

// One product of the Figure 8 construction: the quartic (fv + af τ + bf τ²)
// (gv + ag τ + bg τ²), whose derivative P' is a cubic. Split at its
// inflection, each piece is bounded by its tangent at the piece's start and
// its chord; the slopes of the joining lines U0 + s τ and D0 + s τ that stay
// above (below) them are folded into up_slope (down_slope).
void mul_term(float fv, float af, float bf, float gv, float ag, float bg, float len, float inv_len, float u0, float d0,
              bool SINGLE, inout float up_slope, inout float down_slope) {
    float e0 = fv * ag + gv * af;
    float e1 = 2.0 * (af * ag + bf * gv + bg * fv);
    float e2 = 3.0 * (af * bg + ag * bf);
    float e3 = 4.0 * bf * bg;
    float inflection = e3 != 0.0 ? -e2 / (3.0 * e3) : -1.0;
    float split = inflection > 0.0 && inflection < len ? inflection : len;
    // First piece [0, split]: tangent at 0 (slope e1) and chord.
    float chord = e1 + split * (e2 + split * e3);
    bool convex = e2 + 1.5 * e3 * split >= 0.0;
    // (With a single product, e0 is U0 and D0.)
    float inv = SINGLE || split <= 0.0 ? 0.0 : 1.0 / split;
    up_slope = max(up_slope, (convex ? chord : e1) + (e0 - u0) * inv);
    down_slope = min(down_slope, (convex ? e1 : chord) + (e0 - d0) * inv);
    // Second piece [split, len]: tangent at split and chord. Without a
    // split it is the point len, whose constraint the first piece already
    // meets: computed anyway, without a branch.
    float p = e0 + split * (e1 + split * (e2 + split * e3));
    float tangent = e1 + split * (2.0 * e2 + 3.0 * split * e3);
    chord = e1 + e2 * (split + len) + e3 * (split * split + split * len + len * len);
    convex = e2 + 1.5 * e3 * (split + len) >= 0.0;
    up_slope = max(up_slope, (p + (convex ? chord : tangent) * (len - split) - u0) * inv_len);
    down_slope = min(down_slope, (p + (convex ? tangent : chord) * (len - split) - d0) * inv_len);
}

// Product of forward bounds on [0, len] (Figure 8): the four products of a
// side of f and a side of g, joined as in quad::mul (which explains why
// that is valid). U0 (D0) is the largest (least) P'(0). F_EXACT / G_EXACT:
// that input's two sides are one quadratic, so fewer products are
// distinct (the f64 mirror computes the duplicates too). No loops: lavapipe
// runs straight-line code markedly faster.
Bound quad_mul(Bound f, Bound g, float len, bool F_EXACT, bool G_EXACT) {
    // P'(0) of the products: f.v g' + g.v f' over the sides.
    float p00 = f.v * g.a_lo + g.v * f.a_lo;
    float p01 = G_EXACT ? p00 : f.v * g.a_hi + g.v * f.a_lo;
    float p10 = F_EXACT ? p00 : f.v * g.a_lo + g.v * f.a_hi;
    float p11 = F_EXACT ? p01 : G_EXACT ? p10 : f.v * g.a_hi + g.v * f.a_hi;
    float u0 = max(max(p00, p01), max(p10, p11));
    float d0 = min(min(p00, p01), min(p10, p11));
    float up = -3.0e38, down = 3.0e38;
    float inv_len = len > 0.0 ? 1.0 / len : 0.0;
    bool single = F_EXACT && G_EXACT;
    mul_term(f.v, f.a_lo, f.b_lo, g.v, g.a_lo, g.b_lo, len, inv_len, u0, d0, single, up, down);
    if (!G_EXACT) mul_term(f.v, f.a_lo, f.b_lo, g.v, g.a_hi, g.b_hi, len, inv_len, u0, d0, false, up, down);
    if (!F_EXACT) mul_term(f.v, f.a_hi, f.b_hi, g.v, g.a_lo, g.b_lo, len, inv_len, u0, d0, false, up, down);
    if (!F_EXACT && !G_EXACT) mul_term(f.v, f.a_hi, f.b_hi, g.v, g.a_hi, g.b_hi, len, inv_len, u0, d0, false, up, down);
    return Bound(f.v * g.v, d0, 0.5 * down, u0, 0.5 * up, 0.0);
}

// Compact kernel w (a - x²/R²)³ on [x0, x0 + len] (Figure 11). With
// SC_EXTENSION: the bound of the part inside the support, extended to the
// whole interval (Section 6.2.1, Figure 9); without: max(Q, 0)³ on the
// whole interval.
Bound compact_quad(float w, float inv_r2, float radius, float a, float x0, float len) {
    Bound zero = quad_exact(0.0, 0.0, 0.0);
    if (a <= 0.0) return zero;
    float l = sqrt(a) * radius;
    float xa = max(x0, -l);
    float xb = min(x0 + len, l);
    if (xa >= xb) return zero;      // the support misses the interval: only this test
    g_evals += 1u;
    if (SC_EXTENSION == 0u) {
        Bound m = max_bound(quad_exact(a - x0 * x0 * inv_r2, -2.0 * x0 * inv_r2, -inv_r2), zero, len, true);
        return quad_scale(quad_mul(quad_mul(m, m, len, false, false), m, len, false, false), w);
    }
    float sub = xb - xa;
    bool entering = xa > x0;
    Bound q = quad_exact(entering ? 0.0 : a - xa * xa * inv_r2, -2.0 * xa * inv_r2, -inv_r2);
    Bound k = quad_scale(quad_mul(quad_mul(q, q, sub, true, true), q, sub, false, true), w);
    if (entering) {
        // d1 = (c1 - λ c2)/(1 - λ) with λ = (xa - x0)/span, 1 - λ = sub/span.
        float span = xb - x0;
        float inv_span = 1.0 / span;
        float c1 = k.v + 0.5 * k.a_hi * sub;
        float c2 = max(bound_hi(k, sub), 0.0);
        float d1 = max((c1 * span - (xa - x0) * c2) / sub, 0.0);
        k = Bound(0.0, 0.0, 0.0, 2.0 * d1 * inv_span, (c2 - 2.0 * d1) * inv_span * inv_span, 0.0);
    }
    if (xb < x0 + len) {
        float tau1 = xb - x0;
        float y = 1.0 / len;
        float raise = -k.v * y * y - k.a_hi * y - k.b_hi;
        if (k.v > 0.0 && k.a_hi < 0.0) {
            float vertex = -k.a_hi / (2.0 * k.v);
            if (vertex > y && -k.a_hi * tau1 < 2.0 * k.v) raise = max(raise, -0.5 * k.a_hi * vertex - k.b_hi);
        }
        k.b_hi += max(raise, 0.0);
        k.b_lo -= max(k.v * y * y + k.a_lo * y + k.b_lo, 0.0);
    }
    return k;
}

// Slope of the chord of w e^{-y} between y0 and y1 (y >= 0), by a series
// of (e^{-d} - 1)/d when they are close.
float exp_chord(float w, float y0, float y1) {
    float d = y1 - y0;
    if (abs(d) < 1e-2) {
        float e = abs(d);
        return w * exp(-min(y0, y1)) * (-1.0 + e * (0.5 - e * (1.0 / 6.0 - e / 24.0)));
    }
    return w * (exp(-y1) - exp(-y0)) / d;
}

// Gaussian w e^{-y}, y = α (x² + h²), on [x0, x0 + len] (Appendix B):
// tangent below, chord through y(t0) above; where the interval holds the
// closest approach, the method's rule (Figure 21): shorten `len` (validity
// interval), or relax the bound at t0 or at the maximum.
Bound gaussian_quad(float w, float alpha, float h2, float x0, inout float len) {
    g_evals += 1u;
    float y0 = alpha * (x0 * x0 + h2);
    float y1 = 2.0 * alpha * x0;
    float v = w * exp(-y0);
    Bound b = Bound(v, -v * y1, -v * alpha, 0.0, 0.0, 0.0);
    float x_end = x0 + len;
    float y_end = alpha * (x_end * x_end + h2);
    float slope;
    if (x0 >= 0.0 || y_end <= y0) {
        float x_other = x0 >= 0.0 ? x_end : min(x_end, 0.0);
        slope = exp_chord(w, y0, alpha * (x_other * x_other + h2));
    } else {
        float y_min = alpha * h2;
        if (SC_METHOD == METHOD_QUADRATIC_RELAXED_T0) {
            slope = exp_chord(w, y_min, y_end);
            b.e_hi = max((y0 - y_min) * (slope - exp_chord(w, y_min, y0)), 0.0);
        } else if (SC_METHOD == METHOD_QUADRATIC_RELAXED_MAX || w * exp(-y_min) < globals.tuning.y) {
            // (With validity intervals, a Gaussian fainter than the floor
            // takes this rule instead: see ValidityScope in quad.rs.)
            slope = exp_chord(w, y0, y_end);
            b.a_hi = 2.0 * alpha * abs(x0) * max(slope - exp_chord(w, y_min, y0), 0.0);
        } else {
            len = -2.0 * x0;
            slope = exp_chord(w, y0, y_min);
        }
    }
    b.a_hi += slope * y1;
    b.b_hi = slope * alpha;
    return b;
}

// One primitive's bottom-up quadratic bound on [t0, t0 + len], per kind;
// a Gaussian may shorten len (the compact kinds leave it).
Bound compact_point_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_quad(pr.b.z, pr.b.y, pr.b.x, 1.0 - g.x * pr.b.y, g.y, len);
}

Bound gaussian_point_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return gaussian_quad(pr.b.z, pr.b.y, g.x, g.y, len);
}

Bound compact_plane_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 s = plane_on_ray(pr, o, u, t0);
    if (abs(s.y) < 1e-9) return quad_exact(slab_value(pr, s.x), 0.0, 0.0);
    return compact_quad(pr.b.z, pr.b.y * s.y * s.y, pr.b.x / abs(s.y), 1.0, s.x / s.y, len);
}

// First τ > 0 with -g + A τ + B τ² = 0 (g >= 0), +inf when none; no
// cancellation: small root 2g/(A + √D), or (√D - A)/2B when A < 0 < B.
float first_root(float g, float A, float B) {
    float D = A * A + 4.0 * B * g;
    if (D < 0.0) return INFINITY;
    float sD = sqrt(D);
    if (A >= 0.0) return A + sD > 0.0 ? 2.0 * g / (A + sD) : INFINITY;
    if (B <= 0.0) return INFINITY;
    return (sD - A) / (2.0 * B);
}

// Algorithm 1's next root from outside (f < 0): of the upper bound. A
// relaxed upper bound that starts at or above 0 allows no step.
float upper_root(Bound b) {
    float start = b.v + b.e_hi;
    return start >= 0.0 ? 0.0 : first_root(-start, b.a_hi, b.b_hi);
}

// From outside (f < 0): the first root of the lower bound, a point where
// f >= 0 (INFINITY where the lower bound stays negative).
float lower_root(Bound b) {
    return b.v >= 0.0 ? 0.0 : first_root(-b.v, b.a_lo, b.b_lo);
}

// Where the bound on the far side of f's sign at t0 passes `margin`
// beyond 0: from outside (f < 0) where the lower bound reaches margin, so
// f >= margin is proven; from inside (f > 0) where the upper bound falls
// to -margin (transparent marching). INFINITY where it stays short, and on
// the surface (f = 0). The margin puts the point past f's rounding
// (layout.rs, PROVEN_MARGIN). Mirrors field::bound::proven_root.
float proven_root(Bound b, float margin) {
    if (b.v < 0.0) return first_root(margin - b.v, b.a_lo, b.b_lo);
    if (b.v > 0.0) return first_root(b.v + b.e_hi + margin, -b.a_hi, -b.b_hi);
    return INFINITY;
}

// Algorithm 1's next root: of the upper bound outside (f < 0), of the lower
// bound inside (transparent rendering marches both).
float next_root(Bound b) {
    return b.v > 0.0 ? first_root(b.v, -b.a_lo, -b.b_lo) : upper_root(b);
}

#endif
