// What one primitive adds to its group's sum for each evaluation (Terms),
// and the macro that makes a kind's terms from its six functions
// (kinds.glsl lists the kinds).
#ifndef TERMS_GLSL
#define TERMS_GLSL

#include "bindings.glsl"
#include "query.glsl"
#include "bound.glsl"
#include "quad.glsl"

// --- Terms: what one primitive adds to its group's sum. Each evaluation
// uses its own fields; the others are dead code once the fold is inlined
// with a constant `what`.
struct Terms {
    float v;        // value at the point, or at t0
    vec3 grad;      // EVAL_GRADIENT
    float slope;    // EVAL_LIPSCHITZ: bound on |f'|; EVAL_TAYLOR: f'(t0)
    float lo, hi;   // EVAL_TAYLOR: range of f' or f''; EVAL_LINEAR: slopes
    Bound quad;     // EVAL_QUAD
    vec3 raa;       // EVAL_RAA: x0 + x1 ε ± e
    vec3 color;     // EVAL_GRADIENT with per-primitive colours: colour x value
    bool unknown;   // a primitive of a kind the shader does not know
};

Terms no_terms() {
    return Terms(0.0, vec3(0.0), 0.0, 0.0, 0.0, Bound(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), vec3(0.0), vec3(0.0), false);
}

// A kind the shader does not know: the fold's every result becomes NaN
// (poison_fold), so that a missing case shows rather than passing for
// another kind's value.
Terms poison_terms() {
    Terms t = no_terms();
    t.unknown = true;
    return t;
}

// The sum of two primitives' terms for `what`: only its fields are added
// (with a constant `what` the others are no code at all; a float add of
// zeros is not something the compiler may drop on its own).
Terms terms_add(uint what, Terms a, Terms b) {
    a.v += b.v;
    if (what == EVAL_GRADIENT) {
        a.grad += b.grad;
        a.color += b.color;
    }
    if (what == EVAL_LIPSCHITZ || what == EVAL_TAYLOR) a.slope += b.slope;
    if (what == EVAL_TAYLOR || what == EVAL_LINEAR) {
        a.lo += b.lo;
        a.hi += b.hi;
    }
    if (what == EVAL_QUAD) a.quad = quad_add(a.quad, b.quad);
    if (what == EVAL_RAA) a.raa += b.raa;
    a.unknown = a.unknown || b.unknown;
    return a;
}

Terms taylor_terms(Taylor k) {
    Terms t = no_terms();
    t.v = k.value;
    t.slope = k.slope;
    t.lo = k.lo;
    t.hi = k.hi;
    return t;
}

Terms linear_terms(Lin k) {
    Terms t = no_terms();
    t.v = k.v;
    t.lo = k.lo;
    t.hi = k.hi;
    return t;
}

// Quadratic Taylor (Eq. 19) or linear Taylor (Eq. 13-15).
bool quadratic_taylor() {
    return SC_METHOD == METHOD_QUADRATIC_TAYLOR;
}

// A primitive's own colour, weighted by its share of the field where
// blobs blend (scenes that give colours: globals.surface.w), else none.
vec3 prim_color(GpuPrimitive pr) {
    return globals.surface.w != 0.0 ? unpackUnorm4x8(pr.ids.z).rgb : vec3(0.0);
}

// --- The interface of a kind: six functions named KIND_value,
// KIND_lipschitz, KIND_taylor, KIND_linear, KIND_quad and KIND_raa (in the
// kind's file, kinds/KIND.glsl), from which KIND_TERMS makes its terms for
// every evaluation. A kind missing one of them does not compile.
#define KIND_TERMS(KIND)                                                                           \
    Terms KIND##_terms(uint what, GpuPrimitive pr, Query q, inout float len) {                     \
        Terms t = no_terms();                                                                      \
        switch (what) {                                                                            \
        case EVAL_VALUE:                                                                           \
        case EVAL_GRADIENT:                                                                        \
            t.v = KIND##_value(pr, q.o, what == EVAL_GRADIENT, t.grad);                            \
            if (what == EVAL_GRADIENT) t.color = t.v * prim_color(pr);                             \
            break;                                                                                 \
        case EVAL_LIPSCHITZ:                                                                       \
            t.v = KIND##_value(pr, q.o + q.t0 * q.u, false, t.grad);                               \
            if (q.t1 > q.t0) t.slope = KIND##_lipschitz(pr, q.o, q.u, q.t0, q.t1);                 \
            break;                                                                                 \
        case EVAL_TAYLOR: t = taylor_terms(KIND##_taylor(pr, q.o, q.u, q.t0, q.t1, quadratic_taylor())); break; \
        case EVAL_LINEAR: t = linear_terms(KIND##_linear(pr, q.o, q.u, q.t0, len)); break;        \
        case EVAL_QUAD: t.quad = KIND##_quad(pr, q.o, q.u, q.t0, len); break;                      \
        case EVAL_RAA: t.raa = KIND##_raa(pr, q.o, q.u, q.t0, q.t1); break;                        \
        default: t = poison_terms();                                                               \
        }                                                                                          \
        return t;                                                                                  \
    }

#endif
