// A plane primitive with the compact kernel (PRIM_COMPACT_PLANE): the
// kernel of the signed distance a.xyz · p - a.w, a slab. The six functions
// of a kind (kinds.glsl). Mirrors PlanePrim in src/field/kinds.rs, in f32.
#ifndef KIND_COMPACT_PLANE_GLSL
#define KIND_COMPACT_PLANE_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"
#include "quad.glsl"
#include "kernel_compact.glsl"

// A plane primitive's signed distance along o + t u: (s(t0), ds/dt).
vec2 plane_on_ray(GpuPrimitive pr, vec3 o, vec3 u, float t0) {
    return vec2(dot(pr.a.xyz, o + t0 * u) - pr.a.w, dot(pr.a.xyz, u));
}

// The compact kernel of a plane slab at signed distance s: constant along
// a ray parallel to the plane.
float slab_value(GpuPrimitive pr, float s) {
    float dummy;
    float q = s * s;
    return q < pr.b.x * pr.b.x ? compact_kernel(pr.b, q, dummy) : 0.0;
}

float compact_plane_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    float s = dot(pr.a.xyz, p) - pr.a.w;
    float q = s * s;
    if (q >= pr.b.x * pr.b.x) return 0.0;
    g_evals += 1u;
    float dk_dq;
    float k = compact_kernel(pr.b, q, dk_dq);
    vec3 dir = s * pr.a.xyz;
    if (want_grad) grad += 2.0 * dk_dq * dir;
    return k;
}

float compact_plane_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float sa = dot(pr.a.xyz, o + ta * u) - pr.a.w;
    float sb = dot(pr.a.xyz, o + tb * u) - pr.a.w;
    float lo = sa * sb <= 0.0 ? 0.0 : min(abs(sa), abs(sb));
    if (lo >= pr.b.x) return 0.0;
    g_evals += 1u;
    return compact_slope(pr.b, clamp(pr.b.w, lo, max(abs(sa), abs(sb)))) * abs(dot(pr.a.xyz, u));
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

Lin compact_plane_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    vec2 s = plane_on_ray(pr, o, u, t0);
    if (abs(s.y) < 1e-9) return Lin(slab_value(pr, s.x), 0.0, 0.0);
    return compact_lin(pr.b.z, pr.b.y * s.y * s.y, 1.0, s.x / s.y, len);
}

Bound compact_plane_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    vec2 s = plane_on_ray(pr, o, u, t0);
    if (abs(s.y) < 1e-9) return quad_exact(slab_value(pr, s.x), 0.0, 0.0);
    return compact_quad(pr.b.z, pr.b.y * s.y * s.y, pr.b.x / abs(s.y), 1.0, s.x / s.y, len);
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

#endif
