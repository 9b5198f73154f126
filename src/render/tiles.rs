//! Screen-space lists for camera rays (dynamol's per-pixel lists, 3D
//! Gaussian splatting's tile lists): each 8x8 pixel tile (one 64-wide
//! workgroup of camera rays, `rays::PIXEL_TILE`) gets, per group, every
//! point primitive whose clipped support a ray of the tile may meet, in
//! the order the rays reach them (the distance from the eye to the support's
//! nearest point). A step's candidates are then a prefix of its tile's list:
//! the walk reads entries from the front and stops at the first that starts
//! beyond the step's window. Every lane of a workgroup reads the same
//! entries, where the grid made each ray walk its own cells.
//!
//! The lists are built on the host, in f64, from the primitives as the GPU
//! holds them (f32 centres and clip radii), and are conservative: a ray
//! through any point of any pixel of a tile (anti-aliasing samples included)
//! finds every support it meets in its tile's list. Supports that reach the
//! eye's plane go into every tile; supports behind the eye into none.

use glam::DVec3;

use super::rays::PIXEL_TILE;
use crate::layout::GpuPrimitive;
use crate::scene::Camera;

/// A support's radius is padded by this fraction of its distance from the
/// eye and of itself, so that the f32 rays and the f32 sphere test on the
/// GPU (which round at about 1e-7) meet nothing the f64 binning left out.
const RADIUS_PAD: f64 = 1e-5;
/// Pixel coordinates of a support's projection are padded by this much.
const PIXEL_PAD: f64 = 1e-3;

/// The lists of one camera frame.
#[derive(Clone, Debug, PartialEq)]
pub struct TileLists {
    pub width: u32,
    pub height: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    pub groups: u32,
    /// Where each list starts in `entries`, list `tile * groups + g` for
    /// group g of tile `tile` (tiles in row-major order; the shader's
    /// `tile_list`); one more at the end holds the total.
    pub starts: Vec<u32>,
    /// The entries: a primitive index (into the GPU's primitive buffer)
    /// and its [`TileLists::depth`] as f32 bits, rounded down (a walk may
    /// stop at the first entry whose depth is beyond its query without
    /// fetching the primitive); each list sorted by depth, then by index.
    pub entries: Vec<[u32; 2]>,
    /// The longest list's length.
    pub longest: usize,
    /// The most entries of one tile, all its groups' lists together (a
    /// walk reads every group's list of its tile).
    pub crowd: usize,
}

/// The camera's frame: eye, unit axes, and the half-extents of the image
/// plane at distance 1, as `rays::camera_rays_through` makes its rays.
#[derive(Clone, Copy, Debug)]
pub(super) struct View {
    pub eye: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    pub half_w: f64,
    pub half_h: f64,
}

impl View {
    pub(super) fn new(cam: &Camera, width: u32, height: u32) -> View {
        let forward = (cam.target - cam.eye).normalize();
        let right = forward.cross(cam.up).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * cam.fov_y_deg.to_radians()).tan();
        let half_w = half_h * f64::from(width) / f64::from(height);
        View { eye: cam.eye, forward, right, up, half_w, half_h }
    }
}

/// The range of slopes `x/z` of the lines through the origin that meet the
/// disc of radius `r` about `(x, z)` in the plane, for `z > r`: its two
/// tangents.
fn slopes(x: f64, z: f64, r: f64) -> (f64, f64) {
    let q = z * z - r * r;
    let root = r * (x * x + q).sqrt();
    ((x * z - root) / q, (x * z + root) / q)
}

/// The pixels whose rays may meet a ball: an inclusive range of pixel
/// columns and rows, clamped to the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pixels {
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
}

