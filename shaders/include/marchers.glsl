// The marchers, in the frame of Algorithm 1: from t, with f(t) < 0, each
// method proposes a step that cannot pass the first root; the minimum step
// overrides it; a crossing is registered when f >= 0 and refined inside
// its bracket (docs/benchmark-protocol.md, "Hits, the minimum step and
// refinement"; docs/refinement.md).
//
// A march runs in slices of a bounded number of loop turns, its state kept
// in GpuMarchState between dispatches, so no dispatch runs unboundedly long
// (lavapipe also caps the loop iterations of one invocation at 65535). A
// turn makes at most a few passes over the primitives: a step, or one
// evaluation of a crossing's refinement, which resumes across turns and
// slices like the march itself.
#ifndef MARCHERS_GLSL
#define MARCHERS_GLSL

#include "traverse.glsl"
#include "shade.glsl"
#include "inversion.glsl"

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

// The ray being marched (its crossings go to crossings[]).
uint g_ray = 0u;

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

// Transparent rendering: a crossing at tc (Section 7.2). It is recorded;
// the surface there shows its shaded colour with weight `opacity` and
// passes the rest; leaving, the light crossed the inside since the last
// crossing and is attenuated by Beer-Lambert. Shading evaluations are not
// marching cost, so they are not counted.
//
// A camera ray of Algorithm 1 (defers_shading) shades the crossings it
// recorded after its march (shade_crossings), and those past the buffer's
// MAX_CROSSINGS outside the turn loop (g_pending, shade_pending): lavapipe
// runs every branch of a turn whether or not a lane takes it, so a normal
// and its lights in the turn cost every turn of every ray. Only the
// transmittance is tracked here. (The any-hit and secondary rays are not
// camera rays; the bisection baselines refuse transparency.)
// A function: glslang left a constant of these undefined in the SPIR-V.
bool defers_shading() {
    return SC_TRANSPARENT != 0u && SC_SHADE != 0u && SC_SECONDARY == 0u && SC_ANY_HIT == 0u;
}

// For the same reason the turn holds one copy of on_crossing: the marchers note a crossing
// (note_crossing, at most two a turn) and march.comp records them after
// the turn (record_crossings). A crossing to shade in the loop waits in
// g_pending until march.comp leaves the turn loop for it (shade_pending).
void on_crossing(vec3 o, vec3 u, float tc, bool entering, inout March m);

uint g_noted = 0u;
float g_noted_t[2];
bool g_noted_entering[2];

void note_crossing(float tc, bool entering) {
    uint i = min(g_noted, 1u);
    g_noted_t[i] = tc;
    g_noted_entering[i] = entering;
    g_noted += 1u;
}

void record_crossings(vec3 o, vec3 u, inout March m) {
    for (uint i = 0u; i < g_noted; ++i) on_crossing(o, u, g_noted_t[i], g_noted_entering[i], m);
    g_noted = 0u;
}

// Crossings to shade (a point and the transmittance in front of it).
uint g_pending = 0u;
float g_pending_t[2];
vec3 g_pending_light[2];

void on_crossing(vec3 o, vec3 u, float tc, bool entering, inout March m) {
    uint k = m.crossings;
    if (k < MAX_CROSSINGS) crossings[g_ray * MAX_CROSSINGS + k] = tc;
    if (k == 0u) m.first = tc;
    m.crossings += 1u;
    if (SC_SHADE != 0u) {
        if (!entering) m.transmittance *= exp(-globals.material.rgb * (tc - m.last));
        float opacity = globals.material.w;
        if (defers_shading() && k < MAX_CROSSINGS) {
            // shaded by shade_crossings
        } else {
            uint i = min(g_pending, 1u);
            g_pending_t[i] = tc;
            g_pending_light[i] = m.transmittance;
            g_pending += 1u;
        }
        m.transmittance *= 1.0 - opacity;
    }
    m.last = tc;
}

// The crossings on_crossing left to shade, in order (outside the turn).
void shade_pending(vec3 o, vec3 u, inout March m) {
    for (uint i = 0u; i < g_pending; ++i) {
        uvec2 counted = uvec2(g_evals, g_visits);
        vec3 n = surface_normal(o + g_pending_t[i] * u);
        g_evals = counted.x;
        g_visits = counted.y;
        m.color += g_pending_light[i] * globals.material.w * shade(n, u);
    }
    g_pending = 0u;
}

// defers_shading(): the light of the ray's first MAX_CROSSINGS crossings,
// read back from the crossings buffer, gathered front to back with the
// arithmetic of on_crossing (so the colour is the one it would have
// gathered); crossing k enters where k is even, as an Algorithm 1 march
// alternates from outside. The first crossing's normal and colour are
// left in g_first_normal and g_first_color. The fold must see every
// primitive at the crossings (the caller widens the culling to them).
vec3 g_first_normal = vec3(0.0);
vec3 g_first_color = vec3(0.0);

vec3 shade_crossings(vec3 o, vec3 u, float tmin, uint count) {
    vec3 color = vec3(0.0);
    vec3 transmittance = vec3(1.0);
    float last = tmin;
    float opacity = globals.material.w;
    for (uint k = 0u; k < min(count, MAX_CROSSINGS); ++k) {
        float tc = crossings[g_ray * MAX_CROSSINGS + k];
        if ((k & 1u) != 0u) transmittance *= exp(-globals.material.rgb * (tc - last));
        vec3 n = surface_normal(o + tc * u);
        if (k == 0u) {
            g_first_normal = n;
            g_first_color = g_color;
        }
        color += transmittance * opacity * shade(n, u);
        transmittance *= 1.0 - opacity;
        last = tc;
    }
    return color;
}

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
// (SC_BRACKET, g_reach in traverse.glsl): f >= 0 there, so the first
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
