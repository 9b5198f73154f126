#version 460
// The camera's screen-space tile lists (src/render/tiles.rs) built on the
// GPU (src/render/tile_build.rs), as the host builds them: each point
// primitive's pixels in f64 with the host's arithmetic and pads, the
// primitives sorted by depth, then their (tile, primitive) entries sorted
// by list, stably, so that every list comes out in depth order. One pass
// per dispatch, chosen by the specialization constant TILE_PASS:
//   TILE_PASS_PROJECT     one invocation per primitive: its pixels and
//                         depth (render::tiles::pixel_range and depth), its
//                         tile count; its sort key (the depth word's high
//                         bits, or past every depth when no ray meets it)
//   TILE_PASS_HISTOGRAM   one subgroup per chunk of push.chunk keys: how
//                         many of its keys have each digit (push.shift,
//                         push.bits), into scan[digit * chunks + chunk]
//   TILE_PASS_SCAN_*      an exclusive prefix sum of scan[0, n): each
//                         workgroup's block total (REDUCE), the totals'
//                         sums (TOP, one workgroup), the blocks' sums (DOWN)
//   TILE_PASS_SCATTER     one subgroup per chunk: each key and value to its
//                         place, in order within its digit (a stable LSD
//                         radix sort: lanes of equal digits ranked by
//                         ballots, lanes and rounds in order); the entries'
//                         last pass writes each entry into its list
//   TILE_PASS_COUNT       one invocation per primitive in depth order: its
//                         tile count, for the prefix sum that places its
//                         entries
//   TILE_PASS_TOTAL       one invocation: the entries made, into tile_stats
//   TILE_PASS_EMIT        one invocation per primitive in depth order: an
//                         entry per tile its pixels meet, keyed by list
//   TILE_PASS_RANGES      one invocation per list (and one more): where it
//                         starts among the entries sorted by list
//   TILE_PASS_STATS       one invocation per tile: the longest list and the
//                         most entries of one tile
// No invocation loops more than push.chunk / subgroup size, TILE_SCAN_BLOCK,
// or the tiles of the frame (the host keeps them below lavapipe's cap).
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "tiles_bindings.glsl"

layout(local_size_x = 64) in;

layout(constant_id = TILE_PASS_CONSTANT) const uint TILE_PASS = 0u;

layout(push_constant) uniform TilePush {
    uint count;   // items (TILE_COUNT_ENTRIES: the entries made, at most the capacity)
    uint shift;   // the radix digit's first bit
    uint bits;    // its width, 1 to 8
    uint src;     // where the pass reads keys and values (0 or build.halves.x)
    uint dst;     // where it writes them
    uint chunk;   // keys of a subgroup's chunk, a multiple of the subgroup size
    uint scan_n;  // values of a prefix sum (0: the histogram's)
    uint last;    // SCATTER: 1 in the entries' last pass, which writes them into their lists
} push;

// The radix sort's per-subgroup digit counts (at most 16 subgroups of a
// workgroup: subgroups of 4 lanes or more).
shared uint digit_base[16][256];
// A workgroup's subgroup sums (prefix sums).
shared uint subgroup_sums[64];

// The workgroup's index: dispatches too large for one row of workgroups
// come in rows (src/render/tile_build.rs).
uint linear_group() {
    return gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
}

uint items() {
    return push.count == TILE_COUNT_ENTRIES ? min(tile_stats[TILE_STAT_ENTRIES], build.counts.z) : push.count;
}

uint chunks() {
    return (items() + push.chunk - 1u) / push.chunk;
}

uint scan_length() {
    return push.scan_n != 0u ? push.scan_n : (1u << push.bits) * chunks();
}

double f64_of(uvec2 bits) {
    return packDouble2x32(bits);
}

dvec3 f64_vec(uvec4 xy, uvec4 z) {
    return dvec3(packDouble2x32(xy.xy), packDouble2x32(xy.zw), packDouble2x32(z.xy));
}

// render::tiles::slopes: the slopes x/z of the two tangents from the
// origin to the disc of radius r about (x, z), z > r.
dvec2 slopes(double x, double z, double r) {
    precise double q = z * z - r * r;
    precise double root = r * sqrt(x * x + q);
    precise double lo = (x * z - root) / q;
    precise double hi = (x * z + root) / q;
    return dvec2(lo, hi);
}

