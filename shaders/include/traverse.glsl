// The one loop over primitives. Every evaluation of the field (value,
// gradient, segment tracing's slope, the Taylor, linear, quadratic and RAA
// bounds) is a fold: a cursor yields the primitives that can matter to a
// query, one dispatch on the primitive's kind gives its terms, terms add up
// within a group, and groups combine by max (Eq. 20). Mirrors the fold of
// src/field/fold.rs.
//
// The primitives come from the flat list (per-ray culling, small scenes;
// fold_field's cursor) or from the spatial index (SC_INDEX, a build
// variant: fold_indexed's walk). Either yields every primitive whose
// support meets the query (a point, or the ray on [t0, t1]), each once,
// and a group's primitives one after another, groups in order. A group is
// folded into the max when it yields a primitive, and group 0 always, so
// a query that meets no primitive still gets the empty sum, 0 - iso.
#ifndef TRAVERSE_GLSL
#define TRAVERSE_GLSL

#include "field.glsl"
#include "inclusion.glsl"
#include "grid.glsl"
#include "hrbf.glsl"

// What a fold evaluates.
const uint EVAL_VALUE = 0u;       // f at a point
const uint EVAL_GRADIENT = 1u;    // f and the gradient of the group attaining the max
const uint EVAL_LIPSCHITZ = 2u;   // f at t0 and segment tracing's bound on |f'| over [t0, t1]
const uint EVAL_TAYLOR = 3u;      // linear or quadratic Taylor bound (SC_METHOD says which)
const uint EVAL_LINEAR = 4u;      // bottom-up linear bound
const uint EVAL_QUAD = 5u;        // bottom-up quadratic bound (may shorten the interval)
const uint EVAL_RAA = 6u;         // revised affine arithmetic range

// A query: the ray o + t u on [t0, t1], or the point o.
struct Query {
    vec3 o;
    vec3 u;
    float t0;
    float t1;
    bool point;
};

Query point_query(vec3 p) {
    return Query(p, vec3(0.0), 0.0, 0.0, true);
}

Query ray_query(vec3 o, vec3 u, float t0, float t1) {
    return Query(o, u, t0, t1, false);
}

// --- The primitives, read through texel views (layout.rs: one gather a
// texel on lavapipe, where a storage-buffer load is a loop over the lanes
// with a bounds check per component). Integer texels, so that every bit
// arrives as written (ids as floats would be denormals).

// Texel k of primitive i (0 a, 1 b, 2 c, 3 ids).
uvec4 prim_texel(uint i, uint k) {
    return texelFetch(prim_texels, int(4u * i + k));
}

// Every fold reads the texels, the flat list's too (it read the storage
// buffer, whose four vec4 loads were 36% of a fig1 segment-tracing ray's
// instructions: docs/performance.md, "Where a turn's instructions went").
GpuPrimitive load_prim(uint i) {
    return GpuPrimitive(uintBitsToFloat(prim_texel(i, 0u)), uintBitsToFloat(prim_texel(i, 1u)), uintBitsToFloat(prim_texel(i, 2u)),
                        prim_texel(i, 3u));
}

// --- Per-ray culling, the flat cursor's set-up (without SC_INDEX).

// With SC_CULL: bit i is set when primitive i's support meets the part of
// the ray still to march (cull_to_ray), and the cursor skips the rest.
// Skipped primitives contribute exactly 0, so values, bounds and step
// counts are unchanged; only the work is.
uvec2 g_mask = uvec2(0xffffffffu);

// Does primitive pr's support meet o + t u, t in [ta, tb]? Gaussians have
// unbounded support.
bool meets_ray(GpuPrimitive pr, vec3 o, vec3 u, float ta, float tb) {
    switch (pr.ids.x) {
    case PRIM_COMPACT_POINT: {
        float tc = clamp(dot(pr.a.xyz - o, u), ta, tb);
        return length(o + tc * u - pr.a.xyz) < pr.b.x;
    }
    case PRIM_COMPACT_PLANE: {
        float sa = dot(pr.a.xyz, o + ta * u) - pr.a.w;
        float sb = dot(pr.a.xyz, o + tb * u) - pr.a.w;
        return sa * sb <= 0.0 || min(abs(sa), abs(sb)) < pr.b.x;
    }
    default:   // Gaussians, and kinds the evaluations will poison
        return true;
    }
}

