// One step of Algorithm 1: the fold of a turn on [t0, t1] (step_eval) and
// what the march does with it (step_apply): a crossing check, a proven
// bracket, or the step itself.
#ifndef STEP_GLSL
#define STEP_GLSL

#include "bindings.glsl"
#include "bound.glsl"
#include "field.glsl"
#include "inversion.glsl"
#include "march_state.glsl"
#include "crossings.glsl"

// Where a step of Algorithm 1 stands after its fold: f at t (from the
// bound itself where the method has one: forward bounds are exact at t)
// and the step proven free of crossings.
struct StepEval {
    float f;
    float step;
    float cross;    // from t0, a point where f >= 0 is proven by the lower bound (INFINITY: none)
    float reach;    // BRACKETS: from t0, where the ray enters a primitive's reach (INFINITY: not in [t0, t1])
};

// Opaque first-crossing marches of the inclusion methods take the lower
// bound too: where it reaches 0 inside its validity interval, f >= 0
// there, so the first crossing is bracketed by the two bounds' roots
// without a step to it (docs/refinement.md, "Inclusion refinement").
// The methods whose step folds an inclusion bound (Method::has_bound).
const bool HAS_BOUND = SC_METHOD != METHOD_SPHERE && SC_METHOD != METHOD_SEGMENT && !INVERTS && SC_METHOD != METHOD_RAA
                       && SC_METHOD != METHOD_LINEAR_BISECTION;
const bool TWO_SIDED = SC_SECONDARY == 0u && HAS_BOUND;
// Interval folds also find where the ray enters a primitive's reach
// (SC_BRACKET, g_reach in fold.glsl): f >= 0 there, so the first
// crossing lies no further. Later steps' intervals end there (March::far),
// which keeps their bounds tight, and an any-hit query has its answer. It
// does not start a refinement: the stretch before it may hold more than
// one crossing, and a refinement closes on one of them, not the first.
const bool BRACKETS = SC_BRACKET != 0u;

// The fold of one turn on [t0, t1]: f at t0 and, for a step, the step to
// the first root of the relevant bound on [t0, t1] (at most t1 - t0).
StepEval step_eval(vec3 o, vec3 u, float t0, float t1) {
    float len = t1 - t0;
    if (SC_METHOD == METHOD_SPHERE) {
        float f = field(o + t0 * u);
        return StepEval(f, abs(f) / globals.march.w, INFINITY, INFINITY);            // Eq. 10
    } else if (INVERTS) {
        float f;
        float step = inversion_step(o, u, t0, f);            // not conservative (inversion.glsl)
        return StepEval(f, step, INFINITY, INFINITY);
    } else if (SC_METHOD == METHOD_SEGMENT) {
        float lambda;
        float f = field_and_lipschitz(o, u, t0, t1, lambda);   // Eq. 11, docs/benchmark-protocol.md
        return StepEval(f, lambda > 0.0 ? min(abs(f) / lambda, len) : len, INFINITY, BRACKETS ? g_reach : INFINITY);
    }
    Bound b = method_bound(o, u, t0, t1);   // may shorten t1
    // Opaque marching steps only from outside (f < 0; f >= 0 is a hit
    // below), so the upper bound gives the step and the lower one the
    // point past which the crossing cannot lie.
    float valid = t1 - t0;
    float cross = INFINITY;
    if (TWO_SIDED) {
        // A transparent march refines leaving crossings too, from inside,
        // to a margin past 0 (field::bound::PROVEN_MARGIN of iso); an
        // opaque one is outside here (f >= 0 was a hit), so it holds only
        // the lower bound's root (the turn runs every branch it holds).
        float r = SC_TRANSPARENT != 0u ? proven_root(b, PROVEN_MARGIN * globals.march.x) : lower_root(b);
        if (r <= valid) cross = r;
    }
    return StepEval(b.v, min(SC_TRANSPARENT != 0u || SC_SECONDARY != 0u ? next_root(b) : upper_root(b), valid), cross,
                    BRACKETS ? g_reach : INFINITY);
}

