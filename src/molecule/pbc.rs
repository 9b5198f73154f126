//! Periodic boxes: molecules made whole across them, and kept from jumping
//! between frames (docs/trajectories.md, "Periodic boxes").
//!
//! A simulation puts each atom back into its box, so a molecule that
//! straddles a face is drawn in pieces at opposite sides. GROMACS's
//! `trjconv -pbc mol`, VMD's `pbc unwrap` and MDAnalysis's `make_whole`
//! put it back together; here, as in MDAnalysis: each molecule (a
//! connected set of bonded atoms) keeps its first atom where the file has
//! it, and every other atom is moved by whole box vectors to the image
//! nearest to an atom it is bonded to that is already placed (a walk
//! along its bonds, breadth first). Bonds come from the topology where it
//! has them (a PSF's `!NBOND`), else they are guessed once, on the first
//! frame: two atoms of one residue, or of residues next to each other in
//! one chain, are bonded when their nearest images are closer than 0.55
//! times the sum of their van der Waals radii (MDAnalysis's rule and
//! radii: H 1.1 Å, else Bondi's).
//!
//! Made whole one frame at a time, a molecule would still jump a box
//! length whenever its first atom crosses a face. So after the first
//! frame each molecule is moved, as a whole, by the box vectors that put
//! its centre nearest to its centre in the frame before: it never jumps.
//! That needs the frames in order: frame k's shifts follow from frame
//! k-1's centres, which are kept for the last frame read and for every
//! 32nd frame, so a seek reads forward at most 31 frames from the nearest
//! one kept (and from frame 0 the first time it goes beyond it).

use std::collections::BTreeMap;

use glam::{DMat3, DVec3};

use super::Atom;

/// The narrowest crystal cell read as a periodic box, Å between opposite
/// faces ([`Cell::from_crystal`]). Two atoms of neighbouring residues lie
/// at most about 18 Å apart, so no lattice vector of such a cell brings
/// one within bonding distance of the other; and a simulation box is at
/// least twice its cut-off (about 10 Å) across.
pub const CRYSTAL_MIN_WIDTH: f64 = 20.0;

/// A periodic box: its three vectors, in ångström. Any triclinic box
/// (GROMACS's rhombic dodecahedron and truncated octahedron included).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// The box vectors a, b and c as the columns.
    pub matrix: DMat3,
    inverse: DMat3,
}

impl Cell {
    /// The box of vectors `a`, `b` and `c` (Å), or `None` where they span
    /// no volume (a file's box of zeros: no box).
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Option<Cell> {
        let matrix = DMat3::from_cols(a, b, c);
        let det = matrix.determinant();
        let scale = a.length() * b.length() * c.length();
        if !det.is_finite() || scale == 0.0 || det.abs() < 1e-6 * scale {
            return None;
        }
        Some(Cell { matrix, inverse: matrix.inverse() })
    }

