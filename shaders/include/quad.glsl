// Bottom-up quadratic bounds (Section 6.2), mirrored from
// src/field/quad.rs, whose comments carry the derivations: the arithmetic
// of Bounds (bound.glsl) that the kernels' and kinds' quadratic bounds are
// built with. Pure functions, as bound.glsl says.
#ifndef QUAD_GLSL
#define QUAD_GLSL

#include "bound.glsl"

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

#endif
