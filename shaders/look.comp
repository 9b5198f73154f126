#version 460
// A frame made on the GPU around the march (src/render/frame.rs): the
// camera's rays, the look of each sample, their mean and the 8-bit image,
// the march's statistics, and the gate that lets a march's next slice run
// only while rays are still marching. One pass per dispatch, chosen by
// push.pass:
//   LOOK_PASS_CAMERA      one invocation per ray (tile order): the ray
//                         through its pixel's sub-pixel position of sample
//                         push.sample, clipped to the scene's bounds, as
//                         render::rays::camera_rays_through makes it in f64
//   LOOK_PASS_SAMPLE      one invocation per ray: its colour and view depth
//                         into its pixel, depth cueing, and the statistics
//   LOOK_PASS_ACCUMULATE  one invocation per pixel: outlines, then the
//                         sample added to the sums (set by sample 0)
//   LOOK_PASS_FINISH      one invocation per pixel: the mean of the samples,
//                         coverage alpha, the background taken out where it
//                         is transparent, 8-bit sRGB
//   LOOK_PASS_GATE        one invocation: the next slice's workgroups, none
//                         once no ray is marching; the counter reset. With
//                         push.sample_index 1, after a sample's last slice:
//                         LOOK_STAT_UNFINISHED set if rays are marching
// The host's version of each is in src/render/offscreen.rs (march_image's
// host path) and src/output/mod.rs (srgb, Frame::shaded_rgba).
#extension GL_GOOGLE_include_directive : require

#include "look_bindings.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform LookPush {
    uint pass;
    uint sample_index;
    uint count;    // invocations wanted (rays or pixels)
    uint unused;
} push;

// Infinity (a miss's depth); GLSL has no constant for it.
#define INF uintBitsToFloat(0x7f800000u)

// The pixel of ray i: rays are in 8x8 pixel tiles, tiles row by row.
uvec2 ray_pixel(uint i) {
    uint tile = i / 64u;
    uint lane = i % 64u;
    return uvec2((tile % look.dims.z) * 8u + lane % 8u, (tile / look.dims.z) * 8u + lane / 8u);
}

// Kensler's hashed permutation and float (render::rays::permute and
// hashed_unit): the same words.
uint permute_index(uint i, uint l, uint p) {
    uint w = l - 1u;
    w |= w >> 1u;
    w |= w >> 2u;
    w |= w >> 4u;
    w |= w >> 8u;
    w |= w >> 16u;
    for (;;) {
        i ^= p;
        i *= 0xe170893du;
        i ^= p >> 16u;
        i ^= (i & w) >> 4u;
        i ^= p >> 8u;
        i *= 0x0929eb3fu;
        i ^= p >> 23u;
        i ^= (i & w) >> 1u;
        i *= 1u | p >> 27u;
        i *= 0x6935fa69u;
        i ^= (i & w) >> 11u;
        i *= 0x74dcb303u;
        i ^= (i & w) >> 2u;
        i *= 0x9e501cc3u;
        i ^= (i & w) >> 2u;
        i *= 0xc860a3dfu;
        i &= w;
        i ^= i >> 5u;
        if (i < l) return (i + p) % l;
    }
}

float hashed_unit(uint i, uint p) {
    i ^= p;
    i ^= i >> 17u;
    i ^= i >> 10u;
    i *= 0xb36534e5u;
    i ^= i >> 12u;
    i ^= i >> 21u;
    i *= 0x93fc4795u;
    i ^= 0xdf6e307fu;
    i ^= i >> 17u;
    i *= 1u | p >> 18u;
    return float(i) * (1.0 / 4294967296.0);
}

// render::rays::subpixel: sample s of n in pixel `pixel`, in [0, 1)².
vec2 subpixel(uint pixel, uint s, uint n, uint seed) {
    if (n <= 1u) return vec2(0.5);
    uint p = (pixel * 0x9e3779b9u) ^ (seed * 0x85ebca6bu);
    uint x = permute_index(s, n, p * 0xa511e9b3u);
    uint y = permute_index(s, n, p * 0x63d83595u);
    vec2 j = vec2(hashed_unit(s, p * 0xa399d265u), hashed_unit(s, p * 0x711ad6a5u));
    return (vec2(float(x), float(y)) + j) / float(n);
}

