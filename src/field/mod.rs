//! The f64 CPU reference of every field: the same maths as the shaders, in
//! double precision. It is the oracle for the tests and the benchmarks.

pub mod bound;
pub mod bounds;
pub mod clip;
pub mod fold;
pub mod grid;
pub mod hrbf;
pub mod inversion;
pub mod kinds;
pub mod march;
pub mod prim;
pub mod quad;
pub mod raa;
pub mod reference;

pub use grid::Query;
pub use kinds::PrimitiveKind;
pub use prim::PrimEval;

use grid::Grid;

use glam::DVec3;

use crate::scene::{Kernel, Scene};

/// `|dk/dd|` peaks at `d = R/√5` for the compact kernel, with value
/// `96/(25√5) · w/R` (docs/paper-digest.md, section 0).
pub const COMPACT_PEAK_SLOPE: f64 = 96.0 / (25.0 * 2.236_067_977_499_79);

/// A point along the ray `o + t u` (`|u| = 1`): `(h², x0)`, `h²` the squared
/// distance of `center` from the line and `x0 = t0 - tc` with `tc` the
/// closest approach; written without the cancellation of `|c - o|² - tc²`.
pub fn point_on_ray(center: DVec3, o: DVec3, u: DVec3, t0: f64) -> (f64, f64) {
    let co = center - o;
    let tc = co.dot(u);
    ((co - tc * u).length_squared(), t0 - tc)
}

/// One kernel, precomputed for evaluation.
#[derive(Clone, Copy, Debug)]
pub struct KernelEval {
    pub gaussian: bool,
    /// Support radius R (compact) or scale r (Gaussian).
    pub scale: f64,
    /// 1/R² (compact) or s/r² (Gaussian).
    pub inv: f64,
    pub weight: f64,
    /// Distance where `|dk/dd|` peaks.
    pub peak_distance: f64,
    /// The peak of `|dk/dd|` (non-negative whatever the weight's sign).
    pub peak_slope: f64,
}

impl KernelEval {
    pub fn new(k: Kernel) -> KernelEval {
        match k {
            Kernel::Compact { radius, weight } => KernelEval {
                gaussian: false,
                scale: radius,
                inv: 1.0 / (radius * radius),
                weight,
                peak_distance: radius / 5f64.sqrt(),
                peak_slope: COMPACT_PEAK_SLOPE * weight.abs() / radius,
            },
            Kernel::Gaussian { r, s, weight } => KernelEval {
                gaussian: true,
                scale: r,
                inv: s / (r * r),
                weight,
                peak_distance: r / (2.0 * s).sqrt(),
                peak_slope: weight.abs() * (2.0 * s).sqrt() / r * (-0.5f64).exp(),
            },
        }
    }

    /// The kernel of a squared distance `q`.
    pub fn value(&self, q: f64) -> f64 {
        if self.gaussian {
            self.weight * (-q * self.inv).exp()
        } else {
            let x = 1.0 - q * self.inv;
            if x > 0.0 { self.weight * x * x * x } else { 0.0 }
        }
    }

    /// `dk/dq`, so that `∇k = 2 (dk/dq) (p - c)` for a point.
    pub fn dq(&self, q: f64) -> f64 {
        if self.gaussian {
            -self.inv * self.weight * (-q * self.inv).exp()
        } else {
            let x = 1.0 - q * self.inv;
            if x > 0.0 { -3.0 * self.weight * self.inv * x * x } else { 0.0 }
        }
    }

    /// `|dk/dd|` at distance `d`.
    pub fn slope(&self, d: f64) -> f64 {
        (2.0 * d * self.dq(d * d)).abs()
    }

    /// The largest `|dk/dd|` for distances in `[lo, hi]`: `|dk/dd|` is
    /// unimodal with its peak at `peak_distance`.
    pub fn max_slope(&self, lo: f64, hi: f64) -> f64 {
        self.slope(self.peak_distance.clamp(lo, hi))
    }

    /// The distance within which the kernel alone reaches `level` (0 where
    /// it never does): where a ray enters that ball, a sum of non-negative
    /// kernels is at least `level` (the first-crossing bracket).
    pub fn reach(&self, level: f64) -> f64 {
        if !(self.weight > level) {
            return 0.0;
        }
        let q = if self.gaussian { (self.weight / level).ln() / self.inv } else { (1.0 - (level / self.weight).cbrt()) / self.inv };
        q.max(0.0).sqrt()
    }

