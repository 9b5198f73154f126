//! How time per ray grows with the scene: `isomarch scaling`.
//!
//! Scenes of `generate particles` at a fixed density (one blob per 1.5³),
//! one per count, each marched by every method on the benchmark protocol's
//! rays (docs/benchmark-protocol.md; the same seed for every count, so the
//! same rays scaled to each box) and compared with the f64 reference.
//!
//! Every scene gets its own renderer, all alive at once, so that timing can
//! interleave them: each repeat marches every (count, method) once, in
//! count-major order, ascending in even repeats and descending in odd ones,
//! so that a drift of the machine's speed (another process, heat) does not
//! favour one count. A count's time relative to the smallest count is the
//! median over repeats of the ratio measured within each repeat; its time
//! per ray is the median over repeats, with the minimum and maximum. At the
//! start of its block in each repeat, a scene's spatial index is built
//! again (the same scene), and the index build time is the median of those
//! builds.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressStyle};

use crate::bench::{accuracy, match_window, reference_crossings};
use crate::generate::{Particles, SPACING};
use crate::gpu::Context;
use crate::layout::GpuRay;
use crate::method::Method;
use crate::output::MarchStats;
use crate::output::plot::thousands;
use crate::output::plot::{plot_err, write_png_svg};
use crate::render::index::IndexStats;
use crate::render::rays::protocol_rays;
use crate::render::{MarchOptions, Renderer};
use crate::scene::Scene;
use crate::stats::median;

pub const DEFAULT_COUNTS: &str = "100,1000,10000,100000";
pub const DEFAULT_METHODS: &str = "segment,quadratic-taylor,quadratic";
pub const DEFAULT_RAYS: usize = 32_768;
pub const DEFAULT_REPEAT: usize = 5;
/// Rays of the untimed march that compiles each pipeline before timing.
const WARM_UP_RAYS: usize = 1024;
/// Rays per call of the f64 reference (its progress is shown between calls).
const REFERENCE_CHUNK: usize = 4096;

/// What a sweep measures.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Numbers of blobs, ascending, each at least 1.
    pub counts: Vec<usize>,
    pub methods: Vec<Method>,
    pub rays: usize,
    pub repeat: usize,
    /// Seed of the scenes (`generate particles --seed`).
    pub seed: u64,
    /// Seed of the protocol rays, the same for every count.
    pub ray_seed: u64,
    /// Gaussian blobs (`generate particles --gaussian`).
    pub gaussian: bool,
}

impl Sweep {
    /// Fails in one line on what cannot be measured.
    pub fn check(&self) -> Result<()> {
        if self.counts.is_empty() {
            bail!("--counts: no count given");
        }
        if self.counts.contains(&0) {
            bail!("--counts: every count must be at least 1");
        }
        if !self.counts.windows(2).all(|w| w[0] < w[1]) {
            bail!("--counts must be ascending and without repeats, got {}", join(&self.counts));
        }
        if self.methods.is_empty() {
            bail!("--methods: no method given");
        }
        if let Some(m) = self.methods.iter().enumerate().find_map(|(i, m)| self.methods[..i].contains(m).then_some(m)) {
            bail!("--methods: {m} is given twice");
        }
        if self.rays == 0 {
            bail!("--rays must be at least 1");
        }
        if self.repeat == 0 {
            bail!("--repeat must be at least 1");
        }
        Ok(())
    }

    /// The scene of `count` blobs.
    pub fn particles(&self, count: usize) -> Particles {
        Particles { count, seed: self.seed, gaussian: self.gaussian, motion: false }
    }
}

/// Parses `--counts`: comma-separated numbers of blobs (`_` allowed as a
/// digit separator), sorted; a one-line error for anything else.
pub fn parse_counts(list: &str) -> Result<Vec<usize>> {
    let mut counts = Vec::new();
    for part in list.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let digits = part.replace('_', "");
        match digits.parse::<usize>() {
            Ok(n) if !digits.is_empty() => counts.push(n),
            _ => bail!("--counts: expected numbers of blobs such as 100,1000, got {part:?}"),
        }
    }
    if counts.is_empty() {
        bail!("--counts: no count given");
    }
    counts.sort_unstable();
    if let Some(w) = counts.windows(2).find(|w| w[0] == w[1]) {
        bail!("--counts: {} is given twice", w[0]);
    }
    Ok(counts)
}

