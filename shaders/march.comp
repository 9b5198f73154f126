#version 460
// The march kernel: one invocation per ray. The method, the primitive kinds
// and the group operator are specialization constants (layout.glsl), so a
// pipeline holds only what its scene uses.
#extension GL_GOOGLE_include_directive : require

#include "bindings.glsl"
#include "marchers.glsl"
#include "shade.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.ray_count) return;
    GpuRay ray = rays[i];
    vec3 o = ray.o.xyz;
    vec3 u = ray.d.xyz;

    March m = march_ray(o, u, ray.o.w, ray.d.w);
    uint march_evals = g_evals;

    GpuResult r;
    r.hit = vec4(0.0, 0.0, 0.0, -1.0);
    r.color = vec4(globals.background.rgb, 0.0);
    uint flags = (m.hit ? FLAG_HIT : 0u) | (m.out_of_steps ? FLAG_OUT_OF_STEPS : 0u);
    if (m.hit) {
        vec3 n = surface_normal(o + m.t * u);
        r.hit = vec4(n, m.t);
        if (SC_SHADE != 0u) r.color = vec4(shade(n, u), 1.0);
    }
    // Shading evaluations are not marching cost: count only the march.
    r.counts = uvec4(m.steps, march_evals, m.refine_evals, flags);
    results[i] = r;
}
