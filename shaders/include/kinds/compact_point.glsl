// A point primitive with the compact kernel (PRIM_COMPACT_POINT): the
// kernel of the distance to its centre. The six functions of a kind
// (kinds.glsl). Mirrors PointPrim in src/field/kinds.rs, in f32.
#ifndef KIND_COMPACT_POINT_GLSL
#define KIND_COMPACT_POINT_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "points.glsl"
#include "kernel_compact.glsl"

float compact_point_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    vec3 d = p - pr.a.xyz;
    float q = dot(d, d);
    if (q >= pr.b.x * pr.b.x) return 0.0;   // a support that misses p costs only this test
    g_evals += 1u;
    float dk_dq;
    float k = compact_kernel(pr.b, q, dk_dq);
    if (want_grad) grad += 2.0 * dk_dq * d;
    return k;
}

float compact_point_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float lo = point_distance_lo(pr, o, u, ta, tb);
    if (lo >= pr.b.x) return 0.0;   // a support that misses the segment costs only this test
    g_evals += 1u;
    vec2 hi = point_distance_hi(pr, o, u, ta, tb);
    return compact_slope(pr.b, clamp(pr.b.w, lo, hi.x)) * hi.y;
}

Taylor compact_point_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_taylor(pr.b.z, pr.b.y, pr.b.x, g.x, g.y, g.y + (t1 - t0), QUADRATIC, SC_EXTENSION != 0u);
}

Lin compact_point_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_lin(pr.b.z, pr.b.y, 1.0 - g.x * pr.b.y, g.y, len);
}

Bound compact_point_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 g = point_on_ray(pr, o, u, t0);
    return compact_quad(pr.b.z, pr.b.y, pr.b.x, 1.0 - g.x * pr.b.y, g.y, len);
}

vec3 compact_point_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    vec2 g = point_on_ray(pr, o, u, ta);
    return compact_raa(pr.b.z, pr.b.y, g.x, g.y, g.y + (tb - ta));
}

#endif
