//! `isomarch frames`: a trajectory's frames as CSV.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;

use super::report::count;

/// `isomarch frames`.
#[derive(Args)]
pub struct FramesArgs {
    /// Topology: a molecule file (.pdb, .cif, .gro, optionally .gz) or .psf.
    topology: PathBuf,
    /// Its trajectory (.xtc, .dcd, multi-model .pdb or .cif, multi-frame .gro);
    /// default: the topology's own models or frames.
    trajectory: Option<PathBuf>,
    /// Atoms whose positions to print, by index in the file (0-based,
    /// counting every coordinate site: virtual sites and hydrogens too).
    #[arg(long, value_delimiter = ',', value_name = "I,J,...")]
    atoms: Vec<usize>,
    /// Molecules split by the periodic box, as `render --pbc` (whole,
    /// center, auto); by default the file's coordinates as they are.
    #[arg(long, value_enum, default_value = "none")]
    pbc: isomarch::molecule::pbc::Pbc,
    /// K frames between each pair of saved ones, as `render
    /// --interpolate`; adds the columns saved_from, saved_to and fraction
    /// (how far from the first to the second).
    #[arg(long, value_name = "K", default_value_t = 0)]
    interpolate: usize,
}

/// `isomarch frames`: every frame's time and mean position, as CSV on
/// stdout.
pub fn run(args: FramesArgs) -> Result<()> {
    use std::io::Write as _;
    let (mut t, note) = isomarch::molecule::trajectory::open_with(&args.topology, args.trajectory.as_deref(), args.pbc)?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    t.set_interpolate(args.interpolate);
    let sites = t.topology.sites;
    if let Some(&i) = args.atoms.iter().find(|&&i| i >= sites) {
        bail!("--atoms {i}: the topology has {sites} atoms (0 to {})", sites - 1);
    }
    let mut out = std::io::stdout().lock();
    let mut header = "frame,time_ps,atoms,mean_x,mean_y,mean_z".to_string();
    for i in &args.atoms {
        header.push_str(&format!(",x{i},y{i},z{i}"));
    }
    if args.interpolate > 0 {
        header.push_str(",saved_from,saved_to,fraction");
    }
    writeln!(out, "{header}")?;
    for k in 0..t.len() {
        let f = t.read(k)?;
        let present: Vec<glam::DVec3> = f.positions.iter().copied().filter(|p| p.is_finite()).collect();
        let mean = present.iter().fold(glam::DVec3::ZERO, |a, &p| a + p) / present.len().max(1) as f64;
        let mut row =
            format!("{k},{},{},{:.6},{:.6},{:.6}", f.time_ps.map_or(String::new(), |t| format!("{t:.6}")), present.len(), mean.x, mean.y, mean.z);
        for &i in &args.atoms {
            let p = f.positions[i];
            row.push_str(&format!(",{:.6},{:.6},{:.6}", p.x, p.y, p.z));
        }
        if args.interpolate > 0 {
            let (i, j, f) = t.between(k);
            row.push_str(&format!(",{i},{j},{f:.6}"));
        }
        writeln!(out, "{row}")?;
    }
    eprintln!("{}: {} of {sites} atoms", t.source, count(t.len() as u64, "frame"));
    Ok(())
}
