// The evaluations of the field that the marchers and the bounds probe
// make: f = max over groups of the group's sum, minus iso, at a point or
// with its bound on an interval, each one fold over the primitives
// (fold.glsl).
#ifndef FIELD_GLSL
#define FIELD_GLSL

#include "fold.glsl"

// The surface colour at the point of the last field_eval with want_grad,
// in scenes whose primitives have colours: their average weighted by each
// one's kernel value there.
vec3 g_color = vec3(0.0);

// f(p) = max over groups of the group's sum, minus iso; with the gradient of
// the group attaining the max when want_grad.
float field_eval(vec3 p, bool want_grad, out vec3 grad) {
    float len = 0.0;
    Fold r = fold_field(want_grad ? EVAL_GRADIENT : EVAL_VALUE, point_query(p), len);
    grad = r.grad;
    if (want_grad) g_color = r.v > 0.0 ? r.color / r.v : vec3(0.0);
    return r.v - globals.march.x;
}

float field(vec3 p) {
    vec3 unused;
    return field_eval(p, false, unused);
}

// f at o + ta u and segment tracing's Lipschitz bound on [ta, tb], in one
// pass over the primitives: max over groups of sums for both.
float field_and_lipschitz(vec3 o, vec3 u, float ta, float tb, out float lambda) {
    float len = tb - ta;
    Fold r = fold_field(EVAL_LIPSCHITZ, ray_query(o, u, ta, tb), len);
    lambda = r.slope;
    return r.v - globals.march.x;
}

// Range of f = max over groups (sums) - iso over [ta, tb].
vec2 field_raa(vec3 o, vec3 u, float ta, float tb) {
    float len = tb - ta;
    return fold_field(EVAL_RAA, ray_query(o, u, ta, tb), len).range - globals.march.x;
}

bool bottom_up_quadratic() {
    return SC_METHOD == METHOD_QUADRATIC || SC_METHOD == METHOD_QUADRATIC_RELAXED_T0 || SC_METHOD == METHOD_QUADRATIC_RELAXED_MAX;
}

// The bound of the specialised inclusion method for f = max over groups
// (sums) - iso on [t0, t1]: per-primitive bounds add within a group
// (Eq. 16), and groups combine by the bottom-up max (Section 5.2,
// Appendix C). A validity interval may shorten t1 (Section 4.2).
Bound method_bound(vec3 o, vec3 u, float t0, inout float t1) {
    uint what = bottom_up_quadratic() ? EVAL_QUAD
              : SC_METHOD == METHOD_LINEAR || SC_METHOD == METHOD_LINEAR_BISECTION ? EVAL_LINEAR
              : EVAL_TAYLOR;
    float len = t1 - t0;
    Bound b = fold_field(what, ray_query(o, u, t0, t1), len).bound;
    b.v -= globals.march.x;
    t1 = t0 + len;
    return b;
}

#endif