// The length of v as glam computes it (x² + y² + z², then the root).
double length64(dvec3 v) {
    precise double s = v.x * v.x + v.y * v.y + v.z * v.z;
    return sqrt(s);
}

// The pixel holding image-plane coordinate p, clamped to the frame (in
// f64 first: a support near the eye's plane projects far beyond a uint).
uint pixel_of(double p, uint n) {
    return uint(min(floor(max(p, 0.0LF)), double(n - 1u)));
}

// render::tiles::pixel_range and TileLists::depth for primitive i, in the
// host's order of operations (`precise`: no fused multiply-adds).
void project(uint i) {
    GpuPrimitive pr = prims[i];
    dvec3 eye = f64_vec(build.eye64, build.eye64_z);
    dvec3 forward = f64_vec(build.forward64, build.forward64_z);
    dvec3 right = f64_vec(build.right64, build.right64_z);
    dvec3 up = f64_vec(build.up64, build.up64_z);
    double half_w = f64_of(build.eye64_z.zw);
    double half_h = f64_of(build.forward64_z.zw);
    uint width = build.sizes.x;
    uint height = build.sizes.y;
    dvec3 c = dvec3(pr.a.xyz);
    double radius = double(pr.a.w);
    precise dvec3 rel = c - eye;
    double dist = length64(rel);
    // The depth: the distance to the support's nearest point, rounded
    // down to f32 (f32_below), the pixel bits cleared.
    precise double depth = max(dist - radius, 0.0LF);
    float f = float(depth);
    if (double(f) > depth) f = uintBitsToFloat(floatBitsToUint(f) - 1u);
    uint word = floatBitsToUint(f) & ~((1u << TILE_PIXEL_BITS) - 1u);
    // The padded radius (RADIUS_PAD = 1e-5) and the pixel pad (PIXEL_PAD).
    precise double r = radius * (1.0LF + 1e-5LF) + 1e-5LF * dist;
    precise double z = rel.x * forward.x + rel.y * forward.y + rel.z * forward.z;
    uvec4 x_range = uvec4(0u, width - 1u, 0u, height - 1u);
    bool seen = true;
    if (z + r <= 0.0LF) {
        seen = false;
    } else if (!(z - r <= 1e-9LF * max(r, 1e-300LF))) {
        precise double rx = rel.x * right.x + rel.y * right.y + rel.z * right.z;
        precise double ry = rel.x * up.x + rel.y * up.y + rel.z * up.z;
        dvec2 sx = slopes(rx, z, r);
        dvec2 sy = slopes(ry, z, r);
        double w = double(width);
        double h = double(height);
        precise double px0 = (sx.x / half_w + 1.0LF) * 0.5LF * w - 1e-3LF;
        precise double px1 = (sx.y / half_w + 1.0LF) * 0.5LF * w + 1e-3LF;
        precise double py0 = (1.0LF - sy.y / half_h) * 0.5LF * h - 1e-3LF;
        precise double py1 = (1.0LF - sy.x / half_h) * 0.5LF * h + 1e-3LF;
        if (!(px1 >= 0.0LF && px0 < w && py1 >= 0.0LF && py0 < h)) {
            seen = false;
        } else {
            x_range = uvec4(pixel_of(px0, width), pixel_of(px1, width), pixel_of(py0, height), pixel_of(py1, height));
        }
    }
    uint tiles = 0u;
    if (seen) tiles = (x_range.y / 8u - x_range.x / 8u + 1u) * (x_range.w / 8u - x_range.z / 8u + 1u);
    prim_tiles[i] = uvec4(x_range.x | x_range.y << 16u, x_range.z | x_range.w << 16u, word, tiles);
    // Sorted by the depth word's high bits; unseen past them all.
    // (A depth word's high bits are below 1 << 19: its sign bit is 0.)
    sort_keys[i] = seen ? word >> TILE_PIXEL_BITS : 1u << (31u - TILE_PIXEL_BITS);
    sort_values[i] = i;
}