// Scene::Aabb::clip_ray: the slabs, a NaN (a ray in a face's plane) left
// out as glam's min and max leave it out.
vec2 clip_to_box(vec3 o, vec3 d) {
    float t0 = 0.0;
    float t1 = INF;
    for (int k = 0; k < 3; ++k) {
        float inv = 1.0 / d[k];
        float a = (look.box_min[k] - o[k]) * inv;
        float b = (look.box_max[k] - o[k]) * inv;
        float lo = isnan(a) ? b : (isnan(b) ? a : min(a, b));
        float hi = isnan(a) ? b : (isnan(b) ? a : max(a, b));
        if (!isnan(lo)) t0 = max(t0, lo);
        if (!isnan(hi)) t1 = min(t1, hi);
    }
    return t0 <= t1 ? vec2(t0, t1) : vec2(1.0, 0.0);
}

void camera_ray(uint i) {
    uvec2 xy = ray_pixel(i);
    uint width = look.dims.x;
    uint height = look.dims.y;
    if (xy.x >= width || xy.y >= height) {
        rays[i] = GpuRay(vec4(0.0), vec4(0.0, 0.0, 1.0, -1.0));
        return;
    }
    vec2 at = subpixel(xy.y * width + xy.x, push.sample_index, look.dims.w, look.flags.z);
    float sx = (2.0 * (float(xy.x) + at.x) / float(width) - 1.0) * look.eye.w;
    float sy = (1.0 - 2.0 * (float(xy.y) + at.y) / float(height)) * look.right.w;
    vec3 o = look.eye.xyz;
    vec3 d = look.forward.xyz;
    if (look.up.w != 0.0) {
        o += sx * look.right.xyz + sy * look.up.xyz;
    } else {
        d = normalize(d + sx * look.right.xyz + sy * look.up.xyz);
    }
    vec2 t = clip_to_box(o, d);
    rays[i] = GpuRay(vec4(o, t.x), vec4(d, t.y));
}

// The workgroup's statistics, added to the frame's once per workgroup.
shared uint wg_stats[LOOK_STAT_WORDS];

// A 64-bit sum kept as two words: the carry into the high one.
void add_wide(uint k, uint v) {
    if (v == 0u) return;
    uint before = atomicAdd(stats[k], v);
    if (before + v < before) atomicAdd(stats[k + 1u], 1u);
}

void sample_pass(uint i, bool live) {
    bool counted = false;
    GpuResult r;
    if (live) {
        uvec2 xy = ray_pixel(i);
        counted = xy.x < look.dims.x && xy.y < look.dims.y;
        if (counted) {
            r = results[i];
            bool hit = (r.counts.w & FLAG_HIT) != 0u;
            vec3 color = r.color.rgb;
            float depth = INF;
            if (hit) {
                GpuRay ray = rays[i];
                vec3 p = ray.o.xyz + r.hit.w * normalize(ray.d.xyz);
                depth = dot(p - look.eye.xyz, look.forward.xyz);
                if (look.flags.x != 0u) {
                    // DepthCue::blend: from no blend at box_min.w to all
                    // background at box_max.w.
                    float a = look.box_min.w;
                    float b = look.box_max.w;
                    float f = b > a ? clamp((depth - a) / (b - a), 0.0, 1.0) : (depth >= b ? 1.0 : 0.0);
                    color = color * (1.0 - f) + look.background.rgb * f;
                }
            }
            sample_pixels[xy.y * look.dims.x + xy.x] = vec4(color, depth);
        }
    }
    uint lane = gl_LocalInvocationID.x;
    if (lane < LOOK_STAT_WORDS) wg_stats[lane] = 0u;
    barrier();
    if (counted) {
        atomicAdd(wg_stats[LOOK_STAT_RAYS], 1u);
        atomicAdd(wg_stats[LOOK_STAT_HITS], (r.counts.w & FLAG_HIT) != 0u ? 1u : 0u);
        atomicAdd(wg_stats[LOOK_STAT_OUT_OF_STEPS], (r.counts.w & FLAG_OUT_OF_STEPS) != 0u ? 1u : 0u);
        atomicMax(wg_stats[LOOK_STAT_MAX_STEPS], r.counts.x);
        atomicAdd(wg_stats[LOOK_STAT_STEPS], r.counts.x);
        atomicAdd(wg_stats[LOOK_STAT_EVALS], r.counts.y);
        atomicAdd(wg_stats[LOOK_STAT_REFINE], r.counts.z);
        atomicAdd(wg_stats[LOOK_STAT_VISITS], r.crossings.y);
        atomicAdd(wg_stats[LOOK_STAT_TURNS], r.crossings.z);
    }
    barrier();
    if (lane == 0u) {
        atomicAdd(stats[LOOK_STAT_RAYS], wg_stats[LOOK_STAT_RAYS]);
        atomicAdd(stats[LOOK_STAT_HITS], wg_stats[LOOK_STAT_HITS]);
        atomicAdd(stats[LOOK_STAT_OUT_OF_STEPS], wg_stats[LOOK_STAT_OUT_OF_STEPS]);
        atomicMax(stats[LOOK_STAT_MAX_STEPS], wg_stats[LOOK_STAT_MAX_STEPS]);
        add_wide(LOOK_STAT_STEPS, wg_stats[LOOK_STAT_STEPS]);
        add_wide(LOOK_STAT_EVALS, wg_stats[LOOK_STAT_EVALS]);
        add_wide(LOOK_STAT_REFINE, wg_stats[LOOK_STAT_REFINE]);
        add_wide(LOOK_STAT_VISITS, wg_stats[LOOK_STAT_VISITS]);
        add_wide(LOOK_STAT_TURNS, wg_stats[LOOK_STAT_TURNS]);
    }
}

