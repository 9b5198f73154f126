//! The speed-accuracy trade: every method at every minimum step and step
//! budget on one seeded ray set, timed on the GPU and compared with the f64
//! reference; CSV out, and a plot of time per ray against error with the
//! Pareto front marked.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Result, bail};
use serde::Serialize;

use crate::bench::{accuracy_all, any_hit_rays, check_any_hit_methods, match_window, reference_crossings, with_any_hit_defaults};
use crate::gpu::Context;
use crate::layout::FLAG_HIT;
use crate::method::Method;
use crate::output::MarchStats;
use crate::render::rays::protocol_rays;
use crate::render::{MarchOptions, Renderer, light};
use crate::scene::Scene;

/// The settings a sweep covers.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub methods: Vec<Method>,
    pub min_steps: Vec<f64>,
    pub max_steps: Vec<u32>,
    pub rays: usize,
    pub seed: u64,
    /// Sweep the any-hit query of shadows and occlusion instead
    /// (`bench --any-hit`'s rays, cast from the reference's hits of the
    /// protocol rays): errors are then wrong answers, each counting 1.
    pub any_hit: bool,
}

impl Sweep {
    /// The full sweep: minimum steps 1e-4 to 1, step budgets 8 to 10,000.
    pub fn full(methods: Vec<Method>) -> Sweep {
        Sweep {
            methods,
            min_steps: vec![1e-4, 1e-3, 1e-2, 0.1, 1.0],
            max_steps: vec![8, 32, 128, 1000, 10_000],
            rays: crate::bench::SAMPLE_RAYS,
            seed: crate::bench::DEFAULT_SEED,
            any_hit: false,
        }
    }

    /// One-line errors for a sweep that cannot run, named by the command
    /// line's flags (the Python package's `tradeoff` checks the same).
    pub fn check(&self) -> Result<()> {
        if self.methods.is_empty() {
            bail!("--methods names no marcher");
        }
        if self.min_steps.is_empty() {
            bail!("--min-steps needs at least one value");
        }
        if let Some(bad) = self.min_steps.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            bail!("--min-steps must be positive, got {bad}");
        }
        if self.max_steps.is_empty() {
            bail!("--max-steps-list needs at least one value");
        }
        if self.max_steps.contains(&0) {
            bail!("--max-steps-list must be at least 1");
        }
        if self.rays == 0 {
            bail!("--rays must be at least 1");
        }
        if self.any_hit {
            check_any_hit_methods(&self.methods)?;
        }
        Ok(())
    }

    /// A few settings on few rays, for CI.
    pub fn quick(methods: Vec<Method>) -> Sweep {
        Sweep { methods, min_steps: vec![0.01, 0.1], max_steps: vec![32, 1000], rays: 1024, seed: crate::bench::DEFAULT_SEED, any_hit: false }
    }
}

/// One setting's measurements. Errors are relative to the scene's size
/// (the diagonal of its bounds).
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    pub method: String,
    pub min_step: f64,
    pub max_steps: u32,
    pub ns_per_ray: Option<f64>,
    pub steps_per_ray: f64,
    pub evals_per_ray: f64,
    /// First-hit distance error where both the method and the reference
    /// hit: mean, 99th percentile, maximum.
    pub mean_error: f64,
    pub p99_error: f64,
    pub max_error: f64,
    /// The reference hits, the method does not (per ray).
    pub miss_rate: f64,
    /// The method hits, the reference does not (per ray).
    pub false_hit_rate: f64,
    /// Transparent scenes: reference crossings not found (per crossing).
    pub missed_crossings: Option<f64>,
    /// The plotted error: over rays where either hits, the relative
    /// distance error capped at 1, a miss or a false hit counting 1.
    pub error: f64,
    /// On the Pareto front of (time, error): no other setting is both
    /// faster and more accurate.
    pub pareto: bool,
    pub out_of_steps_rate: f64,
}

