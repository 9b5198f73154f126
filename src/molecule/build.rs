//! A molecule as a scene: one Gaussian blob per atom (docs/molecules.md).
//!
//! Each atom is `Gaussian(r: scale · r_vdW, s, weight: e^s)` in one group
//! (a sum), with iso 1 by default: a lone atom's surface is then the sphere
//! of its van der Waals radius times the scale, and nearby atoms blend into
//! one smooth surface, as in Blinn's blobby molecules, VMD's QuickSurf and
//! Bruckner's dynamol. The weight is fixed (not `iso·e^s`) so that the iso
//! value is a real control: above 1 the surface shrinks towards the atoms
//! (a lone atom's surface is at `r·sqrt(1 - ln(iso)/s)`), below 1 it grows
//! and blends more.
//!
//! The scene is produced as RON text and parsed by the scene loader, so
//! `isomarch render 1tii.pdb` and `isomarch scene 1tii.pdb -o s.ron` followed
//! by `isomarch render s.ron` render the same scene.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use anyhow::{Result, bail};
use glam::DVec3;

use std::sync::Arc;

use super::color::{self, Legend, Palette, Range, Values};
use super::select::{self, Selection};
use super::{Atom, Molecule, elements};
use crate::scene::Scene;

/// Default sharpness s of the atoms' Gaussians `e^{-s d²/r²}`. dynamol's
/// default is 1 and QuickSurf's equivalent about 0.7; both fuse a protein
/// into a smooth skin. 2 keeps side chains and grooves readable at the
/// scale of a protein while still blending bonded and touching atoms, and
/// it keeps the spatial index's clipping radius near 3 r (5 Å for carbon).
pub const SHARPNESS: f64 = 2.0;
/// Default factor on the van der Waals radii.
pub const RADIUS_SCALE: f64 = 1.0;
/// Default iso value (with the weight e^s, a lone atom's surface at r).
pub const ISO: f64 = 1.0;
/// Default marcher, minimum step (Å; the paper's 0.1 scene units) and
/// step budget of molecule scenes.
pub const METHOD: &str = "quadratic-taylor";
pub const MIN_STEP: f64 = 0.1;
pub const MAX_STEPS: u32 = 1000;
/// The image of a molecule scene: the paper's Table 2 size.
pub const RESOLUTION: (u32, u32) = (750, 750);
/// The camera's vertical field of view, degrees.
pub const FOV_Y: f64 = 30.0;

/// How atoms are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Coloring {
    /// By element (Jmol's CPK colours).
    Element,
    /// By chain (Tableau 10, in the order chains appear; GRO files: a
    /// chain ends where residue numbers start again).
    Chain,
    /// By B-factor (temperature factor; AlphaFold's pLDDT), through
    /// `--palette` over `--range`.
    Bfactor,
    /// By occupancy, through `--palette` over `--range`.
    Occupancy,
    /// By residue class (VMD's ResType): nonpolar white, polar green,
    /// acidic red, basic blue; other residues by element.
    Restype,
    /// By residue name (Jmol's shapely colours for amino acids and
    /// nucleotides); other residues by element.
    Resname,
    /// By the values of `--color-values FILE` (or Python's `values=`),
    /// through `--palette` over `--range`.
    Values,
    /// One colour for the whole surface (the scene's `surface`).
    None,
}

impl Coloring {
    /// The per-atom value it colours by, through a palette, if any.
    pub fn value(self) -> Option<fn(&super::Atom) -> f64> {
        match self {
            Coloring::Bfactor => Some(|a| a.beta),
            Coloring::Occupancy => Some(|a| a.occupancy),
            Coloring::Values => Some(|_| f64::NAN),
            _ => None,
        }
    }

    /// Its name on the command line.
    pub fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self).map_or_else(String::new, |v| v.get_name().to_string())
    }

    /// What the scene file's comment says it colours by.
    fn describe(self) -> &'static str {
        match self {
            Coloring::Element => "element (Jmol)",
            Coloring::Chain => "chain",
            Coloring::Bfactor => "B-factor",
            Coloring::Values => "values given",
            Coloring::Occupancy => "occupancy",
            Coloring::Restype => "residue class (VMD ResType)",
            Coloring::Resname => "residue name (Jmol shapely)",
            Coloring::None => "nothing (surface)",
        }
    }
}

