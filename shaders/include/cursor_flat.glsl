// The flat cursor (without SC_INDEX): every primitive of the list in
// order, and with SC_CULL only those whose support meets the part of the
// ray still to march. Per-ray culling (cull_to_ray) is its set-up.
#ifndef CURSOR_FLAT_GLSL
#define CURSOR_FLAT_GLSL

#include "bindings.glsl"
#include "primitives.glsl"

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

#endif