/// One scene of the sweep.
#[derive(Clone, Debug)]
pub struct CountReport {
    pub count: usize,
    /// Side of the cube that holds the centres.
    pub side: f64,
    /// Rays on which the f64 reference finds a crossing.
    pub reference_hit_rate: f64,
    /// The spatial index (`None`: at most 64 primitives, marched without one).
    pub index: Option<IndexStats>,
    /// GPU time of each repeat's build of the index, ms.
    pub build_ms: Vec<f64>,
}

/// One (count, method).
#[derive(Clone, Debug)]
pub struct Row {
    pub count: usize,
    pub method: Method,
    /// From the first repeat (the counts are the same in every repeat).
    pub stats: MarchStats,
    /// Per ray, against the f64 reference (as `bench`).
    pub miss_rate: f64,
    pub false_hit_rate: f64,
    /// GPU time per ray of each repeat, ns.
    pub ns_per_ray: Vec<f64>,
    /// Median over repeats of the ratio, within the repeat, of this time to
    /// the smallest count's with the same method.
    pub time_ratio: f64,
}

impl Row {
    pub fn median_ns(&self) -> f64 {
        median(&self.ns_per_ray)
    }
    pub fn min_ns(&self) -> f64 {
        self.ns_per_ray.iter().copied().fold(f64::INFINITY, f64::min)
    }
    pub fn max_ns(&self) -> f64 {
        self.ns_per_ray.iter().copied().fold(0.0, f64::max)
    }
}

#[derive(Clone, Debug)]
pub struct Report {
    pub sweep: Sweep,
    pub device: String,
    /// The command line that produced the report.
    pub command: String,
    pub counts: Vec<CountReport>,
    /// Count-major, in the order of `sweep.counts` and `sweep.methods`.
    pub rows: Vec<Row>,
    /// Wall time of the whole sweep, s.
    pub seconds: f64,
}

/// A scene ready to march: its rays, the reference's first hits, and its
/// renderer.
struct Prepared {
    scene: Scene,
    rays: Vec<GpuRay>,
    reference: Vec<Option<f64>>,
    renderer: Renderer,
}

fn bar(len: u64, template: &str, show: bool) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> "));
    bar
}

