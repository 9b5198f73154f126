// The one loop over primitives. Every evaluation of the field (value,
// gradient, segment tracing's slope, the Taylor, linear, quadratic and RAA
// bounds) is a fold: a cursor yields the primitives that can matter to a
// query, one dispatch on the primitive's kind gives its terms (kinds.glsl),
// terms add up within a group, and groups combine by max (Eq. 20). Mirrors
// the fold of src/field/fold.rs.
//
// The primitives come from the flat list (per-ray culling, small scenes;
// fold_field's cursor) or from the spatial index (SC_INDEX, a build
// variant: fold_indexed's walk). Either yields every primitive whose
// support meets the query (a point, or the ray on [t0, t1]), each once,
// and a group's primitives one after another, groups in order. A group is
// folded into the max when it yields a primitive, and group 0 always, so
// a query that meets no primitive still gets the empty sum, 0 - iso.
#ifndef FOLD_GLSL
#define FOLD_GLSL

#include "bindings.glsl"
#include "counters.glsl"
#include "bound.glsl"
#include "quad.glsl"
#include "raa.glsl"
#include "query.glsl"
#include "primitives.glsl"
#include "cursor_flat.glsl"
#include "cursor_grid.glsl"
#include "cursor_tiles.glsl"
#include "points.glsl"
#include "terms.glsl"
#include "kinds.glsl"

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
        if (SC_TILES != 0u) {
            // Every primitive is in the tile lists, those of the grid's
            // everywhere lists too; and a tile pipeline's list bindings
            // hold the tile lists, not the grid's (Renderer::buffers_for).
            uint list = tile_list(g);
            uint end = list_start(list + 1u);
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
        uint list = everywhere_list(g);
        uint end = list_start(list + 1u);
        g_visits += end - list_start(list);
        for (uint at = list_start(list); at < end; ++at) {
            GpuPrimitive pr = load_prim(list_entry(at));
            if (SC_BRACKET != 0u && !q.point) g_reach = min(g_reach, reach_entry(pr, q));
            add_terms(what, pr, q, sum, len);
            met = true;
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

#endif
