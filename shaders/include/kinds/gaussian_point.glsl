// A point primitive with the Gaussian kernel (PRIM_GAUSSIAN_POINT): the
// kernel of the distance to its centre, whose support is unbounded. The six
// functions of a kind (kinds.glsl). Mirrors PointPrim in
// src/field/kinds.rs, in f32.
#ifndef KIND_GAUSSIAN_POINT_GLSL
#define KIND_GAUSSIAN_POINT_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"
#include "raa.glsl"
#include "points.glsl"
#include "kernel_gaussian.glsl"

float gaussian_point_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    vec3 d = p - pr.a.xyz;
    g_evals += 1u;
    float dk_dq;
    float k = gaussian_kernel(pr.b, dot(d, d), dk_dq);
    if (want_grad) grad += 2.0 * dk_dq * d;
    return k;
}

float gaussian_point_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float lo = point_distance_lo(pr, o, u, ta, tb);
    vec2 hi = point_distance_hi(pr, o, u, ta, tb);
    g_evals += 1u;
    float d = clamp(pr.b.w, lo, hi.x);
    float dk_dq;
    gaussian_kernel(pr.b, d * d, dk_dq);
    return abs(2.0 * d * dk_dq) * hi.y;
}

Taylor gaussian_point_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return gaussian_taylor(pr.b.z, pr.b.y, g.x, g.y, g.y + (t1 - t0), QUADRATIC);
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

Bound gaussian_point_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return gaussian_quad(pr.b.z, pr.b.y, g.x, g.y, len);
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

#endif