// The rest of one iteration of Algorithm 1, from its fold on [m.t, t_end]:
// a crossing check, and the step, at least the minimum step. The next
// window is `growth` times the step.
void step_apply(vec3 o, vec3 u, float tmax, StepEval e, inout March m) {
    m.steps += 1u;
    float f = e.f;
    float step = e.step;
    if (SC_METHOD == METHOD_FIELD_INVERSION_DYNAMOL) {
        // dynamol's hit rule: the inverted distance g (the step is ω g
        // outside) below DYNAMOL_EPSILON reference radii, or inside, is a
        // hit here, unrefined; the point of smallest g so far is kept in
        // (rb, gb) for a ray that runs out of steps.
        float g = f >= 0.0 ? -1.0 : step / INVERSION_OVER_RELAXATION;
        if (g < DYNAMOL_EPSILON * globals.inversion.x) {
            m.flags |= FLAG_HIT | FLAG_DONE;
            return;
        }
        if (m.steps == 1u || g < m.gb) {
            m.rb = m.t;
            m.gb = g;
        }
    }
    // A secondary ray (reflected or refracted) starts just past a surface,
    // on the side its sign at the start says, and looks for the first
    // sign change from there.
    if (SC_SECONDARY != 0u && m.steps == 1u && f > 0.0) m.flags |= FLAG_INSIDE;
    // A crossing: f >= 0 entering, f <= 0 again leaving (docs/benchmark-protocol.md).
    // Found after the first step, it lies in (t_prev, t] and is refined
    // over the next loop turns; a transparent march steps on meanwhile.
    bool inside = (m.flags & FLAG_INSIDE) != 0u;
    if (inside ? f <= 0.0 : f >= 0.0) {
        m.flags |= FLAG_HIT;
        // An any-hit query has its answer: there is a crossing in (t_prev, t].
        if (SC_ANY_HIT != 0u) {
            m.flags |= FLAG_DONE;
            return;
        }
        if (m.steps > 1u) {
            begin_refinement(m.t_prev, m.f_prev, m.t, f, !inside, m);
            if (SC_TRANSPARENT == 0u) return;
        } else if (SC_TRANSPARENT == 0u) {
            m.flags |= FLAG_DONE;
            return;
        } else {
            note_crossing(m.t, !inside);
        }
        m.flags ^= FLAG_INSIDE;
    }
    if (BRACKETS && e.reach < INFINITY) {
        if (SC_ANY_HIT != 0u) {
            // f >= 0 proven inside the ray: the query's answer.
            m.flags |= FLAG_HIT | FLAG_DONE;
            return;
        }
        m.far = min(m.far, m.t + e.reach);
    }
    if (TWO_SIDED && SC_TRANSPARENT == 0u && e.cross < INFINITY) {
        // f < 0 up to the upper bound's root, f >= 0 at the lower one's.
        // (A transparent march steps on: the stretch to the proven point
        // may hold more crossings, which a jump there would miss.)
        float rb = m.t + e.cross;
        m.flags |= FLAG_HIT;
        if (SC_ANY_HIT != 0u) {
            // Proven without a step to it: the answer of an any-hit query.
            m.flags |= FLAG_DONE;
            return;
        }
        begin_refinement(min(m.t + step, rb), 0.0, rb, 0.0, true, m);
        return;
    }
    if (m.t >= tmax) {
        m.flags |= (m.flags & FLAG_REFINING) != 0u ? FLAG_ENDED : FLAG_DONE;
        return;
    }
    // `step` is proven free of crossings. Reaching the end with it ends the
    // march (Algorithm 1 stops at t1 without evaluating there); a step
    // forced longer by the minimum step must be checked at its end.
    float safe = step;
    step = max(step, globals.march.y);
    m.t_prev = m.t;
    m.f_prev = f;
    m.t = min(m.t + step, tmax);
    if (m.t >= tmax && safe >= tmax - m.t_prev) m.flags |= (m.flags & FLAG_REFINING) != 0u ? FLAG_ENDED : FLAG_DONE;
    m.window = window_cap(globals.tuning.x * step);
}

#endif
