#version 460
// A frame made on the GPU around the march (src/render/frame.rs): the
// camera's rays, the look of each sample, their mean and the 8-bit image,
// the march's statistics, and the gate that lets a march's next slice run
// only while rays are still marching. One pass per dispatch, chosen by
// the specialization constant LOOK_PASS:
//   LOOK_PASS_CAMERA      one invocation per ray (tile order): the ray
//                         through its pixel's sub-pixel position of sample
//                         push.sample, clipped to the scene's bounds, as
//                         render::rays::camera_rays_through makes it in f64
//   LOOK_PASS_SURFACE     one invocation per ray: the statistics, and what
//                         its shadow and occlusion rays need kept (the hit,
//                         its unlit colour); what they take away zeroed
//   LOOK_PASS_SPAWN       one invocation per ray: its shadow ray towards
//                         light push.batch, or occlusion ray push.batch -
//                         lights, as render::light::spawn casts them (a
//                         ray not cast misses the box)
//   LOOK_PASS_OCCLUDE     one invocation per ray: what that ray's answer
//                         takes away (render::light::apply), its counts
//   LOOK_PASS_SAMPLE      one invocation per ray: its colour less what its
//                         shadows and occlusion take away, and its view
//                         depth, into its pixel; depth cueing
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
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require

#include "look_bindings.glsl"

layout(local_size_x = 64) in;

// The pass: a pipeline each (src/render/frame.rs), so that each holds
// only its own code.
layout(constant_id = LOOK_PASS_CONSTANT) const uint LOOK_PASS = 0u;

