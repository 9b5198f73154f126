//! Ray sets: camera rays for images and the benchmark protocol's rays.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::layout::GpuRay;
use crate::scene::{Aabb, Camera, Projection};

/// Camera rays are ordered in 8x8 pixel tiles, one 64-wide workgroup each,
/// so that neighbouring lanes march neighbouring pixels.
pub const PIXEL_TILE: u32 = 8;

/// A ray as the GPU sees it, in f64 for the reference: the GPU's f32 values
/// widened, the direction renormalised (it is unit only to f32 precision,
/// and the along-ray algebra of the bounds assumes |u| = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: DVec3,
    pub d: DVec3,
    pub t0: f64,
    pub t1: f64,
}

impl Ray {
    pub fn from_gpu(r: &GpuRay) -> Ray {
        Ray {
            o: DVec3::new(r.o[0].into(), r.o[1].into(), r.o[2].into()),
            d: DVec3::new(r.d[0].into(), r.d[1].into(), r.d[2].into()).normalize_or_zero(),
            t0: r.o[3].into(),
            t1: r.d[3].into(),
        }
    }

    pub fn misses(&self) -> bool {
        !(self.t0 <= self.t1)
    }
}

/// A ray from `o` along unit `d`, clipped to `bounds` (a miss has
/// `tmax < tmin`).
pub fn clipped_ray(o: DVec3, d: DVec3, bounds: &Aabb) -> GpuRay {
    let (t0, t1) = bounds.clip_ray(o, d).unwrap_or((1.0, 0.0));
    GpuRay { o: [o.x as f32, o.y as f32, o.z as f32, t0 as f32], d: [d.x as f32, d.y as f32, d.z as f32, t1 as f32] }
}

/// Camera rays for a `width` x `height` image in tile order, and for each
/// ray its pixel index (`y * width + x`), `None` for padding rays of partial
/// tiles. Each ray goes through its pixel's centre.
pub fn camera_rays(cam: &Camera, width: u32, height: u32, bounds: &Aabb) -> (Vec<GpuRay>, Vec<Option<u32>>) {
    camera_rays_through(cam, width, height, bounds, |_| (0.5, 0.5))
}

/// Kensler's hashed permutation ("Correlated Multi-Jittered Sampling",
/// Pixar technical memo 13-01, 2013): `i`'s place in a permutation of
/// `0..l` chosen by `p`, for any `l`, by cycle walking.
fn permute(mut i: u32, l: u32, p: u32) -> u32 {
    let mut w = l - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < l {
            return i.wrapping_add(p) % l;
        }
    }
}

/// Kensler's hashed float in [0, 1).
fn hashed_unit(mut i: u32, p: u32) -> f64 {
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i = i.wrapping_mul(0xb365_34e5);
    i ^= i >> 12;
    i ^= i >> 21;
    i = i.wrapping_mul(0x93fc_4795);
    i ^= 0xdf6e_307f;
    i ^= i >> 17;
    i = i.wrapping_mul(1 | p >> 18);
    f64::from(i) / 4_294_967_296.0
}

/// Sub-pixel position `s` of `n` in pixel `pixel` (in [0, 1)², from the
/// pixel's top-left corner): a Latin hypercube, so each of the pixel's `n`
/// columns and each of its `n` rows holds exactly one sample (a straight
/// vertical or horizontal edge is then covered within 1/n), jittered
/// within its cell, with a permutation of its own for every pixel (hashed
/// from the pixel and `seed`), so neighbouring pixels do not repeat one
/// pattern. Deterministic; one sample is the pixel's centre.
pub fn subpixel(pixel: u32, s: u32, n: u32, seed: u32) -> (f64, f64) {
    if n <= 1 {
        return (0.5, 0.5);
    }
    let p = pixel.wrapping_mul(0x9e37_79b9) ^ seed.wrapping_mul(0x85eb_ca6b);
    let x = permute(s, n, p.wrapping_mul(0xa511_e9b3));
    let y = permute(s, n, p.wrapping_mul(0x63d8_3595));
    let (jx, jy) = (hashed_unit(s, p.wrapping_mul(0xa399_d265)), hashed_unit(s, p.wrapping_mul(0x711a_d6a5)));
    ((f64::from(x) + jx) / f64::from(n), (f64::from(y) + jy) / f64::from(n))
}

/// A camera's image plane for a `width` x `height` frame: the camera's unit
/// axes, and half the plane's width and height. Perspective: the plane at
/// distance 1; orthographic (`ortho`, its height): the plane through the
/// eye, every ray along `forward`. The host's camera rays and the shader's
/// (render::frame) start from these numbers.
pub struct ImagePlane {
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub ortho: Option<f64>,
    pub half_w: f64,
    pub half_h: f64,
}

impl ImagePlane {
    pub fn of(cam: &Camera, width: u32, height: u32) -> ImagePlane {
        let forward = (cam.target - cam.eye).normalize();
        let right = forward.cross(cam.up).normalize();
        let up = right.cross(forward);
        let ortho = match cam.projection {
            Projection::Perspective => None,
            Projection::Orthographic { height } => Some(height),
        };
        let half_h = ortho.map_or_else(|| (0.5 * cam.fov_y_deg.to_radians()).tan(), |h| 0.5 * h);
        let half_w = half_h * f64::from(width) / f64::from(height);
        ImagePlane { forward, right, up, ortho, half_w, half_h }
    }
}