/// The pixels whose rays may meet the ball of radius `r` about `c`; `None`
/// when no camera ray meets it (behind the eye, or off the image). A ray
/// of pixel x passes through the image plane at x + o, o in [0, 1).
fn pixel_range(view: &View, width: u32, height: u32, c: DVec3, r: f64) -> Option<Pixels> {
    let all = Some(Pixels { x0: 0, x1: width - 1, y0: 0, y1: height - 1 });
    let rel = c - view.eye;
    let r = r * (1.0 + RADIUS_PAD) + RADIUS_PAD * rel.length();
    let z = rel.dot(view.forward);
    if z + r <= 0.0 {
        return None;
    }
    if z - r <= 1e-9 * r.max(1e-300) {
        // The ball reaches the eye's plane: rays of every direction may
        // meet it.
        return all;
    }
    let (sx0, sx1) = slopes(rel.dot(view.right), z, r);
    let (sy0, sy1) = slopes(rel.dot(view.up), z, r);
    // Pixel coordinates (from the image's top-left corner) of those slopes:
    // sx = (2 px / w - 1) half_w, sy = (1 - 2 py / h) half_h.
    let (w, h) = (f64::from(width), f64::from(height));
    let px0 = (sx0 / view.half_w + 1.0) * 0.5 * w - PIXEL_PAD;
    let px1 = (sx1 / view.half_w + 1.0) * 0.5 * w + PIXEL_PAD;
    let py0 = (1.0 - sy1 / view.half_h) * 0.5 * h - PIXEL_PAD;
    let py1 = (1.0 - sy0 / view.half_h) * 0.5 * h + PIXEL_PAD;
    // Pixel x holds the rays of [x, x + 1].
    if !(px1 >= 0.0 && px0 < w && py1 >= 0.0 && py0 < h) {
        return None;
    }
    let pixel = |p: f64, n: u32| (p.max(0.0).floor() as u32).min(n - 1);
    Some(Pixels { x0: pixel(px0, width), x1: pixel(px1, width), y0: pixel(py0, height), y1: pixel(py1, height) })
}

/// The low bits of an entry's depth word: the pixels of its tile whose rays
/// may meet the support, as the tile-local columns x0..=x1 (bits 0-2, 3-5)
/// and rows y0..=y1 (bits 6-8, 9-11). The depth keeps the high bits: it
/// is rounded down to 12 fewer bits of mantissa, still no more than the
/// support's (shaders/include/cursor_tiles.glsl, `tile_entry`).
pub const PIXEL_BITS: u32 = crate::layout::TILE_PIXEL_BITS;

impl TileLists {
    /// The distance from the eye to the nearest point of the ball of
    /// radius `r` about `c` (0 inside): no ray from the eye meets the ball
    /// before it. The lists' order.
    pub fn depth(eye: DVec3, c: DVec3, r: f64) -> f64 {
        ((c - eye).length() - r).max(0.0)
    }

    /// The lists of `prims` (the GPU's records: centre and clip radius in
    /// `a`, group in `ids.y`; every one a point primitive) for `cam`'s
    /// `width` x `height` frame.
    pub fn build(prims: &[GpuPrimitive], groups: u32, cam: &Camera, width: u32, height: u32) -> TileLists {
        let view = View::new(cam, width, height);
        let tiles_x = width.div_ceil(PIXEL_TILE);
        let tiles_y = height.div_ceil(PIXEL_TILE);
        let tiles = (tiles_x * tiles_y) as usize;
        let per_tile = groups.max(1) as usize;
        let lists = tiles * per_tile;
        let ball = |p: &GpuPrimitive| (DVec3::new(p.a[0].into(), p.a[1].into(), p.a[2].into()), f64::from(p.a[3]));
        let ranges: Vec<Option<Pixels>> = prims
            .iter()
            .map(|p| {
                let (c, r) = ball(p);
                pixel_range(&view, width, height, c, r)
            })
            .collect();
        let depth: Vec<f64> = prims
            .iter()
            .map(|p| {
                let (c, r) = ball(p);
                TileLists::depth(view.eye, c, r)
            })
            .collect();
        let t = PIXEL_TILE;
        // Every list of a tile a primitive's pixels cover, with its pixels
        // in that tile.
        let covered = |i: usize| {
            let p = ranges[i];
            let g = prims[i].ids[1] as usize;
            p.into_iter().flat_map(move |p| {
                (p.y0 / t..=p.y1 / t).flat_map(move |ty| {
                    (p.x0 / t..=p.x1 / t).map(move |tx| {
                        let local = |v: u32, tile: u32| v.saturating_sub(tile * t).min(t - 1);
                        let bits = local(p.x0, tx) | local(p.x1, tx) << 3 | local(p.y0, ty) << 6 | local(p.y1, ty) << 9;
                        ((ty * tiles_x + tx) as usize * per_tile + g, bits)
                    })
                })
            })
        };
        // A counting sort into the lists, the primitives taken nearest
        // first: every list comes out in depth order.
        let mut counts = vec![0u32; lists + 1];
        for i in 0..prims.len() {
            for (list, _) in covered(i) {
                counts[list] += 1;
            }
        }
        let mut starts = vec![0u32; lists + 1];
        for k in 0..lists {
            starts[k + 1] = starts[k] + counts[k];
        }
        let mut order: Vec<u32> = (0..prims.len() as u32).filter(|&i| ranges[i as usize].is_some()).collect();
        order.sort_unstable_by(|&a, &b| depth[a as usize].total_cmp(&depth[b as usize]).then(a.cmp(&b)));
        let mut fill = starts.clone();
        let mut entries = vec![[0u32; 2]; starts[lists] as usize];
        let mask = (1u32 << PIXEL_BITS) - 1;
        for &i in &order {
            let key = f32_below(depth[i as usize]).to_bits() & !mask;
            for (list, bits) in covered(i as usize) {
                entries[fill[list] as usize] = [i, key | bits];
                fill[list] += 1;
            }
        }
        TileLists::from_parts(width, height, groups, starts, entries)
    }

