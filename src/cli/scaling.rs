//! `isomarch scaling`: time per ray against the scene's size.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use isomarch::bench;
use isomarch::checks;

use super::args::GpuArgs;
use super::finish;
use super::report::command_line;

/// `isomarch scaling`.
#[derive(Args)]
pub struct ScalingArgs {
    /// Comma-separated numbers of blobs, one scene each.
    #[arg(long, default_value = isomarch::scaling::DEFAULT_COUNTS, value_name = "N,N,...")]
    counts: String,
    /// Comma-separated marchers.
    #[arg(long, default_value = isomarch::scaling::DEFAULT_METHODS)]
    methods: String,
    /// Protocol rays per scene.
    #[arg(long, default_value_t = isomarch::scaling::DEFAULT_RAYS)]
    rays: usize,
    /// Timed marches of each scene and method; their order alternates
    /// between repeats.
    #[arg(long, default_value_t = isomarch::scaling::DEFAULT_REPEAT, value_name = "R")]
    repeat: usize,
    /// Seed of the scenes, as `generate particles --seed`.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Seed of the protocol rays, the same for every count.
    #[arg(long, default_value_t = bench::DEFAULT_SEED)]
    ray_seed: u64,
    /// Gaussian blobs, as `generate particles --gaussian`.
    #[arg(long)]
    gaussian: bool,
    /// Output folder.
    #[arg(short, long, default_value = "scaling", value_name = "DIR")]
    output: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// What `scaling` will measure, every value checked, before the device is
/// opened.
struct Plan {
    sweep: isomarch::scaling::Sweep,
    output: PathBuf,
    gpu: GpuArgs,
}

impl TryFrom<ScalingArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(args: ScalingArgs) -> Result<Plan> {
        let ScalingArgs { counts, methods, rays, repeat, seed, ray_seed, gaussian, output, gpu } = args;
        let sweep = isomarch::scaling::Sweep {
            counts: isomarch::scaling::parse_counts(&counts)?,
            methods: checks::methods(&methods)?,
            rays: checks::rays(rays)?,
            repeat,
            seed,
            ray_seed,
            gaussian,
        };
        sweep.check()?;
        Ok(Plan { sweep, output, gpu })
    }
}

pub fn run(args: ScalingArgs) -> Result<()> {
    let Plan { sweep, output, gpu } = Plan::try_from(args)?;
    let gpu = gpu.open()?;
    let report = isomarch::scaling::run(&gpu.ctx, &sweep, gpu.timeout, command_line(), true)?;
    report.write(&output)?;
    print!("{}", report.markdown());
    eprintln!("wrote {}/scaling.md, .csv, .png, .svg", output.display());
    finish(&gpu.ctx)
}
