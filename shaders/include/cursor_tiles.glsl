// Screen-space lists (SC_TILES, src/render/tiles.rs): a camera ray's
// workgroup is one 8x8 pixel tile, whose list per group holds every
// support a ray of the tile may meet, nearest first (the distance from the
// eye to the support's nearest point). A walk reads a list from the front
// and stops at the first entry that starts beyond the query: no later one
// reaches the query either.
#ifndef CURSOR_TILES_GLSL
#define CURSOR_TILES_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "query.glsl"
#include "primitives.glsl"
#include "cursor_grid.glsl"

// The eye (every camera ray starts there), the ray's direction, and its
// tile.
vec3 g_origin = vec3(0.0);
vec3 g_dir = vec3(0.0);
uint g_tile = 0u;

// Group g's list of the ray's tile (the lists are tile-major).
uint tile_list(uint g) {
    return g_tile * globals.sizes.y + g;
}

// With one group, the ray's first entry of its list still worth reading:
// every entry before it the ray misses, or has left before g_floor, the
// least parameter of any later query of the ray. Kept across slices in
// the march state.
uint g_cursor = 0u;
// An opaque march's queries never go back before the one being made; a
// transparent march refines a crossing behind while it steps on, back to
// its bracket's start (algorithm1_turn sets it).
float g_floor = 0.0;

// Where a walk of `list` starts.
uint tile_begin(uint list) {
    uint start = list_start(list);
    return globals.sizes.y == 1u ? max(start, g_cursor) : start;
}

// Whether the ray o + t u misses support a, or leaves it before t0: then
// no query of the rest of its march meets it (the miss with the sphere
// test of segment_meets, to the bit).
bool tile_behind(vec4 a, vec3 o, vec3 u, float t0) {
    vec3 co = a.xyz - o;
    float tc = dot(co, u);
    vec3 w = co - tc * u;
    float r2 = a.w * a.w - dot(w, w);
    // The ray leaves the support at tc + sqrt(r2): before t0, padded.
    float past = t0 - TILE_PAD * (1.0 + abs(t0)) - tc;
    return r2 <= 0.0 || (past > 0.0 && r2 < past * past);
}

// A tile list's entry at `at`: the primitive, and a word holding the
// distance from the eye to its support's nearest point (rounded down: no
// ray from the eye meets the support before it) and, in its low
// TILE_PIXEL_BITS, the pixels of the tile whose rays may meet the support
// (src/render/tiles.rs).
uvec2 tile_entry(uint at) {
    return texelFetch(entry_texels, int(at)).xy;
}

// An entry's depth.
float tile_depth(uvec2 e) {
    return uintBitsToFloat(e.y & ~((1u << TILE_PIXEL_BITS) - 1u));
}

// Whether the ray's pixel is among those of entry e: its lane is the
// pixel (x, y) of its 8x8 tile, row by row (src/render/rays.rs).
bool tile_covers(uvec2 e) {
    uint x = gl_LocalInvocationID.x & 7u;
    uint y = gl_LocalInvocationID.x >> 3u;
    return x >= (e.y & 7u) && x <= ((e.y >> 3u) & 7u) && y >= ((e.y >> 6u) & 7u) && y <= ((e.y >> 9u) & 7u);
}

// The horizon of a walk to t: an entry whose depth (rounded down from
// the host's f64) is beyond it, and every later one, starts past t. Padded
// for the f32 rounding of the ray's parameters.
float tile_horizon(float t) {
    return t + TILE_PAD * (1.0 + abs(t));
}

// Whether the walk of a tile list hands primitive a (centre and index
// radius) to the evaluations of query q: every primitive whose support
// meets the query, once (a list holds it once).
bool tile_admits(vec4 a, bool gaussian, Query q) {
    if (q.point) return point_admits(a, gaussian, q);
    float tn;
    return segment_meets(a, q, tn);
}

// The first point from t0 where the ray enters a support listed for its
// tile (t0 itself when it is inside one; tmax when none is before tmax):
// before it every group's sum is 0 and f = -iso (globals.tuning.w), as
// skip_empty_cells finds with the grid. Entered a little early (TILE_PAD)
// for the f32 rounding of the square root.
float skip_to_support(vec3 o, vec3 u, float t0, float tmax) {
    float best = tmax;
    bool prefix = globals.sizes.y == 1u;
    for (uint g = 0u; g < globals.sizes.y; ++g) {
        uint list = tile_list(g);
        uint end = list_start(list + 1u);
        for (uint at = tile_begin(list); at < end; ++at) {
            uvec2 e = tile_entry(at);
            g_visits += 1u;
            if (tile_depth(e) > tile_horizon(best)) break;
            if (!tile_covers(e)) {
                if (prefix) g_cursor = at + 1u;
                continue;
            }
            vec4 a = uintBitsToFloat(prim_texel(e.x, 0u));
            if (prefix) {
                if (tile_behind(a, o, u, t0)) {
                    g_cursor = at + 1u;
                    continue;
                }
                prefix = false;
            }
            vec3 co = a.xyz - o;
            float tc = dot(co, u);
            float r2 = a.w * a.w - (dot(co, co) - tc * tc);
            if (r2 <= 0.0) continue;
            float s = sqrt(r2);
            if (tc + s < t0) continue;
            best = min(best, max(t0, tc - s - TILE_PAD * (1.0 + abs(tc))));
            if (best <= t0) return t0;
        }
    }
    return best;
}

#endif