void accumulate(uint p) {
    vec4 v = sample_pixels[p];
    vec3 color = v.rgb;
    float z = v.w;
    bool hit = z < INF;
    int r = int(look.flags.y);
    if (r > 0 && hit) {
        // Outline::mask: the farthest depth within r pixels (a box), beyond
        // this pixel's by more than the jump.
        int w = int(look.dims.x);
        int h = int(look.dims.y);
        int x = int(p % look.dims.x);
        int y = int(p / look.dims.x);
        float far = -INF;
        for (int row = max(y - r, 0); row <= min(y + r, h - 1); ++row) {
            for (int u = max(x - r, 0); u <= min(x + r, w - 1); ++u) {
                far = max(far, sample_pixels[row * w + u].w);
            }
        }
        if (far - z > look.outline.w) color = look.outline.rgb;
    }
    vec4 s = vec4(color, hit ? 1.0 : 0.0);
    accum[p] = push.sample_index == 0u ? s : accum[p] + s;
}

// output::srgb: linear [0, 1] to 8-bit sRGB.
uint srgb8(float linear) {
    float c = clamp(linear, 0.0, 1.0);
    float s = c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
    return uint(s * 255.0 + 0.5);
}

void finish(uint p) {
    vec4 c = accum[p] / float(max(look.dims.w, 1u));
    uint rgba;
    if (look.background.w != 0.0) {
        // Frame::shaded_rgba: what the hits saw, alpha their coverage.
        float a = clamp(c.a, 0.0, 1.0);
        if (a <= 0.0) {
            rgba = 0u;
        } else {
            vec3 own = (c.rgb - (1.0 - a) * look.background.rgb) / a;
            rgba = srgb8(own.r) | (srgb8(own.g) << 8u) | (srgb8(own.b) << 16u) | (uint(floor(a * 255.0 + 0.5)) << 24u);
        }
    } else {
        rgba = srgb8(c.r) | (srgb8(c.g) << 8u) | (srgb8(c.b) << 16u) | (255u << 24u);
    }
    image[p] = rgba;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (push.pass == LOOK_PASS_SAMPLE) {
        // Every invocation of a workgroup reaches its barriers.
        sample_pass(i, i < push.count);
        return;
    }
    if (i >= push.count) return;
    if (push.pass == LOOK_PASS_CAMERA) {
        camera_ray(i);
    } else if (push.pass == LOOK_PASS_ACCUMULATE) {
        accumulate(i);
    } else if (push.pass == LOOK_PASS_FINISH) {
        finish(i);
    } else if (push.pass == LOOK_PASS_GATE && i != 0u) {
        // One invocation, whatever push.count (the rays the gate counts).
    } else if (push.pass == LOOK_PASS_GATE && push.sample_index != 0u) {
        // After a sample's last slice: rays still marching void the frame.
        if (active_rays > 0u) stats[LOOK_STAT_UNFINISHED] = 1u;
        active_rays = 0u;
    } else if (push.pass == LOOK_PASS_GATE) {
        next_groups[0] = active_rays > 0u ? (push.count + 63u) / 64u : 0u;
        next_groups[1] = 1u;
        next_groups[2] = 1u;
        active_rays = 0u;
    }
}
