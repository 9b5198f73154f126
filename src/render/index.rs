//! The spatial index, host side: the grid's geometry for a scene, the sizes
//! of its buffers, the GPU build (shaders/index.comp, every frame), and the
//! loop budget of a marching step that walks it (shaders/include/grid.glsl
//! and cursor_grid.glsl say what the lists hold and how they are walked).
//!
//! Why a uniform grid: it is built in seven short compute passes (a
//! counting sort) with no tree to balance, its cells' lists keep each
//! group's primitives together (the fold needs groups one after another),
//! and a step walks a bounded number of cells (`window`), so the work of a
//! step does not grow with the scene. Scenes whose primitives' sizes differ
//! by orders of magnitude put the largest in per-group "everywhere" lists.
//! docs/spatial-index.md has the measurements behind the choices.

use anyhow::{Result, bail};
use glam::DVec3;

use crate::field::clip;
use crate::gpu::DeviceInfo;
use crate::layout::{CELL_PAD, MAX_CELLS_PER_PRIMITIVE, SCAN_BLOCK, SKIP_CELLS};
use crate::scene::{Kernel, Primitive, Scene};

/// Scenes of more primitives than per-ray culling handles march with the
/// index.
pub const INDEX_MIN_PRIMITIVES: usize = super::CULL_MAX_PRIMITIVES + 1;
/// Lists at most: the index build dispatches one invocation per list, and
/// Vulkan guarantees 65,535 workgroups (of 64) per dispatch; the top scan
/// loops over lists / 256 blocks, far below lavapipe's per-invocation cap.
const MAX_LISTS: usize = 65_535 * 64 - 1;
/// Primitives at most, for the same reason (one invocation each).
pub const MAX_INDEXED_PRIMITIVES: usize = 65_535 * 64;
/// Groups at most: the walk crosses the cells once per group, so a scene
/// of many groups marches faster flat.
pub const MAX_INDEX_GROUPS: usize = 256;
/// Cell size over the median index radius: a cell of side h holds about
/// `density (h + 2ρ)³` entries and a ray crosses `1/h` cells per unit of
/// length, so the entries a ray visits per unit of length, `density (h +
/// 2ρ)³ / h`, are least at h = ρ.
pub const CELL_PER_RADIUS: f64 = 1.0;
/// The longest candidate interval of a step, in cells. With storage-buffer
/// loads 2 and 4 were within noise of each other on the particle sweep, 8
/// slower (docs/spatial-index.md); once entries cost a texel fetch, 2 took
/// 12–15% less GPU time than 4 on 1,000 blobs and 20% less on 1A8O, with
/// fewer steps for segment tracing and 0.97x to 1.03x the steps for
/// quadratic Taylor (docs/performance.md).
pub const WINDOW_CELLS: f64 = 2.0;
/// The same where most of the grid's primitives are Gaussians: one cell
/// of [`GAUSSIAN_CELL_PER_RADIUS`], half a clipping radius ρ, about 1.35
/// of their scales r; a bound over more than a few r is loose, and a
/// longer interval walks more cells. At 750x750 with cells of ρ/2, GPU
/// ms of the march with windows of one and two cells: quadratic Taylor
/// 1A8O 500 and 547, 1TII 533 and 599, 3KPR 434 and 475, 6WG6 667 and
/// 714, YiiP 815 and 927; segment tracing 806 and 915, 821 and 908, 6WG6
/// 931 and 1023, YiiP 1256 and 1403 (one or two runs each), with more
/// steps but cheaper folds.
pub const GAUSSIAN_WINDOW_CELLS: f64 = 1.0;
/// Cell size over the median index radius where most of the grid's
/// primitives are Gaussians. [`CELL_PER_RADIUS`]'s argument holds for
/// long queries; near a Gaussian surface the steps are short (bounded by
/// the kernels' curvature, on the scale r = ρ/2.7), so most folds are
/// nearly points, whose lists hold about `density (h + 2ρ)³` entries: less
/// with smaller cells, while the entries, and the index build with them,
/// grow as `((h + 2ρ)/h)³`. At 750x750, march and build GPU ms of
/// quadratic Taylor with ρ, 0.75ρ and 0.5ρ: 1A8O 776, 700, 553; 1TII 829,
/// 735, 602; 3KPR 765, 644, 529; 6WG6 1049, 892, 814; YiiP with hydrogens
/// 1272, 1202, 1371 (its build alone 118, 193, 442 ms; one run each;
/// docs/spatial-index.md).
pub const GAUSSIAN_CELL_PER_RADIUS: f64 = 0.5;
/// Cells at most per primitive: a few, and more where most are Gaussians,
/// whose cells are finer (6WG6 holds 21 per atom at half a radius).
const CELLS_PER_PRIMITIVE: usize = 8;
const GAUSSIAN_CELLS_PER_PRIMITIVE: usize = 32;
/// The clipped tails of a group's Gaussians add up to at most this
/// fraction of iso anywhere (see [`index_radius`]).
pub const GAUSSIAN_CLIP_FRACTION: f64 = 1e-3;

