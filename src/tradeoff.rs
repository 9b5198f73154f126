//! The speed-accuracy trade: every method at every minimum step and step
//! budget on one seeded ray set, timed on the GPU and compared with the f64
//! reference; CSV out, and a plot of time per ray against error with the
//! Pareto front marked.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Result, bail};
use serde::Serialize;

use crate::bench::{accuracy_all, match_window, reference_crossings};
use crate::gpu::Context;
use crate::layout::FLAG_HIT;
use crate::method::Method;
use crate::output::MarchStats;
use crate::render::{MarchOptions, Renderer};
use crate::render::rays::protocol_rays;
use crate::scene::Scene;

/// The settings a sweep covers.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub methods: Vec<Method>,
    pub min_steps: Vec<f64>,
    pub max_steps: Vec<u32>,
    pub rays: usize,
    pub seed: u64,
}

impl Sweep {
    /// The full sweep: minimum steps 1e-4 to 1, step budgets 8 to 10,000.
    pub fn full(methods: Vec<Method>) -> Sweep {
        Sweep { methods, min_steps: vec![1e-4, 1e-3, 1e-2, 0.1, 1.0], max_steps: vec![8, 32, 128, 1000, 10_000], rays: 16_384, seed: 20230601 }
    }

    /// A few settings on few rays, for CI.
    pub fn quick(methods: Vec<Method>) -> Sweep {
        Sweep { methods, min_steps: vec![0.01, 0.1], max_steps: vec![32, 1000], rays: 1024, seed: 20230601 }
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
    let scene = &scene.recentred(scene.bounds.center());
    let rays = protocol_rays(&scene.bounds, sweep.rays, sweep.seed);
    let transparent = scene.transparency.is_some();
    let reference = reference_crossings(scene, &rays, !transparent, false);
    let size = scene.bounds.diagonal();
    let mut renderer = Renderer::new(ctx, scene)?;
    renderer.timeout = timeout;
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
                let out = renderer.march(method, options, &rays, |_| {})?;
                let stats = MarchStats::of(&out.results, out.gpu_ns);
                let (mut errors, mut misses, mut false_hits, mut either) = (Vec::new(), 0usize, 0usize, 0usize);
                for (r, reference) in out.results.iter().zip(&reference) {
                    let hit = (r.counts[3] & FLAG_HIT != 0).then_some(f64::from(r.hit[3]));
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
                let missed_crossings = transparent.then(|| {
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
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
    let x_desc = if points.iter().all(|p| p.ns_per_ray.is_some()) { "GPU time per ray (ns)" } else { "steps per ray" };
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d((t0 / 1.3..t1 * 1.3).log_scale(), (e0 / 2.0..e1 * 2.0).log_scale())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("error (relative; a miss counts 1)")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut methods: Vec<&str> = Vec::new();
    for p in points {
        if !methods.contains(&p.method.as_str()) {
            methods.push(&p.method);
        }
    }
    for (i, m) in methods.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(points.iter().filter(|p| p.method == *m).map(|p| Circle::new((time(p), err(p)), 4, color.filled())))
            .map_err(|e| anyhow::anyhow!("{e}"))?
            .label(*m)
            .legend(move |(x, y)| Circle::new((x, y), 4, color.filled()));
    }
    let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.pareto).map(|p| (time(p), err(p))).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2)))
        .map_err(|e| anyhow::anyhow!("{e}"))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(front.iter().map(|&(x, y)| Circle::new((x, y), 7, BLACK.stroke_width(1))))
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
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
    fn the_pareto_front_keeps_only_undominated_settings() {
        let mut ps = vec![point(1.0, 0.5), point(2.0, 0.1), point(3.0, 0.2), point(4.0, 0.01), point(2.0, 0.1)];
        mark_pareto(&mut ps);
        let front: Vec<bool> = ps.iter().map(|p| p.pareto).collect();
        assert_eq!(front, vec![true, true, false, true, true]);
    }
}