/// How the atoms drawn make surfaces (`--surfaces`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Surfaces {
    /// One surface: every atom in one sum, so touching chains melt into
    /// each other.
    #[default]
    One,
    /// A surface per chain: each chain its own sum, the chains combined by
    /// max, so that they meet with a seam.
    PerChain,
}

/// How a molecule becomes a scene; every field has a command-line flag.
#[derive(Clone, Debug, PartialEq)]
pub struct MoleculeOptions {
    /// The atoms drawn; `None`: [`select::DEFAULT`], all but water and
    /// ions.
    pub select: Option<Selection>,
    /// Values to colour by (`Coloring::Values`), shared by every frame.
    pub values: Option<Arc<Values>>,
    /// One surface or one per chain.
    pub surfaces: Surfaces,
    /// Selections whose atoms make surfaces of their own (`--apart`), in
    /// order; an atom goes to the first that picks it.
    pub apart: Vec<Selection>,
    /// Keep hydrogen atoms (left out by default: most crystal structures
    /// have none, and in those that do they hide under their heavy atoms).
    pub hydrogens: bool,
    pub sharpness: f64,
    pub radius_scale: f64,
    pub iso: f64,
    pub coloring: Coloring,
    /// The palette of colourings by value; `None`: viridis.
    pub palette: Option<Palette>,
    /// The values at the palette's ends; `None`: the least and greatest
    /// of the atoms drawn (values given: of every value given, so that a
    /// colour means one value in every frame).
    pub range: Option<Range>,
    /// Seconds per turn of a turntable camera (an orbit about the
    /// vertical axis through the molecule's centre); `None`: still.
    pub turntable: Option<f64>,
}

impl Default for MoleculeOptions {
    fn default() -> Self {
        MoleculeOptions {
            select: None,
            values: None,
            surfaces: Surfaces::One,
            apart: Vec::new(),
            hydrogens: false,
            sharpness: SHARPNESS,
            radius_scale: RADIUS_SCALE,
            iso: ISO,
            coloring: Coloring::Element,
            palette: None,
            range: None,
            turntable: None,
        }
    }
}

/// Molecule options as a user gives them (the command line's flags,
/// Python's keywords): each one left out takes its default.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MoleculeChoices {
    pub select: Option<Selection>,
    pub values: Option<Arc<Values>>,
    pub surfaces: Option<Surfaces>,
    pub apart: Vec<Selection>,
    pub hydrogens: Option<bool>,
    pub sharpness: Option<f64>,
    pub radius_scale: Option<f64>,
    pub iso: Option<f64>,
    pub coloring: Option<Coloring>,
    pub palette: Option<Palette>,
    pub range: Option<Range>,
    pub turntable: Option<f64>,
}

impl MoleculeChoices {
    /// The options, the default where a choice was left out (not checked:
    /// [`MoleculeOptions::check`]).
    pub fn resolve(&self) -> MoleculeOptions {
        let d = MoleculeOptions::default();
        MoleculeOptions {
            select: self.select.clone(),
            values: self.values.clone(),
            surfaces: self.surfaces.unwrap_or(d.surfaces),
            apart: self.apart.clone(),
            hydrogens: self.hydrogens.unwrap_or(d.hydrogens),
            sharpness: self.sharpness.unwrap_or(d.sharpness),
            radius_scale: self.radius_scale.unwrap_or(d.radius_scale),
            iso: self.iso.unwrap_or(d.iso),
            // Values given colour by themselves unless told otherwise.
            coloring: self.coloring.unwrap_or(if self.values.is_some() { Coloring::Values } else { d.coloring }),
            palette: self.palette.or(d.palette),
            range: self.range.or(d.range),
            turntable: self.turntable.or(d.turntable),
        }
    }

    /// The options, checked.
    pub fn options(&self) -> Result<MoleculeOptions> {
        let o = self.resolve();
        o.check()?;
        Ok(o)
    }

    /// The command-line flags of the choices made (`hydrogens: Some(false)`
    /// counts as made).
    pub fn flags(&self) -> Vec<&'static str> {
        [
            (self.select.is_some(), "--select"),
            (self.values.is_some(), "--color-values"),
            (self.surfaces.is_some(), "--surfaces"),
            (!self.apart.is_empty(), "--apart"),
            (self.hydrogens.is_some(), "--hydrogens"),
            (self.sharpness.is_some(), "--sharpness"),
            (self.radius_scale.is_some(), "--radius-scale"),
            (self.iso.is_some(), "--iso"),
            (self.coloring.is_some(), "--color"),
            (self.palette.is_some(), "--palette"),
            (self.range.is_some(), "--range"),
            (self.turntable.is_some(), "--turntable"),
        ]
        .into_iter()
        .filter_map(|(given, flag)| given.then_some(flag))
        .collect()
    }
}

