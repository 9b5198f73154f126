// The field: kernels of point and plane primitives, summed within a group,
// max over groups (Eq. 20), minus iso. Mirrors src/field/mod.rs in f32.
#ifndef FIELD_GLSL
#define FIELD_GLSL

#include "bindings.glsl"

// Per-primitive kernel evaluations made by this invocation (values, bounds).
uint g_evals = 0u;

// With SC_CULL: bit i is set when primitive i's support meets the part of
// the ray still to march (cull_to_ray), and the field loops skip the rest.
// Skipped primitives contribute exactly 0, so values, bounds and step
// counts are unchanged; only the work is.
uvec2 g_mask = uvec2(0xffffffffu);

bool prim_active(uint i) {
    return SC_CULL == 0u || ((g_mask[i >> 5u] >> (i & 31u)) & 1u) != 0u;
}

// Kernel of a squared distance q, and dk/dq. b = (R or r, 1/R² or s/r², w, -).
float kernel_value(uint kind, vec4 b, float q, out float dk_dq) {
    if (kind == PRIM_GAUSSIAN_POINT) {
        float k = b.z * exp(-q * b.y);
        dk_dq = -b.y * k;
        return k;
    }
    float x = 1.0 - q * b.y;            // compact (1 - q/R²)³, Eq. 7
    dk_dq = -3.0 * b.z * b.y * x * x;
    return b.z * x * x * x;
}

bool kind_enabled(uint kind) {
    return (kind == PRIM_COMPACT_POINT && SC_HAS_COMPACT_POINT != 0u)
        || (kind == PRIM_GAUSSIAN_POINT && SC_HAS_GAUSSIAN_POINT != 0u)
        || (kind == PRIM_COMPACT_PLANE && SC_HAS_COMPACT_PLANE != 0u);
}

// One primitive at p: kernel value, and its gradient added to `grad`.
float prim_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    uint kind = pr.ids.x;
    if (!kind_enabled(kind)) return 0.0;
    vec3 dir;
    float q;
    if (kind == PRIM_COMPACT_PLANE) {
        float s = dot(pr.a.xyz, p) - pr.a.w;
        q = s * s;
        dir = s * pr.a.xyz;
    } else {
        dir = p - pr.a.xyz;
        q = dot(dir, dir);
    }
    // A compact support that misses p costs only this test.
    if (kind != PRIM_GAUSSIAN_POINT && q >= pr.b.x * pr.b.x) return 0.0;
    g_evals += 1u;
    float dk_dq;
    float k = kernel_value(kind, pr.b, q, dk_dq);
    if (want_grad) grad += 2.0 * dk_dq * dir;
    return k;
}

// f(p) = max over groups of the group's sum, minus iso; with the gradient of
// the group attaining the max when want_grad.
float field_eval(vec3 p, bool want_grad, out vec3 grad) {
    uint n = globals.sizes.x;
    float best = -3.0e38;
    vec3 best_grad = vec3(0.0);
    float sum = 0.0;
    vec3 sum_grad = vec3(0.0);
    uint group = 0u;
    for (uint i = 0u; i < n; ++i) {
        if (!prim_active(i)) continue;
        GpuPrimitive pr = prims[i];
        if (SC_MULTI_GROUP != 0u && pr.ids.y != group) {
            if (sum > best) { best = sum; best_grad = sum_grad; }
            sum = 0.0;
            sum_grad = vec3(0.0);
            group = pr.ids.y;
        }
        sum += prim_value(pr, p, want_grad, sum_grad);
    }
    if (sum > best) { best = sum; best_grad = sum_grad; }
    grad = best_grad;
    return best - globals.march.x;
}

