// The marchers, in the frame of Algorithm 1: from t, with f(t) < 0, each
// method proposes a step that cannot pass the first root; the minimum step
// overrides it; a crossing is registered when f >= 0 and refined by
// bisection (BENCHMARKS.md, "Hits and the minimum step").
#ifndef MARCHERS_GLSL
#define MARCHERS_GLSL

#include "field.glsl"

struct March {
    float t;            // hit distance, or the last point reached
    bool hit;
    bool out_of_steps;
    uint steps;
    uint refine_evals;
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

March march_ray(vec3 o, vec3 u, float tmin, float tmax) {
    March m;
    m.t = tmin;
    m.hit = false;
    m.out_of_steps = false;
    m.steps = 0u;
    m.refine_evals = 0u;
    if (!(tmax >= tmin)) return m;

    float min_step = globals.march.y;
    uint max_steps = globals.sizes.w;
    float growth = globals.tuning.x;
    float t = tmin;
    float f = field(o + t * u);
    if (f >= 0.0) {          // the ray starts inside
        m.hit = true;
        return m;
    }
    float window = tmax - tmin;
    while (t < tmax) {
        if (m.steps >= max_steps) {
            m.out_of_steps = true;
            break;
        }
        m.steps += 1u;
        float step;
        if (SC_METHOD == METHOD_SPHERE) {
            step = sphere_step(f);
        } else {
            step = segment_step(o, u, t, f, tmax, window);
        }
        step = max(step, min_step);
        float t_prev = t;
        t = min(t + step, tmax);
        f = field(o + t * u);
        if (f >= 0.0) {
            uint before = g_evals;
            m.t = refine_crossing(o, u, t_prev, t);
            m.refine_evals = g_evals - before;
            m.hit = true;
            return m;
        }
        window = growth * step;
    }
    m.t = t;
    return m;
}

#endif
