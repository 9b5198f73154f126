// Revised affine arithmetic (the paper's [FPC10] baseline), mirrored
// from src/field/raa.rs: on [a, b], t = tm + tr ε; a quantity is
// x0 + x1 ε ± e (vec3(x0, x1, e)). Pure functions, as bound.glsl says.
#ifndef RAA_GLSL
#define RAA_GLSL

vec3 aa_mul(vec3 x, vec3 y) {
    return vec3(x.x * y.x + 0.5 * x.y * y.y,
                x.x * y.y + y.x * x.y,
                0.5 * abs(x.y * y.y) + (abs(x.x) + abs(x.y)) * y.z + (abs(y.x) + abs(y.y)) * x.z + x.z * y.z);
}

vec3 aa_scale(vec3 x, float c) {
    return vec3(c * x.x, c * x.y, abs(c) * x.z);
}

vec2 aa_range(vec3 x) {
    float r = abs(x.y) + x.z;
    return vec2(x.x - r, x.x + r);
}

// e^{-y} by min-range linearisation; y is at least y_min.
vec3 aa_exp_neg(vec3 y, float y_min) {
    vec2 r = aa_range(y);
    float hi = r.y;
    float lo = min(max(r.x, y_min), hi);
    float s = -exp(-hi);
    float top = exp(-lo) - s * lo;
    float bottom = exp(-hi) - s * hi;
    return vec3(s * y.x + 0.5 * (top + bottom), s * y.y, abs(s) * y.z + 0.5 * (top - bottom));
}

// √y by min-range linearisation (concave increasing: the least slope, at
// the top of y's range); y is at least y_min.
vec3 aa_sqrt(vec3 y, float y_min) {
    vec2 r = aa_range(y);
    float hi = max(r.y, y_min);
    float lo = min(max(r.x, y_min), hi);
    if (hi <= 0.0) return vec3(0.0);
    float s = 0.5 / sqrt(hi);
    float top = sqrt(hi) - s * hi;
    float bottom = sqrt(lo) - s * lo;
    return vec3(s * y.x + 0.5 * (top + bottom), s * y.y, s * y.z + 0.5 * (top - bottom));
}

#endif