/// Runs the sweep (see the module's documentation). `command` is the
/// command line written at the top of the report; `show_progress` draws
/// progress bars on stderr.
pub fn run(ctx: &Arc<Context>, sweep: &Sweep, timeout: Duration, command: String, show_progress: bool) -> Result<Report> {
    sweep.check()?;
    if !ctx.info.timestamps {
        bail!("scaling measures GPU time with timestamp queries, which {} does not have", ctx.info.name);
    }
    let start = std::time::Instant::now();
    let mut prepared = Vec::with_capacity(sweep.counts.len());
    let mut counts = Vec::with_capacity(sweep.counts.len());
    for &count in &sweep.counts {
        let (p, c) = prepare(ctx, sweep, count, timeout, show_progress)?;
        prepared.push(p);
        counts.push(c);
    }

    // Timing: every (count, method) once per repeat, count-major, the order
    // reversed in odd repeats.
    let order: Vec<(usize, usize)> = (0..sweep.counts.len()).flat_map(|c| (0..sweep.methods.len()).map(move |m| (c, m))).collect();
    let total = (sweep.repeat * order.len() * sweep.rays) as u64;
    let timing = bar(total, "{msg:>36} [{bar:30}] {percent}% ({eta} left)", show_progress);
    let mut ns = vec![vec![Vec::with_capacity(sweep.repeat); sweep.methods.len()]; sweep.counts.len()];
    let mut first: Vec<Vec<Option<(MarchStats, f64, f64)>>> = vec![vec![None; sweep.methods.len()]; sweep.counts.len()];
    for r in 0..sweep.repeat {
        let pass: Vec<(usize, usize)> = if r % 2 == 0 { order.clone() } else { order.iter().rev().copied().collect() };
        let mut last_count = None;
        for (c, m) in pass {
            let p = &mut prepared[c];
            if last_count != Some(c) {
                // The same scene again: only the index is rebuilt.
                p.renderer.set_scene(&p.scene)?;
                if let Some(i) = p.renderer.index_stats() {
                    counts[c].build_ms.push(i.build_ns * 1e-6);
                }
                last_count = Some(c);
            }
            let method = sweep.methods[m];
            timing.set_message(format!("repeat {}/{}: {} blobs, {method}", r + 1, sweep.repeat, sweep.counts[c]));
            let done = timing.position();
            let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&p.scene) };
            let out = p.renderer.march(method, options, &p.rays, |n| timing.set_position(done + n as u64))?;
            let Some(gpu_ns) = out.gpu_ns else {
                bail!("{}: the march returned no GPU time", p.scene.source);
            };
            ns[c][m].push(gpu_ns / sweep.rays as f64);
            if first[c][m].is_none() {
                let stats = MarchStats::of(&out.results, out.gpu_ns);
                let (late, early) = match_window(p.scene.marching.min_step, p.scene.refine_tolerance());
                let a = accuracy(&out.results, &p.reference, late, early);
                let n = sweep.rays as f64;
                first[c][m] = Some((stats, a.misses as f64 / n, a.false_hits as f64 / n));
            }
        }
    }
    timing.finish_and_clear();

    let mut rows = Vec::new();
    for (c, &count) in sweep.counts.iter().enumerate() {
        for (m, &method) in sweep.methods.iter().enumerate() {
            let (stats, miss_rate, false_hit_rate) = first[c][m].clone().expect("every (count, method) is marched in every repeat");
            let ratios: Vec<f64> = ns[c][m].iter().zip(&ns[0][m]).map(|(t, t0)| t / t0).collect();
            rows.push(Row { count, method, stats, miss_rate, false_hit_rate, ns_per_ray: ns[c][m].clone(), time_ratio: median(&ratios) });
        }
    }
    // The index as last built (the statistics do not change between builds
    // of the same scene; the build time is reported from `build_ms`).
    for (c, p) in counts.iter_mut().zip(&prepared) {
        c.index = p.renderer.index_stats();
    }
    Ok(Report { sweep: sweep.clone(), device: ctx.info.name.clone(), command, counts, rows, seconds: start.elapsed().as_secs_f64() })
}

/// Builds the scene of `count` blobs, its rays, the f64 reference and its
/// renderer, and compiles the pipelines with an untimed march of a few rays
/// per method.
fn prepare(ctx: &Arc<Context>, sweep: &Sweep, count: usize, timeout: Duration, show_progress: bool) -> Result<(Prepared, CountReport)> {
    let particles = sweep.particles(count);
    let name = format!("particles --count {count} --seed {}{}", sweep.seed, if sweep.gaussian { " --gaussian" } else { "" });
    let scene = Scene::parse(&particles.ron()?, &name)?;
    // The GPU's coordinates centred on the box the rays aim at (f32).
    let scene = scene.recentred(scene.bounds.center());
    let rays = protocol_rays(&scene.bounds, sweep.rays, sweep.ray_seed);
    let progress = bar(sweep.rays as u64, "{msg:>36} [{bar:30}] {pos}/{len} rays ({eta} left)", show_progress);
    progress.set_message(format!("{count} blobs: f64 reference"));
    let mut reference = Vec::with_capacity(rays.len());
    for chunk in rays.chunks(REFERENCE_CHUNK) {
        reference.extend(reference_crossings(&scene, chunk, true, false).into_iter().map(|c| c.first().copied()));
        progress.inc(chunk.len() as u64);
    }
    progress.set_message(format!("{count} blobs: index, pipelines"));
    let mut renderer = Renderer::with_timeout(ctx, &scene, timeout)?;
    let warm = &rays[..rays.len().min(WARM_UP_RAYS)];
    for &method in &sweep.methods {
        renderer.march(method, MarchOptions { shade: false, ..MarchOptions::for_scene(&scene) }, warm, |_| {})?;
    }
    progress.finish_and_clear();
    let hits = reference.iter().filter(|r| r.is_some()).count();
    let report = CountReport {
        count,
        side: particles.side(),
        reference_hit_rate: hits as f64 / rays.len() as f64,
        index: renderer.index_stats(),
        build_ms: Vec::new(),
    };
    Ok((Prepared { scene, rays, reference, renderer }, report))
}