impl MoleculeOptions {
    /// The selection of the atoms drawn.
    pub fn selection(&self) -> Selection {
        self.select.clone().unwrap_or_else(|| select::DEFAULT.parse().expect("the default selection parses"))
    }

    /// One-line errors for values out of range.
    pub fn check(&self) -> Result<()> {
        if self.values.is_some() && self.coloring != Coloring::Values {
            bail!("--color-values colours by its values: --color {} cannot be given with it", self.coloring.name());
        }
        if !(self.sharpness.is_finite() && self.sharpness > 0.0 && self.sharpness <= 80.0) {
            bail!("--sharpness must be in (0, 80] (the GPU's f32 holds e^s up to about s = 80), got {}", self.sharpness);
        }
        if !(self.radius_scale.is_finite() && self.radius_scale > 0.0) {
            bail!("--radius-scale must be positive, got {}", self.radius_scale);
        }
        if !(self.iso.is_finite() && self.iso > 0.0) {
            bail!("--iso must be positive, got {}", self.iso);
        }
        if let Some(t) = self.turntable
            && !(t.is_finite() && t > 0.0)
        {
            bail!("--turntable must be a positive number of seconds per turn, got {t}");
        }
        if (self.palette.is_some() || self.range.is_some()) && self.coloring.value().is_none() {
            let flag = if self.palette.is_some() { "--palette" } else { "--range" };
            bail!("{flag} applies to colourings by value (--color bfactor, occupancy or --color-values), not to --color {}", self.coloring.name());
        }
        if let Some(r) = self.range
            && !(r.min.is_finite() && r.max.is_finite() && r.min < r.max)
        {
            bail!("--range MIN:MAX needs finite numbers with MIN below MAX, got {r}");
        }
        Ok(())
    }
}

/// What building the scene found worth saying: one line each.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Notes {
    /// Warnings (elements without a radius).
    pub warnings: Vec<String>,
    /// A summary line: atoms used and left out.
    pub summary: String,
    /// The colour key of a colouring by value.
    pub legend: Option<Legend>,
}

/// A number rounded to six decimals, trailing zeros dropped (one kept
/// after the point, as RON floats need), no negative zero.
pub(crate) fn num(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0');
    let s = if s.ends_with('.') { format!("{s}0") } else { s.to_string() };
    if s == "-0.0" { "0.0".into() } else { s }
}

fn vec3(p: DVec3) -> String {
    format!("({}, {}, {})", num(p.x), num(p.y), num(p.z))
}

/// The scene of `m` as RON text, with what is worth telling the user.
pub fn scene_text(m: &Molecule, o: &MoleculeOptions) -> Result<(String, Notes)> {
    staged_text(m, o, Stage::default())
}

/// What a trajectory's frame brings to [`staged_text`]: the camera kept
/// from the first frame, a comment line, its index (for values per frame)
/// and the atoms chosen once, on the first frame, so that a selection by
/// distance draws the same atoms in every frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stage<'a> {
    /// The camera's framing; `None`: framed on the molecule itself.
    pub framing: Option<Framing>,
    /// A comment line after the first, or empty.
    pub note: &'a str,
    pub frame: usize,
    /// What the selections pick, made on the first frame; `None`: made
    /// of this molecule.
    pub picks: Option<&'a Picks>,
}

/// Where the camera looks and how much it must hold: the sphere about
/// `center` of radius `reach` (Å).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    pub center: DVec3,
    pub reach: f64,
}

impl Framing {
    /// The sphere about the centre of the balls' bounding box that holds
    /// every ball whole.
    pub fn of(balls: &[Ball]) -> Framing {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for b in balls {
            lo = lo.min(b.center);
            hi = hi.max(b.center);
        }
        let center = 0.5 * (lo + hi);
        let reach = balls.iter().map(|b| (b.center - center).length() + b.radius).fold(0.0, f64::max);
        Framing { center, reach }
    }
}

/// The balls `m` is drawn with under `o` (see [`kept`]).
pub fn balls_of(m: &Molecule, o: &MoleculeOptions, picks: Option<&Picks>) -> Result<Vec<Ball>> {
    let k = kept(m, o, picks)?;
    Ok(k.atoms.iter().zip(&k.groups).map(|(a, &group)| Ball { center: a.position, radius: radius(&a.element, o), color: None, group }).collect())
}

