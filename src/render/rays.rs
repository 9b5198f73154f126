//! Ray sets: camera rays for images and the benchmark protocol's rays.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

use crate::layout::GpuRay;
use crate::scene::{Aabb, Camera};

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
/// tiles.
pub fn camera_rays(cam: &Camera, width: u32, height: u32, bounds: &Aabb) -> (Vec<GpuRay>, Vec<Option<u32>>) {
    let forward = (cam.target - cam.eye).normalize();
    let right = forward.cross(cam.up).normalize();
    let up = right.cross(forward);
    let half_h = (0.5 * cam.fov_y_deg.to_radians()).tan();
    let half_w = half_h * f64::from(width) / f64::from(height);
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
                    let sx = (2.0 * (f64::from(x) + 0.5) / f64::from(width) - 1.0) * half_w;
                    let sy = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(height)) * half_h;
                    let d = (forward + sx * right + sy * up).normalize();
                    rays.push(clipped_ray(cam.eye, d, bounds));
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
