// The Gaussian kernel w e^{-q s/r²} of a squared distance q, which along a
// ray is w e^{-α (x² + h²)}: its value and derivatives, and its Taylor and
// bottom-up quadratic bounds on an interval of x, for
// kinds/gaussian_point.glsl. The bounds count an evaluation (g_evals);
// gaussian_quad follows the method (SC_METHOD) and the validity floor
// (globals.tuning.y). Mirrors src/field/bounds.rs and quad.rs.
#ifndef KERNEL_GAUSSIAN_GLSL
#define KERNEL_GAUSSIAN_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"

// Gaussian kernel w e^{-q s/r²} and dk/dq. b = (r, s/r², w, -).
float gaussian_kernel(vec4 b, float q, out float dk_dq) {
    float k = b.z * exp(-q * b.y);
    dk_dq = -b.y * k;
    return k;
}

// (k, k', k'') of the Gaussian amp e^{-α x²} at x.
vec3 gaussian_derivs(float amp, float alpha, float x) {
    float k = amp * exp(-alpha * x * x);
    return vec3(k, -2.0 * alpha * x * k, 2.0 * alpha * (2.0 * alpha * x * x - 1.0) * k);
}

// k' or k'' of the Gaussian amp e^{-α x²} at x.
float gaussian_deriv(float amp, float alpha, float x, bool QUADRATIC) {
    float k = amp * exp(-alpha * x * x);
    return QUADRATIC ? 2.0 * alpha * (2.0 * alpha * x * x - 1.0) * k : -2.0 * alpha * x * k;
}

// The Gaussian's k' and k'' have their extrema in closed form: k'' is
// least at 0 (-2α amp) and greatest at ±√(1.5/α) (4α amp e^{-3/2}); k' =
// -2αx k is least at 1/√(2α) and greatest at -1/√(2α) (∓√(2α) amp
// e^{-1/2}). An extremum inside [x0, x1] adds its value, so the range
// costs the ends' exponentials and no more.
Taylor gaussian_taylor(float w, float alpha, float h2, float x0, float x1, bool QUADRATIC) {
    g_evals += 1u;
    float amp = w * exp(-alpha * h2);
    vec3 v0 = gaussian_derivs(amp, alpha, x0);
    float d0 = QUADRATIC ? v0.z : v0.y;
    float d1 = gaussian_deriv(amp, alpha, x1, QUADRATIC);
    float lo = min(d0, d1);
    float hi = max(d0, d1);
    if (QUADRATIC) {
        float c = sqrt(1.5 / alpha);
        if (x0 <= 0.0 && x1 >= 0.0) lo = min(lo, -2.0 * alpha * amp);
        if ((x0 <= c && x1 >= c) || (x0 <= -c && x1 >= -c)) hi = max(hi, 4.0 * alpha * amp * 0.22313016);   // e^{-3/2}
    } else {
        float c = inversesqrt(2.0 * alpha);
        float peak = sqrt(2.0 * alpha) * amp * 0.60653066;   // e^{-1/2}
        if (x0 <= c && x1 >= c) lo = min(lo, -peak);
        if (x0 <= -c && x1 >= -c) hi = max(hi, peak);
    }
    return Taylor(v0.x, v0.y, lo, hi);
}

// Slope of the chord of w e^{-y} between y0 and y1 (y >= 0), by a series
// of (e^{-d} - 1)/d when they are close.
float exp_chord(float w, float y0, float y1) {
    float d = y1 - y0;
    if (abs(d) < 1e-2) {
        float e = abs(d);
        return w * exp(-min(y0, y1)) * (-1.0 + e * (0.5 - e * (1.0 / 6.0 - e / 24.0)));
    }
    return w * (exp(-y1) - exp(-y0)) / d;
}

// Gaussian w e^{-y}, y = α (x² + h²), on [x0, x0 + len] (Appendix B):
// tangent below, chord through y(t0) above; where the interval holds the
// closest approach, the method's rule (Figure 21): shorten `len` (validity
// interval), or relax the bound at t0 or at the maximum.
Bound gaussian_quad(float w, float alpha, float h2, float x0, inout float len) {
    g_evals += 1u;
    float y0 = alpha * (x0 * x0 + h2);
    float y1 = 2.0 * alpha * x0;
    float v = w * exp(-y0);
    Bound b = Bound(v, -v * y1, -v * alpha, 0.0, 0.0, 0.0);
    float x_end = x0 + len;
    float y_end = alpha * (x_end * x_end + h2);
    float slope;
    if (x0 >= 0.0 || y_end <= y0) {
        float x_other = x0 >= 0.0 ? x_end : min(x_end, 0.0);
        slope = exp_chord(w, y0, alpha * (x_other * x_other + h2));
    } else {
        float y_min = alpha * h2;
        if (SC_METHOD == METHOD_QUADRATIC_RELAXED_T0) {
            slope = exp_chord(w, y_min, y_end);
            b.e_hi = max((y0 - y_min) * (slope - exp_chord(w, y_min, y0)), 0.0);
        } else if (SC_METHOD == METHOD_QUADRATIC_RELAXED_MAX || w * exp(-y_min) < globals.tuning.y) {
            // (With validity intervals, a Gaussian fainter than the floor
            // takes this rule instead: see ValidityScope in quad.rs.)
            slope = exp_chord(w, y0, y_end);
            b.a_hi = 2.0 * alpha * abs(x0) * max(slope - exp_chord(w, y_min, y0), 0.0);
        } else {
            len = -2.0 * x0;
            slope = exp_chord(w, y0, y_min);
        }
    }
    b.a_hi += slope * y1;
    b.b_hi = slope * alpha;
    return b;
}

#endif
