//! The flags that several commands share, each group one struct that
//! turns itself into the library's values: the molecule options, a
//! trajectory's frame and framing, the device, and the marching overrides.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Result;
use clap::Args;

use isomarch::checks;
use isomarch::gpu::{Context, ContextOptions};
use isomarch::method::Method;
use isomarch::molecule::pbc::Pbc;
use isomarch::molecule::playback::FramingRule;
use isomarch::molecule::{MoleculeChoices, MoleculeOptions};
use isomarch::open::{Adjust, Input, Source};
use isomarch::scene::Scene;

/// How a molecule file becomes a scene (docs/molecules.md). These apply
/// to molecule files only (.pdb, .ent, .cif, .mmcif, .gro, each optionally
/// .gz); a scene file given with one is refused.
#[derive(Args)]
pub struct MoleculeArgs {
    /// The atoms drawn, in VMD's selection language: `protein`, `chain A
    /// and resid 10 to 50`, `not water`, `within 5 of resname HEM`
    /// (docs/molecules.md) [default: not (water or ion)].
    #[arg(long, value_name = "EXPR")]
    pub select: Option<String>,
    /// One surface for all the atoms drawn, or one per chain (chains
    /// combined by max: they meet with a seam instead of melting
    /// together) [default: one].
    #[arg(long, value_enum)]
    pub surfaces: Option<isomarch::molecule::build::Surfaces>,
    /// A surface of its own for the atoms EXPR selects, e.g. a ligand apart
    /// from its protein (repeatable; an atom goes to the first that picks it).
    #[arg(long, value_name = "EXPR")]
    pub apart: Vec<String>,
    /// Keep hydrogen atoms (left out by default).
    #[arg(long)]
    pub hydrogens: bool,
    /// Sharpness s of each atom's Gaussian e^(-s d^2/r^2) [default: 2].
    #[arg(long, value_name = "S")]
    pub sharpness: Option<f64>,
    /// Factor on the van der Waals radii (Bondi 1964) [default: 1].
    #[arg(long, value_name = "K")]
    pub radius_scale: Option<f64>,
    /// Iso value; with each atom's weight e^s, 1 puts a lone atom's
    /// surface at its radius, more shrinks the surface [default: 1].
    #[arg(long)]
    pub iso: Option<f64>,
    /// Colour atoms by element (Jmol CPK colours), chain, B-factor or
    /// occupancy (through --palette over --range), residue class or name,
    /// or not at all [default: element].
    #[arg(long, value_enum)]
    pub color: Option<isomarch::molecule::Coloring>,
    /// The palette of --color bfactor and occupancy [default: viridis].
    #[arg(long, value_enum)]
    pub palette: Option<isomarch::molecule::color::Palette>,
    /// The values at the palette's ends, MIN:MAX [default: the least and
    /// greatest of the atoms drawn; with --color-values, of every value
    /// the file holds, all atoms and frames].
    #[arg(long, value_name = "MIN:MAX", allow_hyphen_values = true)]
    pub range: Option<String>,
    /// Colour atoms by values from a CSV file: one value per atom (of the
    /// file, or of the atoms drawn), on one line or one per line, or one
    /// line per frame of a trajectory.
    #[arg(long, value_name = "FILE")]
    pub color_values: Option<std::path::PathBuf>,
    /// Turntable: the camera circles the molecule once per SECONDS of
    /// scene time (the viewer plays it; `render --frames` renders it).
    #[arg(long, value_name = "SECONDS")]
    pub turntable: Option<f64>,
}

impl MoleculeArgs {
    /// The choices made: `--hydrogens` absent is no choice. The
    /// selection, range and values file are read here, each problem one
    /// line.
    fn choices(&self) -> Result<MoleculeChoices> {
        let select = self.select.as_deref().map(|s| s.parse().map_err(|e| anyhow::anyhow!("--select: {e}"))).transpose()?;
        let range = self.range.as_deref().map(isomarch::molecule::color::Range::parse).transpose()?;
        let values = self.color_values.as_deref().map(isomarch::molecule::color::Values::read).transpose()?.map(Arc::new);
        let apart = self.apart.iter().map(|s| s.parse().map_err(|e| anyhow::anyhow!("--apart: {e}"))).collect::<Result<Vec<_>>>()?;
        Ok(MoleculeChoices {
            select,
            values,
            surfaces: self.surfaces,
            apart,
            hydrogens: self.hydrogens.then_some(true),
            sharpness: self.sharpness,
            radius_scale: self.radius_scale,
            iso: self.iso,
            coloring: self.color,
            palette: self.palette,
            range,
            turntable: self.turntable,
        })
    }

    /// The options, defaults where not given (checked where they are used).
    pub fn options(&self) -> Result<MoleculeOptions> {
        Ok(self.choices()?.resolve())
    }