float field(vec3 p) {
    vec3 unused;
    return field_eval(p, false, unused);
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

// The kernel of a plane slab at signed distance s: constant along a ray
// parallel to the plane.
float slab_value(GpuPrimitive pr, float s) {
    float dummy;
    float q = s * s;
    return q < pr.b.x * pr.b.x ? kernel_value(pr.ids.x, pr.b, q, dummy) : 0.0;
}

// |dk/dd| at distance d.
float kernel_slope(uint kind, vec4 b, float d) {
    float dk_dq;
    kernel_value(kind, b, d * d, dk_dq);
    return abs(2.0 * d * dk_dq);
}

float cos_along(vec3 v, vec3 u) {
    float l = length(v);
    return l > 0.0 ? abs(dot(v, u)) / l : 1.0;
}

// Segment tracing's bound on |df/dt| of one primitive over o + t u,
// t in [ta, tb] (BENCHMARKS.md); 0 when the support misses the segment.
float prim_segment_slope(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    uint kind = pr.ids.x;
    if (!kind_enabled(kind)) return 0.0;
    float support = kind == PRIM_GAUSSIAN_POINT ? 3.0e38 : pr.b.x;
    float lo, hi, dd_dt;
    if (kind == PRIM_COMPACT_PLANE) {
        float sa = dot(pr.a.xyz, o + ta * u) - pr.a.w;
        float sb = dot(pr.a.xyz, o + tb * u) - pr.a.w;
        lo = sa * sb <= 0.0 ? 0.0 : min(abs(sa), abs(sb));
        if (lo >= support) return 0.0;
        hi = max(abs(sa), abs(sb));
        dd_dt = abs(dot(pr.a.xyz, u));
    } else {
        vec3 c = pr.a.xyz;
        float tc = clamp(dot(c - o, u), ta, tb);
        lo = length(o + tc * u - c);
        if (lo >= support) return 0.0;
        vec3 ca = o + ta * u - c;
        vec3 cb = o + tb * u - c;
        hi = sqrt(max(dot(ca, ca), dot(cb, cb)));
        dd_dt = max(cos_along(ca, u), cos_along(cb, u));
    }
    g_evals += 1u;
    return kernel_slope(kind, pr.b, clamp(pr.b.w, lo, hi)) * dd_dt;
}

// f at o + ta u and segment tracing's Lipschitz bound on [ta, tb], in one
// pass over the primitives: max over groups of sums for both.
float field_and_lipschitz(vec3 o, vec3 u, float ta, float tb, out float lambda) {
    uint n = globals.sizes.x;
    vec3 p = o + ta * u;
    vec3 unused = vec3(0.0);
    float best = -3.0e38;
    float best_slope = 0.0;
    float sum = 0.0;
    float slope = 0.0;
    uint group = 0u;
    for (uint i = 0u; i < n; ++i) {
        if (!prim_active(i)) continue;
        GpuPrimitive pr = prims[i];
        if (SC_MULTI_GROUP != 0u && pr.ids.y != group) {
            best = max(best, sum);
            best_slope = max(best_slope, slope);
            sum = 0.0;
            slope = 0.0;
            group = pr.ids.y;
        }
        sum += prim_value(pr, p, false, unused);
        slope += prim_segment_slope(pr, o, u, ta, tb);
    }
    lambda = max(best_slope, slope);
    return max(best, sum) - globals.march.x;
}

// Sets g_mask to the primitives whose support meets o + t u, t in [ta, tb]
// (Gaussians always). Only with SC_CULL, which the host sets for scenes of
// at most 64 primitives.
void cull_to_ray(vec3 o, vec3 u, float ta, float tb) {
    if (SC_CULL == 0u) return;
    g_mask = uvec2(0u);
    uint n = globals.sizes.x;
    for (uint i = 0u; i < n; ++i) {
        GpuPrimitive pr = prims[i];
        uint kind = pr.ids.x;
        bool meets;
        if (kind == PRIM_GAUSSIAN_POINT) {
            meets = true;
        } else if (kind == PRIM_COMPACT_PLANE) {
            float sa = dot(pr.a.xyz, o + ta * u) - pr.a.w;
            float sb = dot(pr.a.xyz, o + tb * u) - pr.a.w;
            meets = sa * sb <= 0.0 || min(abs(sa), abs(sb)) < pr.b.x;
        } else {
            float tc = clamp(dot(pr.a.xyz - o, u), ta, tb);
            meets = length(o + tc * u - pr.a.xyz) < pr.b.x;
        }
        if (meets) g_mask[i >> 5u] |= 1u << (i & 31u);
    }
}

#endif