/// The sites of the atoms drawn, in the order of the scene's primitives.
pub(crate) fn kept_sites(m: &Molecule, o: &MoleculeOptions, picks: Option<&Picks>) -> Result<Vec<usize>> {
    Ok(kept(m, o, picks)?.atoms.iter().map(|a| a.site).collect())
}

/// What the selections pick of a molecule's atoms, one entry per atom:
/// whether it is drawn, and which `--apart` surface takes it. Made once
/// on a trajectory's first frame, so that selections by distance pick the
/// same atoms in every frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Picks {
    pub chosen: Vec<bool>,
    pub apart: Vec<Option<usize>>,
}

impl Picks {
    pub fn of(m: &Molecule, o: &MoleculeOptions) -> Picks {
        let chosen = o.selection().matches(&m.atoms);
        let mut apart = vec![None; m.atoms.len()];
        for (k, s) in o.apart.iter().enumerate() {
            for (slot, hit) in apart.iter_mut().zip(s.matches(&m.atoms)) {
                if hit && slot.is_none() {
                    *slot = Some(k);
                }
            }
        }
        Picks { chosen, apart }
    }
}

/// The atoms drawn, in the order of the scene's primitives (group by
/// group), their groups, and how many were left out and why.
pub(crate) struct Kept<'a> {
    pub atoms: Vec<&'a Atom>,
    /// Each atom's group (its surface).
    pub groups: Vec<usize>,
    /// Each atom's place among the atoms drawn in file order (values given
    /// per atom drawn are in that order).
    pub drawn: Vec<usize>,
    /// Selected hydrogens left out (no `--hydrogens`).
    pub hydrogens: usize,
    /// Atoms the selection left out.
    pub unselected: usize,
}

/// The atoms drawn: those the selection picks (`chosen`, else the
/// options' selection, by default every atom but water and ions), of
/// which hydrogens are left out unless asked for. A selection of no atoms
/// is an error, as is one of hydrogens alone without `--hydrogens`.
pub(crate) fn kept<'a>(m: &'a Molecule, o: &MoleculeOptions, picks: Option<&Picks>) -> Result<Kept<'a>> {
    let evaluated;
    let picks = match picks {
        Some(p) => p,
        None => {
            evaluated = Picks::of(m, o);
            &evaluated
        }
    };
    let selected: Vec<(&Atom, Option<usize>)> =
        m.atoms.iter().zip(&picks.chosen).zip(&picks.apart).filter_map(|((a, &c), &apart)| c.then_some((a, apart))).collect();
    if selected.is_empty() {
        bail!("{}: the selection '{}' picks none of its {} atoms", m.source, o.selection(), m.atoms.len());
    }
    let unselected = m.atoms.len() - selected.len();
    let drawn: Vec<(&Atom, Option<usize>)> =
        selected.iter().copied().filter(|(a, _)| o.hydrogens || !matches!(a.element.as_str(), "H" | "D")).collect();
    if drawn.is_empty() {
        bail!("{}: all {} atoms selected are hydrogens, which are left out unless --hydrogens is given", m.source, selected.len());
    }
    // Groups: the main surface (one, or a chain each in order of
    // appearance), then each `--apart` surface.
    let mut chains: Vec<&str> = Vec::new();
    if o.surfaces == Surfaces::PerChain {
        for (a, _) in drawn.iter().filter(|(_, apart)| apart.is_none()) {
            if !chains.contains(&a.chain.as_str()) {
                chains.push(&a.chain);
            }
        }
    }
    let main = chains.len().max(usize::from(drawn.iter().any(|(_, apart)| apart.is_none())));
    let mut used = vec![false; o.apart.len()];
    let mut grouped: Vec<(usize, usize, &Atom)> = drawn
        .iter()
        .enumerate()
        .map(|(k, &(a, apart))| match apart {
            Some(s) => {
                used[s] = true;
                (main + s, k, a)
            }
            None => (chains.iter().position(|c| *c == a.chain).unwrap_or(0), k, a),
        })
        .collect();
    if let Some(k) = used.iter().position(|u| !u) {
        bail!("{}: --apart '{}' picks none of the atoms drawn (or an earlier --apart took them all)", m.source, o.apart[k]);
    }
    // Every group holds an atom, so the numbers have no gaps.
    grouped.sort_by_key(|(g, _, _)| *g);
    let groups = grouped.iter().map(|(g, _, _)| *g).collect();
    let order = grouped.iter().map(|(_, k, _)| *k).collect();
    let atoms: Vec<&Atom> = grouped.into_iter().map(|(_, _, a)| a).collect();
    Ok(Kept { hydrogens: selected.len() - atoms.len(), unselected, atoms, groups, drawn: order })
}

