//! `isomarch generate`: benchmark scenes.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use isomarch::output::FileFormat;

/// `isomarch generate`: what to make.
#[derive(Subcommand)]
pub enum GenerateCommand {
    /// N blobs at a fixed density (one per 1.5^3) in a cube whose side grows
    /// as N^(1/3), seen whole by the scene's camera: a sweep over --count
    /// holds the density fixed while the scene grows. Compact blobs of
    /// support radius 1 at iso 0.5; the choices are documented in
    /// src/generate.rs.
    Particles(ParticlesArgs),
}

/// `isomarch generate particles`.
#[derive(Args)]
pub struct ParticlesArgs {
    /// Number of blobs.
    #[arg(long, value_name = "N")]
    count: usize,
    /// Seed: the same seed and flags write the same bytes.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gaussian blobs (r 0.5, s 2, surface of a lone blob at 0.5) instead of compact ones.
    #[arg(long)]
    gaussian: bool,
    /// Move every centre on a sine (amplitude 0.5, random axis and phase,
    /// period 2 to 4 s): an animated scene.
    #[arg(long)]
    motion: bool,
    /// The scene file to write (.ron), atomically.
    #[arg(short, long)]
    output: PathBuf,
}

pub fn run(command: GenerateCommand) -> Result<()> {
    match command {
        GenerateCommand::Particles(args) => {
            FileFormat::of("-o", &args.output, &[FileFormat::Ron])?;
            let p = isomarch::generate::Particles { count: args.count, seed: args.seed, gaussian: args.gaussian, motion: args.motion };
            p.write(&args.output)?;
            println!("{}", p.summary(&args.output));
            Ok(())
        }
    }
}