const bool ONLY_COMPACT_POINTS = SC_HAS_COMPACT_POINT != 0u && SC_HAS_GAUSSIAN_POINT == 0u && SC_HAS_COMPACT_PLANE == 0u && SC_HAS_HRBF == 0u
                                 && SC_HAS_AFFINE == 0u;

// Sets g_mask to the primitives whose support meets o + t u, t in [ta, tb].
// Only with SC_CULL, which the host sets for scenes of at most 64
// primitives. This is the flat cursor's set-up, not an evaluation; it
// reads only the texels meets_ray uses (a, b, ids).
void cull_to_ray(vec3 o, vec3 u, float ta, float tb) {
    if (SC_CULL == 0u) return;
    g_mask = uvec2(0u);
    for (uint i = 0u; i < globals.sizes.x; ++i) {
        GpuPrimitive pr;
        pr.a = uintBitsToFloat(prim_texel(i, 0u));
        pr.b = uintBitsToFloat(prim_texel(i, 1u));
        // A scene of compact points alone needs no texel for the kind.
        pr.ids.x = ONLY_COMPACT_POINTS ? PRIM_COMPACT_POINT : prim_texel(i, 3u).x;
        if (meets_ray(pr, o, u, ta, tb)) g_mask[i >> 5u] |= 1u << (i & 31u);
    }
}

// Every primitive visible again (culling kept only those ahead of the ray).
void uncull() {
    g_mask = uvec2(0xffffffffu);
}

// --- The flat cursor (without SC_INDEX): every primitive in order, or
// culled (SC_CULL), only those whose bits are set, one loop turn each, so
// that a fold costs what the ray meets rather than what the scene holds.
struct Cursor {
    uint at;        // the primitive
    uint end;       // past the last primitive
    uvec2 bits;     // SC_CULL: the culled primitives not yet yielded
};

// SC_CULL: the lowest set bit's primitive (at least `end` when none is
// left; bits past the last primitive, set by uncull, are past `end` too).
uint lowest_bit(uvec2 bits) {
    return bits.x != 0u ? uint(findLSB(bits.x)) : bits.y != 0u ? 32u + uint(findLSB(bits.y)) : 64u;
}

Cursor cursor_begin() {
    Cursor c = Cursor(0u, globals.sizes.x, g_mask);
    if (SC_CULL != 0u) c.at = lowest_bit(c.bits);
    return c;
}

void cursor_advance(inout Cursor c) {
    if (SC_CULL != 0u) {
        c.bits[c.at >> 5u] &= ~(1u << (c.at & 31u));
        c.at = lowest_bit(c.bits);
    } else {
        c.at += 1u;
    }
}

// --- The spatial index's walk (SC_INDEX; grid.glsl has the lists). Per
// group: its everywhere list, then the grid's lists along the query (the
// one cell of a point; the cells a 3D DDA walks for an interval), each
// primitive of the grid yielded once, in the cell holding the query's
// point nearest its centre (grid_admits). Nested loops, so that a list
// entry costs a turn of a tight loop: its index, one texel (the centre and
// the index radius) to test it, and the rest of the primitive only when it
// is admitted.

uint list_start(uint list) {
    return texelFetch(cell_texels, int(list)).x;
}

uint list_entry(uint k) {
    return texelFetch(entry_texels, int(k)).x;
}

// The DDA over the grid's cells: the cell, its part [ta, tb] of the query,
// the next boundary per axis, the step between boundaries.
struct Dda {
    ivec3 cell;
    ivec3 dir;
    vec3 t_next;
    vec3 t_delta;
    float ta;
    float tb;
    float t_end;
    bool first_cell;
};