layout(push_constant) uniform LookPush {
    uint pass;     // LOOK_PASS again (a pipeline of every pass takes it here)
    uint sample_index;
    uint count;    // invocations wanted (rays or pixels)
    uint batch;    // SPAWN, OCCLUDE: a light, then the occlusion rays
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
// hashed_unit): the same words, the float in f64 as the host's.
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

double hashed_unit(uint i, uint p) {
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
    return double(i) / 4294967296.0LF;
}

// render::rays::subpixel: sample s of n in pixel `pixel`, in [0, 1)².
dvec2 subpixel(uint pixel, uint s, uint n, uint seed) {
    if (n <= 1u) return dvec2(0.5LF);
    uint p = (pixel * 0x9e3779b9u) ^ (seed * 0x85ebca6bu);
    uint x = permute_index(s, n, p * 0xa511e9b3u);
    uint y = permute_index(s, n, p * 0x63d83595u);
    precise double ox = (double(x) + hashed_unit(s, p * 0xa399d265u)) / double(n);
    precise double oy = (double(y) + hashed_unit(s, p * 0x711ad6a5u)) / double(n);
    return dvec2(ox, oy);
}

// An f64 vector from its bits: x and y in `xy`, z in the low half of `z`.
dvec3 d3(uvec4 xy, uvec4 z) {
    return dvec3(packDouble2x32(xy.xy), packDouble2x32(xy.zw), packDouble2x32(z.xy));
}

// glam's min and max of two (a NaN on the left gives the right).
double lesser(double a, double b) {
    return a < b ? a : b;
}
double greater(double a, double b) {
    return a > b ? a : b;
}

// Scene::Aabb::clip_ray with glam's min, max and elements, and f64's max
// with 0 (which drops a NaN).
dvec2 clip_to_box64(dvec3 o, dvec3 d) {
    dvec3 lo = d3(look.min64, look.min64_z);
    dvec3 hi = d3(look.max64, look.max64_z);
    precise dvec3 inv = dvec3(1.0LF / d.x, 1.0LF / d.y, 1.0LF / d.z);
    precise dvec3 a = (lo - o) * inv;
    precise dvec3 b = (hi - o) * inv;
    dvec3 near = dvec3(lesser(a.x, b.x), lesser(a.y, b.y), lesser(a.z, b.z));
    dvec3 far = dvec3(greater(a.x, b.x), greater(a.y, b.y), greater(a.z, b.z));
    double t0 = greater(greater(near.x, near.y), near.z);
    t0 = isnan(t0) ? 0.0LF : max(t0, 0.0LF);
    double t1 = lesser(lesser(far.x, far.y), far.z);
    return t0 <= t1 ? dvec2(t0, t1) : dvec2(1.0LF, 0.0LF);
}

// Camera ray i of sample push.sample_index (a padding ray where its pixel
// is outside the frame), made in f64 as render::rays::camera_rays_through
// makes it and rounded to f32 as it rounds: the same bits (`precise` keeps
// the compiler from fusing a multiply and an add the host does apart).
GpuRay camera_ray(uint i) {
    uvec2 xy = ray_pixel(i);
    uint width = look.dims.x;
    uint height = look.dims.y;
    if (xy.x >= width || xy.y >= height) {
        return GpuRay(vec4(0.0), vec4(0.0, 0.0, 1.0, -1.0));
    }
    dvec2 at = subpixel(xy.y * width + xy.x, push.sample_index, look.dims.w, look.flags.z);
    double half_w = packDouble2x32(look.eye64_z.zw);
    double half_h = packDouble2x32(look.right64_z.zw);
    dvec3 eye = d3(look.eye64, look.eye64_z);
    dvec3 right = d3(look.right64, look.right64_z);
    dvec3 up = d3(look.up64, look.up64_z);
    dvec3 forward = d3(look.forward64, look.forward64_z);
    precise double sx = (2.0LF * (double(xy.x) + at.x) / double(width) - 1.0LF) * half_w;
    precise double sy = (1.0LF - 2.0LF * (double(xy.y) + at.y) / double(height)) * half_h;
    precise dvec3 o = eye;
    precise dvec3 d = forward;
    if (look.up.w != 0.0) {
        o = eye + sx * right + sy * up;
    } else {
        precise dvec3 v = forward + sx * right + sy * up;
        precise double len2 = v.x * v.x + v.y * v.y + v.z * v.z;
        precise double recip = 1.0LF / sqrt(len2);
        d = v * recip;
    }
    dvec2 t = clip_to_box64(o, d);
    return GpuRay(vec4(vec3(o), float(t.x)), vec4(vec3(d), float(t.y)));
}

bool in_frame(uint i) {
    uvec2 xy = ray_pixel(i);
    return xy.x < look.dims.x && xy.y < look.dims.y;
}

uint rotate_left(uint x, uint k) {
    return (x << k) | (x >> (32u - k));
}

// render::light's hash_unit.
float hash_unit(uint x, uint seed) {
    x ^= seed;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return float(x) * (1.0 / 4294967296.0);
}

// render::light::ao_direction: direction k of the cosine-weighted
// occlusion rays about unit n, rotated by the camera ray's hash.
vec3 ao_direction(vec3 n, uint k, uint ray) {
    const float G = 1.324717957244746;
    float rx = hash_unit(ray, 0x68bc21ebu);
    float ry = hash_unit(ray, 0x02e5be93u);
    float u1 = fract(0.5 + float(k) / G + rx);
    float u2 = fract(0.5 + float(k) / (G * G) + ry);
    float r = sqrt(u1);
    float phi = 6.283185307179586 * u2;
    // glam's any_orthonormal_pair (Duff et al.), the sign of z with -0's.
    float sign_z = (floatBitsToUint(n.z) & 0x80000000u) != 0u ? -1.0 : 1.0;
    float a = -1.0 / (sign_z + n.z);
    float b = n.x * n.y * a;
    vec3 t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * b, -sign_z * n.x);
    vec3 bt = vec3(b, sign_z + n.y * n.y * a, -n.y);
    return normalize(t * (r * cos(phi)) + bt * (r * sin(phi)) + n * sqrt(max(1.0 - u1, 0.0)));
}

// The side of a surface of normal n that a ray along u sees.
vec3 facing(vec3 n, vec3 u) {
    return dot(n, u) > 0.0 ? -n : n;
}

// render::light::unpack_base.
vec3 unpack_base(uint w) {
    return vec3(float(w >> 21u) / 2047.0, float((w >> 10u) & 0x7ffu) / 2047.0, float(w & 0x3ffu) / 1023.0);
}

// render::light::light_terms.
vec3 light_terms(vec3 base, vec3 n, vec3 u, vec3 l, vec3 color) {
    float ndl = max(dot(n, l), 0.0);
    vec3 h = l - u;
    h = dot(h, h) > 0.0 ? normalize(h) : vec3(0.0);
    float spec = ndl > 0.0 ? pow(max(dot(n, h), 0.0), 48.0) : 0.0;
    return color * (base * ndl + 0.25 * spec);
}

