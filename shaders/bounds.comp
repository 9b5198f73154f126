#version 460
// The bounds probe: for each query (ray, [t0, t1]), the field's evaluation
// of the specialised method, so that tests can check the GPU against dense
// f64 samples (forward, containment, tightness) and against the f64 mirror.
#extension GL_GOOGLE_include_directive : require

#define BOUNDS_PROBE 1
#include "bindings.glsl"
#include "field.glsl"
#include "inversion.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.ray_count) return;
    GpuRay q = rays[i];
    vec3 o = q.o.xyz;
    vec3 u = q.d.xyz;
    float t0 = q.o.w;
    float t1 = q.d.w;
    if (SC_METHOD == METHOD_SPHERE || INVERTS) {
        // No bound: f and its gradient at t0.
        vec3 grad;
        float f = field_eval(o + t0 * u, true, grad);
        bounds[i] = GpuBound(vec4(f, 0.0, 0.0, t1), vec4(grad, 0.0));
        return;
    }
    if (SC_METHOD == METHOD_SEGMENT) {
        // f at t0 and the Lipschitz bound on [t0, t1].
        float lambda;
        float f = field_and_lipschitz(o, u, t0, t1, lambda);
        bounds[i] = GpuBound(vec4(f, -lambda, 0.0, t1), vec4(f, lambda, 0.0, 0.0));
        return;
    }
    if (SC_METHOD == METHOD_RAA) {
        // Not a forward bound: a range over the whole interval.
        vec2 r = field_raa(o, u, t0, t1);
        bounds[i] = GpuBound(vec4(r.x, 0.0, 0.0, t1), vec4(r.y, 0.0, 0.0, 0.0));
        return;
    }
    Bound b = method_bound(o, u, t0, t1);   // t1: where the bound is valid
    bounds[i] = GpuBound(vec4(b.v, b.a_lo, b.b_lo, t1), vec4(b.v, b.a_hi, b.b_hi, b.e_hi));
}