/// An element's radius as drawn (Bondi's, or the fallback, times the scale).
fn radius(symbol: &str, o: &MoleculeOptions) -> f64 {
    elements::radius(symbol).unwrap_or(elements::FALLBACK_RADIUS) * o.radius_scale
}

/// [`scene_text`] of a trajectory's frame (see [`Stage`]).
pub fn staged_text(m: &Molecule, o: &MoleculeOptions, stage: Stage) -> Result<(String, Notes)> {
    let Stage { framing, note, frame, picks } = stage;
    o.check()?;
    let Kept { atoms, groups, drawn, hydrogens, unselected } = kept(m, o, picks)?;
    // Elements without a Bondi radius: one warning naming each with its
    // first line and count.
    let mut unknown: BTreeMap<&str, (usize, usize)> = BTreeMap::new();
    for a in &atoms {
        if elements::radius(&a.element).is_none() {
            let e = unknown.entry(if a.element.is_empty() { "(blank)" } else { a.element.as_str() }).or_insert((a.line, 0));
            e.1 += 1;
        }
    }
    let mut notes = Notes::default();
    if !unknown.is_empty() {
        let list: Vec<String> =
            unknown.iter().map(|(e, (line, n))| format!("{e} ({n} atom{}, first at line {line})", if *n == 1 { "" } else { "s" })).collect();
        notes.warnings.push(format!(
            "{}: no van der Waals radius for {}: drawn with the fallback radius {} Å",
            m.source,
            list.join(", "),
            elements::FALLBACK_RADIUS
        ));
    }
    // Chains in order of appearance, for chain colours.
    let mut chains: Vec<&str> = Vec::new();
    for a in &atoms {
        if !chains.contains(&a.chain.as_str()) {
            chains.push(&a.chain);
        }
    }
    // Colourings by value: the range given, else the values' own (all
    // frames' for values given per frame).
    let given: Option<Vec<f64>> = match (&o.values, o.coloring) {
        (Some(values), Coloring::Values) => Some(values_drawn(values, frame, m, &atoms, &drawn)?),
        (None, Coloring::Values) => bail!("--color values colours by the values of --color-values FILE, which was not given"),
        _ => None,
    };
    let value_of = |i: usize, a: &Atom| given.as_ref().map_or_else(|| o.coloring.value().map_or(0.0, |v| v(a)), |g| g[i]);
    let own = || match &o.values {
        Some(v) if o.coloring == Coloring::Values => Some(v.range()),
        _ => Range::of(atoms.iter().enumerate().map(|(i, a)| value_of(i, a))),
    };
    let range = o.range.or_else(own).unwrap_or(Range { min: 0.0, max: 1.0 });
    let palette = o.palette.unwrap_or_default();
    let color = |i: usize, a: &Atom| -> Option<[f64; 3]> {
        match o.coloring {
            Coloring::Element => Some(elements::color(&a.element)),
            Coloring::Chain => {
                let i = chains.iter().position(|c| *c == a.chain).unwrap_or(0);
                let c = colorous::TABLEAU10[i % colorous::TABLEAU10.len()];
                Some([elements::linear(c.r), elements::linear(c.g), elements::linear(c.b)])
            }
            Coloring::Bfactor | Coloring::Occupancy | Coloring::Values => Some(palette.color(value_of(i, a), range)),
            Coloring::Restype => Some(color::restype(&a.resname).unwrap_or_else(|| elements::color(&a.element))),
            Coloring::Resname => Some(color::shapely(&a.resname).unwrap_or_else(|| elements::color(&a.element))),
            Coloring::None => None,
        }
    };
    let balls: Vec<Ball> = atoms
        .iter()
        .zip(&groups)
        .enumerate()
        .map(|(i, (a, &group))| Ball { center: a.position, radius: radius(&a.element, o), color: color(i, a), group })
        .collect();
    let mut left_out = Vec::new();
    if unselected > 0 {
        left_out.push(match &o.select {
            None => format!("{unselected} water and ion atoms left out: --select all keeps them"),
            Some(s) => format!("{unselected} not selected by '{s}'"),
        });
    }
    if hydrogens > 0 {
        left_out.push(format!("{hydrogens} hydrogens left out"));
    }
    if o.coloring.value().is_some() {
        let label = match (&o.values, o.coloring) {
            (Some(v), Coloring::Values) => std::path::Path::new(&v.source).file_stem().map_or(v.source.clone(), |s| s.to_string_lossy().into_owned()),
            (_, Coloring::Occupancy) => "occupancy".into(),
            _ if palette == Palette::Alphafold => "pLDDT".into(),
            _ => "B-factor".into(),
        };
        notes.legend = Some(Legend { palette, range, label });
    }
    notes.summary = format!(
        "{}: {} atoms{}{}{}, {} chain{}",
        m.source,
        atoms.len(),
        if left_out.is_empty() { String::new() } else { format!(" ({})", left_out.join("; ")) },
        m.skipped_sites.map_or(String::new(), |(n, line)| format!(", {n} dummy or virtual sites skipped (first at line {line})")),
        if m.extra_models > 0 { format!(", first model only ({} more left out)", m.extra_models) } else { String::new() },
        chains.len(),
        if chains.len() == 1 { "" } else { "s" },
    );

    let made_by = format!(
        "// Made by isomarch from {} (src/molecule/build.rs, docs/molecules.md).\n\
         // {}{} atoms, one Gaussian each: r = {} x Bondi's van der Waals radius, s = {}, weight e^s; iso {}; colours by {}.",
        m.source,
        if note.is_empty() { String::new() } else { format!("{note}\n// ") },
        atoms.len(),
        num(o.radius_scale),
        num(o.sharpness),
        num(o.iso),
        match o.coloring.value() {
            Some(_) if palette.uses_range() => format!("{} ({palette:?} palette over {range})", o.coloring.describe()),
            Some(_) => format!("{} ({palette:?} palette)", o.coloring.describe()),
            None => o.coloring.describe().to_string(),
        }
    );
    Ok((framed_text(&made_by, &balls, o, framing.unwrap_or_else(|| Framing::of(&balls))), notes))
}