// The DDA's start for the query: false when it misses the grid. A point
// is a cell; an interval is clipped to the grid's box.
bool dda_start(Query q, out Dda c) {
    vec3 lo = globals.grid.xyz;
    float h = globals.grid.w;
    vec3 hi = lo + h * vec3(globals.grid_dims.xyz);
    c.first_cell = true;
    c.ta = 0.0;
    c.tb = 0.0;
    c.t_end = 0.0;
    if (q.point) {
        c.cell = cell_of(q.o);
        return !(any(lessThan(q.o, lo)) || any(greaterThanEqual(q.o, hi)));
    }
    vec3 inv_u = vec3(q.u.x < 0.0 ? -1.0 : 1.0, q.u.y < 0.0 ? -1.0 : 1.0, q.u.z < 0.0 ? -1.0 : 1.0) / max(abs(q.u), vec3(1e-30));
    vec3 ta3 = (lo - q.o) * inv_u;
    vec3 tb3 = (hi - q.o) * inv_u;
    vec3 tmin3 = min(ta3, tb3);
    vec3 tmax3 = max(ta3, tb3);
    float t_in = max(q.t0, max(tmin3.x, max(tmin3.y, tmin3.z)));
    c.t_end = min(q.t1, min(tmax3.x, min(tmax3.y, tmax3.z)));
    c.cell = cell_of(q.o + t_in * q.u);
    c.dir = ivec3(q.u.x > 0.0 ? 1 : q.u.x < 0.0 ? -1 : 0, q.u.y > 0.0 ? 1 : q.u.y < 0.0 ? -1 : 0, q.u.z > 0.0 ? 1 : q.u.z < 0.0 ? -1 : 0);
    vec3 boundary = lo + h * (vec3(c.cell) + vec3(greaterThan(c.dir, ivec3(0))));
    c.t_next = mix((boundary - q.o) * inv_u, vec3(3.0e38), equal(c.dir, ivec3(0)));
    c.t_delta = h * abs(inv_u);
    c.ta = t_in;
    c.tb = min(c.t_end, min(c.t_next.x, min(c.t_next.y, c.t_next.z)));
    return t_in <= c.t_end;
}

// The DDA's next cell, across the nearest boundary: false past the query's
// end or the grid.
bool dda_advance(inout Dda c) {
    if (c.tb >= c.t_end) return false;
    int axis = c.t_next.x <= c.t_next.y && c.t_next.x <= c.t_next.z ? 0 : c.t_next.y <= c.t_next.z ? 1 : 2;
    c.cell[axis] += c.dir[axis];
    c.t_next[axis] += c.t_delta[axis];
    c.ta = c.tb;
    c.tb = min(c.t_end, min(c.t_next.x, min(c.t_next.y, c.t_next.z)));
    c.first_cell = false;
    return c.cell[axis] >= 0 && c.cell[axis] < int(globals.grid_dims[axis]);
}

// Empty space (globals.tuning.w, set when every primitive is in the grid
// and iso > 0): in a cell whose lists are all empty no support reaches,
// every group's sum is 0 and f = -iso < 0, so no crossing lies there. The
// ray's parameter where, from t0, it first enters a cell that lists a
// primitive (t0 itself when it is in one), tmax when none is left before
// tmax, or where the look-ahead of SKIP_CELLS cells stopped (the next turn
// goes on from there). A list's padded sphere test (CELL_PAD) covers the
// DDA's rounding.
float skip_empty_cells(vec3 o, vec3 u, float t0, float tmax) {
    Dda c;
    if (!dda_start(ray_query(o, u, t0, tmax), c)) return tmax;
    for (uint k = 0u; k < SKIP_CELLS; ++k) {
        for (uint g = 0u; g < globals.sizes.y; ++g) {
            uint list = cell_list(g, c.cell);
            if (list_start(list + 1u) != list_start(list)) return max(t0, c.ta);
        }
        if (!dda_advance(c)) return tmax;
    }
    return max(t0, c.ta);
}

// A point query at q.o and the support (centre and index radius) a: a
// Gaussian is clipped at its radius, so that the field does not depend on
// the list it is evaluated from; compact kernels test their support
// themselves.
bool point_admits(vec4 a, bool gaussian, Query q) {
    vec3 d = q.o - a.xyz;
    return !gaussian || dot(d, d) < a.w * a.w;
}

