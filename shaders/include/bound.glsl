// The algebra of forward bounds along a ray (Sections 4-6): the Bound
// type, the data of the Taylor bounds and the lines of the bottom-up linear
// ones, the max of two bounds and Algorithm 1's roots. Pure functions, as
// quad.glsl and raa.glsl: no bindings, specialization constants or
// globals, so what each returns is what its arguments make. The kernels
// (kernel_*.glsl) and the kinds (kinds/) build bounds with them; fold.glsl
// combines them over the primitives. Mirrors src/field/bound.rs and
// bounds.rs, whose comments carry the derivations.
//
// A Bound on [t0, t1] is lo(τ) = v + a_lo τ + b_lo τ² and
// hi(τ) = v + e_hi + a_hi τ + b_hi τ², τ = t - t0, exact at t0 (forward)
// except for quadratic-relaxed-t0, whose upper bound starts e_hi >= 0 above.
#ifndef BOUND_GLSL
#define BOUND_GLSL

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

// One primitive's Taylor data on [t0, t1]: its value and slope at t0, and
// the range [lo, hi] of the order's derivative over the interval.
struct Taylor {
    float value, slope, lo, hi;
};

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