// The lanes of this subgroup whose digit equals this lane's, among those
// with a key.
uvec4 peers_of(uint digit, bool valid) {
    uvec4 peers = subgroupBallot(valid);
    for (uint b = 0u; b < push.bits; ++b) {
        bool set = ((digit >> b) & 1u) != 0u;
        uvec4 m = subgroupBallot(set);
        peers &= set ? m : ~m;
    }
    return peers;
}

// HISTOGRAM (scatter false) or SCATTER (true) of this subgroup's chunk.
void radix_chunk(bool scatter) {
    uint sg = gl_SubgroupID;
    uint lane = gl_SubgroupInvocationID;
    uint size = gl_SubgroupSize;
    uint chunk = linear_group() * gl_NumSubgroups + sg;
    uint n = items();
    uint count = chunks();
    if (chunk >= count) return;
    uint bins = 1u << push.bits;
    for (uint d = lane; d < bins; d += size) digit_base[sg][d] = scatter ? scan[d * count + chunk] : 0u;
    subgroupMemoryBarrierShared();
    subgroupBarrier();
    uint first = chunk * push.chunk;
    uint last = min(first + push.chunk, n);
    if (!scatter) {
        // Counting needs no order: shared atomics, no ballots.
        for (uint at = first; at < last; at += size) {
            uint k = at + lane;
            if (k < last) atomicAdd(digit_base[sg][(sort_keys[push.src + k] >> push.shift) & (bins - 1u)], 1u);
        }
        subgroupMemoryBarrierShared();
        subgroupBarrier();
    }
    for (uint at = first; scatter && at < last; at += size) {
        uint k = at + lane;
        bool valid = k < last;
        uint key = valid ? sort_keys[push.src + k] : 0u;
        uint digit = (key >> push.shift) & (bins - 1u);
        uvec4 peers = peers_of(digit, valid);
        bool leader = valid && subgroupBallotFindMSB(peers) == lane;
        uint base = digit_base[sg][digit];
        subgroupMemoryBarrierShared();
        subgroupBarrier();
        if (leader) digit_base[sg][digit] = base + subgroupBallotBitCount(peers);
        subgroupMemoryBarrierShared();
        subgroupBarrier();
        if (valid) {
            uint place = base + subgroupBallotExclusiveBitCount(peers);
            uint value = sort_values[push.src + k];
            sort_keys[push.dst + place] = key;
            // The entries' last pass puts each entry in its list at once.
            if (push.last != 0u) list_entries[place] = emitted[value];
            else sort_values[push.dst + place] = value;
        }
    }
    if (!scatter) {
        for (uint d = lane; d < bins; d += size) scan[d * count + chunk] = digit_base[sg][d];
    }
}

// The exclusive prefix sum of v over the workgroup, and its total.
uint workgroup_exclusive(uint v, out uint total) {
    uint inside = subgroupExclusiveAdd(v);
    uint sum = subgroupAdd(v);
    if (subgroupElect()) subgroup_sums[gl_SubgroupID] = sum;
    barrier();
    uint before = 0u;
    total = 0u;
    for (uint s = 0u; s < gl_NumSubgroups; ++s) {
        uint x = subgroup_sums[s];
        if (s < gl_SubgroupID) before += x;
        total += x;
    }
    barrier();
    return before + inside;
}

void scan_reduce() {
    uint n = scan_length();
    uint first = linear_group() * TILE_SCAN_BLOCK + gl_LocalInvocationID.x * 16u;
    uint sum = 0u;
    for (uint k = first; k < min(first + 16u, n); ++k) sum += scan[k];
    uint total;
    workgroup_exclusive(sum, total);
    if (gl_LocalInvocationID.x == 0u) scan[build.halves.y + linear_group()] = total;
}

void scan_top() {
    uint blocks = (scan_length() + TILE_SCAN_BLOCK - 1u) / TILE_SCAN_BLOCK;
    uint running = 0u;
    for (uint at = 0u; at < blocks; at += 64u) {
        uint k = at + gl_LocalInvocationID.x;
        uint v = k < blocks ? scan[build.halves.y + k] : 0u;
        uint total;
        uint before = workgroup_exclusive(v, total);
        if (k < blocks) scan[build.halves.y + k] = running + before;
        running += total;
    }
}

