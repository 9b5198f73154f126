//! Where the spatial index (src/render/index.rs) clips a group's Gaussians: a threshold τ on a
//! term's value, the same for every Gaussian of the group, so that
//! Gaussian j is cut at ρ_j, where `w_j e^{-a_j ρ_j²} = τ` (`a_j = s_j /
//! r_j²`). τ is chosen so that the cut tails add up to less than
//! `GAUSSIAN_CLIP_FRACTION · iso` at any point, from the largest number of
//! centres the group packs near one point, not from its total count.
//!
//! The bound. A term cut at x (d_j > ρ_j) is `τ e^{-a_j (d_j² - ρ_j²)} ≤
//! τ φ(d_j)`, with `φ(d) = e^{-a_min max(0, d² - ρ_max²)}` non-increasing
//! (a_j ≥ a_min, ρ_j ≤ ρ_max). With shells `D_m = ρ_max + m Δ` and `N(D)`
//! the centres within D of x, valuing each centre at φ of its shell's
//! inner radius and summing by parts:
//!
//! `Σ_j τ φ(d_j) ≤ τ [Σ_{m=1..K} (φ(D_{m-1}) - φ(D_m)) N(D_m) + φ(D_K) n]`,
//!
//! every coefficient non-negative, so any upper bound M(D) ≥ N(D) may
//! replace N. M(D) is the largest count of centres in a cube of
//! `2⌈D/h⌉ + 1` cells of a counting grid (side h) about any cell: such a
//! cube around x's cell holds the ball of radius D about x. A molecule
//! packs far fewer atoms near any point than it has, so τ is larger than
//! the density-free `ε iso / n` and the clip radii smaller (docs/molecules.md
//! has the figures). The density-free threshold is the start: each round
//! computes the bound with the ρ_max of the last τ, and a larger τ only
//! shrinks ρ_max and φ, so the bound still holds at the new τ.

use glam::DVec3;

use crate::scene::{Kernel, Primitive};

/// A Gaussian term `weight e^{-s d²/r²}` about `center`.
#[derive(Clone, Copy, Debug)]
pub struct Gaussian {
    pub center: DVec3,
    pub r: f64,
    pub s: f64,
    pub weight: f64,
}

impl Gaussian {
    /// The Gaussian of a point primitive with a Gaussian kernel.
    pub fn of(p: &Primitive) -> Option<Gaussian> {
        match *p {
            Primitive::Point { center, kernel: Kernel::Gaussian { r, s, weight } } => Some(Gaussian { center, r, s, weight }),
            _ => None,
        }
    }

    fn decay(&self) -> f64 {
        self.s / (self.r * self.r)
    }

    /// Where the term falls to τ (0 where it never exceeds τ).
    pub fn radius_at(&self, tau: f64) -> f64 {
        if self.weight <= tau { 0.0 } else { ((self.weight / tau).ln() / self.decay()).sqrt() }
    }
}

/// Cells of the counting grid at most (its cell grows until they fit), so
/// that the cube counts stay a few milliseconds however large the scene.
const MAX_COUNT_CELLS: usize = 1 << 19;
/// Rounds of the fixed point.
const ROUNDS: usize = 4;

/// The threshold τ for one group's Gaussians, cut tails under `budget`
/// (`GAUSSIAN_CLIP_FRACTION · iso`) everywhere.
pub fn threshold(gaussians: &[Gaussian], budget: f64) -> f64 {
    let n = gaussians.len();
    let mut tau = budget / n.max(1) as f64;
    if n < 2 || !(budget > 0.0) {
        return tau;
    }
    let counts = Counts::new(gaussians);
    let a_min = gaussians.iter().map(Gaussian::decay).fold(f64::INFINITY, f64::min);
    for _ in 0..ROUNDS {
        let rho_max = gaussians.iter().map(|g| g.radius_at(tau)).fold(0.0, f64::max);
        let bound = counts.tail_factor(rho_max, a_min, n);
        let next = budget / bound;
        if !(next > tau * (1.0 + 1e-9)) {
            break;
        }
        tau = next;
    }
    tau
}

/// Centres per cell of a grid of side h, with the largest cube counts.
struct Counts {
    h: f64,
    dims: [usize; 3],
    /// Summed-volume table, (dims + 1)³.
    sat: Vec<u32>,
}

