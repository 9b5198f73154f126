// The marchers, in the frame of Algorithm 1: from t, with f(t) < 0, each
// method proposes a step that cannot pass the first root; the minimum step
// overrides it; a crossing is registered when f >= 0 and refined by
// bisection (BENCHMARKS.md, "Hits and the minimum step").
//
// A march runs in slices of a bounded number of steps, its state kept in
// GpuMarchState between dispatches, so no dispatch runs unboundedly long
// (lavapipe also caps the loop iterations of one invocation at 65535).
#ifndef MARCHERS_GLSL
#define MARCHERS_GLSL

#include "field.glsl"

struct March {
    float t;            // current point; the hit distance once FLAG_HIT
    float f;            // f(t)
    float window;       // candidate interval length for the next step
    uint steps;
    uint refine_evals;
    uint flags;
};

// Bisection between a (outside, f < 0) and b (inside, f >= 0) down to the
// refinement tolerance; returns the inside end, so the hit is never early.
float refine_crossing(vec3 o, vec3 u, float a, float b) {
    float tol = globals.march.z;
    for (int i = 0; i < 64 && b - a > tol; ++i) {
        float m = 0.5 * (a + b);
        if (m <= a || m >= b) break;
        if (field(o + m * u) >= 0.0) b = m; else a = m;
    }
    return b;
}

// Sphere tracing: the global Lipschitz bound (Eq. 10).
float sphere_step(float f) {
    return abs(f) / globals.march.w;
}

// Segment tracing (Galin et al. 2020, pinned in BENCHMARKS.md): the bound
// on the candidate segment [t, t + window].
float segment_step(vec3 o, vec3 u, float t, float f, float tmax, float window) {
    float tb = min(t + window, tmax);
    float lambda = segment_lipschitz(o, u, t, tb);
    float len = tb - t;
    return lambda > 0.0 ? min(abs(f) / lambda, len) : len;
}

March march_start(vec3 o, vec3 u, float tmin, float tmax) {
    March m;
    m.t = tmin;
    m.f = -1.0;
    m.window = tmax - tmin;
    m.steps = 0u;
    m.refine_evals = 0u;
    m.flags = 0u;
    if (!(tmax >= tmin)) {
        m.flags = FLAG_DONE;
        return m;
    }
    m.f = field(o + tmin * u);
    if (m.f >= 0.0) m.flags = FLAG_DONE | FLAG_HIT;   // the ray starts inside
    return m;
}

// One iteration of Algorithm 1.
void march_step(vec3 o, vec3 u, float tmax, inout March m) {
    if (m.t >= tmax) {
        m.flags |= FLAG_DONE;
        return;
    }
    if (m.steps >= globals.sizes.w) {
        m.flags |= FLAG_DONE | FLAG_OUT_OF_STEPS;
        return;
    }
    m.steps += 1u;
    float step;
    if (SC_METHOD == METHOD_SPHERE) {
        step = sphere_step(m.f);
    } else {
        step = segment_step(o, u, m.t, m.f, tmax, m.window);
    }
    step = max(step, globals.march.y);
    float t_prev = m.t;
    m.t = min(m.t + step, tmax);
    m.f = field(o + m.t * u);
    if (m.f >= 0.0) {
        uint before = g_evals;
        m.t = refine_crossing(o, u, t_prev, m.t);
        m.refine_evals += g_evals - before;
        m.flags |= FLAG_DONE | FLAG_HIT;
        return;
    }
    m.window = globals.tuning.x * step;
}

#endif
