// The spatial index's geometry: a uniform grid over the scene's box, and
// per group one list of primitives per cell plus one "everywhere" list
// (planes, and primitives whose support covers too many cells). Built by
// index.comp every frame, walked by the cursor of cursor_grid.glsl. Mirrored
// by src/render/index.rs (layout and budgets) and src/field/grid.rs.
//
// globals.grid: xyz the box's minimum corner, w the cell size h.
// globals.grid_dims: xyz cells per axis, w lists per group (cells + 1).
// Primitive i's support for the index is the sphere of radius
// prims[i].c.y about its centre (R for compact kernels, the clipping
// radius for Gaussians).
#ifndef GRID_GLSL
#define GRID_GLSL

// MAX_CELLS_PER_PRIMITIVE and CELL_PAD come from src/layout.rs.

uint grid_lists_per_group() {
    return globals.grid_dims.w;
}

uint everywhere_list(uint group) {
    return group * grid_lists_per_group() + grid_lists_per_group() - 1u;
}

uint cell_list(uint group, ivec3 cell) {
    uvec3 n = globals.grid_dims.xyz;
    return group * grid_lists_per_group() + uint(cell.x) + n.x * (uint(cell.y) + n.y * uint(cell.z));
}

// The cell holding x, clamped into the grid.
ivec3 cell_of(vec3 x) {
    vec3 c = floor((x - globals.grid.xyz) / globals.grid.w);
    return clamp(ivec3(c), ivec3(0), ivec3(globals.grid_dims.xyz) - 1);
}

// Does primitive pr go to its group's everywhere list? Every kind but the
// points does (planes, HRBF terms, affine functions), and any
// primitive whose padded box may cover more than MAX_CELLS_PER_PRIMITIVE
// cells wherever it is (a bound independent of its position, so that the
// host can count these lists without reading the primitives back).
bool in_everywhere_list(GpuPrimitive pr) {
    if (pr.ids.x != PRIM_COMPACT_POINT && pr.ids.x != PRIM_GAUSSIAN_POINT) return true;
    float span = ceil(2.0 * (pr.c.y + CELL_PAD * globals.grid.w) / globals.grid.w) + 1.0;
    return span * span * span > float(MAX_CELLS_PER_PRIMITIVE);
}

// The cells of a grid primitive's padded box.
void primitive_cells(GpuPrimitive pr, out ivec3 lo, out ivec3 hi) {
    float pad = pr.c.y + CELL_PAD * globals.grid.w;
    lo = cell_of(pr.a.xyz - pad);
    hi = cell_of(pr.a.xyz + pad);
}

// Whether a grid primitive's sphere, padded like its box, meets the cell:
// only those cells list it (about 0.76 of its box's cells for a radius of
// one cell). A walk yields a primitive in the cell holding the query's
// point nearest its centre, inside the sphere, or the point of a point
// query, and such a cell meets the sphere; the pad covers the walk's
// rounding.
bool sphere_meets_cell(GpuPrimitive pr, ivec3 cell) {
    float h = globals.grid.w;
    vec3 lo = globals.grid.xyz + h * vec3(cell);
    vec3 d = max(max(lo - pr.a.xyz, pr.a.xyz - (lo + h)), vec3(0.0));
    float r = pr.c.y + CELL_PAD * h;
    return dot(d, d) < r * r;
}

#endif