    /// The box of edge lengths a, b, c (Å) and angles alpha (between b
    /// and c), beta (a, c) and gamma (a, b) in degrees, with a along x and
    /// b in the xy plane (the PDB's and MDAnalysis's convention).
    pub fn from_lengths_angles(lengths: [f64; 3], angles: [f64; 3]) -> Option<Cell> {
        let [a, b, c] = lengths;
        let [alpha, beta, gamma] = angles.map(f64::to_radians);
        let (ca, cb, cg, sg) = (alpha.cos(), beta.cos(), gamma.cos(), gamma.sin());
        // Exact zeros for right angles, so a rectangular box stays one.
        let snap = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x };
        let (ca, cb, cg) = (snap(ca), snap(cb), snap(cg));
        let va = DVec3::new(a, 0.0, 0.0);
        let vb = DVec3::new(b * cg, b * sg, 0.0);
        let cx = c * cb;
        let cy = c * (ca - cb * cg) / sg;
        let cz = (c * c - cx * cx - cy * cy).max(0.0).sqrt();
        Cell::new(va, vb, DVec3::new(cx, cy, cz))
    }

    /// A crystal's unit cell (a PDB's `CRYST1`, an mmCIF's `_cell`) as a
    /// periodic box: lengths a, b, c (Å) and angles alpha, beta, gamma
    /// (degrees). None for the placeholder of files that have no cell
    /// (a = b = c = 1 Å, which cryo-EM and NMR entries carry; MDAnalysis
    /// ignores it too), nor for a cell whose opposite faces are closer than
    /// [`CRYSTAL_MIN_WIDTH`]: across a cell that thin, bonds guessed by
    /// distance would join atoms of one residue that are not bonded, and
    /// making molecules whole would then break a structure that was whole.
    pub fn from_crystal(lengths: [f64; 3], angles: [f64; 3]) -> Option<Cell> {
        if lengths == [1.0; 3] {
            return None;
        }
        Cell::from_lengths_angles(lengths, angles).filter(|c| c.widths().iter().all(|&w| w >= CRYSTAL_MIN_WIDTH))
    }

    /// The distances between the box's opposite faces (across the b-c,
    /// c-a and a-b faces), Å.
    pub fn widths(&self) -> [f64; 3] {
        let [a, b, c] = self.vectors();
        let volume = self.matrix.determinant().abs();
        [volume / b.cross(c).length(), volume / c.cross(a).length(), volume / a.cross(b).length()]
    }

    /// The box of a GRO file's last line: 3 numbers (a rectangular box)
    /// or 9 (v1(x) v2(y) v3(z) v1(y) v1(z) v2(x) v2(z) v3(x) v3(y)), in
    /// nanometres.
    pub fn from_gro(numbers: &[f64]) -> Option<Cell> {
        let n = |i: usize| numbers.get(i).copied().unwrap_or(0.0) * 10.0;
        match numbers.len() {
            3 | 9 => Cell::new(DVec3::new(n(0), n(3), n(4)), DVec3::new(n(5), n(1), n(6)), DVec3::new(n(7), n(8), n(2))),
            _ => None,
        }
    }

    /// The box of a DCD frame's unit cell, as CHARMM and NAMD write it:
    /// A, gamma, B, beta, alpha, C; the angles in degrees, or as their
    /// cosines where all three lie in [-1, 1] (CHARMM since c34, NAMD,
    /// MDAnalysis).
    pub fn from_dcd(cell: [f64; 6]) -> Option<Cell> {
        let [a, gamma, b, beta, alpha, c] = cell;
        let mut angles = [alpha, beta, gamma];
        if angles.iter().all(|x| (-1.0..=1.0).contains(x)) {
            angles = angles.map(|x| x.acos().to_degrees());
        }
        Cell::from_lengths_angles([a, b, c], angles)
    }

    /// The box vectors a, b and c.
    pub fn vectors(&self) -> [DVec3; 3] {
        [self.matrix.x_axis, self.matrix.y_axis, self.matrix.z_axis]
    }

    /// The box's centre: half the sum of its vectors.
    pub fn centre(&self) -> DVec3 {
        0.5 * (self.matrix.x_axis + self.matrix.y_axis + self.matrix.z_axis)
    }

    /// The whole box vectors nearest to `d` in the box's own coordinates.
    fn lattice(&self, d: DVec3) -> DVec3 {
        (self.inverse * d).round()
    }

    /// The shortest of `d`'s periodic images, `d` plus whole box vectors
    /// (the minimum image): exact in any triclinic box, since the 27
    /// neighbours of the nearest lattice point in fractional coordinates
    /// are all tried.
    pub fn minimum_image(&self, d: DVec3) -> DVec3 {
        let base = d - self.matrix * self.lattice(d);
        let mut best = base;
        let mut shortest = base.length_squared();
        for i in -1..=1 {
            for j in -1..=1 {
                for k in -1..=1 {
                    if (i, j, k) == (0, 0, 0) {
                        continue;
                    }
                    let v = base + self.matrix * DVec3::new(f64::from(i), f64::from(j), f64::from(k));
                    let l = v.length_squared();
                    // Strictly shorter: of images at the same distance the
                    // one nearest the plain reduction wins.
                    if l < shortest * (1.0 - 1e-12) {
                        (best, shortest) = (v, l);
                    }
                }
            }
        }
        best
    }

    /// `s` rounded to whole box vectors (a shift made of them, taken back
    /// to the exact lattice point it stands for).
    pub fn whole(&self, s: DVec3) -> DVec3 {
        self.matrix * self.lattice(s)
    }

    /// The whole box vectors (integers) of shift `s`.
    pub fn counts(&self, s: DVec3) -> [i64; 3] {
        let n = self.lattice(s);
        [n.x as i64, n.y as i64, n.z as i64]
    }
}

