// The crossings of a transparent march (Section 7.2): recorded in
// crossings[], their light gathered front to back, shaded in the turn
// loop's wake or after the march.
#ifndef CROSSINGS_GLSL
#define CROSSINGS_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "field.glsl"
#include "shade.glsl"
#include "march_state.glsl"

// The ray being marched (its crossings go to crossings[]).
uint g_ray = 0u;

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

#endif
