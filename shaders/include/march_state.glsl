// The state of one ray's march (March), its start, and its refinement's
// start; march_load and march_store convert it to and from GpuMarchState.
//
// A march runs in slices of a bounded number of loop turns, its state kept
// in GpuMarchState between dispatches, so no dispatch runs unboundedly long
// (lavapipe also caps the loop iterations of one invocation at 65535). A
// turn makes at most a few passes over the primitives: a step, or one
// evaluation of a crossing's refinement, which resumes across turns and
// slices like the march itself.
#ifndef MARCH_STATE_GLSL
#define MARCH_STATE_GLSL

#include "bindings.glsl"
#include "bound.glsl"

struct March {
    float t;            // current point; the hit distance once FLAG_HIT (opaque)
    float t_prev;       // the point before, on the other side of a crossing found at t
    float window;       // candidate interval length for the next step
    uint steps;
    uint refine_evals;
    uint flags;
    uint depth;         // bisection: the current node of the binary
    uint index;         //   subdivision of [tmin, tmax]
    uint base_depth;    //   the depth it starts at (its coarsest nodes)
    // Transparent rendering:
    uint crossings;     // crossings found so far
    float first;        // the first crossing
    float last;         // the last crossing
    vec3 color;         // light gathered so far, front to back
    vec3 transmittance; // what still passes
    float f_prev;       // f at t_prev (0 where unknown)
    // Refinement (FLAG_REFINING): the crossing lies in (ra, rb], with g
    // (f, or -f for a crossing that leaves) negative at ra and not at rb.
    float ra;
    float rb;
    float ga;           // g at the ends as the interpolation uses them
    float gb;           //   (ga 0 where unknown)
    uint refine_side;   // the end the last turn moved: 0 none, 1 ra, 2 rb
    uint refine_turns;
    float far;          // SC_BRACKET: a point where f >= 0 is known (INFINITY: none yet)
};

// The longest candidate interval (with the spatial index, so that a step
// walks a bounded number of cells: globals.tuning.z; 0 is no limit).
float window_cap(float window) {
    return globals.tuning.z > 0.0 ? min(window, globals.tuning.z) : window;
}

March march_start(float tmin, float tmax) {
    March m = March(tmin, tmin, window_cap(tmax - tmin), 0u, 0u, 0u, 0u, 0u, 0u, 0u, -1.0, tmin, vec3(0.0), vec3(1.0), 0.0,
                    0.0, 0.0, 0.0, 0.0, 0u, 0u, INFINITY);
    // Bisection starts at nodes no longer than the cap.
    if (globals.tuning.z > 0.0 && tmax - tmin > globals.tuning.z) {
        m.base_depth = min(uint(ceil(log2((tmax - tmin) / globals.tuning.z))), 24u);
        m.depth = m.base_depth;
    }
    if (!(tmax >= tmin)) m.flags = FLAG_DONE;
    return m;
}

// A crossing between a and b (f changes sign; `entering`: f < 0 at a; fa
// and fb f at the ends, fa 0 where unknown) is to be refined, one field
// evaluation per loop turn (refine_next, refine_update).
void begin_refinement(float a, float fa, float b, float fb, bool entering, inout March m) {
    m.ra = a;
    m.rb = b;
    float ga = entering ? fa : -fa;
    m.ga = ga < 0.0 ? ga : 0.0;
    m.gb = entering ? fb : -fb;
    m.refine_side = 0u;
    m.refine_turns = 0u;
    m.flags |= FLAG_REFINING;
    if (entering) m.flags |= FLAG_REFINE_ENTERING; else m.flags &= ~FLAG_REFINE_ENTERING;
}

// The march between slices, in `states`: what march_store writes,
// march_load reads back, with the invocation's counters kept beside it
// (g_evals, g_visits, the tile walk's g_cursor) and the loop turns so far.
// The flags' upper half holds the refinement's turns and side.
uint march_flags_word(March m) {
    return m.flags | (m.refine_turns << 16u) | (m.refine_side << 24u);
}

March march_load(GpuMarchState s, out uint evals, out uint visits, out uint turns, out uint cursor) {
    March m = March(s.v.x, s.v.y, s.v.z, s.n.x, s.n.z, s.n.w & 0xFFFFu, s.node.x, s.node.y, s.node.w, s.node.z, s.v.w, s.light.w, s.light.rgb,
                    s.trans.rgb, s.trans.w, s.refine.x, s.refine.y, s.refine.z, s.refine.w, s.n.w >> 24u, (s.n.w >> 16u) & 0xFFu, uintBitsToFloat(s.tally.z));
    evals = s.n.y;
    visits = s.tally.x;
    cursor = s.tally.w;
    turns = s.tally.y;
    return m;
}

GpuMarchState march_store(March m, uint evals, uint visits, uint turns, uint cursor) {
    return GpuMarchState(vec4(m.t, m.t_prev, m.window, m.first), uvec4(m.steps, evals, m.refine_evals, march_flags_word(m)),
                         uvec4(m.depth, m.index, m.crossings, m.base_depth), vec4(m.color, m.last), vec4(m.transmittance, m.f_prev),
                         vec4(m.ra, m.rb, m.ga, m.gb), uvec4(visits, turns, floatBitsToUint(m.far), cursor));
}

#endif