// Whether batch push.batch casts a ray from camera ray i: a shaded hit
// inside the frame, and for a shadow ray a light on the side it sees.
bool cast_from(uint i) {
    if (!in_frame(i) || surfaces[i].x == 0u) return false;
    GpuRay cam = camera_rays[i];
    vec3 n = results[i].hit.xyz;
    if (cam.d.w < cam.o.w || n == vec3(0.0)) return false;
    if (push.batch >= look.lighting.x) return look.lighting.z > 0u;
    return look.lighting.y != 0u && dot(facing(n, cam.d.xyz), lights[push.batch].dir.xyz) > 0.0;
}

// The shadow ray (batch < lights) or occlusion ray of camera ray i, as
// render::light::spawn casts it: from the hit, off the surface on the side
// the camera ray sees, in f64 from the march's f32 results as the host
// does (an occlusion ray's direction in f32: GLSL has no f64 sine).
void spawn(uint i) {
    GpuRay miss = GpuRay(vec4(0.0, 0.0, 0.0, 1.0), vec4(0.0, 0.0, 1.0, 0.0));
    if (!cast_from(i)) {
        rays[i] = miss;
        return;
    }
    GpuRay cam = camera_rays[i];
    GpuResult r = results[i];
    dvec3 n = dvec3(r.hit.xyz);
    dvec3 u = dvec3(cam.d.xyz);
    precise double side = n.x * u.x + n.y * u.y + n.z * u.z;
    dvec3 f = side > 0.0LF ? -n : n;
    double eps = packDouble2x32(look.min64_z.zw);
    precise dvec3 start = dvec3(cam.o.xyz) + double(r.hit.w) * u + eps * f;
    vec3 dir;
    double reach = double(INF);
    uint lights_n = look.lighting.x;
    if (push.batch < lights_n) {
        dir = lights[push.batch].dir.xyz;
    } else {
        uint key = floatBitsToUint(cam.d.x) ^ rotate_left(floatBitsToUint(cam.d.y), 11u) ^ rotate_left(floatBitsToUint(cam.d.z), 22u);
        dir = ao_direction(vec3(f), push.batch - lights_n, key);
        reach = double(look.reach.y);
    }
    dvec2 t = clip_to_box64(start, dvec3(dir));
    rays[i] = GpuRay(vec4(vec3(start), float(max(t.x, 0.0LF))), vec4(dir, float(min(t.y, reach))));
}


// A 64-bit sum kept as two words: the carry into the high one.
void add_wide(uint k, uint v) {
    if (v == 0u) return;
    uint before = atomicAdd(stats[k], v);
    if (before + v < before) atomicAdd(stats[k + 1u], 1u);
}

// The march's statistics of camera ray i (live: a ray of the dispatch),
// and what its shadow and occlusion rays need kept: whether it hit and
// its unlit colour (their marches overwrite its counts); what they take
// away zeroed. The statistics are summed over the subgroup, then added to
// the frame's by one lane (lavapipe pays a workgroup barrier dearly).
void surface_pass(uint i, bool live) {
    bool counted = live && in_frame(i);
    GpuResult r;
    r.counts = uvec4(0u);
    r.crossings = uvec4(0u);
    if (counted) {
        r = results[i];
        surfaces[i] = uvec4((r.counts.w & FLAG_HIT) != 0u ? 1u : 0u, r.crossings.w, 0u, 0u);
        shadows[i] = vec4(0.0);
    }
    uint rays_n = subgroupAdd(counted ? 1u : 0u);
    uint hits = subgroupAdd((r.counts.w & FLAG_HIT) != 0u ? 1u : 0u);
    uint out_of_steps = subgroupAdd((r.counts.w & FLAG_OUT_OF_STEPS) != 0u ? 1u : 0u);
    uint most = subgroupMax(r.counts.x);
    uint steps = subgroupAdd(r.counts.x);
    uint evals = subgroupAdd(r.counts.y);
    uint refine = subgroupAdd(r.counts.z);
    uint visits = subgroupAdd(r.crossings.y);
    uint turns = subgroupAdd(r.crossings.z);
    if (subgroupElect() && rays_n > 0u) {
        atomicAdd(stats[LOOK_STAT_RAYS], rays_n);
        atomicAdd(stats[LOOK_STAT_HITS], hits);
        atomicAdd(stats[LOOK_STAT_OUT_OF_STEPS], out_of_steps);
        atomicMax(stats[LOOK_STAT_MAX_STEPS], most);
        add_wide(LOOK_STAT_STEPS, steps);
        add_wide(LOOK_STAT_EVALS, evals);
        add_wide(LOOK_STAT_REFINE, refine);
        add_wide(LOOK_STAT_VISITS, visits);
        add_wide(LOOK_STAT_TURNS, turns);
    }
}