/// A primitive's radius for the index: its support for a compact kernel;
/// for a Gaussian, the clipping radius ρ where `w e^{-s ρ²/r²}` falls to
/// the group's threshold τ (`clip::threshold`): the cut tails of a
/// group's Gaussians add up to less than `GAUSSIAN_CLIP_FRACTION · iso` at
/// any point, by a bound on how many centres the group packs near one
/// point. The rendered field is the clipped one; `None` for planes, HRBF
/// terms and affine functions (not in the grid: their support is
/// everywhere).
pub fn index_radius(p: &Primitive, tau: f64) -> Option<f64> {
    match *p {
        Primitive::Point { kernel: Kernel::Compact { radius, .. }, .. } => Some(radius),
        Primitive::Point { .. } => clip::Gaussian::of(p).map(|g| g.radius_at(tau)),
        Primitive::Plane { .. } | Primitive::Hrbf { .. } | Primitive::Affine { .. } => None,
    }
}

/// Index radii of every primitive in GPU order (group by group). The
/// thresholds count centres on a grid: compute them once per pose and
/// hand them to [`GridSpec::with_radii`] and `render::primitives_with_radii`.
pub fn index_radii(scene: &Scene) -> Vec<Option<f64>> {
    let budget = GAUSSIAN_CLIP_FRACTION * scene.iso;
    scene
        .groups
        .iter()
        .flat_map(|g| {
            let gaussians: Vec<clip::Gaussian> = g.iter().filter_map(clip::Gaussian::of).collect();
            let tau = clip::threshold(&gaussians, budget);
            g.iter().map(move |p| index_radius(p, tau))
        })
        .collect()
}

/// The grid of one pose of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec {
    pub origin: DVec3,
    pub cell: f64,
    pub dims: [u32; 3],
    pub groups: usize,
    /// Cells and one everywhere list per group.
    pub lists_per_group: usize,
    /// Entries the lists can hold at most, wherever the primitives are.
    pub entry_capacity: usize,
    /// Entries of the everywhere lists, all groups together.
    pub everywhere: usize,
    /// The longest candidate interval of a step.
    pub window: f64,
}

/// Cells per axis a box of half-width `radius` (padded) can cover.
fn span(radius: f64, cell: f64) -> f64 {
    (2.0 * (radius + f64::from(CELL_PAD) * cell) / cell).ceil() + 1.0
}

impl GridSpec {
    /// The grid for `scene` as posed, or `None` when it marches without
    /// (few primitives, many groups, or an HRBF in a max of groups:
    /// [`Scene::max_needs_every_group`]).
    pub fn for_scene(scene: &Scene) -> Option<GridSpec> {
        GridSpec::with_radii(scene, &index_radii(scene))
    }