fn join(counts: &[usize]) -> String {
    counts.iter().map(usize::to_string).collect::<Vec<_>>().join(",")
}

/// Ticks of the plot's x axis: the counts, and the powers of ten between.
fn x_ticks(counts: &[usize]) -> Vec<f64> {
    let (lo, hi) = (counts[0] as f64, counts[counts.len() - 1] as f64);
    let mut ticks: Vec<f64> = counts.iter().map(|&c| c as f64).collect();
    ticks.extend((0..=12).map(|k| 10f64.powi(k)).filter(|&p| p >= lo && p <= hi));
    ticks.sort_by(f64::total_cmp);
    ticks.dedup();
    ticks
}

/// Ticks of the plot's y axis: 1, 1.5, 2, 3, 5 and 7 times the powers of
/// ten within [lo, hi].
fn y_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        ticks.extend([1.0, 1.5, 2.0, 3.0, 5.0, 7.0].iter().map(|m| m * decade).filter(|&t| t >= lo && t <= hi));
        decade *= 10.0;
    }
    ticks
}

impl Report {
    fn kind(&self) -> &'static str {
        if self.sweep.gaussian { "Gaussian" } else { "compact" }
    }

    fn build_ms(c: &CountReport) -> Option<(f64, f64, f64)> {
        (!c.build_ms.is_empty()).then(|| {
            let (lo, hi) = c.build_ms.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
            (median(&c.build_ms), lo, hi)
        })
    }

    /// The report as markdown: the command line, what was measured, a row
    /// per (count, method), and a row per count for its scene and index.
    pub fn markdown(&self) -> String {
        let s = &self.sweep;
        let base = thousands(s.counts[0]);
        let mut out = format!("```sh\n{}\n```\n\n", self.command);
        out.push_str(&format!(
            "{} {} blobs at a fixed density (one per {SPACING}³; `generate particles --seed {}`), {} protocol rays per scene \
             (seed {}, the same for every count), {} repeat{} interleaved, on {}. ns/ray: the median over repeats of GPU time \
             per ray (timestamp queries), then the fastest and slowest repeat; time vs {base}: the median over repeats of the \
             ratio to {base} blobs within the repeat. Miss rate: against the f64 reference, per ray.\n\n",
            s.counts.iter().map(|&c| thousands(c)).collect::<Vec<_>>().join(", "),
            self.kind(),
            s.seed,
            s.rays,
            s.ray_seed,
            s.repeat,
            if s.repeat == 1 { "" } else { "s" },
            self.device,
        ));
        out.push_str(&format!("| blobs | method | hit rate | miss rate | steps/ray | evals/ray | ns/ray | min–max | time vs {base} |\n"));
        out.push_str("|---:|---|---:|---:|---:|---:|---:|---:|---:|\n");
        for r in &self.rows {
            out.push_str(&format!(
                "| {} | {} | {:.4} | {:.5} | {:.2} | {:.1} | {:.0} | {:.0}–{:.0} | {:.3}x |\n",
                thousands(r.count),
                r.method,
                r.stats.hit_rate,
                r.miss_rate,
                r.stats.steps_per_ray,
                r.stats.evals_per_ray,
                r.median_ns(),
                r.min_ns(),
                r.max_ns(),
                r.time_ratio
            ));
        }
        out.push_str(
            "\n| blobs | cube side | reference hit rate | cells | entries | longest list | bytes/blob | index build ms (median, min–max) |\n",
        );
        out.push_str("|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        for c in &self.counts {
            let index = match (&c.index, Self::build_ms(c)) {
                (Some(i), Some((med, lo, hi))) => format!(
                    "{} | {} | {} | {:.1} | {med:.3} ({lo:.3}–{hi:.3})",
                    thousands(i.cells),
                    thousands(i.entries),
                    i.longest_list,
                    i.bytes_per_primitive
                ),
                _ => "no index (at most 64 blobs) | | | | ".to_string(),
            };
            out.push_str(&format!("| {} | {:.2} | {:.4} | {index} |\n", thousands(c.count), c.side, c.reference_hit_rate));
        }
        out.push_str(&format!("\nSweep wall time {:.1} s.\n", self.seconds));
        out
    }

    /// The report as CSV, one row per (count, method); `ns_per_ray_each`
    /// lists every repeat's time, separated by `;`. Index columns are empty
    /// for scenes without an index.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "count,method,rays,repeats,reference_hit_rate,hit_rate,miss_rate,false_hit_rate,out_of_steps_rate,\
             steps_per_ray,evals_per_ray,refine_per_ray,ns_per_ray,ns_per_ray_min,ns_per_ray_max,time_ratio,ns_per_ray_each,\
             index_build_ms,index_build_ms_min,index_build_ms_max,bytes_per_primitive,index_cells,index_entries,index_longest_list\n",
        );
        for r in &self.rows {
            let c = self.counts.iter().find(|c| c.count == r.count).expect("a row's count is a count of the sweep");
            let index = match (&c.index, Self::build_ms(c)) {
                (Some(i), Some((med, lo, hi))) => {
                    format!("{med:.4},{lo:.4},{hi:.4},{:.2},{},{},{}", i.bytes_per_primitive, i.cells, i.entries, i.longest_list)
                }
                _ => ",,,,,,".to_string(),
            };
            out.push_str(&format!(
                "{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.2},{:.2},{:.1},{:.1},{:.1},{:.4},{},{index}\n",
                r.count,
                r.method,
                self.sweep.rays,
                r.ns_per_ray.len(),
                c.reference_hit_rate,
                r.stats.hit_rate,
                r.miss_rate,
                r.false_hit_rate,
                r.stats.out_of_steps_rate,
                r.stats.steps_per_ray,
                r.stats.evals_per_ray,
                r.stats.refine_per_ray,
                r.median_ns(),
                r.min_ns(),
                r.max_ns(),
                r.time_ratio,
                r.ns_per_ray.iter().map(|t| format!("{t:.1}")).collect::<Vec<_>>().join(";"),
            ));
        }
        out
    }

    /// Writes scaling.md, scaling.csv, scaling.png and scaling.svg into
    /// `dir`, each atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        crate::output::write_atomic(&dir.join("scaling.csv"), self.csv().as_bytes())?;
        self.plot(&dir.join("scaling.png"), &dir.join("scaling.svg"))?;
        crate::output::write_atomic(&dir.join("scaling.md"), self.markdown().as_bytes())
    }

    /// Log-log plot of median time per ray against blobs, one line per
    /// method (each shifted a few percent along x so that their whiskers
    /// stay apart), whiskers from the fastest to the slowest repeat.
    pub fn plot(&self, png: &Path, svg: &Path) -> Result<()> {
        write_png_svg(png, svg, (960, 640), |b| self.draw(b), |b| self.draw(b))
    }

    fn draw<B: plotters::prelude::DrawingBackend>(&self, backend: B) -> Result<()>
    where
        B::ErrorType: 'static,
    {
        use plotters::prelude::*;
        if self.rows.is_empty() {
            bail!("nothing to plot");
        }
        let (x0, x1) = (self.sweep.counts[0] as f64, *self.sweep.counts.last().expect("counts are not empty") as f64);
        let (y0, y1) = self.rows.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| (a.min(r.min_ns()), b.max(r.max_ns())));
        // At least a factor of 4 from bottom to top, so that a small
        // spread does not look like a steep slope.
        let (y0, y1) = (y0.max(1e-3), y1.max(y0.max(1e-3)));
        let widen = (4.0 / (y1 / y0)).max(1.0).sqrt();
        let (y0, y1) = (y0 / widen, y1 * widen);
        let root = backend.into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let title = format!(
            "Time per ray at a fixed density: {} blobs, {} rays, {} repeats, {}",
            self.kind(),
            self.sweep.rays,
            self.sweep.repeat,
            self.device
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (x0 / 1.6..x1 * 1.6).log_scale().with_key_points(x_ticks(&self.sweep.counts)),
                (y0 / 1.2..y1 * 1.2).log_scale().with_key_points(y_ticks(y0 / 1.2, y1 * 1.2)),
            )
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("primitives (blobs)")
            .y_desc("GPU time per ray (ns), median and range of repeats")
            .x_label_formatter(&|v| thousands(v.round() as usize))
            .y_label_formatter(&|v| thousands(v.round() as usize))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(plot_err)?;
        let methods = self.sweep.methods.len();
        for (i, &method) in self.sweep.methods.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            let rows: Vec<&Row> = self.rows.iter().filter(|r| r.method == method).collect();
            // Each method a little to the side (4% per method on the log
            // axis), so that whiskers at the same count do not overlap.
            let dodge = 1.04f64.powf(i as f64 - 0.5 * (methods as f64 - 1.0));
            let at = |r: &Row| r.count as f64 * dodge;
            chart
                .draw_series(LineSeries::new(rows.iter().map(|r| (at(r), r.median_ns())), color.stroke_width(2)))
                .map_err(plot_err)?
                .label(method.name())
                .legend(move |(x, y)| PathElement::new(vec![(x - 10, y), (x + 10, y)], color.stroke_width(2)));
            chart.draw_series(rows.iter().map(|r| Circle::new((at(r), r.median_ns()), 4, color.filled()))).map_err(plot_err)?;
            // Whiskers from the fastest to the slowest repeat, with caps
            // a fixed number of pixels wide.
            chart
                .draw_series(rows.iter().map(|r| PathElement::new(vec![(at(r), r.min_ns()), (at(r), r.max_ns())], color.stroke_width(2))))
                .map_err(plot_err)?;
            let cap = move |p: (f64, f64)| EmptyElement::at(p) + PathElement::new(vec![(-6, 0), (6, 0)], color.stroke_width(2));
            chart.draw_series(rows.iter().flat_map(|r| [cap((at(r), r.min_ns())), cap((at(r), r.max_ns()))])).map_err(plot_err)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_parse_sorted_and_refuse_nonsense_in_one_line() {
        assert_eq!(parse_counts("1000, 100,100_000").unwrap(), vec![100, 1000, 100_000]);
        for (bad, says) in [("", "no count"), (" , ", "no count"), ("10,x", "\"x\""), ("-5", "\"-5\""), ("_", "\"_\""), ("7,7", "twice")] {
            let e = parse_counts(bad).unwrap_err().to_string();
            assert!(e.contains(says) && !e.contains('\n'), "{bad:?}: {e}");
        }
    }

    #[test]
    fn a_sweep_checks_itself() {
        let ok = Sweep { counts: vec![100, 300], methods: vec![Method::Segment], rays: 8, repeat: 2, seed: 1, ray_seed: 2, gaussian: false };
        assert!(ok.check().is_ok());
        let bad = |f: &dyn Fn(&mut Sweep)| {
            let mut s = ok.clone();
            f(&mut s);
            s.check().unwrap_err().to_string()
        };
        assert!(bad(&|s| s.counts.clear()).contains("no count"));
        assert!(bad(&|s| s.counts = vec![0, 10]).contains("at least 1"));
        assert!(bad(&|s| s.counts = vec![10, 5]).contains("ascending"));
        assert!(bad(&|s| s.methods = vec![Method::Segment, Method::Segment]).contains("twice"));
        assert!(bad(&|s| s.rays = 0).contains("--rays"));
        assert!(bad(&|s| s.repeat = 0).contains("--repeat"));
    }

    #[test]
    fn medians_and_thousands() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert_eq!(thousands(100_000), "100,000");
        assert_eq!(thousands(100), "100");
        assert_eq!(thousands(1000), "1,000");
    }
}