/// What is done about the periodic box (`--pbc`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Pbc {
    /// Whole where the file has a box and a molecule of its first frame
    /// is split by it; else the file's coordinates.
    #[default]
    Auto,
    /// Each molecule made whole, and kept from jumping between frames.
    Whole,
    /// Whole, then every frame moved so that the centre of the atoms drawn
    /// is the box's.
    Center,
    /// The file's coordinates as they are.
    None,
}

impl Pbc {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Pbc::Auto => "auto",
            Pbc::Whole => "whole",
            Pbc::Center => "center",
            Pbc::None => "none",
        }
    }
}

/// What was done, as the note on stderr says it: `count` molecules made
/// whole in `cell` as `pbc` asked, with the topology's bonds or guessed
/// ones, in `seconds`; `frames`: kept from jumping between frames too.
pub fn note(pbc: Pbc, cell: &Cell, count: usize, topology_bonds: bool, seconds: f64, frames: bool) -> String {
    let [a, b, c] = cell.vectors();
    let shape = if [a.y, a.z, b.x, b.z, c.x, c.y].iter().all(|&v| v == 0.0) { "rectangular" } else { "triclinic" };
    let bonds = if topology_bonds { "the topology's bonds" } else { "bonds guessed by residue and distance" };
    let kept = if frames { " and kept from jumping between frames" } else { "" };
    let count = if count == 1 { "1 molecule".to_string() } else { format!("{count} molecules") };
    let size = format!("{shape}, {:.1} x {:.1} x {:.1} Å", a.length(), b.length(), c.length());
    match pbc {
        Pbc::Auto => format!(
            "a molecule of {} is split by the periodic box ({size}): {count} made whole ({bonds}, {seconds:.2} s){kept}; --pbc none keeps the file's coordinates",
            if frames { "frame 0" } else { "the structure" }
        ),
        _ => format!("--pbc {}: {count} made whole across the periodic box ({size}; {bonds}){kept}", pbc.name()),
    }
}

/// Makes the molecules of one structure whole in its box (a GRO file's)
/// as `pbc` says, then moves them so that the centre of the `center`
/// sites is the box's where given (`--pbc center`). The note to print,
/// where something was done.
pub fn make_molecule_whole(m: &mut super::Molecule, pbc: Pbc, center: Option<Vec<usize>>) -> Result<Option<String>, super::MoleculeError> {
    if pbc == Pbc::None {
        return Ok(None);
    }
    let Some(cell) = m.cell else {
        if pbc == Pbc::Auto {
            return Ok(None);
        }
        return Err(super::MoleculeError {
            file: m.source.clone(),
            line: None,
            message: format!("--pbc {}: the file gives no periodic box", pbc.name()),
        });
    };
    let started = std::time::Instant::now();
    let molecules = Molecules::of_topology(&m.atoms, &m.bonds, Some(&cell));
    let mut positions = vec![DVec3::NAN; m.sites];
    for a in &m.atoms {
        positions[a.site] = a.position;
    }
    let split = molecules.make_whole(&mut positions, &cell);
    if pbc == Pbc::Auto && !split {
        return Ok(None);
    }
    let mut unwrap = Unwrap::new(molecules);
    unwrap.center = center;
    let mut positions: Vec<DVec3> = vec![DVec3::NAN; m.sites];
    for a in &m.atoms {
        positions[a.site] = a.position;
    }
    unwrap.apply(0, &mut positions, &cell, None);
    for a in &mut m.atoms {
        a.position = positions[a.site];
    }
    let note = note(pbc, &cell, unwrap.molecules.len(), !m.bonds.is_empty(), started.elapsed().as_secs_f64(), false);
    Ok(Some(format!("{}: {note}", m.source)))
}

