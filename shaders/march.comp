#version 460
// The march kernel: one invocation per ray, one slice of its march per
// dispatch. The method, the primitive kinds and the group operator are
// specialization constants (layout.glsl), so a pipeline holds only what its
// scene uses.
#extension GL_GOOGLE_include_directive : require

#include "bindings.glsl"
#include "marchers.glsl"
#include "shade.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.ray_count) return;
    // A ray done in an earlier slice costs one load (its flags).
    if (push.first_slice == 0u && (states[i].n.w & FLAG_DONE) != 0u) return;
    GpuRay ray = rays[i];
    vec3 o = ray.o.xyz;
    vec3 u = ray.d.xyz;

    g_ray = i;
    g_origin = o;
    g_dir = u;
    g_tile = push.first_tile + gl_WorkGroupID.x;
    March m;
    uint turns = 0u;   // loop turns of the march so far
    if (push.first_slice != 0u) {
        m = march_start(ray.o.w, ray.d.w);
    } else {
        m = march_load(states[i], g_evals, g_visits, turns, g_cursor);
    }
    // What remains of the ray: bisection revisits it all, Algorithm 1 only
    // from the last point outside (refinement starts there).
    // (Not with the bracket's kernel, which the host picks for Algorithm 1.)
    bool bisects = SC_BRACKET == 0u && (SC_METHOD == METHOD_LINEAR_BISECTION || SC_METHOD == METHOD_RAA);
    float from = bisects ? ray.o.w : m.t_prev;
    // A transparent march steps on while it refines a crossing behind.
    if ((m.flags & FLAG_REFINING) != 0u) from = min(from, m.ra);
    // A ray that misses the box is done before it starts: no culling.
    if ((m.flags & FLAG_DONE) == 0u) cull_to_ray(o, u, from, ray.d.w);
    // One step or one evaluation of a refinement per turn (slice_steps
    // turns). A transparent march records the turn's crossings after it,
    // and leaves the loop to shade one there (crossings.glsl, on_crossing):
    // lavapipe runs every branch of the loop's body each turn, taken or
    // not, so code that few turns need is kept out of it.
    uint k = 0u;
    for (;;) {
        for (; k < push.slice_steps && (m.flags & FLAG_DONE) == 0u; ++k) {
            turns += 1u;
            if (!bisects) {
                algorithm1_turn(o, u, ray.d.w, m);
            } else if ((m.flags & FLAG_REFINING) != 0u) {
                refine_turn(o, u, m);
            } else {
                bisection_step(o, u, ray.o.w, ray.d.w, m);
            }
            if (SC_TRANSPARENT != 0u) {
                record_crossings(o, u, m);
                if (g_pending != 0u) {
                    k += 1u;
                    break;
                }
            }
        }
        if (SC_TRANSPARENT == 0u || g_pending == 0u) break;
        shade_pending(o, u, m);
    }
    uint flags = march_flags_word(m);   // the word march_store packs too
    if ((m.flags & FLAG_DONE) != 0u) {
        // Later slices read only the flags of a ray that is done.
        states[i].n.w = flags;
    } else {
        states[i] = march_store(m, g_evals, g_visits, turns, g_cursor);
        atomicAdd(active_rays, 1u);
        return;
    }

    if (SC_ANY_HIT != 0u) {
        // An any-hit query's answer is its flags; its counts for the
        // statistics. The rest of its result is left as it was.
        results[i].counts = uvec4(m.steps, g_evals, m.refine_evals, m.flags & (FLAG_HIT | FLAG_OUT_OF_STEPS));
        results[i].crossings = uvec4(m.crossings, g_visits, turns, 0u);
        return;
    }
    GpuResult r;
    r.hit = vec4(0.0, 0.0, 0.0, -1.0);
    r.color = vec4(globals.background.rgb, 0.0);
    // Shading evaluations are not marching cost: count only the march.
    r.counts = uvec4(m.steps, g_evals, m.refine_evals, m.flags & (FLAG_HIT | FLAG_OUT_OF_STEPS));
    r.crossings = uvec4(m.crossings, g_visits, turns, 0u);
    // A transparent camera ray's crossings, shaded now (on_crossing): the
    // culling and the tile walk's cursor widened to all of them.
    vec3 deferred = vec3(0.0);
    if (defers_shading() && m.crossings > 0u) {
        cull_to_ray(o, u, m.first, m.last);
        g_cursor = 0u;
        g_floor = m.first;
        deferred = shade_crossings(o, u, ray.o.w, m.crossings);
    }
    if ((m.flags & FLAG_HIT) != 0u) {
        // The first crossing: its normal and distance. A transparent march
        // may have passed it slices ago, behind what culling kept.
        float t = SC_TRANSPARENT != 0u ? m.first : m.t;
        vec3 n;
        if (defers_shading() && m.crossings > 0u) {
            n = g_first_normal;
            g_color = g_first_color;
        } else {
            if (SC_TRANSPARENT != 0u) {
                uncull();
                g_cursor = 0u;
            }
            n = surface_normal(o + t * u);
        }
        r.hit = vec4(n, t);
        if (SC_SHADE != 0u) {
            r.color = vec4(shade(n, u), 1.0);
            // The unlit colour, for shadows and occlusion on the host
            // (src/render/light.rs): 11, 11 and 10 bits.
            vec3 base = clamp(globals.surface.w != 0.0 ? g_color : globals.surface.rgb, 0.0, 1.0);
            r.crossings.w = (uint(base.r * 2047.0 + 0.5) << 21u) | (uint(base.g * 2047.0 + 0.5) << 10u) | uint(base.b * 1023.0 + 0.5);
        }
    }
    if (SC_TRANSPARENT != 0u && SC_SHADE != 0u) {
        // What the crossings let through shows the background.
        r.color = vec4(deferred + m.color + m.transmittance * globals.background.rgb, 1.0);
    }
    results[i] = r;
}
