// Shading from the field gradient: Lambert and Blinn-Phong under the
// scene's directional lights.
#ifndef SHADE_GLSL
#define SHADE_GLSL

#include "field.glsl"

// Outward unit normal at p (the field decreases outwards), or 0 where the
// gradient vanishes.
vec3 surface_normal(vec3 p) {
    vec3 grad;
    field_eval(p, true, grad);
    float l = length(grad);
    return l > 0.0 ? -grad / l : vec3(0.0);
}

vec3 shade(vec3 n, vec3 u) {
    // Two-sided: a ray that starts inside still sees a lit surface.
    if (dot(n, u) > 0.0) n = -n;
    // The primitives' own colours where the scene gives them, blended as
    // at the point of the last surface_normal.
    vec3 base = globals.surface.w != 0.0 ? g_color : globals.surface.rgb;
    vec3 color = base * globals.ambient.rgb;
    vec3 view = -u;
    for (uint i = 0u; i < globals.sizes.z; ++i) {
        vec3 l = lights[i].dir.xyz;
        float ndl = max(dot(n, l), 0.0);
        vec3 h = normalize(l + view);
        float spec = ndl > 0.0 ? pow(max(dot(n, h), 0.0), 48.0) : 0.0;
        color += lights[i].color.rgb * (base * ndl + 0.25 * spec);
    }
    return color;
}

#endif