/// The van der Waals radius bonds are guessed with (MDAnalysis's
/// table: 1.1 Å for hydrogen, else Bondi's, 1.8 Å where unknown).
fn bond_radius(element: &str) -> f64 {
    if element == "H" { 1.1 } else { super::elements::radius(element).unwrap_or(super::elements::FALLBACK_RADIUS) }
}

/// Whether atoms `a` and `b` at these positions are bonded by MDAnalysis's
/// rule: their nearest images closer than 0.55 times the sum of their
/// radii, and farther than 0.1 Å.
pub fn bonded(a: &Atom, b: &Atom, pa: DVec3, pb: DVec3, cell: Option<&Cell>) -> bool {
    let d = pb - pa;
    let d = cell.map_or(d, |c| c.minimum_image(d)).length();
    d > 0.1 && d < 0.55 * (bond_radius(&a.element) + bond_radius(&b.element))
}

/// Bonds guessed by residue and distance (indices into `atoms`, at their
/// positions): within each residue, and between residues next to each
/// other in the file in one chain and segment.
pub fn guess_bonds(atoms: &[Atom], cell: Option<&Cell>) -> Vec<[usize; 2]> {
    // Residues: runs of atoms of one chain, segment, number and name.
    let key = |a: &Atom| (a.chain.clone(), a.segment.clone(), a.resid, a.resname.clone(), a.icode.clone());
    let mut residues: Vec<std::ops::Range<usize>> = Vec::new();
    for i in 0..atoms.len() {
        match residues.last_mut() {
            Some(r) if key(&atoms[r.start]) == key(&atoms[i]) => r.end = i + 1,
            _ => residues.push(i..i + 1),
        }
    }
    let mut bonds = Vec::new();
    for (r, range) in residues.iter().enumerate() {
        let next = residues.get(r + 1).filter(|n| {
            let (a, b) = (&atoms[range.start], &atoms[n.start]);
            a.chain == b.chain && a.segment == b.segment
        });
        for i in range.clone() {
            let later = (i + 1..range.end).chain(next.cloned().unwrap_or(0..0));
            for j in later {
                if bonded(&atoms[i], &atoms[j], atoms[i].position, atoms[j].position, cell) {
                    bonds.push([i, j]);
                }
            }
        }
    }
    bonds
}

/// The molecules of a topology: connected sets of bonded atoms, each as
/// the order its atoms are placed in, the first placed where the file has
/// it, each later one beside an atom placed before it.
#[derive(Clone, Debug, PartialEq)]
pub struct Molecules {
    /// (site, the site of the atom it is placed beside; `None` for the
    /// first of its molecule), molecule after molecule.
    order: Vec<(usize, Option<usize>)>,
    /// Where each molecule starts in `order`, and its end.
    starts: Vec<usize>,
}

