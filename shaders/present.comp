#version 460
// The window's frame (src/gpu/present.rs): an image on the GPU, one RGBA8
// word a pixel row by row (look.comp's image, or host pixels uploaded),
// scaled to the swapchain's size by nearest neighbour as
// src/view/canvas.rs's `upscale` scales it (window pixel x takes frame
// pixel min(x * frame width / window width, frame width - 1)), swizzled to
// the swapchain's byte order and made opaque. A copy then takes the
// window's words into the swapchain image: no format conversion, so the
// sRGB bytes reach the window as they are.
//
// It includes nothing, so that no other kernel's cache key changes with it.
// Its bindings are src/layout.rs's PRESENT_BINDINGS, declared here as that
// list generates them (a unit test checks that they are).

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer FrameBuffer { uint frame_pixels[]; };
layout(std430, binding = 1) writeonly buffer WindowBuffer { uint window_pixels[]; };

layout(push_constant) uniform Push {
    uvec2 frame;   // the image's size in pixels
    uvec2 window;  // the swapchain's
    uint bgra;     // 1: the swapchain's bytes are B, G, R, A
} push;

void main() {
    uvec2 xy = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(xy, push.window))) return;
    uvec2 from = min(xy * push.frame / push.window, push.frame - 1u);
    uint c = frame_pixels[from.y * push.frame.x + from.x];
    if (push.bgra != 0u) c = (c & 0x0000ff00u) | ((c & 0xffu) << 16u) | ((c >> 16u) & 0xffu);
    window_pixels[xy.y * push.window.x + xy.x] = (c & 0x00ffffffu) | 0xff000000u;
}