// Whether an interval query's segment meets the support a, and tn, the
// segment's point nearest its centre.
bool segment_meets(vec4 a, Query q, out float tn) {
    vec3 co = a.xyz - q.o;
    float tc = dot(co, q.u);
    vec3 w = co - tc * q.u;
    float h2 = dot(w, w);
    tn = clamp(tc, q.t0, q.t1);
    float d = tc - tn;
    return h2 + d * d < a.w * a.w;
}

// Whether the walk hands grid primitive i, whose texel a holds its centre
// and index radius (GpuPrimitive::a.w for points), to the evaluations in
// the DDA's cell c. A point query: a Gaussian is clipped at its radius for
// the index, so that the field does not depend on the cell it is evaluated
// in (compact kernels test their support themselves). An interval: a
// primitive is yielded once, in the cell holding the query's point nearest
// its centre (the cells' parts of the query partition it; the first and
// last open to either side), and not at all when that point is outside its
// support. That point is inside the support, so its cell lists the
// primitive; and it needs no square root, where the point where the query
// enters the support did.
bool grid_admits(Dda c, vec4 a, bool gaussian, Query q) {
    if (q.point) return point_admits(a, gaussian, q);
    float tn;
    if (!segment_meets(a, q, tn)) return false;
    bool last = c.tb >= c.t_end;
    return (c.first_cell || tn >= c.ta) && (last || tn < c.tb);
}

// --- Screen-space lists (SC_TILES, src/render/tiles.rs): a camera ray's
// workgroup is one 8x8 pixel tile, whose list per group holds every
// support a ray of the tile may meet, nearest first (the distance from the
// eye to the support's nearest point). A walk reads a list from the front
// and stops at the first entry that starts beyond the query: no later one
// reaches the query either.

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

// The kind of grid primitive i: a point kind, known without a fetch when
// the scene has one.
uint grid_kind(uint i) {
    if (SC_HAS_GAUSSIAN_POINT == 0u) return PRIM_COMPACT_POINT;
    if (SC_HAS_COMPACT_POINT == 0u) return PRIM_GAUSSIAN_POINT;
    return prim_texel(i, 3u).x;
}

// --- Terms: what one primitive adds to its group's sum. Each evaluation
// uses its own fields; the others are dead code once the fold is inlined
// with a constant `what`.
struct Terms {
    float v;        // value at the point, or at t0
    vec3 grad;      // EVAL_GRADIENT
    float slope;    // EVAL_LIPSCHITZ: bound on |f'|; EVAL_TAYLOR: f'(t0)
    float lo, hi;   // EVAL_TAYLOR: range of f' or f''; EVAL_LINEAR: slopes
    Bound quad;     // EVAL_QUAD
    vec3 raa;       // EVAL_RAA: x0 + x1 ε ± e
    vec3 color;     // EVAL_GRADIENT with per-primitive colours: colour x value
    bool unknown;   // a primitive of a kind the shader does not know
};

Terms no_terms() {
    return Terms(0.0, vec3(0.0), 0.0, 0.0, 0.0, Bound(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), vec3(0.0), vec3(0.0), false);
}

// A kind the shader does not know: the fold's every result becomes NaN
// (poison_fold), so that a missing case shows rather than passing for
// another kind's value.
Terms poison_terms() {
    Terms t = no_terms();
    t.unknown = true;
    return t;
}

// The sum of two primitives' terms for `what`: only its fields are added
// (with a constant `what` the others are no code at all; a float add of
// zeros is not something the compiler may drop on its own).
Terms terms_add(uint what, Terms a, Terms b) {
    a.v += b.v;
    if (what == EVAL_GRADIENT) {
        a.grad += b.grad;
        a.color += b.color;
    }
    if (what == EVAL_LIPSCHITZ || what == EVAL_TAYLOR) a.slope += b.slope;
    if (what == EVAL_TAYLOR || what == EVAL_LINEAR) {
        a.lo += b.lo;
        a.hi += b.hi;
    }
    if (what == EVAL_QUAD) a.quad = quad_add(a.quad, b.quad);
    if (what == EVAL_RAA) a.raa += b.raa;
    a.unknown = a.unknown || b.unknown;
    return a;
}