impl Molecules {
    /// The molecules that `bonds` (indices into `atoms`) make of `atoms`,
    /// in the order of their first atoms; each walked breadth first from
    /// its first atom, neighbours in file order.
    pub fn of(atoms: &[Atom], bonds: &[[usize; 2]]) -> Molecules {
        let n = atoms.len();
        let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &[a, b] in bonds {
            if a < n && b < n && a != b {
                neighbours[a].push(b);
                neighbours[b].push(a);
            }
        }
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
        }
        let mut seen = vec![false; n];
        let (mut order, mut starts) = (Vec::with_capacity(n), Vec::new());
        let mut queue = std::collections::VecDeque::new();
        for root in 0..n {
            if seen[root] {
                continue;
            }
            starts.push(order.len());
            seen[root] = true;
            order.push((atoms[root].site, None));
            queue.push_back(root);
            while let Some(i) = queue.pop_front() {
                for &j in &neighbours[i] {
                    if !seen[j] {
                        seen[j] = true;
                        order.push((atoms[j].site, Some(atoms[i].site)));
                        queue.push_back(j);
                    }
                }
            }
        }
        starts.push(order.len());
        Molecules { order, starts }
    }

    /// The molecules of `atoms`: bonds from `topology_bonds` (sites) where
    /// given, else guessed at the atoms' positions in `cell`.
    pub fn of_topology(atoms: &[Atom], topology_bonds: &[[usize; 2]], cell: Option<&Cell>) -> Molecules {
        if topology_bonds.is_empty() {
            return Molecules::of(atoms, &guess_bonds(atoms, cell));
        }
        let mut index = std::collections::HashMap::with_capacity(atoms.len());
        for (i, a) in atoms.iter().enumerate() {
            index.insert(a.site, i);
        }
        let bonds: Vec<[usize; 2]> = topology_bonds.iter().filter_map(|&[a, b]| Some([*index.get(&a)?, *index.get(&b)?])).collect();
        Molecules::of(atoms, &bonds)
    }

    /// How many molecules.
    pub fn len(&self) -> usize {
        self.starts.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The sites of molecule `m`, its first atom first.
    pub fn sites(&self, m: usize) -> impl Iterator<Item = usize> + '_ {
        self.order[self.starts[m]..self.starts[m + 1]].iter().map(|&(s, _)| s)
    }

    /// Makes every molecule whole in `positions` (by site): each atom but
    /// a molecule's first moved by whole box vectors to the image nearest
    /// the atom it is placed beside. Whether any atom moved.
    pub fn make_whole(&self, positions: &mut [DVec3], cell: &Cell) -> bool {
        let mut moved = false;
        for &(site, beside) in &self.order {
            let Some(b) = beside else { continue };
            let (p, anchor) = (positions[site], positions[b]);
            let placed = anchor + cell.minimum_image(p - anchor);
            // The shift in whole box vectors, exactly.
            let shifted = p + cell.whole(placed - p);
            if shifted != p {
                positions[site] = shifted;
                moved = true;
            }
        }
        moved
    }

    /// Each molecule's centre (the mean of its atoms' positions).
    pub fn centres(&self, positions: &[DVec3]) -> Vec<DVec3> {
        (0..self.len()).map(|m| self.sites(m).fold(DVec3::ZERO, |a, s| a + positions[s]) / (self.starts[m + 1] - self.starts[m]) as f64).collect()
    }

    /// Moves each molecule by the whole box vectors that put its centre
    /// nearest to `before` (its centre in the frame before); the centres
    /// after.
    pub fn follow(&self, positions: &mut [DVec3], cell: &Cell, before: &[DVec3]) -> Vec<DVec3> {
        let mut centres = self.centres(positions);
        for (m, c) in centres.iter_mut().enumerate() {
            let d = *c - before[m];
            let shift = cell.whole(cell.minimum_image(d) - d);
            if shift != DVec3::ZERO {
                for s in self.sites(m) {
                    positions[s] += shift;
                }
                *c += shift;
            }
        }
        centres
    }
}

/// How often the centres of a frame are kept for seeks.
const CHECKPOINT: usize = 32;

/// Molecules made whole frame after frame, and kept from jumping.
#[derive(Clone, Debug)]
pub struct Unwrap {
    pub molecules: Molecules,
    /// Moved to the box's centre after (`--pbc center`): these sites'.
    pub center: Option<Vec<usize>>,
    /// The molecules' centres (before centring) of the last two frames
    /// made whole (the last first), and of every 32nd.
    last: std::collections::VecDeque<(usize, Vec<DVec3>)>,
    kept: BTreeMap<usize, Vec<DVec3>>,
}

impl Unwrap {
    pub fn new(molecules: Molecules) -> Unwrap {
        Unwrap { molecules, center: None, last: std::collections::VecDeque::new(), kept: BTreeMap::new() }
    }

    /// The centres of frame `k` if they are known.
    pub fn centres_of(&self, k: usize) -> Option<&[DVec3]> {
        match self.last.iter().find(|(j, _)| *j == k) {
            Some((_, c)) => Some(c),
            None => self.kept.get(&k).map(Vec::as_slice),
        }
    }

