// Descriptor bindings and push constants of march.comp.
#ifndef BINDINGS_GLSL
#define BINDINGS_GLSL

#include "layout.glsl"

layout(std430, binding = 0) readonly buffer GlobalsBuffer { GpuGlobals globals; };
layout(std430, binding = 1) readonly buffer PrimitiveBuffer { GpuPrimitive prims[]; };
layout(std430, binding = 2) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = 3) readonly buffer RayBuffer { GpuRay rays[]; };
#ifdef BOUNDS_PROBE
layout(std430, binding = 4) writeonly buffer BoundBuffer { GpuBound bounds[]; };
#else
layout(std430, binding = 4) writeonly buffer ResultBuffer { GpuResult results[]; };
#endif
layout(std430, binding = 5) buffer StateBuffer { GpuMarchState states[]; };
// Rays still marching after this dispatch.
layout(std430, binding = 6) buffer ActiveBuffer { uint active_rays; };
// Transparent rendering: each ray's crossings, MAX_CROSSINGS per ray, in
// order; the first is entering, then they alternate.
layout(std430, binding = 7) writeonly buffer CrossingBuffer { float crossings[]; };

// One slice of the march of one tile of rays.
layout(push_constant) uniform Push {
    uint ray_count;
    uint first_slice;   // 1: start the rays; 0: resume them from `states`
    uint slice_steps;   // marching steps per ray in this dispatch
} push;

#endif
