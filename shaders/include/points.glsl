// What the point kinds (kinds/compact_point.glsl, kinds/gaussian_point.glsl)
// share: where a centre lies along the ray, and the range of its distance
// over a segment, for segment tracing's bound (kinds.glsl).
#ifndef POINTS_GLSL
#define POINTS_GLSL

#include "bindings.glsl"

// A point primitive along o + t u: (h², x0), h² the squared distance of its
// centre from the line, x0 = t0 - tc with tc the closest approach. Written
// without the cancellation of |c - o|² - tc².
vec2 point_on_ray(GpuPrimitive pr, vec3 o, vec3 u, float t0) {
    vec3 co = pr.a.xyz - o;
    float tc = dot(co, u);
    vec3 w = co - tc * u;
    return vec2(dot(w, w), t0 - tc);
}

float cos_along(vec3 v, vec3 u) {
    float l = length(v);
    return l > 0.0 ? abs(dot(v, u)) / l : 1.0;
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

#endif
