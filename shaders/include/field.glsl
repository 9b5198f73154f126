// Point evaluations of one primitive, one function per kind: the kernel's
// value and gradient at a point, and segment tracing's slope bound along a
// ray. Loops over primitives live only in traverse.glsl. Mirrors
// src/field/kinds.rs in f32.
#ifndef FIELD_GLSL
#define FIELD_GLSL

#include "bindings.glsl"

// Per-primitive kernel evaluations made by this invocation (values, bounds).
uint g_evals = 0u;
// Positions the folds' cursors visited (list entries, culled primitives),
// whether they yielded an evaluation or not: the walk's work.
uint g_visits = 0u;

// Compact kernel w (1 - q/R²)³ of a squared distance q inside the support,
// and dk/dq. b = (R, 1/R², w, -).
float compact_kernel(vec4 b, float q, out float dk_dq) {
    float x = 1.0 - q * b.y;
    dk_dq = -3.0 * b.z * b.y * x * x;
    return b.z * x * x * x;
}

// Gaussian kernel w e^{-q s/r²} and dk/dq. b = (r, s/r², w, -).
float gaussian_kernel(vec4 b, float q, out float dk_dq) {
    float k = b.z * exp(-q * b.y);
    dk_dq = -b.y * k;
    return k;
}

// A point primitive along o + t u: (h², x0), h² the squared distance of its
// centre from the line, x0 = t0 - tc with tc the closest approach. Written
// without the cancellation of |c - o|² - tc².
vec2 point_on_ray(GpuPrimitive pr, vec3 o, vec3 u, float t0) {
    vec3 co = pr.a.xyz - o;
    float tc = dot(co, u);
    vec3 w = co - tc * u;
    return vec2(dot(w, w), t0 - tc);
}

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

// --- Values at p, the gradient added to `grad` when want_grad.

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

float gaussian_point_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    vec3 d = p - pr.a.xyz;
    g_evals += 1u;
    float dk_dq;
    float k = gaussian_kernel(pr.b, dot(d, d), dk_dq);
    if (want_grad) grad += 2.0 * dk_dq * d;
    return k;
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

// --- Segment tracing's bound on |df/dt| over o + t u, t in [ta, tb]
// (docs/benchmark-protocol.md): the largest |dk/dd| over the segment's
// distance range (|dk/dd| is unimodal, peaking at b.w), times the largest
// |dd/dt| at its ends; 0 when the support misses the segment.

float cos_along(vec3 v, vec3 u) {
    float l = length(v);
    return l > 0.0 ? abs(dot(v, u)) / l : 1.0;
}

// |dk/dd| of the compact kernel at distance d.
float compact_slope(vec4 b, float d) {
    float dk_dq;
    compact_kernel(b, d * d, dk_dq);
    return abs(2.0 * d * dk_dq);
}

// The least distance of a point primitive's centre from the segment.
float point_distance_lo(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float tc = clamp(dot(pr.a.xyz - o, u), ta, tb);
    return length(o + tc * u - pr.a.xyz);
}

// The largest distance of the centre from the segment (at an end), and
// max |dd/dt| at the ends. Only for a support that meets the segment.
vec2 point_distance_hi(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    vec3 ca = o + ta * u - pr.a.xyz;
    vec3 cb = o + tb * u - pr.a.xyz;
    return vec2(sqrt(max(dot(ca, ca), dot(cb, cb))), max(cos_along(ca, u), cos_along(cb, u)));
}

float compact_point_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float lo = point_distance_lo(pr, o, u, ta, tb);
    if (lo >= pr.b.x) return 0.0;   // a support that misses the segment costs only this test
    g_evals += 1u;
    vec2 hi = point_distance_hi(pr, o, u, ta, tb);
    return compact_slope(pr.b, clamp(pr.b.w, lo, hi.x)) * hi.y;
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

float compact_plane_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float sa = dot(pr.a.xyz, o + ta * u) - pr.a.w;
    float sb = dot(pr.a.xyz, o + tb * u) - pr.a.w;
    float lo = sa * sb <= 0.0 ? 0.0 : min(abs(sa), abs(sb));
    if (lo >= pr.b.x) return 0.0;
    g_evals += 1u;
    return compact_slope(pr.b, clamp(pr.b.w, lo, max(abs(sa), abs(sb)))) * abs(dot(pr.a.xyz, u));
}

#endif
