// The spatial index's walk (SC_INDEX; grid.glsl has the lists). Per
// group: its everywhere list, then the grid's lists along the query (the
// one cell of a point; the cells a 3D DDA walks for an interval), each
// primitive of the grid yielded once, in the cell holding the query's
// point nearest its centre (grid_admits). Nested loops, so that a list
// entry costs a turn of a tight loop: its index, one texel (the centre and
// the index radius) to test it, and the rest of the primitive only when it
// is admitted. The walk's loops are fold_indexed's (fold.glsl); the tile
// lists (cursor_tiles.glsl) use its list reads and admission tests.
#ifndef CURSOR_GRID_GLSL
#define CURSOR_GRID_GLSL

#include "bindings.glsl"
#include "query.glsl"
#include "primitives.glsl"
#include "grid.glsl"

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

// The kind of grid primitive i: a point kind, known without a fetch when
// the scene has one.
uint grid_kind(uint i) {
    if (SC_HAS_GAUSSIAN_POINT == 0u) return PRIM_COMPACT_POINT;
    if (SC_HAS_COMPACT_POINT == 0u) return PRIM_GAUSSIAN_POINT;
    return prim_texel(i, 3u).x;
}

#endif
