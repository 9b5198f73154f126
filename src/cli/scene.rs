//! `isomarch scene`: a molecule's scene file.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use isomarch::open::{Opened, unchanged};
use isomarch::output::write_atomic;
use isomarch::scene::Scene;

use super::args::{MoleculeArgs, PlayArgs, ViewFlags};

/// `isomarch scene`.
#[derive(Args)]
pub struct SceneArgs {
    /// Molecule file (.pdb, .ent, .cif, .mmcif, .gro; optionally .gz), or
    /// a trajectory's topology (those, or .psf).
    molecule: PathBuf,
    /// Trajectory of the topology (.xtc, .dcd, multi-model .pdb or .cif,
    /// multi-frame .gro): write the scene of one frame (--frame).
    trajectory: Option<PathBuf>,
    #[command(flatten)]
    play: PlayArgs,
    /// The scene file to write (.ron), atomically.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    molecule_args: MoleculeArgs,
    #[command(flatten)]
    view: ViewFlags,
}

/// `isomarch scene`: a molecule's scene file.
pub fn run(args: SceneArgs) -> Result<()> {
    if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("ron")) {
        bail!("-o {}: a scene file must end in .ron", args.output.display());
    }
    let opened = args.molecule_args.source(&args.molecule, args.trajectory.as_deref(), &args.play)?.read(unchanged())?;
    let (text, source) = match opened {
        Opened::Frames(mut stager) => {
            let k = args.play.frame.unwrap_or(0);
            (stager.text(k)?.0, stager.trajectory.topology.source.clone())
        }
        Opened::SceneFile => bail!("{}: not a molecule file: expected .pdb, .ent, .cif, .mmcif or .gro, optionally .gz", args.molecule.display()),
        Opened::Molecule(m, _) => {
            let (text, notes) = isomarch::molecule::build::scene_text(&m, &args.molecule_args.options()?)?;
            for w in &notes.warnings {
                eprintln!("warning: {w}");
            }
            eprintln!("{}", notes.summary);
            (text, m.source)
        }
    };
    // The view flags: the camera they make written into the file, so that
    // rendering it makes the figure the same flags make of the molecule.
    let mut scene = Scene::parse(&text, &source)?;
    let text = if args.view.is_empty() {
        text
    } else {
        args.view.apply(&mut scene)?;
        isomarch::molecule::build::with_view(&text, &scene.camera, scene.background, args.view.camera.is_none())
    };
    // The text must load as the molecule renders: check before writing.
    Scene::parse(&text, &source)?;
    write_atomic(&args.output, text.as_bytes())?;
    println!("wrote {}", args.output.display());
    Ok(())
}
