// Affine functions a.xyz · p + a.w (PRIM_AFFINE, an HRBF's polynomial
// term): every bound is exact. The six functions of a kind (kinds.glsl).
// Mirrors src/field/hrbf.rs, in f32.
#ifndef KIND_AFFINE_GLSL
#define KIND_AFFINE_GLSL

#include "bindings.glsl"
#include "bound.glsl"
#include "quad.glsl"

float affine_value(GpuPrimitive pr, vec3 p, bool want_grad, inout vec3 grad) {
    if (want_grad) grad += pr.a.xyz;
    return dot(pr.a.xyz, p) + pr.a.w;
}

float affine_lipschitz(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    return abs(dot(pr.a.xyz, u));
}

Taylor affine_taylor(GpuPrimitive pr, vec3 o, vec3 u, float t0, float t1, bool QUADRATIC) {
    float slope = dot(pr.a.xyz, u);
    float d = QUADRATIC ? 0.0 : slope;
    return Taylor(dot(pr.a.xyz, o + t0 * u) + pr.a.w, slope, d, d);
}

Lin affine_linear(GpuPrimitive pr, vec3 o, vec3 u, float t0, float len) {
    float slope = dot(pr.a.xyz, u);
    return Lin(dot(pr.a.xyz, o + t0 * u) + pr.a.w, slope, slope);
}

Bound affine_quad(GpuPrimitive pr, vec3 o, vec3 u, float t0, inout float len) {
    return quad_exact(dot(pr.a.xyz, o + t0 * u) + pr.a.w, dot(pr.a.xyz, u), 0.0);
}

vec3 affine_raa(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    float tm = 0.5 * (ta + tb);
    return vec3(dot(pr.a.xyz, o + tm * u) + pr.a.w, dot(pr.a.xyz, u) * 0.5 * (tb - ta), 0.0);
}

#endif
