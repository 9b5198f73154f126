#version 460
// Builds the spatial index (grid.glsl) on the GPU from the primitives as
// they are this frame: a counting sort of (list, primitive) pairs. Seven
// passes, one dispatch each, chosen by push.pass:
//   0 clear   the counts (one invocation per list, and the scratch header)
//   1 count   each primitive adds 1 to every list it belongs to
//   2 scan    each block of SCAN_BLOCK counts: exclusive prefix sums, and
//             the block's total into the scratch
//   3 top     one invocation: exclusive prefix sums of the block totals
//   4 offset  each block adds its offset; the fill counters start at 0
//   5 fill    each primitive writes its index into its lists
//   6 sort    each list of at most SORT_MAX entries is sorted by index, so
//             sums add up in the same order every frame (longer lists keep
//             the order the atomics gave them)
// No invocation loops more than MAX_CELLS_PER_PRIMITIVE, SCAN_BLOCK,
// SORT_MAX·(SORT_MAX + 1)/2 or (lists / SCAN_BLOCK) times, all below lavapipe's
// per-invocation cap; the host keeps lists / SCAN_BLOCK below it.
//
// cell_start[list] ends as the first entry of the list, with
// cell_start[lists] the total; index_scratch[0] the longest cell list,
// [1, 1 + blocks) the block totals, then one fill counter per list.
#extension GL_GOOGLE_include_directive : require

#define INDEX_BUILD 1

#include "layout.glsl"
#include "layout_bindings.glsl"
#include "grid.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform IndexPush {
    uint count;    // invocations wanted
    uint pass;
    uint unused;
    uint unused_too;   // the march's first_tile (one push range for both)
} push;

// (SCAN_BLOCK comes from src/layout.rs.)
// Insertion sort's worst case for 255 entries is 254 + 254·255/2 = 32,639
// loop turns, half lavapipe's cap; molecule lists hold up to about 200.
const uint SORT_MAX = 255u;

uint list_count() {
    return globals.sizes.y * grid_lists_per_group();
}

uint block_count() {
    return (list_count() + SCAN_BLOCK - 1u) / SCAN_BLOCK;
}

// The entries are a texel buffer (layout.rs: it may outgrow a storage
// buffer's range).
uint entry(uint k) {
    return imageLoad(cell_entries, int(k)).x;
}

uint fill_counter(uint list) {
    return 1u + block_count() + list;
}

// Adds primitive i to its lists: counting (fill false) or writing (true).
void visit_lists(uint i, bool fill) {
    GpuPrimitive pr = prims[i];
    uint group = pr.ids.y;
    if (in_everywhere_list(pr)) {
        uint list = everywhere_list(group);
        if (fill) {
            imageStore(cell_entries, int(cell_start[list] + atomicAdd(index_scratch[fill_counter(list)], 1u)), uvec4(i));
        } else {
            atomicAdd(cell_start[list], 1u);
        }
        return;
    }
    ivec3 lo, hi;
    primitive_cells(pr, lo, hi);
    ivec3 span = hi - lo + 1;
    uint cells = uint(span.x * span.y * span.z);
    for (uint k = 0u; k < cells; ++k) {
        ivec3 cell = lo + ivec3(int(k) % span.x, (int(k) / span.x) % span.y, int(k) / (span.x * span.y));
        if (!sphere_meets_cell(pr, cell)) continue;
        uint list = cell_list(group, cell);
        if (fill) {
            imageStore(cell_entries, int(cell_start[list] + atomicAdd(index_scratch[fill_counter(list)], 1u)), uvec4(i));
        } else {
            atomicAdd(cell_start[list], 1u);
        }
    }
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) return;
    uint lists = list_count();
    switch (push.pass) {
    case 0u:
        if (i <= lists) cell_start[i] = 0u;
        if (i == 0u) index_scratch[0] = 0u;
        break;
    case 1u:
        visit_lists(i, false);
        break;
    case 2u: {
        uint first = i * SCAN_BLOCK;
        uint last = min(first + SCAN_BLOCK, lists);
        uint sum = 0u;
        uint longest = 0u;
        for (uint k = first; k < last; ++k) {
            uint c = cell_start[k];
            cell_start[k] = sum;
            sum += c;
            // The everywhere lists are counted apart by the host.
            if (k % grid_lists_per_group() != grid_lists_per_group() - 1u) longest = max(longest, c);
        }
        index_scratch[1u + i] = sum;
        atomicMax(index_scratch[0], longest);
        break;
    }
    case 3u: {
        uint sum = 0u;
        for (uint b = 0u; b < block_count(); ++b) {
            uint c = index_scratch[1u + b];
            index_scratch[1u + b] = sum;
            sum += c;
        }
        cell_start[lists] = sum;
        break;
    }
    case 4u: {
        uint first = i * SCAN_BLOCK;
        uint last = min(first + SCAN_BLOCK, lists);
        uint offset = index_scratch[1u + i];
        for (uint k = first; k < last; ++k) {
            cell_start[k] += offset;
            index_scratch[fill_counter(k)] = 0u;
        }
        break;
    }
    case 5u:
        visit_lists(i, true);
        break;
    case 6u: {
        uint first = cell_start[i];
        uint n = cell_start[i + 1u] - first;
        if (n > SORT_MAX) break;
        for (uint a = 1u; a < n; ++a) {
            uint v = entry(first + a);
            uint b = a;
            for (; b > 0u && entry(first + b - 1u) > v; --b) imageStore(cell_entries, int(first + b), uvec4(entry(first + b - 1u)));
            imageStore(cell_entries, int(first + b), uvec4(v));
        }
        break;
    }
    default:
        break;
    }
}
