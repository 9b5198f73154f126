// The compact kernel w (1 - q/R²)³ of a squared distance q, which along a
// ray is w (a - x²/R²)³: its value and slope, its derivatives, and its
// Taylor, bottom-up linear, RAA and bottom-up quadratic bounds on an
// interval of x, for the kinds built on it (kinds/compact_point.glsl,
// kinds/compact_plane.glsl). The bounds count an evaluation (g_evals) where
// the support meets the interval; compact_quad follows SC_EXTENSION.
// Mirrors src/field/bounds.rs, quad.rs and raa.rs.
#ifndef KERNEL_COMPACT_GLSL
#define KERNEL_COMPACT_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"
#include "quad.glsl"
#include "raa.glsl"

// Compact kernel w (1 - q/R²)³ of a squared distance q inside the support,
// and dk/dq. b = (R, 1/R², w, -).
float compact_kernel(vec4 b, float q, out float dk_dq) {
    float x = 1.0 - q * b.y;
    dk_dq = -3.0 * b.z * b.y * x * x;
    return b.z * x * x * x;
}

// |dk/dd| of the compact kernel at distance d.
float compact_slope(vec4 b, float d) {
    float dk_dq;
    compact_kernel(b, d * d, dk_dq);
    return abs(2.0 * d * dk_dq);
}

// (k, k', k'') of the compact kernel w (a - x²/R²)³ at x; inv_r2 = 1/R².
vec3 compact_derivs(float w, float inv_r2, float a, float x) {
    float q = a - x * x * inv_r2;
    if (q <= 0.0) return vec3(0.0);
    return vec3(w * q * q * q, -6.0 * w * x * q * q * inv_r2, -6.0 * w * q * (a - 5.0 * x * x * inv_r2) * inv_r2);
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

#endif