    /// Lists of a `width` x `height` frame of `groups` groups from their
    /// starts (one per list and the total) and entries; the longest list
    /// and the crowd counted from the starts.
    pub fn from_parts(width: u32, height: u32, groups: u32, starts: Vec<u32>, entries: Vec<[u32; 2]>) -> TileLists {
        let groups = groups.max(1);
        let counts: Vec<usize> = starts.windows(2).map(|w| (w[1] - w[0]) as usize).collect();
        let longest = counts.iter().copied().max().unwrap_or(0);
        let crowd = counts.chunks(groups as usize).map(|c| c.iter().sum()).max().unwrap_or(0);
        let (tiles_x, tiles_y) = (width.div_ceil(PIXEL_TILE), height.div_ceil(PIXEL_TILE));
        TileLists { width, height, tiles_x, tiles_y, groups, starts, entries, longest, crowd }
    }

    /// Group `g`'s list of tile `tile` (row-major).
    pub fn list(&self, g: u32, tile: u32) -> &[[u32; 2]] {
        let k = (tile * self.groups + g) as usize;
        &self.entries[self.starts[k] as usize..self.starts[k + 1] as usize]
    }

    /// Bytes of the two buffers on the GPU.
    pub fn bytes(&self) -> usize {
        4 * self.starts.len() + 8 * self.entries.len()
    }
}

impl TileLists {
    /// The containment check: every support that a camera ray of `cam`'s
    /// frame meets (rays through the centre of every pixel, then again
    /// `samples` less one times through random points of each, as
    /// anti-aliasing makes them, in f32 as the renderer makes them, the
    /// meeting tested in f64)
    /// is in its tile's list, with the ray's pixel among the entry's.
    /// Returns how many meetings were checked, or the first left out.
    pub fn check_containment(&self, prims: &[GpuPrimitive], cam: &Camera, samples: u32, seed: u64) -> Result<usize, String> {
        use rand::{Rng, SeedableRng};
        let (w, h) = (self.width, self.height);
        let bounds = crate::scene::Aabb { min: DVec3::splat(-1e6), max: DVec3::splat(1e6) };
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
        let mask = (1 << PIXEL_BITS) - 1;
        let mut met = 0;
        for s in 0..samples {
            let offsets: Vec<(f64, f64)> = (0..w * h).map(|_| (rng.random::<f64>(), rng.random::<f64>())).collect();
            let at = |p: u32| if s == 0 { (0.5, 0.5) } else { offsets[p as usize] };
            let (rays, pixels) = super::rays::camera_rays_through(cam, w, h, &bounds, at);
            for (k, (ray, pixel)) in rays.iter().zip(&pixels).enumerate() {
                let Some(pixel) = *pixel else { continue };
                let r = super::rays::Ray::from_gpu(ray);
                let tile = (k / 64) as u32;
                let (x, y) = (pixel % w % PIXEL_TILE, pixel / w % PIXEL_TILE);
                for (i, p) in prims.iter().enumerate() {
                    let c = DVec3::new(p.a[0].into(), p.a[1].into(), p.a[2].into());
                    let radius = f64::from(p.a[3]);
                    let co = c - r.o;
                    let tc = co.dot(r.d).max(0.0);
                    if (co - tc * r.d).length_squared() >= radius * radius {
                        continue;
                    }
                    met += 1;
                    let covers = |e: &[u32; 2]| {
                        let b = e[1] & mask;
                        (b & 7..=b >> 3 & 7).contains(&x) && (b >> 6 & 7..=b >> 9 & 7).contains(&y)
                    };
                    if !self.list(p.ids[1], tile).iter().any(|e| e[0] == i as u32 && covers(e)) {
                        return Err(format!(
                            "pixel {pixel} (tile {tile}) meets primitive {i} at {c} radius {radius}, which its list leaves out or says it does not cover"
                        ));
                    }
                }
            }
        }
        Ok(met)
    }