    /// Distance beyond which the kernel is exactly zero.
    pub fn support(&self) -> f64 {
        if self.gaussian { f64::INFINITY } else { self.scale }
    }
}

/// The scene's field `f = max over groups of (sum of kernels) - iso`.
#[derive(Clone, Debug)]
pub struct Field {
    pub groups: Vec<Vec<PrimEval>>,
    pub iso: f64,
    /// Every primitive's (group, position in the group), group by group.
    order: Vec<(u32, u32)>,
    /// The spatial index of large fields (see `grid.rs`).
    grid: Option<Grid>,
}

impl Field {
    pub fn new(scene: &Scene) -> Field {
        let groups: Vec<Vec<PrimEval>> = scene.groups.iter().map(|g| g.iter().map(|p| PrimEval::new(p, &scene.bounds)).collect()).collect();
        let order: Vec<(u32, u32)> = groups.iter().enumerate().flat_map(|(g, prims)| (0..prims.len()).map(move |i| (g as u32, i as u32))).collect();
        // Like the GPU's index (render::index::GridSpec::for_scene).
        let grid = if scene.max_needs_every_group() { None } else { Grid::new(&groups.iter().flatten().collect::<Vec<_>>()) };
        Field { groups, iso: scene.iso, order, grid }
    }

    /// The grid's cell size, when the field has a grid.
    pub fn grid_cell(&self) -> Option<f64> {
        self.grid.as_ref().map(Grid::cell_size)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    fn two_group_scene() -> Scene {
        Scene::parse(
            r#"Scene(camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0)), iso: 0.5, groups: [
                (primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0)),
                              Point(center: (1.0, 0.5, 0.0), kernel: Gaussian(r: 1.0, s: 2.0))]),
                (primitives: [Point(center: (-1.5, 0.0, 0.3), kernel: Compact(radius: 1.5))]),
            ])"#,
            "test",
        )
        .unwrap()
    }

    /// A plane slab summed with a blob, and a second group (a blob).
    fn plane_scene() -> Scene {
        Scene::parse(
            r#"Scene(camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0)), iso: 0.5, groups: [
                (primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: 0.0, radius: 1.0),
                              Point(center: (0.0, 1.2, 0.0), kernel: Compact(radius: 2.0))]),
                (primitives: [Point(center: (2.0, 0.5, 0.0), kernel: Compact(radius: 1.5))]),
            ], bounds: Some((min: (-3.0, -2.0, -3.0), max: (3.0, 3.0, 3.0))))"#,
            "test",
        )
        .unwrap()
    }

    #[test]
    fn gradient_matches_central_differences() {
        let f = Field::new(&two_group_scene());
        let h = 1e-6;
        for p in [DVec3::new(0.3, 0.2, 0.1), DVec3::new(1.2, 0.4, -0.3), DVec3::new(-1.4, 0.1, 0.2)] {
            let (_, g) = f.value_gradient(p);
            for axis in 0..3 {
                let mut e = DVec3::ZERO;
                e[axis] = h;
                let fd = (f.value(p + e) - f.value(p - e)) / (2.0 * h);
                assert!((fd - g[axis]).abs() < 1e-6 * (1.0 + g.length()), "axis {axis} at {p}: {fd} vs {}", g[axis]);
            }
        }
    }

    #[test]
    fn a_kernels_reach_is_where_it_falls_to_the_level() {
        for k in [Kernel::Compact { radius: 1.5, weight: 2.0 }, Kernel::Gaussian { r: 1.7, s: 2.0, weight: 2f64.exp() }] {
            let e = KernelEval::new(k);
            for level in [0.3, 1.0, 1.0 + 1e-3] {
                let d = e.reach(level);
                assert!(d > 0.0 && (e.value(d * d) - level).abs() < 1e-12 * level, "{k:?} at {level}: reach {d}");
            }
            assert_eq!(e.reach(e.weight), 0.0, "{k:?}: never above its weight");
            assert_eq!(e.reach(3.0 * e.weight), 0.0);
        }
    }

    #[test]
    fn kernel_peak_slopes_are_the_maxima_of_the_slopes() {
        for k in [Kernel::Compact { radius: 1.7, weight: 1.3 }, Kernel::Gaussian { r: 0.8, s: 3.0, weight: 2.0 }] {
            let e = KernelEval::new(k);
            let dense = (0..100_000).map(|i| e.slope(i as f64 * 1e-4 * 3.0 * e.scale)).fold(0.0, f64::max);
            assert!((dense - e.peak_slope).abs() < 1e-6 * e.peak_slope, "{k:?}: {dense} vs {}", e.peak_slope);
            assert!((e.slope(e.peak_distance) - e.peak_slope).abs() < 1e-12 * e.peak_slope);
        }
    }

    #[test]
    fn segment_lipschitz_bounds_the_derivative_on_random_segments() {
        use rand::{Rng, SeedableRng};
        // Points, and the plane branch of the bound (a slab in a sum).
        for (name, scene) in [("points", two_group_scene()), ("plane", plane_scene())] {
            let f = Field::new(&scene);
            let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
            let mut sloped = 0;
            for _ in 0..2000 {
                let o = DVec3::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0));
                let u = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize();
                let (ta, tb) = (rng.random_range(0.0..4.0), rng.random_range(4.0..8.0));
                let lambda = f.segment_lipschitz(o, u, ta, tb);
                assert!(lambda <= f.lipschitz() + 1e-12);
                sloped += usize::from(lambda > 0.0);
                let h = 1e-5;
                for i in 0..200 {
                    let t = ta + (tb - ta) * f64::from(i) / 200.0;
                    let d = (f.value(o + (t + h) * u) - f.value(o + (t - h) * u)) / (2.0 * h);
                    assert!(d.abs() <= lambda * (1.0 + 1e-6) + 1e-9, "{name}: |f'| = {} > λ = {lambda}", d.abs());
                }
            }
            assert!(sloped > 500, "{name}: only {sloped} segments meet a support");
        }
    }

    /// A plane slab summed with a blob: the slab's affine form must be in
    /// the ray's own ε whichever way the ray crosses the plane, or the sum's
    /// range misses the field on short intervals (where the linear terms
    /// dominate; long ones hide it in their error terms).
    #[test]
    fn raa_of_a_plane_summed_with_a_blob_contains_the_field_on_short_intervals() {
        use rand::{Rng, SeedableRng};
        let f = Field::new(&plane_scene());
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
        let mut downward = 0;
        for _ in 0..2000 {
            let o = DVec3::new(rng.random_range(-1.5..1.5), rng.random_range(-0.5..2.0), rng.random_range(-1.5..1.5));
            let u = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize();
            let len = 10f64.powf(rng.random_range(-3.0..-1.0));
            let (lo, hi) = fold::field_raa(&f, o, u, 0.0, len);
            downward += usize::from(u.y < 0.0);
            for i in 0..=20 {
                let t = len * f64::from(i) / 20.0;
                let v = f.value(o + t * u);
                assert!(v >= lo - 1e-12 && v <= hi + 1e-12, "RAA [{lo}, {hi}] misses f = {v} at t = {t} on [0, {len}] along {u} from {o}");
            }
        }
        assert!(downward > 500, "only {downward} rays cross the plane downwards");
    }

    #[test]
    fn reference_finds_the_analytic_sphere() {
        let s = Scene::parse(
            r#"Scene(camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0)), iso: 0.5,
                groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))])])"#,
            "test",
        )
        .unwrap();
        let f = Field::new(&s);
        let radius = 2.0 * (1.0 - 0.5f64.cbrt()).sqrt();
        let opts = reference::ReferenceOptions::for_min_radius(2.0);
        let o = DVec3::new(0.3, -0.2, 5.0);
        let all = reference::crossings(&f, o, DVec3::NEG_Z, 0.0, 10.0, opts, false);
        let closest = DVec3::new(0.3, -0.2, 0.0).length();
        let half = (radius * radius - closest * closest).sqrt();
        assert_eq!(all.len(), 2);
        assert!(all[0].entering && !all[1].entering);
        assert!((all[0].t - (5.0 - half)).abs() < 1e-8);
        assert!((all[1].t - (5.0 + half)).abs() < 1e-8);
    }
}