    /// The latest frame at or before `k` whose centres are known.
    pub fn known_before(&self, k: usize) -> Option<usize> {
        let kept = self.kept.range(..=k).next_back().map(|(&j, _)| j);
        let last = self.last.iter().map(|(j, _)| *j).filter(|&j| j <= k).max();
        kept.max(last)
    }

    /// Makes frame `k`'s `positions` whole in `cell`, following `before`
    /// (frame k-1's centres; `None` for frame 0), then centres them where
    /// asked; keeps its centres.
    pub fn apply(&mut self, k: usize, positions: &mut [DVec3], cell: &Cell, before: Option<&[DVec3]>) {
        self.molecules.make_whole(positions, cell);
        let centres = match before {
            Some(b) => self.molecules.follow(positions, cell, b),
            None => self.molecules.centres(positions),
        };
        if let Some(sites) = &self.center
            && !sites.is_empty()
        {
            let mean = sites.iter().fold(DVec3::ZERO, |a, &s| a + positions[s]) / sites.len() as f64;
            let t = cell.centre() - mean;
            for p in positions.iter_mut().filter(|p| p.is_finite()) {
                *p += t;
            }
        }
        if k.is_multiple_of(CHECKPOINT) {
            self.kept.insert(k, centres.clone());
        }
        if self.last.front().is_none_or(|(j, _)| *j != k) {
            self.last.push_front((k, centres));
            self.last.truncate(2);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn atom(element: &str, resid: i64, site: usize, p: DVec3) -> Atom {
        Atom { element: element.into(), resid, site, position: p, chain: "A".into(), resname: "RES".into(), ..Default::default() }
    }

    /// GROMACS's rhombic dodecahedron of AdK's GRO (xy-square), Å.
    fn dodecahedron() -> Cell {
        Cell::from_gro(&[8.00170, 8.00170, 5.65806, 0.0, 0.0, 0.0, 0.0, 4.00085, 4.00085]).unwrap()
    }

    #[test]
    fn boxes_come_from_gro_dcd_and_lengths_with_angles() {
        let c = dodecahedron();
        assert_eq!(c.vectors(), [DVec3::new(80.017, 0.0, 0.0), DVec3::new(0.0, 80.017, 0.0), DVec3::new(40.0085, 40.0085, 56.5806)]);
        let r = Cell::from_gro(&[6.0, 7.0, 8.0]).unwrap();
        assert_eq!(r.vectors(), [DVec3::new(60.0, 0.0, 0.0), DVec3::new(0.0, 70.0, 0.0), DVec3::new(0.0, 0.0, 80.0)]);
        // MDAnalysis writes the cosines of right angles: 0.
        assert_eq!(Cell::from_dcd([60.0, 0.0, 70.0, 0.0, 0.0, 80.0]), Some(r));
        assert_eq!(Cell::from_dcd([60.0, 90.0, 70.0, 90.0, 90.0, 80.0]), Some(r));
        // The dodecahedron by its lengths and angles (60, 60, 90 degrees).
        let l = 80.017f64;
        let d = Cell::from_lengths_angles([l, l, l], [60.0, 60.0, 90.0]).unwrap();
        for (u, v) in d.vectors().iter().zip(c.vectors()) {
            assert!((*u - v).length() < 1e-3, "{u} {v}");
        }
        assert_eq!(Cell::from_gro(&[0.0, 0.0, 0.0]), None, "a box of zeros is none");
        assert_eq!(Cell::from_gro(&[1.0, 2.0]), None);
    }

    #[test]
    fn the_minimum_image_is_the_shortest_in_a_triclinic_box() {
        let c = dodecahedron();
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 400.0;
            let m = c.minimum_image(d);
            // d and m differ by whole box vectors.
            let n = c.inverse * (m - d);
            assert!((n - n.round()).abs().max_element() < 1e-9, "{d} {m}");
            // No image within five box vectors either way is shorter.
            for i in -5..=5 {
                for j in -5..=5 {
                    for k in -5..=5 {
                        let v = m + c.matrix * DVec3::new(f64::from(i), f64::from(j), f64::from(k));
                        assert!(v.length() >= m.length() - 1e-9, "{d}: {m} but {v}");
                    }
                }
            }
        }
    }

    /// A chain of residues of two atoms 1.5 Å apart, and a water, straddling
    /// the dodecahedron's faces once wrapped.
    fn split() -> (Vec<Atom>, Vec<DVec3>, Cell) {
        let c = dodecahedron();
        let mut atoms = Vec::new();
        let mut whole = Vec::new();
        let mut p = DVec3::new(100.0, 78.0, 55.0);
        for k in 0..40 {
            let step = DVec3::new(1.0, 0.5, (k as f64 * 0.7).sin()).normalize() * 1.5;
            p += step;
            whole.push(p);
            atoms.push(atom(if k % 2 == 0 { "C" } else { "N" }, 1 + k as i64 / 2, k, p));
        }
        atoms.push(Atom { resname: "SOL".into(), ..atom("O", 100, 40, DVec3::new(79.9, 1.0, 1.0)) });
        atoms.push(Atom { resname: "SOL".into(), ..atom("H", 100, 41, DVec3::new(80.5, 1.5, 1.2)) });
        whole.push(atoms[40].position);
        whole.push(atoms[41].position);
        // Wrapped into the box: fractional coordinates in [0, 1).
        for a in &mut atoms {
            let f = c.inverse * a.position;
            a.position -= c.matrix * f.floor();
        }
        (atoms, whole, c)
    }

    #[test]
    fn a_split_chain_and_water_are_made_whole_by_box_vectors() {
        let (atoms, whole, cell) = split();
        let bonds = guess_bonds(&atoms, Some(&cell));
        assert_eq!(bonds.len(), 40, "39 along the chain and the water's one: {bonds:?}");
        let m = Molecules::of(&atoms, &bonds);
        assert_eq!(m.len(), 2);
        let mut positions: Vec<DVec3> = atoms.iter().map(|a| a.position).collect();
        let wrapped = positions.clone();
        assert!(positions.windows(2).take(39).any(|w| (w[1] - w[0]).length() > 10.0), "the test's chain is split");
        assert!(m.make_whole(&mut positions, &cell));
        for (k, w) in positions.windows(2).take(39).enumerate() {
            assert!(((w[1] - w[0]).length() - 1.5).abs() < 1e-9, "bond {k}");
        }
        assert!(((positions[41] - positions[40]).length() - (whole[41] - whole[40]).length()).abs() < 1e-9);
        // The first atom stays; every atom moved by whole box vectors.
        assert_eq!(positions[0], wrapped[0]);
        for (p, w) in positions.iter().zip(&wrapped) {
            let n = cell.inverse * (*p - *w);
            assert!((n - n.round()).abs().max_element() < 1e-9);
        }
        // A second pass moves nothing.
        assert!(!m.make_whole(&mut positions, &cell));
    }

    #[test]
    fn a_molecule_whose_first_atom_crosses_a_face_does_not_jump() {
        let (atoms, _, cell) = split();
        let m = Molecules::of(&atoms, &guess_bonds(&atoms, Some(&cell)));
        let mut u = Unwrap::new(m);
        let mut before: Option<Vec<DVec3>> = None;
        let mut last_first: Option<DVec3> = None;
        // The whole system drifts along -x by 2 Å a frame, wrapped each
        // time: the chain's first atom leaves through the face at x = 0.
        for k in 0..60usize {
            let mut positions: Vec<DVec3> = atoms
                .iter()
                .map(|a| {
                    let p = a.position - DVec3::new(2.0 * k as f64, 0.0, 0.0);
                    p - cell.matrix * (cell.inverse * p).floor()
                })
                .collect();
            u.apply(k, &mut positions, &cell, before.as_deref());
            if let Some(l) = last_first {
                assert!((positions[0] - l - DVec3::new(-2.0, 0.0, 0.0)).length() < 1e-9, "frame {k}: {l} to {}", positions[0]);
            }
            last_first = Some(positions[0]);
            before = u.centres_of(k).map(<[DVec3]>::to_vec);
        }
        assert_eq!(u.known_before(45), Some(32));
        assert_eq!(u.known_before(70), Some(59));
        assert_eq!(u.known_before(58), Some(58), "the last two frames are kept");
    }
}
