// The primitives, read through texel views (layout.rs: one gather a
// texel on lavapipe, where a storage-buffer load is a loop over the lanes
// with a bounds check per component). Integer texels, so that every bit
// arrives as written (ids as floats would be denormals).
#ifndef PRIMITIVES_GLSL
#define PRIMITIVES_GLSL

#include "bindings.glsl"

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

#endif