    /// How these lists (the GPU's) differ from `host`'s: each list must
    /// hold the host's entries (the same primitives, depth words and
    /// pixels) in order of depth; entries beyond the host's are counted
    /// (a device whose f64 rounds otherwise than IEEE may widen a bound by
    /// a pixel), and returned. An entry the host has and these lack, or a
    /// list out of depth order, is an error.
    pub fn agreement(&self, host: &TileLists) -> Result<usize, String> {
        if (self.tiles_x, self.tiles_y, self.groups) != (host.tiles_x, host.tiles_y, host.groups) {
            return Err(format!(
                "{}x{} tiles of {} groups against the host's {}x{} of {}",
                self.tiles_x, self.tiles_y, self.groups, host.tiles_x, host.tiles_y, host.groups
            ));
        }
        let mask = !((1u32 << PIXEL_BITS) - 1);
        let mut extra = 0;
        for tile in 0..self.tiles_x * self.tiles_y {
            for g in 0..self.groups {
                let (ours, theirs) = (self.list(g, tile), host.list(g, tile));
                if let Some(k) = (1..ours.len()).find(|&k| f32::from_bits(ours[k][1] & mask) < f32::from_bits(ours[k - 1][1] & mask)) {
                    return Err(format!("tile {tile} group {g}: entry {k} {:?} is nearer than the one before it {:?}", ours[k], ours[k - 1]));
                }
                let mut sorted = ours.to_vec();
                sorted.sort_unstable();
                if let Some(e) = theirs.iter().find(|e| sorted.binary_search(e).is_err()) {
                    return Err(format!("tile {tile} group {g}: the host's entry {e:?} (primitive {}) is missing", e[0]));
                }
                extra += ours.len() - theirs.len();
            }
        }
        Ok(extra)
    }

    /// These lists with the entries of every primitive's last column of
    /// tiles taken out where it spans two or more: lists that the
    /// containment check must refuse (the check broken on purpose).
    pub fn without_last_tile_columns(&self) -> TileLists {
        let mut columns: std::collections::HashMap<u32, (u32, u32)> = std::collections::HashMap::new();
        for tile in 0..self.tiles_x * self.tiles_y {
            for g in 0..self.groups {
                for e in self.list(g, tile) {
                    let c = columns.entry(e[0]).or_insert((u32::MAX, 0));
                    *c = (c.0.min(tile % self.tiles_x), c.1.max(tile % self.tiles_x));
                }
            }
        }
        let mut starts = vec![0u32];
        let mut entries = Vec::new();
        for tile in 0..self.tiles_x * self.tiles_y {
            for g in 0..self.groups {
                entries.extend(self.list(g, tile).iter().filter(|e| {
                    let (first, last) = columns[&e[0]];
                    last == first || tile % self.tiles_x != last
                }));
                starts.push(entries.len() as u32);
            }
        }
        TileLists::from_parts(self.width, self.height, self.groups, starts, entries)
    }
}

