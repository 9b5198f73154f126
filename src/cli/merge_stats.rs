//! `isomarch merge-stats`: a batch's shard statistics as one CSV.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use isomarch::output::FileFormat;

/// `isomarch merge-stats`.
#[derive(Args)]
pub struct MergeStatsArgs {
    /// The frame range that the shards rendered together (as `render --frames`).
    #[arg(long, value_name = "RANGE")]
    frames: isomarch::batch::FrameRange,
    /// The merged CSV, written atomically.
    #[arg(short, long)]
    output: PathBuf,
    /// The per-shard CSVs (`render --csv`).
    #[arg(required = true, value_name = "CSV")]
    inputs: Vec<PathBuf>,
}

/// `isomarch merge-stats`: the shards' statistics CSVs as one.
pub fn run(args: MergeStatsArgs) -> Result<()> {
    FileFormat::of("-o", &args.output, &[FileFormat::Csv])?;
    let frames = isomarch::batch::merge::merge_files(&args.inputs, args.frames, &args.output)?;
    println!("{frames} frames from {} file(s) in {}", args.inputs.len(), args.output.display());
    Ok(())
}