/// The values of the atoms drawn at `frame` (in the scene's order, group
/// by group; `drawn` their places in file order): a row holds one value per
/// atom of the file (by site) or one per atom drawn (in file order).
fn values_drawn(values: &Values, frame: usize, m: &Molecule, atoms: &[&Atom], drawn: &[usize]) -> Result<Vec<f64>> {
    let row = values.row(frame)?;
    if row.len() == m.sites {
        Ok(atoms.iter().map(|a| row[a.site]).collect())
    } else if row.len() == atoms.len() {
        Ok(drawn.iter().map(|&k| row[k]).collect())
    } else {
        bail!(
            "{}: {} values per frame, but {} has {} atoms, {} of them drawn: give one value per atom of the file or per atom drawn",
            values.source,
            row.len(),
            m.source,
            m.sites,
            atoms.len()
        )
    }
}

/// The scene text `text` (as [`framed_text`] writes it) with `camera`
/// written whole (every digit, so the file's camera is the one given, bit
/// for bit) and `background` (the view flags of `isomarch scene`); the
/// camera's path stays where `keep_path` (a camera given whole drops it).
pub fn with_view(text: &str, camera: &crate::scene::Camera, background: DVec3, keep_path: bool) -> String {
    let mut out = String::with_capacity(text.len() + 256);
    let mut in_camera = false;
    for line in text.lines() {
        if line == "    camera: (" {
            in_camera = true;
            let _ = writeln!(out, "{line}");
            let block = camera.to_ron();
            let inner: Vec<&str> = block.lines().collect();
            for l in &inner[1..inner.len() - 1] {
                let _ = writeln!(out, "    {l}");
            }
            continue;
        }
        if in_camera {
            if line == "    )," {
                in_camera = false;
                let _ = writeln!(out, "{line}");
            } else if keep_path && line.trim_start().starts_with("path:") {
                let _ = writeln!(out, "{line}");
            }
            continue;
        }
        if line.starts_with("    background: ") {
            let _ = writeln!(out, "    background: ({:?}, {:?}, {:?}),", background.x, background.y, background.z);
            continue;
        }
        let _ = writeln!(out, "{line}");
    }
    out
}

/// One atom as drawn: its centre, its radius (Å, `radius_scale` applied)
/// and its colour (linear RGB; `None`: the scene's surface colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    pub center: DVec3,
    pub radius: f64,
    pub color: Option<[f64; 3]>,
    /// Its group (surface): balls come group by group.
    pub group: usize,
}