/// The largest f32 not above `x` (x >= 0 and finite).
fn f32_below(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x { f.next_down() } else { f }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    fn point(c: DVec3, r: f64, group: u32) -> GpuPrimitive {
        GpuPrimitive { a: [c.x as f32, c.y as f32, c.z as f32, r as f32], b: [0.0; 4], c: [0.0, r as f32, r as f32, 0.0], ids: [0, group, 0, 0] }
    }

    /// Every support a sampled camera ray meets is in its tile's list
    /// ([`TileLists::check_containment`]).
    fn assert_contained(prims: &[GpuPrimitive], groups: u32, cam: &Camera, w: u32, h: u32, samples: u32, seed: u64) -> usize {
        TileLists::build(prims, groups, cam, w, h).check_containment(prims, cam, samples, seed).unwrap()
    }

    fn camera(eye: DVec3, target: DVec3, fov: f64) -> Camera {
        Camera {
            eye,
            target,
            up: DVec3::Y,
            fov_y_deg: fov,
            projection: Default::default(),
            clip: Default::default(),
            width: 64,
            height: 64,
            samples: 1,
        }
    }

    #[test]
    fn every_support_a_camera_ray_meets_is_in_its_tiles_list() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let mut prims = Vec::new();
        for _ in 0..300 {
            let c = DVec3::new(rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0));
            prims.push(point(c, rng.random_range(0.2..2.5), rng.random_range(0..2)));
        }
        // Behind the eye, straddling its plane, around it, larger than the
        // screen, and off every edge of the frame.
        let eye = DVec3::new(0.0, 0.0, 9.0);
        prims.push(point(eye + DVec3::new(0.0, 0.0, 3.0), 1.0, 0));
        prims.push(point(eye + DVec3::new(2.0, 0.5, 0.3), 1.0, 0));
        prims.push(point(eye, 0.5, 1));
        prims.push(point(DVec3::new(0.0, 0.0, -5.0), 40.0, 0));
        for (x, y) in [(-9.0, 0.0), (9.0, 0.0), (0.0, -9.0), (0.0, 9.0), (8.5, 8.5)] {
            prims.push(point(DVec3::new(x, y, -2.0), 1.5, 1));
        }
        let cam = camera(eye, DVec3::ZERO, 60.0);
        let mut met = 0;
        for (w, h) in [(64, 64), (61, 37), (1, 1), (4096, 16), (16, 4096)] {
            met += assert_contained(&prims, 2, &cam, w, h, if w * h > 20_000 { 1 } else { 3 }, w as u64 * 31 + h as u64);
        }
        assert!(met > 10_000, "only {met} ray-support meetings were checked");
    }

    /// The containment check can fail: lists with one tile edge of every
    /// wide primitive taken out are refused.
    #[test]
    fn the_containment_check_refuses_lists_missing_a_tile_edge() {
        let mut rng = Pcg64Mcg::seed_from_u64(3);
        let prims: Vec<GpuPrimitive> = (0..40)
            .map(|_| {
                point(
                    DVec3::new(rng.random_range(-6.0..6.0), rng.random_range(-6.0..6.0), rng.random_range(-6.0..6.0)),
                    rng.random_range(0.5..2.0),
                    0,
                )
            })
            .collect();
        let cam = camera(DVec3::new(0.0, 0.0, 20.0), DVec3::ZERO, 50.0);
        let lists = TileLists::build(&prims, 1, &cam, 64, 64);
        assert!(lists.check_containment(&prims, &cam, 1, 1).unwrap() > 500);
        let broken = lists.without_last_tile_columns();
        assert!(broken.entries.len() < lists.entries.len());
        let refused = broken.check_containment(&prims, &cam, 1, 1).unwrap_err();
        assert!(refused.contains("leaves out"), "{refused}");
        assert_eq!(lists.agreement(&lists), Ok(0));
        assert!(broken.agreement(&lists).unwrap_err().contains("missing"));
    }

    #[test]
    fn lists_are_in_depth_order_and_leave_out_what_no_ray_meets() {
        let cam = camera(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 40.0);
        let prims = vec![
            point(DVec3::new(0.0, 0.0, -3.0), 1.0, 0),
            point(DVec3::new(0.0, 0.0, 3.0), 1.0, 0),
            point(DVec3::new(0.0, 0.0, 0.0), 1.0, 0),
            point(DVec3::new(0.0, 0.0, 20.0), 1.0, 0),  // behind the eye
            point(DVec3::new(100.0, 0.0, 0.0), 1.0, 0), // off the frame
        ];
        let lists = TileLists::build(&prims, 1, &cam, 64, 64);
        // The centre tiles hold the three on the axis, nearest first.
        let centre = 3 * lists.tiles_x + 3;
        assert_eq!(lists.list(0, centre).iter().map(|e| e[0]).collect::<Vec<_>>(), [1, 2, 0]);
        // Their depths, rounded down: 6, 9 and 12 (from z = 10, radius 1),
        // and the pixels of the tile they cover: all 8x8 for the nearest,
        // fewer for those further.
        let mask = (1 << PIXEL_BITS) - 1;
        let depths: Vec<f32> = lists.list(0, centre).iter().map(|e| f32::from_bits(e[1] & !mask)).collect();
        assert_eq!(depths, [6.0, 9.0, 12.0]);
        let pixels = |e: &[u32; 2]| {
            let b = e[1] & mask;
            ((b & 7)..=(b >> 3 & 7), (b >> 6 & 7)..=(b >> 9 & 7))
        };
        assert_eq!(pixels(&lists.list(0, centre)[0]), (0..=7, 0..=7));
        assert!(lists.entries.iter().all(|e| e[0] < 3), "{:?}", lists.entries);
        assert_eq!(f32_below(0.1), 0.099_999_994);
        assert!(f64::from(f32_below(1.0 / 3.0)) <= 1.0 / 3.0);
        // A corner tile's rays miss the small balls on the axis.
        assert!(lists.list(0, 0).is_empty());
        assert_eq!(lists.longest, 3);
    }
}
