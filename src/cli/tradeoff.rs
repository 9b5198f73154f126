//! `isomarch tradeoff`: the speed-accuracy sweep.

use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};
use clap::Args;

use isomarch::bench;
use isomarch::checks;
use isomarch::output::write_atomic;
use isomarch::scene::Scene;

use super::args::GpuArgs;
use super::finish;

/// `isomarch tradeoff`.
#[derive(Args)]
pub struct TradeoffArgs {
    /// Scene file (RON).
    scene: PathBuf,
    /// Comma-separated marchers (default sphere,segment,linear-taylor,
    /// quadratic-taylor,quadratic; segment,quadratic-taylor with --quick).
    #[arg(long)]
    methods: Option<String>,
    /// Minimum steps to sweep (comma-separated; default 1e-4,1e-3,1e-2,0.1,1).
    #[arg(long, value_delimiter = ',')]
    min_steps: Vec<f64>,
    /// Step budgets to sweep (comma-separated; default 8,32,128,1000,10000).
    #[arg(long = "max-steps-list", value_delimiter = ',')]
    max_steps: Vec<u32>,
    /// Rays (default 16384; 1024 with --quick).
    #[arg(long)]
    rays: Option<usize>,
    /// Seed of the ray set.
    #[arg(long, default_value_t = bench::DEFAULT_SEED)]
    seed: u64,
    /// A small sweep for CI: segment and quadratic-taylor unless
    /// --methods says otherwise, minimum steps 0.01 and 0.1, budgets 32
    /// and 1000, 1024 rays.
    #[arg(long)]
    quick: bool,
    /// Sweep the any-hit query of shadows and ambient occlusion instead:
    /// the scene's shadow and occlusion rays (both, with 8 occlusion rays,
    /// when it asks for neither) cast from the f64 reference's hits of the
    /// protocol rays, as `bench --any-hit` casts them; an answer that
    /// disagrees with the reference's counts as an error of 1.
    #[arg(long)]
    any_hit: bool,
    /// Output folder (default: tradeoff-<scene name>, with -any-hit).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Draw the plot again from the folder's tradeoff.csv, without
    /// marching (for a sweep measured earlier).
    #[arg(long)]
    replot: bool,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// What `tradeoff` will do, every value checked, before the device is
/// opened: draw the plot again from a folder's CSV, or sweep.
#[allow(clippy::large_enum_variant)] // one per run
enum Plan {
    Replot { dir: PathBuf, stem: String },
    Sweep { scene: Scene, sweep: isomarch::tradeoff::Sweep, dir: PathBuf, stem: String, gpu: GpuArgs },
}

impl TryFrom<TradeoffArgs> for Plan {
    type Error = anyhow::Error;

    fn try_from(args: TradeoffArgs) -> Result<Plan> {
        let TradeoffArgs { scene: path, methods, min_steps, max_steps, rays, seed, quick, any_hit, output, replot, gpu } = args;
        let mut stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        if any_hit {
            stem.push_str("-any-hit");
        }
        let dir = output.unwrap_or_else(|| PathBuf::from(format!("tradeoff-{stem}")));
        if replot {
            return Ok(Plan::Replot { dir, stem });
        }
        if isomarch::molecule::is_molecule(&path) || path.extension().is_some_and(|e| e.eq_ignore_ascii_case("psf")) {
            bail!(
                "{}: tradeoff takes a scene file (.ron), not a molecule; `isomarch scene {} -o scene.ron` writes the molecule's",
                path.display(),
                path.display()
            );
        }
        let scene = Scene::load(&path)?.at_time(0.0);
        let default = if quick { "segment,quadratic-taylor" } else { "sphere,segment,linear-taylor,quadratic-taylor,quadratic" };
        let methods = checks::methods(methods.as_deref().unwrap_or(default))?;
        let mut sweep = if quick { isomarch::tradeoff::Sweep::quick(methods) } else { isomarch::tradeoff::Sweep::full(methods) };
        if !min_steps.is_empty() {
            sweep.min_steps = min_steps;
        }
        if !max_steps.is_empty() {
            sweep.max_steps = max_steps;
        }
        if let Some(n) = rays {
            sweep.rays = n;
        }
        sweep.seed = seed;
        sweep.any_hit = any_hit;
        sweep.check()?;
        Ok(Plan::Sweep { scene, sweep, dir, stem, gpu })
    }
}

pub fn run(args: TradeoffArgs) -> Result<()> {
    let (scene, sweep, dir, stem, gpu) = match Plan::try_from(args)? {
        Plan::Replot { dir, stem } => {
            let csv = dir.join("tradeoff.csv");
            let text = std::fs::read_to_string(&csv).with_context(|| format!("reading {}", csv.display()))?;
            let points = isomarch::tradeoff::read_csv(&text).with_context(|| csv.display().to_string())?;
            let title = format!("{stem}: time per ray against error (replotted from tradeoff.csv)");
            isomarch::tradeoff::plot(&points, &title, &dir.join("tradeoff.png"), &dir.join("tradeoff.svg"))?;
            eprintln!("wrote {}/tradeoff.png, .svg from its tradeoff.csv", dir.display());
            return Ok(());
        }
        Plan::Sweep { scene, sweep, dir, stem, gpu } => (scene, sweep, dir, stem, gpu),
    };
    let gpu = gpu.open()?;
    let total = sweep.methods.len() * sweep.min_steps.len() * sweep.max_steps.len();
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("tradeoff [{bar:30}] {pos}/{len} settings ({eta} left)")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let points = isomarch::tradeoff::run(&gpu.ctx, &scene, &sweep, gpu.timeout, |n| bar.set_position(n as u64))?;
    bar.finish_and_clear();
    write_atomic(&dir.join("tradeoff.csv"), isomarch::tradeoff::csv(&points).as_bytes())?;
    let title = format!("{stem}: time per ray against error, {} rays on {}", sweep.rays, gpu.ctx.info.name);
    isomarch::tradeoff::plot(&points, &title, &dir.join("tradeoff.png"), &dir.join("tradeoff.svg"))?;
    eprintln!("{} settings; Pareto front:", points.len());
    for p in points.iter().filter(|p| p.pareto) {
        eprintln!(
            "  {:<18} min step {:<7} max steps {:<6} {} ns/ray, error {:.2e}, miss rate {:.5}",
            p.method,
            p.min_step,
            p.max_steps,
            p.ns_per_ray.map_or("n/a".into(), |v| format!("{v:.0}")),
            p.error,
            p.miss_rate
        );
    }
    eprintln!("wrote {}/tradeoff.csv, .png, .svg", dir.display());
    finish(&gpu.ctx)
}