/// The scene of `balls` as RON text, after the comment lines `made_by`:
/// one Gaussian blob per ball (r its radius, s and iso from `o`), a camera
/// on +z framing them all, the molecule scenes' lights and marching.
pub fn balls_text(made_by: &str, balls: &[Ball], o: &MoleculeOptions) -> String {
    framed_text(made_by, balls, o, Framing::of(balls))
}

/// [`balls_text`] with the camera framing `framing`, with 5% to spare.
fn framed_text(made_by: &str, balls: &[Ball], o: &MoleculeOptions, framing: Framing) -> String {
    let Framing { center, reach } = framing;
    let distance = 1.05 * reach / (0.5 * FOV_Y.to_radians()).sin();
    let eye = center + DVec3::new(0.0, 0.0, distance);
    let weight = o.sharpness.exp();
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(s, "{made_by}");
    let _ = writeln!(s, "Scene(");
    let _ = writeln!(s, "    camera: (");
    let _ = writeln!(s, "        eye: {},", vec3(eye));
    let _ = writeln!(s, "        target: {},", vec3(center));
    let _ = writeln!(s, "        fov_y: {},", num(FOV_Y));
    let _ = writeln!(s, "        resolution: ({}, {}),", RESOLUTION.0, RESOLUTION.1);
    if let Some(t) = o.turntable {
        let _ = writeln!(s, "        path: Some(Orbit(period: {})),", num(t));
    }
    let _ = writeln!(s, "    ),");
    let _ = writeln!(s, "    background: (0.02, 0.025, 0.035),");
    let _ = writeln!(s, "    ambient: (0.2, 0.2, 0.22),");
    let _ = writeln!(s, "    surface: (0.75, 0.75, 0.72),");
    let _ = writeln!(s, "    lights: [");
    let _ = writeln!(s, "        (direction: (0.4, 0.8, 0.6), intensity: 0.8),");
    let _ = writeln!(s, "        (direction: (-0.6, 0.2, 0.3), color: (0.6, 0.7, 1.0), intensity: 0.3),");
    let _ = writeln!(s, "    ],");
    let _ = writeln!(s, "    iso: {},", num(o.iso));
    let _ = writeln!(s, "    marching: (method: {METHOD:?}, min_step: {}, max_steps: {MAX_STEPS}),", num(MIN_STEP));
    let _ = write!(s, "    groups: [(primitives: [");
    for (i, b) in balls.iter().enumerate() {
        if i > 0 && b.group != balls[i - 1].group {
            let _ = write!(s, "    ]), (primitives: [");
        }
        let _ = writeln!(s);
        let _ = write!(
            s,
            "        Point(center: {}, kernel: Gaussian(r: {}, s: {}, weight: Some({}))",
            vec3(b.center),
            num(b.radius),
            num(o.sharpness),
            num(weight)
        );
        if let Some(c) = b.color {
            let _ = write!(s, ", color: Some(({}, {}, {}))", num(c[0]), num(c[1]), num(c[2]));
        }
        let _ = write!(s, "),");
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "    ])],");
    let _ = writeln!(s, ")");
    s
}

/// The scene of atoms given as arrays (the Python package's
/// `Scene.from_atoms`): centres in Å, van der Waals radii (Å, before
/// `radius_scale`), colours in linear RGB or none (the surface colour).
/// The same scene as [`scene_text`] makes of a file with these atoms.
pub fn atoms_scene(centers: &[DVec3], radii: &[f64], colors: Option<&[[f64; 3]]>, o: &MoleculeOptions) -> Result<Scene> {
    o.check()?;
    if o.select.is_some() || o.values.is_some() || !o.apart.is_empty() || o.surfaces != Surfaces::One || o.palette.is_some() || o.range.is_some() {
        bail!("atoms given as arrays are drawn as given: select, values, palette, range, surfaces and apart apply to molecule files");
    }
    if centers.is_empty() {
        bail!("no atoms: positions is empty");
    }
    if radii.len() != centers.len() {
        bail!("{} positions but {} radii", centers.len(), radii.len());
    }
    if let Some(c) = colors
        && c.len() != centers.len()
    {
        bail!("{} positions but {} colors", centers.len(), c.len());
    }
    if let Some(i) = centers.iter().position(|c| !c.is_finite()) {
        bail!("position {i} is not finite: {:?}", centers[i].to_array());
    }
    if let Some(i) = radii.iter().position(|r| !(r.is_finite() && *r > 0.0)) {
        bail!("radius {i} must be positive, got {}", radii[i]);
    }
    if let Some((i, c)) = colors.and_then(|cs| cs.iter().enumerate().find(|(_, c)| !c.iter().all(|v| v.is_finite() && *v >= 0.0))) {
        bail!("color {i} must be finite and non-negative, got {c:?}");
    }
    let balls: Vec<Ball> =
        (0..centers.len()).map(|i| Ball { center: centers[i], radius: radii[i] * o.radius_scale, color: colors.map(|c| c[i]), group: 0 }).collect();
    let made_by = format!("// Made by isomarch from {} atoms given as arrays.", balls.len());
    Ok(Scene::parse(&balls_text(&made_by, &balls, o), "atoms")?)
}

