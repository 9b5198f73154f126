#version 460
// The bounds probe: the forward bound of the specialised method for each
// query (ray, [t0, t1]), so that tests can check the GPU's inclusion
// functions against dense f64 samples (forward, containment, tightness).
#extension GL_GOOGLE_include_directive : require

#define BOUNDS_PROBE 1
#include "bindings.glsl"
#include "inclusion.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.ray_count) return;
    GpuRay q = rays[i];
    float t0 = q.o.w;
    float t1 = q.d.w;
    if (SC_METHOD == METHOD_RAA) {
        // Not a forward bound: a range over the whole interval.
        vec2 r = field_raa(q.o.xyz, q.d.xyz, t0, t1);
        bounds[i] = GpuBound(vec4(r.x, 0.0, 0.0, t1), vec4(r.y, 0.0, 0.0, 0.0));
        return;
    }
    Bound b = method_bound(q.o.xyz, q.d.xyz, t0, t1);   // t1: where the bound is valid
    bounds[i] = GpuBound(vec4(b.v, b.a_lo, b.b_lo, t1), vec4(b.v, b.a_hi, b.b_hi, b.e_hi));
}