// What the answer of camera ray i's shadow or occlusion ray of batch
// push.batch takes away (render::light::apply), and its counts.
void occlude(uint i) {
    if (!cast_from(i)) return;
    GpuRay ray = rays[i];
    GpuResult m = results[i];
    bool hit = ray.d.w >= ray.o.w && (m.counts.w & FLAG_HIT) != 0u;
    if (push.batch < look.lighting.x) {
        atomicAdd(stats[LOOK_STAT_SHADOW_RAYS], 1u);
        add_wide(LOOK_STAT_SHADOW_STEPS, m.counts.x);
        if (hit) {
            vec3 u = camera_rays[i].d.xyz;
            GpuLight l = lights[push.batch];
            shadows[i].rgb += light_terms(unpack_base(surfaces[i].y), facing(m.hit.xyz, u), u, l.dir.xyz, l.color.rgb);
        }
    } else {
        atomicAdd(stats[LOOK_STAT_AO_RAYS], 1u);
        add_wide(LOOK_STAT_AO_STEPS, m.counts.x);
        if (hit) shadows[i].w += 1.0;
    }
}

// Ray i's colour, less what its shadows and occlusion took away, and its
// view depth, into its pixel; depth cueing.
void sample_pass(uint i) {
    if (!in_frame(i)) return;
    uvec2 xy = ray_pixel(i);
    GpuResult r = results[i];
    bool hit = surfaces[i].x != 0u;
    vec3 color = r.color.rgb;
    float depth = INF;
    if (hit) {
        vec4 dark = shadows[i];
        vec3 take = dark.rgb;
        if (look.lighting.z > 0u && dark.w > 0.0) {
            take += unpack_base(surfaces[i].y) * look.ambient.rgb * (dark.w / float(look.lighting.z));
        }
        if (take != vec3(0.0)) color = max(color - take, vec3(0.0));
        GpuRay ray = camera_rays[i];
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
    if (LOOK_PASS == LOOK_PASS_SURFACE) {
        // Every invocation of a subgroup takes part in its sums.
        surface_pass(i, i < push.count);
        return;
    }
    if (i >= push.count) return;
    if (LOOK_PASS == LOOK_PASS_CAMERA) {
        GpuRay ray = camera_ray(i);
        rays[i] = ray;
        camera_rays[i] = ray;
    } else if (LOOK_PASS == LOOK_PASS_SPAWN) {
        spawn(i);
    } else if (LOOK_PASS == LOOK_PASS_OCCLUDE) {
        occlude(i);
    } else if (LOOK_PASS == LOOK_PASS_SAMPLE) {
        sample_pass(i);
    } else if (LOOK_PASS == LOOK_PASS_ACCUMULATE) {
        accumulate(i);
    } else if (LOOK_PASS == LOOK_PASS_FINISH) {
        finish(i);
    } else if (LOOK_PASS == LOOK_PASS_GATE && i != 0u) {
        // One invocation, whatever push.count (the rays the gate counts).
    } else if (LOOK_PASS == LOOK_PASS_GATE && push.sample_index != 0u) {
        // After a march's last slice: rays still marching void the frame.
        if (active_rays > 0u) stats[LOOK_STAT_UNFINISHED] = 1u;
        active_rays = 0u;
    } else if (LOOK_PASS == LOOK_PASS_GATE) {
        next_groups[0] = active_rays > 0u ? (push.count + 63u) / 64u : 0u;
        next_groups[1] = 1u;
        next_groups[2] = 1u;
        active_rays = 0u;
    }
}