    /// [`GridSpec::for_scene`] with the scene's [`index_radii`] at hand.
    pub fn with_radii(scene: &Scene, radii: &[Option<f64>]) -> Option<GridSpec> {
        let n = scene.primitive_count();
        if n < INDEX_MIN_PRIMITIVES || scene.groups.len() > MAX_INDEX_GROUPS || scene.max_needs_every_group() {
            return None;
        }
        let mut sorted: Vec<f64> = radii.iter().flatten().copied().filter(|r| *r > 0.0).collect();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(1.0);
        // The box: the scene's, grown to hold every clipping sphere.
        let (mut lo, mut hi) = (scene.bounds.min, scene.bounds.max);
        for (p, r) in scene.primitives().zip(radii) {
            if let (Primitive::Point { center, .. }, Some(r)) = (p, r) {
                lo = lo.min(*center - DVec3::splat(*r));
                hi = hi.max(*center + DVec3::splat(*r));
            }
        }
        let extent = (hi - lo).max(DVec3::splat(1e-9 * median.max(1e-30)));
        let groups = scene.groups.len();
        let gaussians = 2 * scene.primitives().filter_map(clip::Gaussian::of).count() > n;
        let (per_radius, per_primitive, window_cells) = if gaussians {
            (GAUSSIAN_CELL_PER_RADIUS, GAUSSIAN_CELLS_PER_PRIMITIVE, GAUSSIAN_WINDOW_CELLS)
        } else {
            (CELL_PER_RADIUS, CELLS_PER_PRIMITIVE, WINDOW_CELLS)
        };
        // Finer cells for Gaussians, but not so fine that a primitive
        // within a few medians of the largest leaves the grid for an
        // everywhere list (its box would cover more than
        // MAX_CELLS_PER_PRIMITIVE cells, which would also end the skipping
        // of empty cells); nor coarser than CELL_PER_RADIUS's.
        let largest = sorted.last().copied().unwrap_or(median);
        let per_axis = f64::from(MAX_CELLS_PER_PRIMITIVE).cbrt().floor();
        let grid_radius = 0.98 * (per_axis - 1.0) / 2.0; // radii over a cell that keep a box within it
        let mut cell = (per_radius * median).max((largest / grid_radius).min(CELL_PER_RADIUS * median));
        // At most a few cells per primitive, and at most MAX_LISTS lists.
        let max_cells = (per_primitive * n).min(MAX_LISTS / groups.max(1) - 1).max(64) as f64;
        let cells = |c: f64| (extent / c).ceil().max(DVec3::ONE);
        while cells(cell).element_product() > max_cells {
            cell *= 1.25;
        }
        let d = cells(cell);
        let dims = [d.x as u32, d.y as u32, d.z as u32];
        let window = cell * window_cells;
        let lists_per_group = (d.element_product() as usize) + 1;
        // Bounds that hold whichever way the GPU's f32 decides a primitive
        // on the edge of the everywhere test: at most its box's cells (and
        // at most MAX_CELLS_PER_PRIMITIVE) entries, and counted among the
        // everywhere entries whenever it might be one.
        let (mut entry_capacity, mut everywhere) = (0, 0);
        for r in radii {
            match r {
                Some(r) => {
                    let (lo, hi) = (span(*r * (1.0 - 1e-5), cell), span(*r * (1.0 + 1e-5) + 1e-6 * cell, cell));
                    entry_capacity += hi.powi(3).clamp(1.0, f64::from(MAX_CELLS_PER_PRIMITIVE)) as usize;
                    let most = f64::from(MAX_CELLS_PER_PRIMITIVE);
                    everywhere += usize::from(hi.powi(3) > most || lo.powi(3) > most);
                }
                None => {
                    entry_capacity += 1;
                    everywhere += 1;
                }
            }
        }
        Some(GridSpec { origin: lo, cell, dims, groups, lists_per_group, entry_capacity, everywhere, window })
    }

    pub fn lists(&self) -> usize {
        self.groups * self.lists_per_group
    }

    pub fn blocks(&self) -> usize {
        self.lists().div_ceil(SCAN_BLOCK as usize)
    }

    /// u32s of the three index buffers: list starts, entries, scratch.
    pub fn buffer_words(&self) -> [usize; 3] {
        [self.lists() + 1, self.entry_capacity.max(1), 1 + self.blocks() + self.lists()]
    }

    /// The most cells one interval query of length `window` walks.
    fn cells_per_interval(&self) -> usize {
        (3f64.sqrt() * self.window / self.cell).ceil() as usize + 4
    }