    /// The input files of a command, read with these options, `play`'s
    /// frame and framing.
    pub fn source<'a>(&self, path: &'a Path, trajectory: Option<&'a Path>, play: &PlayArgs) -> Result<Source<'a>> {
        let choices = self.choices()?;
        let mut molecule_flags = choices.flags();
        // A scene file has no periodic box: --pbc, even `auto`, is refused
        // with it, as the other molecule flags are.
        if play.pbc.is_some() {
            molecule_flags.push("--pbc");
        }
        Ok(Source {
            path,
            trajectory,
            molecule: choices.resolve(),
            molecule_flags,
            frame: play.frame,
            framing: play.framing,
            pbc: play.pbc.unwrap_or_default(),
            interpolate: play.interpolate,
        })
    }
}

/// The flags of a trajectory (or a file of several models).
#[derive(Args)]
pub struct PlayArgs {
    /// The frame to render, benchmark or write, of a trajectory or a
    /// multi-model file [default: 0].
    #[arg(long, value_name = "N")]
    pub frame: Option<usize>,
    /// Where a trajectory's camera looks, for every frame: at the first
    /// frame's atoms, or at every frame's (one pass over the trajectory first).
    #[arg(long, value_enum, default_value_t)]
    pub framing: FramingRule,
    /// Molecules split by the periodic box: made whole (each molecule's
    /// atoms moved by whole box vectors, bonds guessed by residue and
    /// distance or taken from a PSF; kept from jumping between frames),
    /// also centred (the centre of the atoms drawn in the box's centre),
    /// or left as the file has them. Auto: whole where the file gives a
    /// box (GRO, XTC, DCD with unit cells, PDB CRYST1, mmCIF _cell) and a
    /// molecule of the first frame is split by it, with a note on stderr;
    /// else none. Molecules only: refused with a scene file [default:
    /// auto].
    #[arg(long, value_enum)]
    pub pbc: Option<Pbc>,
    /// Make K frames between each pair of saved trajectory frames, the
    /// atoms' positions interpolated linearly (the short way across the
    /// periodic box): N saved frames become (N-1)(K+1)+1, and frame r lies
    /// (r mod (K+1))/(K+1) of the way from saved frame r/(K+1) to the next.
    #[arg(long, value_name = "K", default_value_t = 0)]
    pub interpolate: usize,
}

/// The device flags of every command that uses the GPU.
#[derive(Args)]
pub struct GpuArgs {
    /// Vulkan device: index or name substring from `isomarch info` (default: discrete, then integrated, then CPU).
    #[arg(long)]
    pub device: Option<String>,
    /// Give up when the GPU has not finished within this many seconds.
    #[arg(long, default_value_t = 600.0, value_name = "SECONDS")]
    pub timeout: f64,
    /// Enable the Vulkan validation layer (also ISOMARCH_VALIDATION=1).
    #[arg(long)]
    pub validation: bool,
}

/// A command's device, opened without a window, and its `--timeout`.
pub struct Session {
    pub ctx: Arc<Context>,
    pub timeout: Duration,
}

impl GpuArgs {
    /// `--timeout`, checked.
    pub fn timeout(&self) -> Result<Duration> {
        checks::timeout(self.timeout)
    }

    /// Opens the device for a command that renders offscreen; end with
    /// [`finish`].
    pub fn open(&self) -> Result<Session> {
        let timeout = self.timeout()?;
        let ctx = Context::new(&ContextOptions { validation: self.validation, device: self.device.clone(), present: None })?;
        Ok(Session { ctx, timeout })
    }
}

/// The marching flags of `render`, `view` and `bench`: overrides of the
/// scene file's `marching` section.
#[derive(Args, Clone)]
pub struct MarchArgs {
    /// Marcher (default: the scene's marching.method).
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Override the scene's minimum step (scene units).
    #[arg(long)]
    pub min_step: Option<f64>,
    /// Override the scene's step budget per ray.
    #[arg(long)]
    pub max_steps: Option<u32>,
    /// Interval growth k of Algorithm 1 (next interval = k x last step);
    /// default: the scene's, else 1.5 for segment, 3 for linear-taylor,
    /// 2 for the other methods.
    #[arg(long, value_name = "K")]
    pub growth: Option<f64>,
    /// How a crossing is narrowed to the refinement tolerance (default:
    /// the scene's marching.refine, else inclusion: the inclusion methods
    /// fold their own bound over the bracket, the others use secant;
    /// secant and bisection reproduce the figures measured before).
    #[arg(long, value_enum)]
    pub refine: Option<isomarch::settings::Refinement>,
    /// Shadows: from every shaded hit, a ray towards each light, marched
    /// with the same method until the surface crosses it (opaque scenes).
    #[arg(long)]
    pub shadows: bool,
    /// Ambient occlusion: N cosine-weighted rays over the hemisphere of
    /// every shaded hit, each looking --ao-distance far (opaque scenes).
    #[arg(long, value_name = "N")]
    pub ao: Option<u32>,
    /// How far occlusion rays look (scene units) [default: the scene's
    /// ao.distance, else 4 x the smallest primitive radius].
    #[arg(long, value_name = "D", requires = "ao")]
    pub ao_distance: Option<f64>,
    /// March the first crossing only, as if the scene had no
    /// `transparency` section (so that the opaque-only bisection
    /// baselines can run on a transparent or refractive scene).
    #[arg(long)]
    pub opaque: bool,
}

