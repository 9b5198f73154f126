//! What a command was given to render, opened: a scene file, one molecule,
//! or the frames of a trajectory (or of a file of several models), each
//! file read once. The command line's `render`, `view`, `bench` and
//! `scene` open their inputs here; the notes of a molecule's reading go to
//! stderr as they are made.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Result, bail};

use crate::molecule::color::Legend;
use crate::molecule::pbc::Pbc;
use crate::molecule::playback::{FramingRule, Stager};
use crate::molecule::{self, Molecule, MoleculeOptions};
use crate::scene::Scene;

/// Changes made to every scene opened (the command line's marching
/// overrides), checked as they are made.
pub type Adjust = Arc<dyn Fn(&mut Scene) -> Result<()> + Send + Sync>;

/// A command's input files and how to read them.
pub struct Source<'a> {
    /// A scene file, a molecule file, or a trajectory's topology.
    pub path: &'a Path,
    /// The topology's trajectory.
    pub trajectory: Option<&'a Path>,
    /// How molecules become scenes.
    pub molecule: MoleculeOptions,
    /// The flags that set `molecule`, named where a scene file is given
    /// with them (they apply to molecules only).
    pub molecule_flags: Vec<&'static str>,
    /// The frame asked for (`--frame`).
    pub frame: Option<usize>,
    /// Where a trajectory's camera looks.
    pub framing: FramingRule,
    /// What is done about the periodic box (`--pbc`).
    pub pbc: Pbc,
    /// Frames made between each pair of saved ones (`--interpolate`).
    pub interpolate: usize,
}

/// What the files hold, as read.
#[allow(clippy::large_enum_variant)] // one per command
pub enum Opened {
    /// Frames: a trajectory, or a file of several models or frames.
    Frames(Stager),
    /// One molecule, and when its reading started.
    Molecule(Molecule, Instant),
    /// A scene file (not read yet).
    SceneFile,
}

/// What a command renders: one scene, or the frames of a trajectory.
#[allow(clippy::large_enum_variant)] // one per command
pub enum Input {
    /// A scene, and the colour key of a molecule coloured by value.
    Still(Scene, Option<Legend>),
    Frames(Stager),
}

impl Source<'_> {
    /// What the files hold, each read once: frames where there is a
    /// trajectory or the molecule file holds more than one model or
    /// frame; `adjust` is applied to every frame's scene.
    pub fn read(&self, adjust: Adjust) -> Result<Opened> {
        let path = self.path;
        let started = Instant::now();
        let psf = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psf"));
        // A PSF alone goes to the trajectory reader, which says why not.
        if self.trajectory.is_none() && !psf {
            let single = if molecule::is_molecule(path) {
                let m = molecule::read(path)?;
                if m.extra_models > 0 { None } else { Some(Opened::Molecule(m, started)) }
            } else {
                Some(Opened::SceneFile)
            };
            if let Some(mut single) = single {
                if let Some(k) = self.frame.filter(|&k| k > 0) {
                    bail!("--frame {k}: {} holds one frame (frame 0)", path.display());
                }
                if self.interpolate > 0 {
                    bail!("--interpolate applies to trajectories and files of several models; {} holds one frame", path.display());
                }
                if self.framing != FramingRule::First {
                    bail!("--framing applies to trajectories and files of several models; {} holds one", path.display());
                }
                if let Opened::Molecule(m, _) = &mut single {
                    self.whole(m)?;
                }
                return Ok(single);
            }
        }
        let (mut t, note) = molecule::trajectory::open_with(path, self.trajectory, self.pbc)?;
        if let Some(note) = note {
            eprintln!("{note}");
        }
        t.set_interpolate(self.interpolate);
        let frames = t.len();
        let mut stager = Stager::new(t, self.molecule.clone(), self.framing)?.with_adjust(Box::new(move |s| adjust(s)));
        let (_, time, notes) = stager.text(0)?;
        for w in &notes.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("{}", notes.summary);
        let interpolated = match self.interpolate {
            0 => String::new(),
            k => format!(" ({} saved, {k} interpolated between each two)", stager.trajectory.saved_len()),
        };
        eprintln!(
            "{}: {frames} frame{}{interpolated}{}",
            stager.trajectory.source,
            if frames == 1 { "" } else { "s" },
            time.map_or(String::new(), |t| format!(", the first at {} ps", molecule::trajectory::ps(t)))
        );
        Ok(Opened::Frames(stager))
    }

    /// Opens the files: [`Source::read`], then one molecule's scene built
    /// or the scene file loaded, with `adjust` applied.
    pub fn open(&self, adjust: Adjust) -> Result<Input> {
        Ok(match self.read(Arc::clone(&adjust))? {
            Opened::Frames(stager) => Input::Frames(stager),
            Opened::Molecule(m, started) => {
                let (mut scene, legend) = self.scene_of(&m, started)?;
                adjust(&mut scene)?;
                Input::Still(scene, legend)
            }
            Opened::SceneFile => {
                let mut scene = self.scene_file()?;
                adjust(&mut scene)?;
                Input::Still(scene, None)
            }
        })
    }

    /// Makes the molecules of one structure whole in its box (`--pbc`),
    /// saying so; refused where there is no box and one is asked for.
    fn whole(&self, m: &mut Molecule) -> Result<()> {
        let center = (self.pbc == Pbc::Center).then(|| molecule::build::kept_sites(m, &self.molecule, None)).transpose()?;
        if let Some(note) = molecule::pbc::make_molecule_whole(m, self.pbc, center)? {
            eprintln!("{note}");
        }
        Ok(())
    }

    /// The scene file, refused where molecule flags were given.
    fn scene_file(&self) -> Result<Scene> {
        if !self.molecule_flags.is_empty() {
            bail!(
                "{} applies to molecule files (.pdb, .cif, .gro, optionally .gz); {} is a scene file",
                self.molecule_flags.join(", "),
                self.path.display()
            );
        }
        Ok(Scene::load(self.path)?)
    }

    /// The scene of molecule `m` (read from `started` on) and its colour
    /// key, its notes and warnings printed to stderr.
    fn scene_of(&self, m: &Molecule, started: Instant) -> Result<(Scene, Option<Legend>)> {
        let (scene, notes) = molecule::build::scene_of(m, &self.molecule)?;
        for w in &notes.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!("{} (read and built in {:.2} s)", notes.summary, started.elapsed().as_secs_f64());
        Ok((scene, notes.legend))
    }
}

impl Input {
    /// The scene of frame `frame` (0 where not given).
    pub fn scene(&mut self, frame: Option<usize>) -> Result<Scene> {
        match self {
            Input::Still(scene, _) => Ok(scene.clone()),
            Input::Frames(stager) => Ok(stager.scene(frame.unwrap_or(0))?.0),
        }
    }

    /// The colour key of a molecule coloured by value (a trajectory's:
    /// its first frame's, whose range is every frame's).
    pub fn legend(&mut self) -> Result<Option<Legend>> {
        match self {
            Input::Still(_, legend) => Ok(legend.clone()),
            Input::Frames(stager) => Ok(stager.text(0)?.2.legend),
        }
    }
}

/// No changes: the scene as its file or molecule gives it.
pub fn unchanged() -> Adjust {
    Arc::new(|_| Ok(()))
}