    /// Loop turns of one fold over the primitives along an interval (the
    /// walk's nested loops: one per group, per cell and per entry), when no
    /// list holds more than `longest` entries and no cell more than
    /// `crowd`, all groups together.
    pub fn interval_iterations(&self, longest: usize, crowd: usize) -> usize {
        let cells = self.cells_per_interval();
        self.groups * (1 + cells) + cells * crowd.min(self.groups * longest) + self.everywhere
    }

    /// An upper bound on the entries of one cell, all groups together:
    /// the most primitives whose boxes (padded for the GPU's rounding, and
    /// without its sphere test) share a cell. Only a walk over several
    /// groups needs it; one group's is its longest list.
    pub fn crowd(&self, scene: &Scene, radii: &[Option<f64>]) -> usize {
        let [nx, ny, nz] = self.dims.map(|d| d as usize);
        let mut counts = vec![0u32; nx * ny * nz];
        let most = f64::from(MAX_CELLS_PER_PRIMITIVE);
        for (p, r) in scene.primitives().zip(radii) {
            let (Primitive::Point { center, .. }, Some(r)) = (p, r) else { continue };
            let pad = *r * (1.0 + 1e-5) + f64::from(CELL_PAD) * self.cell + 1e-5 * (*center - self.origin).abs().max_element() + 1e-6 * self.cell;
            if span(*r * (1.0 - 1e-5), self.cell).powi(3) > most {
                continue; // in its group's everywhere list, counted apart
            }
            let cell_of = |x: f64, n: usize| ((x / self.cell).floor().max(0.0) as usize).min(n - 1);
            let (lo, hi) = (*center - DVec3::splat(pad) - self.origin, *center + DVec3::splat(pad) - self.origin);
            for z in cell_of(lo.z, nz)..=cell_of(hi.z, nz) {
                for y in cell_of(lo.y, ny)..=cell_of(hi.y, ny) {
                    for x in cell_of(lo.x, nx)..=cell_of(hi.x, nx) {
                        counts[(z * ny + y) * nx + x] += 1;
                    }
                }
            }
        }
        counts.into_iter().max().unwrap_or(0) as usize
    }

    /// Loop turns of the look-ahead over empty cells (once a turn).
    pub fn skip_iterations(&self) -> usize {
        self.groups * SKIP_CELLS as usize + SKIP_CELLS as usize
    }

    /// Whether a march may skip the cells that list no primitive: there
    /// every group's sum is 0 and f = -iso, no crossing when iso > 0, as
    /// long as no primitive is in an everywhere list (planes, HRBF terms,
    /// affine functions, primitives too large for the grid).
    pub fn skips_empty_cells(&self, iso: f64) -> bool {
        self.everywhere == 0 && iso > 0.0
    }

    /// The same for a point query: its one cell.
    pub fn point_iterations(&self, longest: usize, crowd: usize) -> usize {
        self.groups * 2 + crowd.min(self.groups * longest) + self.everywhere
    }
}

/// What building the index cost and holds, for statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct IndexStats {
    /// GPU time of the last build.
    pub build_ns: f64,
    /// Entries in the lists (a primitive is in every cell it may touch).
    pub entries: usize,
    /// The longest list.
    pub longest_list: usize,
    /// Bytes of the index buffers over the primitives.
    pub bytes_per_primitive: f64,
    pub cells: usize,
    pub cell_size: f64,
}

/// Fails when the index of `spec` cannot fit the device's buffers: the
/// list starts and the scratch are storage buffers, the entries a texel
/// buffer (shaders reach it through texel views, whose limit is in texels).
pub fn check_fits(spec: &GridSpec, device: &DeviceInfo, source: &str) -> Result<()> {
    let [starts, entries, scratch] = spec.buffer_words();
    let need = 4 * starts.max(scratch) as u64;
    if need > device.max_storage_buffer_range {
        bail!(
            "{source}: the spatial index needs a buffer of {need} bytes ({} lists), more than the device's {}",
            spec.lists(),
            device.max_storage_buffer_range
        );
    }
    if entries as u64 > device.max_texel_buffer_elements {
        bail!(
            "{source}: the spatial index may need {entries} entries, more than the device's texel buffers hold ({})",
            device.max_texel_buffer_elements
        );
    }
    Ok(())
}
