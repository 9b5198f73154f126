// Descriptor bindings and push constants of march.comp.
#ifndef BINDINGS_GLSL
#define BINDINGS_GLSL

#include "layout.glsl"

layout(std430, binding = 0) readonly buffer GlobalsBuffer { GpuGlobals globals; };
layout(std430, binding = 1) readonly buffer PrimitiveBuffer { GpuPrimitive prims[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = 3) readonly buffer RayBuffer { GpuRay rays[]; };
layout(std430, binding = 4) writeonly buffer ResultBuffer { GpuResult results[]; };

// The tile of rays this dispatch handles.
layout(push_constant) uniform Push {
    uint ray_count;
} push;

#endif