/// [`camera_rays`] through the point `at(pixel)` of each pixel (from its
/// top-left corner, in pixels).
pub fn camera_rays_through(cam: &Camera, width: u32, height: u32, bounds: &Aabb, at: impl Fn(u32) -> (f64, f64)) -> (Vec<GpuRay>, Vec<Option<u32>>) {
    let ImagePlane { forward, right, up, ortho, half_w, half_h } = ImagePlane::of(cam, width, height);
    let tiles_x = width.div_ceil(PIXEL_TILE);
    let tiles_y = height.div_ceil(PIXEL_TILE);
    let n = (tiles_x * tiles_y * PIXEL_TILE * PIXEL_TILE) as usize;
    let mut rays = Vec::with_capacity(n);
    let mut pixels = Vec::with_capacity(n);
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            for iy in 0..PIXEL_TILE {
                for ix in 0..PIXEL_TILE {
                    let (x, y) = (tx * PIXEL_TILE + ix, ty * PIXEL_TILE + iy);
                    if x >= width || y >= height {
                        rays.push(GpuRay { o: [0.0; 4], d: [0.0, 0.0, 1.0, -1.0] });
                        pixels.push(None);
                        continue;
                    }
                    let (ox, oy) = at(y * width + x);
                    let sx = (2.0 * (f64::from(x) + ox) / f64::from(width) - 1.0) * half_w;
                    let sy = (1.0 - 2.0 * (f64::from(y) + oy) / f64::from(height)) * half_h;
                    let (o, d) = match ortho {
                        None => (cam.eye, (forward + sx * right + sy * up).normalize()),
                        Some(_) => (cam.eye + sx * right + sy * up, forward),
                    };
                    let mut ray = clipped_ray(o, d, bounds);
                    // Clipping narrows the ray's interval (the march and the
                    // f64 reference both keep to it).
                    if !cam.clip.is_empty() {
                        let r = Ray::from_gpu(&ray);
                        let (t0, t1) =
                            if r.misses() { (1.0, 0.0) } else { cam.clip.interval(cam, o, d, (r.t0, r.t1)).map_or((1.0, 0.0), |(a, b, _)| (a, b)) };
                        ray.o[3] = t0 as f32;
                        ray.d[3] = t1 as f32;
                    }
                    rays.push(ray);
                    pixels.push(Some(y * width + x));
                }
            }
        }
    }
    (rays, pixels)
}

/// The benchmark protocol's rays (docs/benchmark-protocol.md, "Rays"): origin uniform on the
/// sphere around the box centre with radius the box diagonal, direction
/// towards a point uniform in the box, clipped to the box. Seeded.
pub fn protocol_rays(bounds: &Aabb, count: usize, seed: u64) -> Vec<GpuRay> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let centre = bounds.center();
    let radius = bounds.diagonal();
    let size = bounds.max - bounds.min;
    (0..count)
        .map(|_| {
            // Uniform on the sphere: z uniform in [-1, 1], angle uniform.
            let z: f64 = rng.random_range(-1.0..=1.0);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let s = (1.0 - z * z).max(0.0).sqrt();
            let o = centre + radius * DVec3::new(s * phi.cos(), s * phi.sin(), z);
            let target = bounds.min + size * DVec3::new(rng.random(), rng.random(), rng.random());
            clipped_ray(o, (target - o).normalize(), bounds)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subpixel_samples_are_a_latin_hypercube_of_their_own_in_every_pixel() {
        for n in [2u32, 3, 4, 7, 16, 33] {
            for pixel in [0u32, 1, 77, 1_000_003] {
                let pts: Vec<(f64, f64)> = (0..n).map(|s| subpixel(pixel, s, n, 1)).collect();
                let mut cols: Vec<u32> = pts.iter().map(|p| (p.0 * f64::from(n)) as u32).collect();
                let mut rows: Vec<u32> = pts.iter().map(|p| (p.1 * f64::from(n)) as u32).collect();
                cols.sort_unstable();
                rows.sort_unstable();
                assert_eq!(cols, (0..n).collect::<Vec<_>>(), "n {n}, pixel {pixel}: one sample per column");
                assert_eq!(rows, (0..n).collect::<Vec<_>>(), "n {n}, pixel {pixel}: one sample per row");
                assert!(pts.iter().all(|p| (0.0..1.0).contains(&p.0) && (0.0..1.0).contains(&p.1)));
                assert_eq!(pts, (0..n).map(|s| subpixel(pixel, s, n, 1)).collect::<Vec<_>>(), "deterministic");
            }
            assert_ne!(subpixel(0, 0, n, 1), subpixel(1, 0, n, 1), "pixels differ");
        }
        assert_eq!(subpixel(5, 0, 1, 9), (0.5, 0.5));
    }
}