impl Counts {
    fn new(gaussians: &[Gaussian]) -> Counts {
        let (lo, hi) =
            gaussians.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), g| (lo.min(g.center), hi.max(g.center)));
        let mut r: Vec<f64> = gaussians.iter().map(|g| g.r).filter(|r| *r > 0.0).collect();
        r.sort_by(f64::total_cmp);
        let extent = (hi - lo).max(DVec3::splat(1e-9));
        let mut h = r.get(r.len() / 2).copied().unwrap_or(1.0).max(extent.max_element() * 1e-6);
        let cells = |h: f64| (extent / h).floor() + DVec3::ONE;
        while cells(h).element_product() > MAX_COUNT_CELLS as f64 {
            h *= 1.25;
        }
        let d = cells(h);
        let dims = [d.x as usize, d.y as usize, d.z as usize];
        let (sx, sy) = (dims[0] + 1, dims[1] + 1);
        let mut sat = vec![0u32; sx * sy * (dims[2] + 1)];
        for g in gaussians {
            let c = ((g.center - lo) / h).floor();
            let at = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1) + 1;
            sat[at(c.x, dims[0]) + sx * (at(c.y, dims[1]) + sy * at(c.z, dims[2]))] += 1;
        }
        // Prefix sums along each axis in turn.
        for z in 0..=dims[2] {
            for y in 0..=dims[1] {
                for x in 1..=dims[0] {
                    sat[x + sx * (y + sy * z)] += sat[x - 1 + sx * (y + sy * z)];
                }
            }
        }
        for z in 0..=dims[2] {
            for y in 1..=dims[1] {
                for x in 0..=dims[0] {
                    sat[x + sx * (y + sy * z)] += sat[x + sx * (y - 1 + sy * z)];
                }
            }
        }
        for z in 1..=dims[2] {
            for y in 0..=dims[1] {
                for x in 0..=dims[0] {
                    sat[x + sx * (y + sy * z)] += sat[x + sx * (y + sy * (z - 1))];
                }
            }
        }
        Counts { h, dims, sat }
    }

    /// The most centres in a cube of `2k + 1` cells about any cell (cells
    /// off the grid hold none).
    fn cube_max(&self, k: usize) -> u32 {
        let [nx, ny, nz] = self.dims;
        let (sx, sy) = (nx + 1, ny + 1);
        let s = |x: usize, y: usize, z: usize| i64::from(self.sat[x + sx * (y + sy * z)]);
        let span = |c: usize, n: usize| (c.saturating_sub(k), (c + k + 1).min(n));
        let mut most = 0i64;
        for z in 0..nz {
            let (z0, z1) = span(z, nz);
            for y in 0..ny {
                let (y0, y1) = span(y, ny);
                for x in 0..nx {
                    let (x0, x1) = span(x, nx);
                    let sum =
                        s(x1, y1, z1) - s(x0, y1, z1) - s(x1, y0, z1) - s(x1, y1, z0) + s(x0, y0, z1) + s(x0, y1, z0) + s(x1, y0, z0) - s(x0, y0, z0);
                    most = most.max(sum);
                }
            }
        }
        most as u32
    }

    /// The bound's factor on τ (module docs) for cut radii up to `rho_max`.
    fn tail_factor(&self, rho_max: f64, a_min: f64, n: usize) -> f64 {
        let phi = |d: f64| (-a_min * (d * d - rho_max * rho_max).max(0.0)).exp();
        let total = n as f64;
        let mut sum = 0.0;
        let mut memo: Vec<Option<f64>> = Vec::new();
        for m in 1.. {
            let (d0, d1) = (rho_max + (m - 1) as f64 * self.h, rho_max + m as f64 * self.h);
            let k = (d1 / self.h).ceil() as usize;
            if memo.len() <= k {
                memo.resize(k + 1, None);
            }
            let count = *memo[k].get_or_insert_with(|| f64::from(self.cube_max(k)));
            // Past the grid or holding every centre: the rest is φ(D) n.
            if count >= total || k > self.dims.into_iter().max().unwrap_or(0) || phi(d1) * total < 1e-6 * sum {
                return sum + phi(d0) * total;
            }
            sum += (phi(d0) - phi(d1)) * count;
        }
        unreachable!()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The brute-force sum of the cut tails at x.
    fn tails(gs: &[Gaussian], tau: f64, x: DVec3) -> f64 {
        gs.iter()
            .filter(|g| (x - g.center).length() > g.radius_at(tau))
            .map(|g| g.weight * (-g.decay() * (x - g.center).length_squared()).exp())
            .sum()
    }

    fn lattice(n: usize, spacing: f64) -> Vec<Gaussian> {
        let side = (n as f64).cbrt().ceil() as usize;
        (0..n)
            .map(|i| {
                let c = DVec3::new((i % side) as f64, ((i / side) % side) as f64, (i / side / side) as f64) * spacing;
                let r = if i % 3 == 0 { 1.2 } else { 1.7 };
                Gaussian { center: c, r, s: 2.0, weight: 2f64.exp() }
            })
            .collect()
    }

    /// The tails cut at the threshold stay under the budget at the densest
    /// points (brute force over a sample), and the threshold is well above
    /// the density-free one for a large, protein-dense group.
    #[test]
    fn cut_tails_stay_under_the_budget() {
        let gs = lattice(8000, 2.7);
        let budget = 1e-3;
        let tau = threshold(&gs, budget);
        assert!(tau > 20.0 * budget / gs.len() as f64, "τ {tau} barely above the density-free {}", budget / 8000.0);
        let mut worst: f64 = 0.0;
        for i in 0..2000 {
            let k = i as f64;
            let x = DVec3::new(10.0 + (k * 0.618).fract() * 35.0, 10.0 + (k * 0.414).fract() * 35.0, 10.0 + (k * 0.732).fract() * 35.0);
            worst = worst.max(tails(&gs, tau, x));
        }
        assert!(worst < budget, "cut tails reach {worst} > {budget}");
        assert!(worst > 0.02 * budget, "the bound is loose: tails at most {worst}");
    }

    /// Clustered centres (all at one point) get the density-free
    /// threshold's order: the bound sees the cluster.
    #[test]
    fn a_cluster_is_as_dense_as_its_count() {
        let mut gs = lattice(1000, 3.0);
        for g in gs.iter_mut().take(500) {
            g.center = DVec3::splat(13.0);
        }
        let budget = 1e-3;
        let tau = threshold(&gs, budget);
        let x = DVec3::splat(13.0) + DVec3::new(gs[0].radius_at(tau) * 1.0001, 0.0, 0.0);
        assert!(tails(&gs, tau, x) < budget);
        assert!(tau < 4.0 * budget / 500.0, "τ {tau} ignores the cluster of 500");
    }
}
