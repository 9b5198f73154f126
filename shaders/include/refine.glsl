// The refinement of a bracketed crossing, one field evaluation per loop
// turn (docs/refinement.md): the point inside the bracket, the bracket
// after f there, and the end of it.
#ifndef REFINE_GLSL
#define REFINE_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "field.glsl"
#include "march_state.glsl"
#include "crossings.glsl"
#include "step.glsl"

// The bracket's middle, and whether a turn may narrow it: within the turn
// budget, wider than the tolerance, with a float strictly inside.
bool bracket_open(March m, out float mid) {
    float w = m.rb - m.ra;
    mid = m.ra + 0.5 * w;
    return m.refine_turns < MAX_REFINE_TURNS && w > globals.march.z && mid > m.ra && mid < m.rb;
}

// A refinement's next point inside its bracket (ra, rb), or false when the
// bracket is within the tolerance. SC_REFINE picks the point: the
// bracket's middle (bisection), or Illinois regula falsi placed a quarter
// tolerance past its estimate, so that consecutive points straddle the
// crossing and close the bracket from both sides; after four such turns
// every other turn bisects. Mirrored in f64 by settings::Bracket
// (docs/refinement.md).
bool refine_next(March m, out float x) {
    if (!bracket_open(m, x)) return false;
    float w = m.rb - m.ra;
    float tol = globals.march.z;
    if (SC_REFINE != REFINE_BISECTION && m.ga < 0.0 && (m.refine_turns < SECANT_FREE_TURNS || (m.refine_turns & 1u) == 0u)) {
        float margin = SECANT_STRADDLE * tol;
        float s = m.ra + w * (m.ga / (m.ga - m.gb));
        s += m.refine_side == 1u ? margin : (m.refine_side == 2u ? -margin : 0.0);
        s = clamp(s, m.ra + margin, m.rb - margin);
        if (s > m.ra && s < m.rb) x = s;
    }
    return true;
}

// The bracket after f at its point x: the crossing stays in (ra, rb].
void refine_update(float x, float f, inout March m) {
    float g = (m.flags & FLAG_REFINE_ENTERING) != 0u ? f : -f;
    if (g < 0.0) {
        if (m.refine_side == 1u) m.gb *= 0.5;
        m.ra = x;
        m.ga = g;
        m.refine_side = 1u;
    } else {
        if (m.refine_side == 2u) m.ga *= 0.5;
        m.rb = x;
        m.gb = g;
        m.refine_side = 2u;
    }
    m.refine_turns += 1u;
}

// Inclusion refinement (SC_REFINE == REFINE_INCLUSION, TWO_SIDED
// marches): the turn folds the method's bound over [x, rb], x the
// bracket's start, or its middle after a turn that did not halve it.
// f(x) >= 0 moves rb to x; else f < 0 up to the upper bound's root and
// f >= 0 at the lower bound's, so both ends move. Mirrored in f64 by
// settings::Bracket::update_inclusion.
const bool INCLUSION_REFINE = TWO_SIDED && SC_REFINE == REFINE_INCLUSION;

// The point the next inclusion turn folds from, or false when the bracket
// is within the tolerance (or no float lies strictly inside it).
bool inclusion_next(March m, out float x) {
    float mid;
    bool open = bracket_open(m, mid);
    x = m.refine_side == REFINE_SIDE_SPLIT ? mid : m.ra;
    return open;
}

void inclusion_update(float x, StepEval e, inout March m) {
    float w = m.rb - m.ra;
    // Past the crossing: f >= 0 entering, f <= 0 leaving. Before it, the
    // step and the proven root are those of f's sign at x either way.
    if ((m.flags & FLAG_REFINE_ENTERING) != 0u ? e.f >= 0.0 : e.f <= 0.0) {
        m.rb = x;
        m.refine_side = 2u;
    } else {
        m.ra = min(x + e.step, m.rb);
        m.rb = min(m.rb, x + e.cross);
        m.refine_side = m.rb - m.ra > 0.5 * w ? REFINE_SIDE_SPLIT : 1u;
    }
    m.refine_turns += 1u;
}

// The bracket is within the tolerance: the crossing is its end past the
// crossing, so a crossing is never reported early.
void refine_finish(vec3 o, vec3 u, inout March m) {
    m.flags &= ~FLAG_REFINING;
    if (SC_TRANSPARENT == 0u) {
        m.t = m.rb;
        m.flags |= FLAG_DONE;
        return;
    }
    note_crossing(m.rb, (m.flags & FLAG_REFINE_ENTERING) != 0u);
    if ((m.flags & FLAG_ENDED) != 0u) m.flags |= FLAG_DONE;
}

// One loop turn of a refinement on its own (the bisection baselines):
// f at the next point by a pass over the primitives for the value.
void refine_turn(vec3 o, vec3 u, inout March m) {
    float x;
    if (!refine_next(m, x)) {
        refine_finish(o, u, m);
        return;
    }
    uint before = g_evals;
    float f = field(o + x * u);
    m.refine_evals += g_evals - before;
    refine_update(x, f, m);
}

#endif