/// The scene of the molecule file at `path` (see [`scene_text`]), its
/// molecules made whole where its box splits one, as the command line's
/// default `--pbc auto` does (the note among the warnings).
pub fn load_scene(path: &std::path::Path, o: &MoleculeOptions) -> Result<(Scene, Notes)> {
    let mut m = super::read(path)?;
    let note = super::pbc::make_molecule_whole(&mut m, super::pbc::Pbc::Auto, None)?;
    let (scene, mut notes) = scene_of(&m, o)?;
    notes.warnings.extend(note);
    Ok((scene, notes))
}

/// The scene of a molecule read (see [`scene_text`]).
pub fn scene_of(m: &Molecule, o: &MoleculeOptions) -> Result<(Scene, Notes)> {
    let (text, notes) = scene_text(m, o)?;
    let scene = Scene::parse(&text, &m.source)?;
    Ok((scene, notes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::molecule::Atom;

    fn molecule(elements: &[&str]) -> Molecule {
        let atoms = elements
            .iter()
            .enumerate()
            .map(|(i, e)| Atom {
                element: e.to_string(),
                position: DVec3::new(3.0 * i as f64, 0.0, 0.0),
                chain: "A".into(),
                line: i + 10,
                site: i,
                ..Default::default()
            })
            .collect();
        Molecule { source: "m.pdb".into(), atoms, skipped_sites: None, extra_models: 0, sites: elements.len(), cell: None, bonds: Vec::new() }
    }

    #[test]
    fn one_gaussian_per_heavy_atom_with_bondi_radii() {
        let (text, notes) = scene_text(&molecule(&["C", "H", "O", "Fe", "Xx", "Fe"]), &MoleculeOptions::default()).unwrap();
        let scene = Scene::parse(&text, "m").unwrap();
        assert_eq!(scene.primitive_count(), 5);
        assert_eq!(scene.min_radius(), 1.52);
        assert_eq!(notes.warnings.len(), 1, "one warning for every unknown element");
        assert_eq!(
            notes.warnings[0],
            "m.pdb: no van der Waals radius for Fe (2 atoms, first at line 13), Xx (1 atom, first at line 14): drawn with the fallback radius 1.8 Å"
        );
        let with_h = scene_text(&molecule(&["C", "H"]), &MoleculeOptions { hydrogens: true, ..Default::default() }).unwrap().0;
        assert_eq!(Scene::parse(&with_h, "m").unwrap().primitive_count(), 2);
        assert!(scene.colors.is_some());
    }

    #[test]
    fn a_lone_atom_surface_sits_at_its_radius_at_iso_one() {
        let (text, _) = scene_text(&molecule(&["N"]), &MoleculeOptions::default()).unwrap();
        let scene = Scene::parse(&text, "m").unwrap();
        let field = crate::field::Field::new(&scene);
        assert!(field.value(DVec3::new(1.55, 0.0, 0.0)).abs() < 1e-5);
    }

    #[test]
    fn options_out_of_range_are_refused() {
        for o in [
            MoleculeOptions { sharpness: 0.0, ..Default::default() },
            MoleculeOptions { sharpness: 100.0, ..Default::default() },
            MoleculeOptions { radius_scale: -1.0, ..Default::default() },
            MoleculeOptions { iso: f64::NAN, ..Default::default() },
            MoleculeOptions { turntable: Some(0.0), ..Default::default() },
        ] {
            assert!(o.check().is_err(), "{o:?}");
        }
        assert!(scene_text(&molecule(&["H"]), &MoleculeOptions::default()).is_err());
    }
}