void scan_down() {
    uint n = scan_length();
    uint first = linear_group() * TILE_SCAN_BLOCK + gl_LocalInvocationID.x * 16u;
    uint last = min(first + 16u, n);
    uint sum = 0u;
    for (uint k = first; k < last; ++k) sum += scan[k];
    uint total;
    uint running = scan[build.halves.y + linear_group()] + workgroup_exclusive(sum, total);
    for (uint k = first; k < last; ++k) {
        uint v = scan[k];
        scan[k] = running;
        running += v;
    }
}

void main() {
    uint i = linear_group() * 64u + gl_LocalInvocationID.x;
    switch (TILE_PASS) {
    case TILE_PASS_PROJECT:
        if (i < push.count) project(i);
        if (i < TILE_STAT_WORDS) tile_stats[i] = 0u;
        break;
    case TILE_PASS_HISTOGRAM:
        radix_chunk(false);
        break;
    case TILE_PASS_SCATTER:
        radix_chunk(true);
        break;
    case TILE_PASS_SCAN_REDUCE:
        scan_reduce();
        break;
    case TILE_PASS_SCAN_TOP:
        scan_top();
        break;
    case TILE_PASS_SCAN_DOWN:
        scan_down();
        break;
    case TILE_PASS_COUNT:
        // push.count primitives, then one more: the total's place.
        if (i < push.count) scan[i] = prim_tiles[sort_values[push.src + i]].w;
        if (i == push.count) scan[i] = 0u;
        break;
    case TILE_PASS_TOTAL:
        if (i == 0u) tile_stats[TILE_STAT_ENTRIES] = scan[push.count];
        break;
    case TILE_PASS_EMIT:
        if (i < push.count) {
            uint prim = sort_values[push.src + i];
            uvec4 t = prim_tiles[prim];
            uint place = scan[i];
            uint x0 = t.x & 0xffffu, x1 = t.x >> 16u, y0 = t.y & 0xffffu, y1 = t.y >> 16u;
            uint group = prims[prim].ids.y;
            uint tiles_x = x1 / 8u - x0 / 8u + 1u;
            for (uint k = 0u; k < t.w; ++k) {
                uint e = place + k;
                if (e >= build.counts.z) break;
                uint tx = x0 / 8u + k % tiles_x;
                uint ty = y0 / 8u + k / tiles_x;
                // The pixels of the tile the support may cover, tile-local.
                uint lx0 = min(x0 - min(x0, tx * 8u), 7u), lx1 = min(x1 - min(x1, tx * 8u), 7u);
                uint ly0 = min(y0 - min(y0, ty * 8u), 7u), ly1 = min(y1 - min(y1, ty * 8u), 7u);
                uint pixels = lx0 | lx1 << 3u | ly0 << 6u | ly1 << 9u;
                sort_keys[push.dst + e] = (ty * build.sizes.z + tx) * build.counts.y + group;
                sort_values[push.dst + e] = e;
                emitted[e] = uvec2(prim, t.z | pixels);
            }
        }
        break;
    case TILE_PASS_RANGES:
        if (i <= build.counts.w) {
            // The first entry of list i or a later one.
            uint lo = 0u, hi = items();
            while (lo < hi) {
                uint mid = (lo + hi) / 2u;
                if (sort_keys[push.src + mid] < i) lo = mid + 1u; else hi = mid;
            }
            list_starts[i] = lo;
        }
        break;
    case TILE_PASS_STATS: {
        uint longest = 0u, crowd = 0u;
        uint tiles = build.sizes.z * build.sizes.w;
        if (i < tiles) {
            uint g = build.counts.y;
            for (uint k = 0u; k < g; ++k) longest = max(longest, list_starts[i * g + k + 1u] - list_starts[i * g + k]);
            crowd = list_starts[(i + 1u) * g] - list_starts[i * g];
        }
        longest = subgroupMax(longest);
        crowd = subgroupMax(crowd);
        if (subgroupElect()) {
            atomicMax(tile_stats[TILE_STAT_LONGEST], longest);
            atomicMax(tile_stats[TILE_STAT_CROWD], crowd);
        }
        break;
    }
    default:
        break;
    }
}