/// Runs the sweep; `progress` gets the number of settings done.
pub fn run(ctx: &Arc<Context>, scene: &Scene, sweep: &Sweep, timeout: std::time::Duration, mut progress: impl FnMut(usize)) -> Result<Vec<Point>> {
    // The GPU's coordinates centred on the box the rays aim at (f32).
    let recentred = scene.recentred(scene.bounds.center());
    let transparent = recentred.transparency.is_some();
    if sweep.any_hit && transparent {
        bail!("--any-hit: {} is transparent, and transparent scenes cast no shadow rays", scene.source);
    }
    let scene = &if sweep.any_hit { with_any_hit_defaults(recentred) } else { recentred };
    let mut rays = protocol_rays(&scene.bounds, sweep.rays, sweep.seed);
    if sweep.any_hit {
        rays = any_hit_rays(scene, &rays).0.rays;
    }
    let reference = reference_crossings(scene, &rays, !transparent, false);
    let size = scene.bounds.diagonal();
    let mut renderer = Renderer::with_timeout(ctx, scene, timeout)?;
    let mut points = Vec::new();
    for &method in &sweep.methods {
        for &min_step in &sweep.min_steps {
            for &max_steps in &sweep.max_steps {
                let mut s = scene.clone();
                s.marching.min_step = min_step;
                s.marching.max_steps = max_steps;
                renderer.set_scene(&s)?;
                // Unshaded: only hits and counts are measured.
                let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
                let options = if sweep.any_hit { light::any_hit_options(options) } else { options };
                let out = renderer.march(method, options, &rays, |_| {})?;
                let stats = MarchStats::of(&out.results, out.gpu_ns);
                let (mut errors, mut misses, mut false_hits, mut either) = (Vec::new(), 0usize, 0usize, 0usize);
                for ((r, reference), ray) in out.results.iter().zip(&reference).zip(&rays) {
                    // An any-hit answer has no distance: right is error 0.
                    let hit = if sweep.any_hit {
                        light::occluded(ray, r).then(|| reference.first().copied().unwrap_or(0.0))
                    } else {
                        (r.counts[3] & FLAG_HIT != 0).then_some(f64::from(r.hit[3]))
                    };
                    match (hit, reference.first()) {
                        (Some(t), Some(&tr)) => errors.push((t - tr).abs() / size),
                        (None, Some(_)) => misses += 1,
                        (Some(_), None) => false_hits += 1,
                        (None, None) => continue,
                    }
                    either += 1;
                }
                errors.sort_by(f64::total_cmp);
                let quantile = |q: f64| errors.get(((errors.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(0.0);
                let capped: f64 = errors.iter().map(|e| e.min(1.0)).sum::<f64>() + (misses + false_hits) as f64;
                let n = rays.len().max(1) as f64;
                let missed_crossings = (transparent && !sweep.any_hit).then(|| {
                    // The window of `bench` (bench::match_window).
                    let (late, early) = match_window(min_step, s.refine_tolerance());
                    let a = accuracy_all(&out.crossings, &reference, late, early);
                    a.misses as f64 / reference.iter().map(Vec::len).sum::<usize>().max(1) as f64
                });
                points.push(Point {
                    method: method.to_string(),
                    min_step,
                    max_steps,
                    ns_per_ray: stats.ns_per_ray,
                    steps_per_ray: stats.steps_per_ray,
                    evals_per_ray: stats.evals_per_ray,
                    mean_error: if errors.is_empty() { 0.0 } else { errors.iter().sum::<f64>() / errors.len() as f64 },
                    p99_error: quantile(0.99),
                    max_error: errors.last().copied().unwrap_or(0.0),
                    miss_rate: misses as f64 / n,
                    false_hit_rate: false_hits as f64 / n,
                    missed_crossings,
                    error: capped / either.max(1) as f64,
                    pareto: false,
                    out_of_steps_rate: stats.out_of_steps_rate,
                });
                progress(points.len());
            }
        }
    }
    mark_pareto(&mut points);
    Ok(points)
}

/// Marks the settings no other setting beats on both time and error.
pub fn mark_pareto(points: &mut [Point]) {
    let key = |p: &Point| (p.ns_per_ray.unwrap_or(p.steps_per_ray), p.error);
    let all: Vec<(f64, f64)> = points.iter().map(key).collect();
    for (i, p) in points.iter_mut().enumerate() {
        let (t, e) = all[i];
        p.pareto = !all.iter().enumerate().any(|(j, &(t2, e2))| j != i && t2 <= t && e2 <= e && (t2 < t || e2 < e));
    }
}

/// The points as CSV, one row per setting.
pub fn csv(points: &[Point]) -> String {
    let mut s = String::from(
        "method,min_step,max_steps,ns_per_ray,steps_per_ray,evals_per_ray,mean_error,p99_error,max_error,miss_rate,false_hit_rate,missed_crossings,error,pareto,out_of_steps_rate\n",
    );
    for p in points {
        s.push_str(&format!(
            "{},{},{},{},{:.4},{:.2},{:.3e},{:.3e},{:.3e},{:.6},{:.6},{},{:.3e},{},{:.6}\n",
            p.method,
            p.min_step,
            p.max_steps,
            p.ns_per_ray.map_or(String::new(), |v| format!("{v:.1}")),
            p.steps_per_ray,
            p.evals_per_ray,
            p.mean_error,
            p.p99_error,
            p.max_error,
            p.miss_rate,
            p.false_hit_rate,
            p.missed_crossings.map_or(String::new(), |v| format!("{v:.6}")),
            p.error,
            p.pareto,
            p.out_of_steps_rate,
        ));
    }
    s
}

/// Reads the points back from [`csv`]'s text (to plot a sweep again
/// without marching it); errors name the line.
pub fn read_csv(text: &str) -> Result<Vec<Point>> {
    let mut lines = text.lines().enumerate();
    let header = lines.next().map(|(_, l)| l).unwrap_or_default();
    if header != csv(&[]).trim_end() {
        bail!("line 1: not the header of a tradeoff CSV");
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, line)| {
            let f: Vec<&str> = line.split(',').collect();
            let at = || format!("line {}", i + 1);
            if f.len() != 15 {
                bail!("{}: {} fields, expected 15", at(), f.len());
            }
            let num = |k: usize| f[k].parse::<f64>().map_err(|e| anyhow::anyhow!("{}: field {}: {e}", at(), k + 1));
            let opt = |k: usize| if f[k].is_empty() { Ok(None) } else { num(k).map(Some) };
            Ok(Point {
                method: f[0].to_string(),
                min_step: num(1)?,
                max_steps: f[2].parse().map_err(|e| anyhow::anyhow!("{}: field 3: {e}", at()))?,
                ns_per_ray: opt(3)?,
                steps_per_ray: num(4)?,
                evals_per_ray: num(5)?,
                mean_error: num(6)?,
                p99_error: num(7)?,
                max_error: num(8)?,
                miss_rate: num(9)?,
                false_hit_rate: num(10)?,
                missed_crossings: opt(11)?,
                error: num(12)?,
                pareto: f[13] == "true",
                out_of_steps_rate: num(14)?,
            })
        })
        .collect()
}

/// Plots time per ray (log) against the error (log), one colour per
/// method, the Pareto front joined and its points ringed, into `png` and
/// `svg` (atomically).
pub fn plot(points: &[Point], title: &str, png: &Path, svg: &Path) -> Result<()> {
    crate::output::plot::write_png_svg(png, svg, (960, 640), |b| draw(points, title, b), |b| draw(points, title, b))
}

fn draw<B: plotters::prelude::DrawingBackend>(points: &[Point], title: &str, backend: B) -> Result<()>
where
    B::ErrorType: 'static,
{
    use crate::output::plot::{LegendMark, decade_axis, decade_label, decade_minors, draw_legend, plot_err};
    use plotters::prelude::*;
    let time = |p: &Point| p.ns_per_ray.unwrap_or(p.steps_per_ray).max(1e-3);
    // Errors of 0 (every hit exact to the tolerance) sit on the floor.
    let floor = 1e-7;
    let err = |p: &Point| p.error.max(floor);
    if points.is_empty() {
        bail!("nothing to plot");
    }
    let (t0, t1) = points.iter().map(time).fold((f64::INFINITY, 0.0f64), |(a, b), t| (a.min(t), b.max(t)));
    let (e0, e1) = points.iter().map(err).fold((f64::INFINITY, 0.0f64), |(a, b), e| (a.min(e), b.max(e)));
    // Whole decades on both axes, each labelled; the error is at most 1,
    // so its axis ends at 2 rather than a decade higher.
    let (x_range, x_decades) = decade_axis(t0, t1, 1.15);
    let (mut y_range, mut y_decades) = decade_axis(e0, e1, 1.2);
    if e1 <= 1.0 && y_range.end > 2.0 {
        y_range.end = 2.0;
        y_decades.retain(|&d| d <= 1.0);
    }
    let (x_minor, y_minor) = (decade_minors(&x_range, &x_decades), decade_minors(&y_range, &y_decades));
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let root = root.titled(title, ("sans-serif", 20)).map_err(plot_err)?;
    // The legend gets its own column right of the chart: it covers no data.
    let (plot_area, legend_area) = root.split_horizontally(root.dim_in_pixel().0 as i32 - 190);
    let x_desc = if points.iter().all(|p| p.ns_per_ray.is_some()) { "GPU time per ray (ns)" } else { "steps per ray" };
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(
            x_range.log_scale().with_key_points(x_decades).with_light_points(x_minor),
            y_range.log_scale().with_key_points(y_decades).with_light_points(y_minor),
        )
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("error (relative; a miss counts 1)")
        .x_label_formatter(&|v| decade_label(*v))
        .y_label_formatter(&|v| decade_label(*v))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(plot_err)?;
    let mut methods: Vec<&str> = Vec::new();
    for p in points {
        if !methods.contains(&p.method.as_str()) {
            methods.push(&p.method);
        }
    }
    let mut legend = Vec::new();
    for (i, m) in methods.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart.draw_series(points.iter().filter(|p| p.method == *m).map(|p| Circle::new((time(p), err(p)), 4, color.filled()))).map_err(plot_err)?;
        legend.push((m.to_string(), LegendMark::Dot(color)));
    }
    let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.pareto).map(|p| (time(p), err(p))).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart.draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2))).map_err(plot_err)?;
    chart.draw_series(front.iter().map(|&(x, y)| Circle::new((x, y), 7, BLACK.stroke_width(1)))).map_err(plot_err)?;
    legend.push(("Pareto front".to_string(), LegendMark::RingedLine(BLACK.to_rgba())));
    draw_legend(&legend_area, &legend)?;
    root.present().map_err(plot_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(t: f64, e: f64) -> Point {
        Point {
            method: "m".into(),
            min_step: 0.1,
            max_steps: 10,
            ns_per_ray: Some(t),
            steps_per_ray: 1.0,
            evals_per_ray: 1.0,
            mean_error: 0.0,
            p99_error: 0.0,
            max_error: 0.0,
            miss_rate: 0.0,
            false_hit_rate: 0.0,
            missed_crossings: None,
            error: e,
            pareto: false,
            out_of_steps_rate: 0.0,
        }
    }

    #[test]
    fn the_csv_reads_back() {
        let mut ps = vec![point(1234.5, 0.5), point(2.0, 1.25e-6)];
        ps[1].missed_crossings = Some(0.25);
        ps[1].ns_per_ray = None;
        mark_pareto(&mut ps);
        let text = csv(&ps);
        assert_eq!(csv(&read_csv(&text).unwrap()), text);
        assert!(read_csv("method,x\n").is_err());
        assert!(read_csv(&text.replace("1234.5", "fast")).unwrap_err().to_string().contains("line 2"));
    }

    #[test]
    fn every_decade_of_the_axes_is_a_key_point() {
        let (range, decades) = crate::output::plot::decade_axis(2300.0, 260_000.0, 1.15);
        assert_eq!(range, 1e3..1e6);
        assert_eq!(decades, vec![1e3, 1e4, 1e5, 1e6]);
        let labels: Vec<String> = [1e-7, 1e-1, 1.0, 10.0, 1000.0, 1e6].iter().map(|&v| crate::output::plot::decade_label(v)).collect();
        assert_eq!(labels, ["1e-7", "1e-1", "1", "10", "1,000", "1,000,000"]);
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_settings() {
        let mut ps = vec![point(1.0, 0.5), point(2.0, 0.1), point(3.0, 0.2), point(4.0, 0.01), point(2.0, 0.1)];
        mark_pareto(&mut ps);
        let front: Vec<bool> = ps.iter().map(|p| p.pareto).collect();
        assert_eq!(front, vec![true, true, false, true, true]);
    }
}
