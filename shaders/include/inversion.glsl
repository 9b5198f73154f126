// Field inversion (Bruckner 2019, dynamol; the paper's molecule baseline):
// the Gaussian density F is inverted into an approximate distance with one
// reference blob, g = r_ref (sqrt(ln(w/F)/s) - sqrt(ln(w/iso)/s)), and
// sphere-traced with over-relaxation. Not conservative. Mirrors
// src/field/inversion.rs, which has the derivation and the choices.
#ifndef INVERSION_GLSL
#define INVERSION_GLSL

#include "field.glsl"

// The field-inversion methods, either hit rule (Method::inverts).
const bool INVERTS = SC_METHOD == METHOD_FIELD_INVERSION || SC_METHOD == METHOD_FIELD_INVERSION_DYNAMOL;

// f at o + t u, and the step from there: ω |g|.
float inversion_step(vec3 o, vec3 u, float t, out float f) {
    f = field(o + t * u);
    vec4 k = globals.inversion;   // r_ref, s, ln w, ln of the density floor
    float iso = globals.march.x;
    float density = max(log(max(f + iso, 1e-37)), k.w);
    float a = sqrt(max(k.z - density, 0.0) / k.y);
    float b = sqrt(max(k.z - log(iso), 0.0) / k.y);
    return INVERSION_OVER_RELAXATION * abs(k.x * (a - b));
}

#endif