impl MarchArgs {
    /// Checks the overrides and writes them into `scene`'s marching
    /// settings.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(m) = self.method {
            scene.marching.method = m;
        }
        if let Some(s) = self.min_step {
            scene.marching.min_step = checks::min_step(s)?;
        }
        if let Some(n) = self.max_steps {
            scene.marching.max_steps = checks::max_steps(n)?;
        }
        if let Some(k) = self.growth {
            scene.marching.growth = Some(checks::growth(k)?);
        }
        if let Some(r) = self.refine {
            scene.marching.refine = r;
        }
        if self.opaque {
            scene.transparency = None;
        }
        if self.shadows {
            scene.shadows = true;
        }
        if let Some(n) = self.ao {
            let samples = checks::ao_samples(n)?;
            let distance = checks::ao_distance(self.ao_distance.or(scene.ao.map(|a| a.distance)).unwrap_or_else(|| scene.default_ao_distance()))?;
            scene.ao = Some(isomarch::scene::Ao { samples, distance });
        }
        Ok(())
    }
}

/// The flags of a command that opens a scene file, a molecule or a
/// trajectory and marches it on the device (`render`, `view`, `bench`):
/// how molecules become scenes, the marching overrides, the device.
#[derive(Args)]
pub struct SceneFlags {
    #[command(flatten)]
    pub molecule: MoleculeArgs,
    #[command(flatten)]
    pub march: MarchArgs,
    #[command(flatten)]
    pub view: ViewFlags,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

impl SceneFlags {
    /// Opens `path` (and `trajectory`) with these flags and `play`'s frame
    /// and framing: the marching overrides and the view applied to every
    /// scene opened.
    pub fn open(&self, path: &Path, trajectory: Option<&Path>, play: &PlayArgs) -> Result<Input> {
        let (march, view) = (self.march.clone(), self.view.clone());
        let adjust: Adjust = Arc::new(move |scene| {
            march.apply(scene)?;
            view.apply(scene)
        });
        self.molecule.source(path, trajectory, play)?.open(adjust)
    }
}

/// The view from the command line: turns of the camera about its target
/// (VTK's and ParaView's Azimuth, Elevation and Roll: the camera moves),
/// a zoom and a field of view, applied to the scene's camera.
#[derive(Args, Clone)]
pub struct ViewFlags {
    /// The camera whole, from a file holding a RON camera block (what the
    /// viewer's C key writes): eye, target, up, field of view, resolution,
    /// projection, clipping. A camera path of the scene is dropped: the
    /// view stays. The other view flags apply after it.
    #[arg(long, value_name = "FILE")]
    pub camera: Option<std::path::PathBuf>,
    /// Turn the camera about its target: AXIS:DEGREES with the view's axes,
    /// y (vertical: the eye moves right for positive degrees), x
    /// (horizontal: the eye rises), z (the view rolls counterclockwise).
    /// Repeatable; applied in the order given.
    #[arg(long, value_name = "AXIS:DEGREES")]
    pub turn: Vec<isomarch::scene::turn::Turn>,
    /// Move the eye this many times closer to the target (below 1: away).
    #[arg(long, value_name = "F")]
    pub zoom: Option<f64>,
    /// Vertical field of view, degrees (default: the scene's camera).
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f64>,
    /// Orthographic projection: parallel rays, a view HEIGHT scene units
    /// high (without a value: the height the perspective view has at the
    /// target, so the target's plane keeps its framing).
    #[arg(long, value_name = "HEIGHT", num_args = 0..=1)]
    pub ortho: Option<Option<f64>>,
    /// Clip the view: near:D (nothing nearer than D from the eye's plane
    /// along the view), far:D, or both (near:D,far:D). Cut faces are
    /// capped.
    #[arg(long, value_name = "near:D,far:D")]
    pub clip: Option<String>,
    /// The background: a colour name (white, black, navy), #rrggbb, or
    /// linear r,g,b in [0, 1] (default: the scene's).
    #[arg(long, value_name = "COLOR")]
    pub background: Option<String>,
}

impl ViewFlags {
    /// The library's view of these flags.
    pub fn view(&self) -> isomarch::look::View {
        isomarch::look::View {
            camera: self.camera.clone(),
            turns: self.turn.clone(),
            zoom: self.zoom,
            fov: self.fov,
            ortho: self.ortho,
            clip: self.clip.clone(),
            background: self.background.clone(),
        }
    }

    /// Whether no view flag was given.
    pub fn is_empty(&self) -> bool {
        self.view().is_empty()
    }

    /// Checks the view flags and applies them to `scene`.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        self.view().apply(scene)
    }
}
