// The marchers, in the frame of Algorithm 1: from t, with f(t) < 0, each
// method proposes a step that cannot pass the first root; the minimum step
// overrides it; a crossing is registered when f >= 0 and refined inside
// its bracket (docs/benchmark-protocol.md, "Hits, the minimum step and
// refinement"; docs/refinement.md).
//
// A loop turn of each march: Algorithm 1's (a step, step.glsl, or an
// evaluation of a refinement, refine.glsl), and the bisection baselines';
// the state they share is march_state.glsl's, the crossings
// crossings.glsl's.
#ifndef MARCHERS_GLSL
#define MARCHERS_GLSL

#include "field.glsl"
#include "shade.glsl"
#include "inversion.glsl"
#include "march_state.glsl"
#include "crossings.glsl"
#include "step.glsl"
#include "refine.glsl"

// One loop turn of Algorithm 1: a step, or a refinement's evaluation.
// Both take f from the same fold, the step's on [m.t, t_end] and the
// refinement's at its point x (f at the start is exact either way: as
// [x, x + tolerance] for the bounds, as [x, x] for segment tracing, whose
// slope is then not computed), so that in a SIMD group the rays that step
// and those that refine make one pass over the primitives together, not
// one each.
void algorithm1_turn(vec3 o, vec3 u, float tmax, inout March m) {
    bool refining = (m.flags & FLAG_REFINING) != 0u;
    float t0 = m.t;
    float t1 = min(m.t + m.window, tmax);
    if (refining && INCLUSION_REFINE) {
        if (!inclusion_next(m, t0)) {
            refine_finish(o, u, m);
            return;
        }
        t1 = m.rb;
    } else if (refining && !INCLUSION_REFINE) {
        if (!refine_next(m, t0)) {
            refine_finish(o, u, m);
            return;
        }
        t1 = HAS_BOUND ? t0 + globals.march.z : t0;
    } else if (m.steps >= (SC_METHOD == METHOD_FIELD_INVERSION_DYNAMOL ? min(globals.sizes.w, DYNAMOL_STEPS) : globals.sizes.w)) {
        m.flags |= FLAG_DONE | FLAG_OUT_OF_STEPS;
        // dynamol out of steps: the closest point seen is the hit.
        if (SC_METHOD == METHOD_FIELD_INVERSION_DYNAMOL && m.steps > 0u) {
            m.t = m.rb;
            m.flags |= FLAG_HIT;
        }
        return;
    } else if (SC_INDEX != 0u && globals.tuning.w != 0.0 && (SC_TILES == 0u || m.steps == 0u || m.f_prev == -globals.march.x)) {
        // Across empty cells in one move (f = -iso there): no step, no
        // evaluation; the march goes on from the first cell that lists a
        // primitive, or ends at tmax. With the tile lists, from the start
        // and after a step that met nothing, to the first support listed.
        float t = SC_TILES != 0u ? skip_to_support(o, u, t0, tmax) : skip_empty_cells(o, u, t0, tmax);
        if (t > t0) {
            m.t = t;
            m.t_prev = t;
            m.f_prev = -globals.march.x;
            if (t >= tmax) {
                m.flags |= FLAG_DONE;
                return;
            }
            t0 = t;
            t1 = min(t + m.window, tmax);
        }
    }
    // A step's interval ends where f >= 0 is known (BRACKETS).
    if (BRACKETS && !refining && m.far > t0) t1 = min(t1, m.far);
    // Where later queries may go back to (the tile walk's cursor).
    g_floor = (m.flags & FLAG_REFINING) != 0u ? min(t0, m.ra) : t0;
    uint before = g_evals;
    StepEval e = step_eval(o, u, t0, t1);
    if (refining) {
        m.refine_evals += g_evals - before;
        if (INCLUSION_REFINE) inclusion_update(t0, e, m); else refine_update(t0, e.f, m);
    } else {
        step_apply(o, u, tmax, e, m);
    }
    // A bracket the bounds closed ends in this turn, not with a turn of
    // its own.
    float x;
    if (INCLUSION_REFINE && (m.flags & FLAG_REFINING) != 0u && !inclusion_next(m, x)) refine_finish(o, u, m);
}

// Leaves the current bisection node for the next one in front-to-back
// order: the next sibling, climbing while it was a right child.
void bisection_advance(inout March m) {
    m.index += 1u;
    while (m.depth > m.base_depth && (m.index & 1u) == 0u) {
        m.index >>= 1u;
        m.depth -= 1u;
    }
    if (m.depth == m.base_depth && m.index >= (1u << m.base_depth)) m.flags |= FLAG_DONE;
}

// The paper's interval-arithmetic baselines (Section 7.1, Figure 10 e, f):
// bisection of [tmin, tmax] with pruning. One step examines one
// sub-interval: if its range excludes 0 it is discarded; below the minimum
// step, a sign change at its end is a crossing; otherwise it is split and
// its front half comes next. Stackless: the node is (depth, index). The
// range comes from bottom-up linear bounds or revised affine arithmetic.
void bisection_step(vec3 o, vec3 u, float tmin, float tmax, inout March m) {
    if (m.steps >= globals.sizes.w) {
        m.flags |= FLAG_DONE | FLAG_OUT_OF_STEPS;
        return;
    }
    m.steps += 1u;
    if (m.steps == 1u && field(o + tmin * u) >= 0.0) {   // the ray starts inside
        m.t = tmin;
        m.flags |= FLAG_DONE | FLAG_HIT;
        return;
    }
    float size = (tmax - tmin) * exp2(-float(m.depth));
    float a = tmin + float(m.index) * size;
    float b = min(a + size, tmax);
    float len = b - a;
    vec2 range;
    if (SC_METHOD == METHOD_RAA) {
        range = field_raa(o, u, a, b);
    } else {
        float end = b;
        Bound bd = method_bound(o, u, a, end);
        range = vec2(bd.v + min(0.0, bd.a_lo * len), bd.v + max(0.0, bd.a_hi * len));
    }
    if (range.y < 0.0) {
        bisection_advance(m);
        return;
    }
    if (len <= globals.march.y || m.depth >= 30u) {
        float fb = field(o + b * u);
        if (fb >= 0.0) {
            m.flags |= FLAG_HIT;
            begin_refinement(a, 0.0, b, fb, true, m);
            return;
        }
        bisection_advance(m);
        return;
    }
    m.depth += 1u;
    m.index *= 2u;
}

#endif
