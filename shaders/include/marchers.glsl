// The marchers, in the frame of Algorithm 1: from t, with f(t) < 0, each
// method proposes a step that cannot pass the first root; the minimum step
// overrides it; a crossing is registered when f >= 0 and refined by
// bisection (docs/benchmark-protocol.md, "Hits, the minimum step and refinement").
//
// A march runs in slices of a bounded number of loop turns, its state kept
// in GpuMarchState between dispatches, so no dispatch runs unboundedly long
// (lavapipe also caps the loop iterations of one invocation at 65535). A
// turn makes at most a few passes over the primitives: a step, or one
// bisection of a crossing's refinement, which resumes across turns and
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
    // Refinement (FLAG_REFINING): the crossing lies in (ra, rb].
    float ra;
    float rb;
    uint bisections;
};

// The ray being marched (its crossings go to crossings[]).
uint g_ray = 0u;

// The longest candidate interval (with the spatial index, so that a step
// walks a bounded number of cells: globals.tuning.z; 0 is no limit).
float window_cap(float window) {
    return globals.tuning.z > 0.0 ? min(window, globals.tuning.z) : window;
}

March march_start(float tmin, float tmax) {
    March m = March(tmin, tmin, window_cap(tmax - tmin), 0u, 0u, 0u, 0u, 0u, 0u, 0u, -1.0, tmin, vec3(0.0), vec3(1.0), 0.0, 0.0, 0u);
    // Bisection starts at nodes no longer than the cap.
    if (globals.tuning.z > 0.0 && tmax - tmin > globals.tuning.z) {
        m.base_depth = min(uint(ceil(log2((tmax - tmin) / globals.tuning.z))), 24u);
        m.depth = m.base_depth;
    }
    if (!(tmax >= tmin)) m.flags = FLAG_DONE;
    return m;
}

// A crossing between a and b (f changes sign; `entering`: f < 0 at a) is
// to be refined by bisection, one halving per loop turn (refine_turn).
void begin_refinement(float a, float b, bool entering, inout March m) {
    m.ra = a;
    m.rb = b;
    m.bisections = 0u;
    m.flags |= FLAG_REFINING;
    if (entering) m.flags |= FLAG_REFINE_ENTERING; else m.flags &= ~FLAG_REFINE_ENTERING;
}

// Transparent rendering: a crossing at tc (Section 7.2). It is recorded;
// the surface there shows its shaded colour with weight `opacity` and
// passes the rest; leaving, the light crossed the inside since the last
// crossing and is attenuated by Beer-Lambert. Shading evaluations are not
// marching cost, so they are not counted.
void on_crossing(vec3 o, vec3 u, float tc, bool entering, inout March m) {
    if (m.crossings < MAX_CROSSINGS) crossings[g_ray * MAX_CROSSINGS + m.crossings] = tc;
    if (m.crossings == 0u) m.first = tc;
    m.crossings += 1u;
    if (SC_SHADE != 0u) {
        if (!entering) m.transmittance *= exp(-globals.material.rgb * (tc - m.last));
        uint evals = g_evals;
        vec3 n = surface_normal(o + tc * u);
        g_evals = evals;
        float opacity = globals.material.w;
        m.color += m.transmittance * opacity * shade(n, u);
        m.transmittance *= 1.0 - opacity;
    }
    m.last = tc;
}

// One iteration of Algorithm 1: f at t (from the bound itself where the
// method has one: forward bounds are exact at t), a crossing check, and a
// step to the first root of the relevant bound on [t, t + window], at
// least the minimum step. The next window is `growth` times the step.
void march_step(vec3 o, vec3 u, float tmax, inout March m) {
    if (m.steps >= globals.sizes.w) {
        m.flags |= FLAG_DONE | FLAG_OUT_OF_STEPS;
        return;
    }
    m.steps += 1u;
    float t_end = min(m.t + m.window, tmax);
    float len = t_end - m.t;
    float f;
    float step;
    if (SC_METHOD == METHOD_SPHERE) {
        f = field(o + m.t * u);
        step = abs(f) / globals.march.w;                      // Eq. 10
    } else if (SC_METHOD == METHOD_FIELD_INVERSION) {
        step = inversion_step(o, u, m.t, f);                  // not conservative (inversion.glsl)
    } else if (SC_METHOD == METHOD_SEGMENT) {
        float lambda;
        f = field_and_lipschitz(o, u, m.t, t_end, lambda);   // Eq. 11, docs/benchmark-protocol.md
        step = lambda > 0.0 ? min(abs(f) / lambda, len) : len;
    } else {
        Bound b = method_bound(o, u, m.t, t_end);   // may shorten t_end
        f = b.v;
        // Opaque marching steps only from outside (f < 0; f >= 0 is a hit
        // below), so only the upper bound's root is needed, and the
        // compiler drops the lower bounds' arithmetic altogether.
        step = min(SC_TRANSPARENT != 0u || SC_SECONDARY != 0u ? next_root(b) : upper_root(b), t_end - m.t);
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
        if (m.steps > 1u) {
            begin_refinement(m.t_prev, m.t, !inside, m);
            if (SC_TRANSPARENT == 0u) return;
        } else if (SC_TRANSPARENT == 0u) {
            m.flags |= FLAG_DONE;
            return;
        } else {
            on_crossing(o, u, m.t, !inside, m);
        }
        m.flags ^= FLAG_INSIDE;
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
    m.t = min(m.t + step, tmax);
    if (m.t >= tmax && safe >= tmax - m.t_prev) m.flags |= (m.flags & FLAG_REFINING) != 0u ? FLAG_ENDED : FLAG_DONE;
    m.window = window_cap(globals.tuning.x * step);
}

// One loop turn of a refinement: halve the bracket down to the tolerance
// (at most 64 times), keeping the crossing in (ra, rb]; then report the
// end past the crossing, so a crossing is never reported early.
void refine_turn(vec3 o, vec3 u, inout March m) {
    float mid = 0.5 * (m.ra + m.rb);
    if (m.bisections < 64u && m.rb - m.ra > globals.march.z && mid > m.ra && mid < m.rb) {
        uint before = g_evals;
        bool a_inside = (m.flags & FLAG_REFINE_ENTERING) == 0u;
        if ((field(o + mid * u) >= 0.0) == a_inside) m.ra = mid; else m.rb = mid;
        m.refine_evals += g_evals - before;
        m.bisections += 1u;
        return;
    }
    m.flags &= ~FLAG_REFINING;
    if (SC_TRANSPARENT == 0u) {
        m.t = m.rb;
        m.flags |= FLAG_DONE;
        return;
    }
    on_crossing(o, u, m.rb, (m.flags & FLAG_REFINE_ENTERING) != 0u, m);
    if ((m.flags & FLAG_ENDED) != 0u) m.flags |= FLAG_DONE;
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
        if (field(o + b * u) >= 0.0) {
            m.flags |= FLAG_HIT;
            begin_refinement(a, b, true, m);
            return;
        }
        bisection_advance(m);
        return;
    }
    m.depth += 1u;
    m.index *= 2u;
}

#endif
