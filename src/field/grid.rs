//! The f64 mirror's spatial index: a uniform grid over the compact
//! supports, so that the reference and the f64 marchers visit what a query
//! can meet instead of every primitive. It mirrors the GPU's cursor
//! contract (every primitive whose support meets the query, each once, a
//! group's primitives together), not its layout: the reference stays the
//! exact field, so Gaussians (unbounded) and planes are in a list every
//! query visits.

use glam::DVec3;

use super::prim::PrimEval;

/// A query of the field: a point, or the ray `o + t u` on `[t0, t1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Query {
    Point(DVec3),
    Segment { o: DVec3, u: DVec3, t0: f64, t1: f64 },
}

/// Fields of fewer primitives are walked flat.
pub const GRID_MIN_PRIMITIVES: usize = 65;
/// The longest interval the f64 reference steps over in a scene with a
/// grid, in cells, so that its windows stay local.
pub const REFERENCE_WINDOW_CELLS: f64 = 4.0;

#[derive(Clone, Debug)]
pub struct Grid {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    /// Where each cell's entries start in `entries` (and the end).
    starts: Vec<u32>,
    /// Primitive indices (group by group order), ascending in each cell.
    entries: Vec<u32>,
    /// Primitives every query visits: Gaussians, planes.
    everywhere: Vec<u32>,
}

/// A compact point's centre and support radius.
fn compact_sphere(p: &PrimEval) -> Option<(DVec3, f64)> {
    match p {
        PrimEval::Point(q) if !q.kernel.gaussian => Some((q.center, q.kernel.scale)),
        _ => None,
    }
}

impl Grid {
    /// A grid over `prims` (in group by group order), or `None` for a
    /// field of few primitives or no compact ones.
    pub fn new(prims: &[&PrimEval]) -> Option<Grid> {
        if prims.len() < GRID_MIN_PRIMITIVES {
            return None;
        }
        let spheres: Vec<Option<(DVec3, f64)>> = prims.iter().map(|p| compact_sphere(p)).collect();
        let mut radii: Vec<f64> = spheres.iter().flatten().map(|s| s.1).collect();
        if radii.is_empty() {
            return None;
        }
        radii.sort_by(f64::total_cmp);
        let mut cell = radii[radii.len() / 2];
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for (c, r) in spheres.iter().flatten() {
            lo = lo.min(*c - DVec3::splat(*r));
            hi = hi.max(*c + DVec3::splat(*r));
        }
        let max_cells = (8 * prims.len()) as f64;
        let cells = |c: f64| ((hi - lo) / c).ceil().max(DVec3::ONE);
        while cells(cell).element_product() > max_cells {
            cell *= 1.25;
        }
        let d = cells(cell);
        let dims = [d.x as usize, d.y as usize, d.z as usize];
        let mut grid = Grid { origin: lo, cell, dims, starts: Vec::new(), entries: Vec::new(), everywhere: Vec::new() };
        // Counting sort by cell; primitives in index order, so each cell's
        // list ascends.
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; n_cells + 1];
        let mut ranges = Vec::with_capacity(prims.len());
        for (i, s) in spheres.iter().enumerate() {
            match s {
                Some((c, r)) => {
                    let range = (grid.cell_of(*c - DVec3::splat(*r)), grid.cell_of(*c + DVec3::splat(*r)));
                    grid.for_cells(range, |k| counts[k] += 1);
                    ranges.push(Some(range));
                }
                None => {
                    grid.everywhere.push(i as u32);
                    ranges.push(None);
                }
            }
        }
        let mut sum = 0;
        for c in counts.iter_mut() {
            let n = *c;
            *c = sum;
            sum += n;
        }
        grid.starts = counts.clone();
        grid.entries = vec![0; sum as usize];
        for (i, range) in ranges.iter().enumerate() {
            if let Some(range) = range {
                let (entries, fill) = (&mut grid.entries, &mut counts);
                for_cells_of(grid.dims, *range, |k| {
                    entries[fill[k] as usize] = i as u32;
                    fill[k] += 1;
                });
            }
        }
        Some(grid)
    }

    /// The cell holding `x`, clamped into the grid.
    fn cell_of(&self, x: DVec3) -> [usize; 3] {
        let c = ((x - self.origin) / self.cell).floor();
        let clamp = |v: f64, n: usize| (v.max(0.0) as usize).min(n - 1);
        [clamp(c.x, self.dims[0]), clamp(c.y, self.dims[1]), clamp(c.z, self.dims[2])]
    }

    fn for_cells(&self, range: ([usize; 3], [usize; 3]), f: impl FnMut(usize)) {
        for_cells_of(self.dims, range, f)
    }

    /// The cell size: the f64 reference keeps its windows to a few cells.
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Indices of the primitives `q` may meet, ascending (so each group's
    /// together), each once.
    pub fn candidates(&self, q: Query) -> Vec<u32> {
        let (lo, hi) = match q {
            Query::Point(p) => (p, p),
            Query::Segment { o, u, t0, t1 } => {
                let (a, b) = (o + t0 * u, o + t1 * u);
                (a.min(b), a.max(b))
            }
        };
        let top = self.origin + self.cell * DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64);
        let mut out = self.everywhere.clone();
        if hi.cmpge(self.origin).all() && lo.cmple(top).all() {
            let range = (self.cell_of(lo), self.cell_of(hi));
            self.for_cells(range, |k| out.extend_from_slice(&self.entries[self.starts[k] as usize..self.starts[k + 1] as usize]));
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

fn for_cells_of(dims: [usize; 3], (lo, hi): ([usize; 3], [usize; 3]), mut f: impl FnMut(usize)) {
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                f(x + dims[0] * (y + dims[1] * z));
            }
        }
    }
}