Terms taylor_terms(Taylor k) {
    Terms t = no_terms();
    t.v = k.value;
    t.slope = k.slope;
    t.lo = k.lo;
    t.hi = k.hi;
    return t;
}

Terms linear_terms(Lin k) {
    Terms t = no_terms();
    t.v = k.v;
    t.lo = k.lo;
    t.hi = k.hi;
    return t;
}

// Quadratic Taylor (Eq. 19) or linear Taylor (Eq. 13-15).
bool quadratic_taylor() {
    return SC_METHOD == METHOD_QUADRATIC_TAYLOR;
}

// A primitive's own colour, weighted by its share of the field where
// blobs blend (scenes that give colours: globals.surface.w), else none.
vec3 prim_color(GpuPrimitive pr) {
    return globals.surface.w != 0.0 ? unpackUnorm4x8(pr.ids.z).rgb : vec3(0.0);
}

// --- The interface of a kind: six functions named KIND_value,
// KIND_lipschitz, KIND_taylor, KIND_linear, KIND_quad and KIND_raa (in
// field.glsl, inclusion.glsl and hrbf.glsl), from which KIND_TERMS makes its terms
// for every evaluation. A kind missing one of them does not compile.
#define KIND_TERMS(KIND)                                                                           \
    Terms KIND##_terms(uint what, GpuPrimitive pr, Query q, inout float len) {                     \
        Terms t = no_terms();                                                                      \
        switch (what) {                                                                            \
        case EVAL_VALUE:                                                                           \
        case EVAL_GRADIENT:                                                                        \
            t.v = KIND##_value(pr, q.o, what == EVAL_GRADIENT, t.grad);                            \
            if (what == EVAL_GRADIENT) t.color = t.v * prim_color(pr);                             \
            break;                                                                                 \
        case EVAL_LIPSCHITZ:                                                                       \
            t.v = KIND##_value(pr, q.o + q.t0 * q.u, false, t.grad);                               \
            if (q.t1 > q.t0) t.slope = KIND##_lipschitz(pr, q.o, q.u, q.t0, q.t1);                 \
            break;                                                                                 \
        case EVAL_TAYLOR: t = taylor_terms(KIND##_taylor(pr, q.o, q.u, q.t0, q.t1, quadratic_taylor())); break; \
        case EVAL_LINEAR: t = linear_terms(KIND##_linear(pr, q.o, q.u, q.t0, len)); break;        \
        case EVAL_QUAD: t.quad = KIND##_quad(pr, q.o, q.u, q.t0, len); break;                      \
        case EVAL_RAA: t.raa = KIND##_raa(pr, q.o, q.u, q.t0, q.t1); break;                        \
        default: t = poison_terms();                                                               \
        }                                                                                          \
        return t;                                                                                  \
    }

KIND_TERMS(compact_point)
KIND_TERMS(gaussian_point)
KIND_TERMS(compact_plane)
KIND_TERMS(hrbf)
KIND_TERMS(affine)

// The one dispatch on the primitive's kind: exhaustive, a kind the shader
// does not know poisons the result. A kind the scene does not use is
// compiled out (SC_HAS_*) and adds nothing.
Terms prim_terms(uint what, GpuPrimitive pr, Query q, inout float len) {
    switch (pr.ids.x) {
    case PRIM_COMPACT_POINT: return SC_HAS_COMPACT_POINT != 0u ? compact_point_terms(what, pr, q, len) : no_terms();
    case PRIM_GAUSSIAN_POINT: return SC_HAS_GAUSSIAN_POINT != 0u ? gaussian_point_terms(what, pr, q, len) : no_terms();
    // The bracket's kernel (SC_BRACKET) marches point kernels alone.
    case PRIM_COMPACT_PLANE: return SC_BRACKET == 0u && SC_HAS_COMPACT_PLANE != 0u ? compact_plane_terms(what, pr, q, len) : no_terms();
    case PRIM_HRBF: return SC_BRACKET == 0u && SC_HAS_HRBF != 0u ? hrbf_terms(what, pr, q, len) : no_terms();
    case PRIM_AFFINE: return SC_BRACKET == 0u && SC_HAS_AFFINE != 0u ? affine_terms(what, pr, q, len) : no_terms();
    default: return poison_terms();
    }
}

// --- The accumulator across groups: the max of the groups' sums.
struct Fold {
    float v;        // EVAL_VALUE, EVAL_GRADIENT, EVAL_LIPSCHITZ
    vec3 grad;      // EVAL_GRADIENT
    vec3 color;     // EVAL_GRADIENT: the colours of the group attaining the max, weighted
    float slope;    // EVAL_LIPSCHITZ
    Bound bound;    // EVAL_TAYLOR, EVAL_LINEAR, EVAL_QUAD
    bool have;      //   whether `bound` holds a group yet
    vec2 range;     // EVAL_RAA
    bool poisoned;  // a group held a primitive of an unknown kind
};

// Every result NaN. (A NaN summed into a group would not survive the max
// over groups, whose comparisons drop it.)
void poison_fold(inout Fold r) {
    float n = uintBitsToFloat(0x7fc00000u);
    r.v = n;
    r.grad = vec3(n);
    r.slope = n;
    r.bound = Bound(n, n, n, n, n, n);
    r.range = vec2(n);
}

bool bounds_quadratic(uint what) {
    return what == EVAL_QUAD || (what == EVAL_TAYLOR && quadratic_taylor());
}

// A group's sum as a bound on [0, len]: summed Taylor terms (Eq. 19 or
// Eq. 13-15), summed linear slopes, or the summed quadratic bounds.
Bound group_bound(uint what, Terms s) {
    if (what == EVAL_QUAD) return s.quad;
    if (what == EVAL_TAYLOR && quadratic_taylor()) return Bound(s.v, s.slope, 0.5 * s.lo, s.slope, 0.5 * s.hi, 0.0);   // Eq. 19
    // Linear Taylor (Eq. 13-15) and bottom-up linear (Section 5.2): slopes.
    return Bound(s.v, s.lo, 0.0, s.hi, 0.0, 0.0);
}

// Folds one group's sum into the max over groups (for bounds, the
// bottom-up max of Section 5.2 and Appendix C on [0, len]).
void fold_group(uint what, Terms s, float len, inout Fold r) {
    r.poisoned = r.poisoned || s.unknown;
    switch (what) {
    case EVAL_VALUE:
    case EVAL_GRADIENT:
        if (s.v > r.v) {
            r.v = s.v;
            r.grad = s.grad;
            r.color = s.color;
        }
        break;
    case EVAL_LIPSCHITZ:
        r.v = max(r.v, s.v);
        r.slope = max(r.slope, s.slope);
        break;
    case EVAL_RAA:
        r.range = max(r.range, aa_range(s.raa));
        break;
    default: {
        Bound g = group_bound(what, s);
        r.bound = r.have ? max_bound(r.bound, g, len, bounds_quadratic(what)) : g;
        r.have = true;
    }
    }
}

Fold empty_fold() {
    return Fold(-3.0e38, vec3(0.0), vec3(0.0), 0.0, Bound(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), false, vec2(-3.0e38), false);
}

// The first-crossing bracket (SC_BRACKET: every primitive a point kernel
// of non-negative weight, iso > 0; Scene::bracket_holds). Each group's sum
// is at least any one of its terms and f the max of the groups, so f >= 0
// wherever one primitive alone reaches iso: inside its reach (c.z, the
// distance within which its kernel is at least iso (1 + 1e-3), so that
// rounding does not undo it; 0 where it never is). An interval fold
// yields every primitive whose support meets its interval, so it also
// finds where, from t0, the ray first enters a yielded primitive's reach:
// g_reach (INFINITY: nowhere in [t0, t1]). The first crossing lies no
// further, so the march brackets it there without a step to it.
float g_reach = INFINITY;

// From q.t0, where the ray enters point primitive pr's reach within the
// query (INFINITY: it does not).
float reach_entry(GpuPrimitive pr, Query q) {
    vec2 hx = point_on_ray(pr, q.o, q.u, q.t0);   // (h², t0 - tc)
    float r2 = pr.c.z * pr.c.z - hx.x;
    if (r2 <= 0.0) return INFINITY;
    float s = sqrt(r2);
    if (hx.y > s) return INFINITY;   // past the ball
    float e = max(0.0, -s - hx.y);
    return e <= q.t1 - q.t0 ? e : INFINITY;
}

// Adds primitive pr's terms for `what` to a group's sum. Only Gaussians
// shorten the interval: a copy keeps len loop-invariant for scenes
// without them.
void add_terms(uint what, GpuPrimitive pr, Query q, inout Terms sum, inout float len) {
    float valid = len;
    sum = terms_add(what, sum, prim_terms(what, pr, q, valid));
    if (what == EVAL_QUAD && SC_HAS_GAUSSIAN_POINT != 0u) len = valid;
}

// Adds listed point primitive i of group g (its kind, and its texel a
// already read) to its group's sum, and, for the bracket, where the query
// enters its reach: what a walk does with an entry it admits.
void add_listed(uint what, uint i, uint kind, vec4 a, uint g, Query q, inout Terms sum, inout float len) {
    GpuPrimitive pr = GpuPrimitive(a, uintBitsToFloat(prim_texel(i, 1u)), uintBitsToFloat(prim_texel(i, 2u)), uvec4(kind, g, 0u, 0u));
    if (what == EVAL_GRADIENT) pr.ids.z = prim_texel(i, 3u).z;
    if (SC_BRACKET != 0u && !q.point) g_reach = min(g_reach, reach_entry(pr, q));
    add_terms(what, pr, q, sum, len);
}

// The fold over the spatial index: per group, its everywhere list and its
// grid lists along the query. A group is folded into the max when it
// yields a primitive, and group 0 always, as the flat fold does (so that a
// query that meets nothing still gets the empty sum), in group order.
Fold fold_indexed(uint what, Query q, inout float len) {
    Fold r = empty_fold();
    g_reach = INFINITY;
    Dda start;
    bool in_grid = SC_TILES == 0u && dda_start(q, start);
    for (uint g = 0u; g < globals.sizes.y; ++g) {
        Terms sum = no_terms();
        bool met = g == 0u;
        uint list = everywhere_list(g);
        uint end = list_start(list + 1u);
        g_visits += end - list_start(list);
        for (uint at = list_start(list); at < end; ++at) {
            GpuPrimitive pr = load_prim(list_entry(at));
            if (SC_BRACKET != 0u && !q.point) g_reach = min(g_reach, reach_entry(pr, q));
            add_terms(what, pr, q, sum, len);
            met = true;
        }
        if (SC_TILES != 0u) {
            list = tile_list(g);
            end = list_start(list + 1u);
            // A point query's point is on the ray, at tq.
            float tq = q.point ? distance(q.o, g_origin) : q.t0;
            float horizon = tile_horizon(q.point ? tq : q.t1);
            float behind = SC_TRANSPARENT != 0u ? min(tq, g_floor) : tq;
            bool prefix = globals.sizes.y == 1u;
            for (uint at = tile_begin(list); at < end; ++at) {
                uvec2 e = tile_entry(at);
                g_visits += 1u;
                if (tile_depth(e) > horizon) break;
                if (!tile_covers(e)) {
                    if (prefix) g_cursor = at + 1u;
                    continue;
                }
                uint i = e.x;
                vec4 a = uintBitsToFloat(prim_texel(i, 0u));
                if (prefix) {
                    if (tile_behind(a, g_origin, g_dir, behind)) {
                        g_cursor = at + 1u;
                        continue;
                    }
                    prefix = false;
                }
                uint kind = grid_kind(i);
                if (!tile_admits(a, kind == PRIM_GAUSSIAN_POINT, q)) continue;
                add_listed(what, i, kind, a, g, q, sum, len);
                met = true;
            }
            if (met) fold_group(what, sum, len, r);
            continue;
        }
        Dda c = start;
        for (bool more = in_grid; more; more = !q.point && dda_advance(c)) {
            list = cell_list(g, c.cell);
            end = list_start(list + 1u);
            g_visits += end - list_start(list);
            for (uint at = list_start(list); at < end; ++at) {
                uint i = list_entry(at);
                uint kind = grid_kind(i);
                vec4 a = uintBitsToFloat(prim_texel(i, 0u));
                if (!grid_admits(c, a, kind == PRIM_GAUSSIAN_POINT, q)) continue;
                add_listed(what, i, kind, a, g, q, sum, len);
                met = true;
            }
        }
        if (met) fold_group(what, sum, len, r);
    }
    if (r.poisoned) poison_fold(r);
    return r;
}

// The fold: every primitive the cursor yields, its terms summed per group,
// groups combined by max. `len` is the interval t1 - t0; EVAL_QUAD may
// shorten it (a validity interval, Section 4.2): later primitives are
// bounded on the shorter interval, and earlier bounds stay valid on it.
// Iso is not subtracted here.
Fold fold_field(uint what, Query q, inout float len) {
    if (SC_INDEX != 0u) return fold_indexed(what, q, len);
    Fold r = empty_fold();
    g_reach = INFINITY;
    Terms sum = no_terms();
    uint group = 0u;
    for (Cursor c = cursor_begin(); c.at < c.end; cursor_advance(c)) {
        GpuPrimitive pr = load_prim(c.at);
        g_visits += 1u;
        if (SC_MULTI_GROUP != 0u && pr.ids.y != group) {
            fold_group(what, sum, len, r);
            sum = no_terms();
            group = pr.ids.y;
        }
        if (SC_BRACKET != 0u && !q.point) g_reach = min(g_reach, reach_entry(pr, q));
        add_terms(what, pr, q, sum, len);
    }
    fold_group(what, sum, len, r);
    if (r.poisoned) poison_fold(r);
    return r;
}

// --- The evaluations the marchers use.

// The surface colour at the point of the last field_eval with want_grad,
// in scenes whose primitives have colours: their average weighted by each
// one's kernel value there.
vec3 g_color = vec3(0.0);

// f(p) = max over groups of the group's sum, minus iso; with the gradient of
// the group attaining the max when want_grad.
float field_eval(vec3 p, bool want_grad, out vec3 grad) {
    float len = 0.0;
    Fold r = fold_field(want_grad ? EVAL_GRADIENT : EVAL_VALUE, point_query(p), len);
    grad = r.grad;
    if (want_grad) g_color = r.v > 0.0 ? r.color / r.v : vec3(0.0);
    return r.v - globals.march.x;
}

float field(vec3 p) {
    vec3 unused;
    return field_eval(p, false, unused);
}

// f at o + ta u and segment tracing's Lipschitz bound on [ta, tb], in one
// pass over the primitives: max over groups of sums for both.
float field_and_lipschitz(vec3 o, vec3 u, float ta, float tb, out float lambda) {
    float len = tb - ta;
    Fold r = fold_field(EVAL_LIPSCHITZ, ray_query(o, u, ta, tb), len);
    lambda = r.slope;
    return r.v - globals.march.x;
}

// Range of f = max over groups (sums) - iso over [ta, tb].
vec2 field_raa(vec3 o, vec3 u, float ta, float tb) {
    float len = tb - ta;
    return fold_field(EVAL_RAA, ray_query(o, u, ta, tb), len).range - globals.march.x;
}

bool bottom_up_quadratic() {
    return SC_METHOD == METHOD_QUADRATIC || SC_METHOD == METHOD_QUADRATIC_RELAXED_T0 || SC_METHOD == METHOD_QUADRATIC_RELAXED_MAX;
}

// The bound of the specialised inclusion method for f = max over groups
// (sums) - iso on [t0, t1]: per-primitive bounds add within a group
// (Eq. 16), and groups combine by the bottom-up max (Section 5.2,
// Appendix C). A validity interval may shorten t1 (Section 4.2).
Bound method_bound(vec3 o, vec3 u, float t0, inout float t1) {
    uint what = bottom_up_quadratic() ? EVAL_QUAD
              : SC_METHOD == METHOD_LINEAR || SC_METHOD == METHOD_LINEAR_BISECTION ? EVAL_LINEAR
              : EVAL_TAYLOR;
    float len = t1 - t0;
    Bound b = fold_field(what, ray_query(o, u, t0, t1), len).bound;
    b.v -= globals.march.x;
    t1 = t0 + len;
    return b;
}

#endif
