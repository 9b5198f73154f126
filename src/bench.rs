//! The benchmark protocol of docs/benchmark-protocol.md: the same seeded rays for every
//! method in one run, compared with the f64 reference.

use std::sync::Arc;

use anyhow::Result;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;

use crate::field::Field;
use crate::field::march::{MarchSettings, march};
use crate::field::reference::{ReferenceOptions, crossings};
use crate::gpu::Context;
use crate::layout::{FLAG_HIT, GpuRay, GpuResult};
use crate::method::Method;
use crate::output::MarchStats;
use crate::render::index::IndexStats;
use crate::render::rays::{Ray, camera_rays, protocol_rays};
use crate::render::{MarchOptions, Renderer, light};
use crate::scene::{Kernel, Primitive, Scene};
use crate::settings::QuadSettings;
use crate::stats::{median, range};

/// docs/benchmark-protocol.md: 1,048,576 rays unless told otherwise.
pub const DEFAULT_RAYS: usize = 1 << 20;
pub const DEFAULT_SEED: u64 = 20230601;
/// A smaller ray set, for a sweep (`tradeoff`) or an interactive
/// comparison (the Python package's `bench`).
pub const SAMPLE_RAYS: usize = 16_384;
/// `bench --any-hit` on a scene without shadows or occlusion: occlusion
/// rays per hit (and shadows).
pub const DEFAULT_AO_SAMPLES: u32 = 8;

#[derive(Clone, Debug, Serialize)]
pub struct MethodReport {
    pub method: String,
    pub steps_per_ray: f64,
    pub evals_per_ray: f64,
    pub refine_per_ray: f64,
    /// Loop turns (steps and refinement evaluations) and list positions
    /// visited per ray (see `MarchStats`).
    pub turns_per_ray: f64,
    pub visits_per_ray: f64,
    /// GPU time per ray: the median over repeats (`None` without GPU
    /// timestamps), then every repeat's, the fastest and the slowest.
    pub ns_per_ray: Option<f64>,
    pub ns_per_ray_runs: Vec<f64>,
    pub ns_per_ray_min: Option<f64>,
    pub ns_per_ray_max: Option<f64>,
    pub hit_rate: f64,
    /// The reference finds a crossing that the method misses or reports
    /// later than the reference plus the minimum step.
    pub miss_rate: f64,
    /// The method reports a crossing earlier than the reference minus the
    /// refinement tolerance (or where the reference finds none).
    pub false_hit_rate: f64,
    pub mean_abs_error: f64,
    pub max_abs_error: f64,
    pub out_of_steps_rate: f64,
    /// Ratios to the first method of the run; the time ratio is the median
    /// over repeats of the ratio measured within each repeat, then the
    /// smallest and largest of those.
    pub step_ratio: f64,
    pub time_ratio: Option<f64>,
    pub time_ratio_min: Option<f64>,
    pub time_ratio_max: Option<f64>,
    /// Mean over marching steps of the fraction of the requested interval
    /// that validity intervals keep, from the f64 mirror of the march on
    /// the first `VALIDITY_SAMPLE_RAYS` rays (`quadratic` on scenes with
    /// Gaussians only).
    pub validity_kept: Option<f64>,
    /// `bench --any-hit`: steps per shadow and per occlusion ray, and the
    /// agreement of the answers with the reference's (the miss and
    /// false-hit rates are then the two kinds of disagreement).
    pub any_hit: Option<AnyHitFigures>,
}

/// Rays of the f64 mirror march that measures validity intervals.
pub const VALIDITY_SAMPLE_RAYS: usize = 8192;

/// One way to run a method: the settings a benchmark may compare.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    pub cull: bool,
    pub quad: QuadSettings,
    /// Pipelines not specialised to the scene's kernels and operators.
    pub generic: bool,
}

impl Variant {
    /// How the GPU marches `scene` in this variant (unshaded: a benchmark
    /// reads hits and counts only).
    pub fn options(&self, scene: &Scene) -> MarchOptions {
        MarchOptions { shade: false, cull: self.cull, quad: self.quad, generic: self.generic, ..MarchOptions::for_scene(scene) }
    }

    /// Does this variant differ from `other` in a way that changes
    /// `method` on `scene`?
    fn matters(&self, other: &Variant, method: Method, scene: &Scene) -> bool {
        let extends = method.exp_upper().is_some() || matches!(method, Method::LinearTaylor | Method::QuadraticTaylor);
        let gaussians = scene.has_gaussians();
        let compacts = scene.primitives().any(|p| !matches!(p, Primitive::Point { kernel: Kernel::Gaussian { .. }, .. }));
        self.cull != other.cull
            || self.generic != other.generic
            || (extends && compacts && self.quad.extension != other.quad.extension)
            || (method == Method::Quadratic && gaussians && self.quad.validity != other.quad.validity)
    }

    /// The label suffix that tells this variant from `default`.
    fn suffix(&self, default: &Variant) -> String {
        let mut parts = Vec::new();
        if self.cull != default.cull {
            parts.push(if self.cull { "cull" } else { "no cull" }.to_string());
        }
        if self.quad.extension != default.quad.extension {
            parts.push(if self.quad.extension { "extension" } else { "no extension" }.to_string());
        }
        if self.quad.validity != default.quad.validity {
            parts.push(format!("validity: {}", self.quad.validity.name()));
        }
        if self.generic != default.generic {
            parts.push(if self.generic { "generic" } else { "specialised" }.to_string());
        }
        if parts.is_empty() { String::new() } else { format!(" ({})", parts.join(", ")) }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub scene: String,
    pub device: String,
    pub rays: usize,
    pub seed: u64,
    /// The frame whose camera rays were sampled (`bench --camera-rays`); `null`
    /// for the protocol's rays.
    pub camera: Option<(u32, u32)>,
    /// Times the methods ran, interleaved (method after method, then again).
    pub repeats: usize,
    pub min_step: f64,
    pub max_steps: u32,
    pub reference_hit_rate: f64,
    /// Transparent scenes: the reference's crossings per ray (miss and
    /// false-hit rates are then per reference crossing).
    pub reference_crossings: Option<f64>,
    pub methods: Vec<MethodReport>,
    /// The spatial index every method walked (`null` in JSON for scenes
    /// of at most 64 primitives, which march without one); built once,
    /// the scene being posed at time 0.
    pub index: Option<IndexStats>,
    /// `bench --any-hit`: the shadow and occlusion rays every method
    /// marched instead of the ray set (`rays` is then the ray set they
    /// were cast from; per-ray figures are per any-hit ray).
    pub any_hit: Option<AnyHitSetup>,
}

fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg:>22} [{bar:30}] {pos}/{len} rays ({per_sec}, {eta} left)")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

/// The reference's first hit for every ray (`None`: no crossing).
pub fn reference_hits(scene: &Scene, rays: &[GpuRay], show_progress: bool) -> Vec<Option<f64>> {
    reference_crossings(scene, rays, true, show_progress).into_iter().map(|c| c.first().copied()).collect()
}

/// Every crossing the reference finds along every ray, in order (only the
/// first with `first_only`).
pub fn reference_crossings(scene: &Scene, rays: &[GpuRay], first_only: bool, show_progress: bool) -> Vec<Vec<f64>> {
    let field = Field::new(scene);
    let opts = ReferenceOptions::for_min_radius(scene.min_radius());
    let bar = if show_progress { progress(rays.len() as u64, "f64 reference") } else { ProgressBar::hidden() };
    let out = rays
        .par_iter()
        .map(|r| {
            let ray = Ray::from_gpu(r);
            let found = if ray.misses() { Vec::new() } else { crossings(&field, ray.o, ray.d, ray.t0, ray.t1, opts, first_only) };
            bar.inc(1);
            found.into_iter().map(|c| c.t).collect()
        })
        .collect();
    bar.finish_and_clear();
    out
}

/// Accuracy of one method's results against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accuracy {
    pub misses: usize,
    pub false_hits: usize,
    pub mean_abs_error: f64,
    pub max_abs_error: f64,
}

/// The window around a reference crossing in which a found crossing is that
/// crossing, as `(late_by, early_by)` for [`accuracy`] and
/// [`accuracy_all`]; the one definition `bench`, `tradeoff` and `scaling`
/// count misses and false hits with. Refinement reports a crossing on the
/// far side of its root, at most the refinement `tolerance` past it; four
/// tolerances plus 1e-5 (f32 rounding of t on the GPU) cover that and the
/// reference's own position. A crossing may be found up to a minimum step
/// late, so the late side is the larger of the two: a hit within the
/// tolerance is never a miss, however small the minimum step.
pub fn match_window(min_step: f64, tolerance: f64) -> (f64, f64) {
    let slack = 4.0 * tolerance;
    (min_step.max(slack) + 1e-5, slack + 1e-5)
}

/// Compares hits with the reference: a miss is a reference crossing found
/// late (beyond `late_by`) or not at all; a false hit is a crossing earlier
/// than the reference by more than `early_by`, or where it has none.
pub fn accuracy(results: &[GpuResult], reference: &[Option<f64>], late_by: f64, early_by: f64) -> Accuracy {
    let mut a = Accuracy::default();
    let (mut sum, mut n) = (0.0, 0usize);
    for (r, reference) in results.iter().zip(reference) {
        let hit = (r.counts[3] & FLAG_HIT != 0).then_some(f64::from(r.hit[3]));
        match (hit, *reference) {
            (Some(t), Some(tr)) => {
                if t > tr + late_by {
                    a.misses += 1;
                } else if t < tr - early_by {
                    a.false_hits += 1;
                }
                let e = (t - tr).abs();
                sum += e;
                n += 1;
                a.max_abs_error = a.max_abs_error.max(e);
            }
            (None, Some(_)) => a.misses += 1,
            (Some(_), None) => a.false_hits += 1,
            (None, None) => {}
        }
    }
    a.mean_abs_error = if n > 0 { sum / n as f64 } else { 0.0 };
    a
}

/// Compares every crossing with the reference's (transparent rendering):
/// in order along each ray, a reference crossing is matched by the next
/// found crossing within `[tr - early_by, tr + late_by]`; unmatched
/// reference crossings are misses, unmatched found ones false hits.
pub fn accuracy_all(found: &[Vec<f32>], reference: &[Vec<f64>], late_by: f64, early_by: f64) -> Accuracy {
    let mut a = Accuracy::default();
    let (mut sum, mut n) = (0.0, 0usize);
    for (found, reference) in found.iter().zip(reference) {
        let mut next = 0;
        for &tr in reference {
            // Found crossings well before this one match nothing.
            while next < found.len() && f64::from(found[next]) < tr - early_by {
                a.false_hits += 1;
                next += 1;
            }
            match found.get(next).map(|&t| f64::from(t)) {
                Some(t) if t <= tr + late_by => {
                    let e = (t - tr).abs();
                    sum += e;
                    n += 1;
                    a.max_abs_error = a.max_abs_error.max(e);
                    next += 1;
                }
                _ => a.misses += 1,
            }
        }
        a.false_hits += found.len() - next;
    }
    a.mean_abs_error = if n > 0 { sum / n as f64 } else { 0.0 };
    a
}

/// What a benchmark runs: its methods, the variants each runs in, the
/// ray set and how many times.
#[derive(Clone, Debug)]
pub struct Plan<'a> {
    pub methods: &'a [Method],
    pub variants: &'a [Variant],
    pub rays: usize,
    pub seed: u64,
    /// The whole list of rows runs this many times, interleaved, so that a
    /// slow spell of the machine hits every method alike.
    pub repeats: usize,
    /// Sample the scene camera's pixel rays at this resolution instead of
    /// the protocol's rays.
    pub camera: Option<(u32, u32)>,
    /// Benchmark the any-hit query instead: the scene's shadow and
    /// occlusion rays cast from the reference's hits of the ray set (both,
    /// with `DEFAULT_AO_SAMPLES` occlusion rays, where the scene asks for
    /// neither).
    pub any_hit: bool,
}

impl Plan<'_> {
    /// One-line errors for a plan that cannot run, named by the command
    /// line's flags (the Python package's `bench` checks the same).
    pub fn check(&self) -> Result<()> {
        anyhow::ensure!(!self.methods.is_empty(), "--methods names no marcher");
        anyhow::ensure!(self.rays >= 1, "--rays must be at least 1");
        anyhow::ensure!(self.repeats >= 1, "--repeat must be at least 1");
        if self.any_hit {
            check_any_hit_methods(self.methods)?;
        }
        Ok(())
    }
}

/// `--any-hit` (bench, tradeoff): one-line error for a method of `methods`
/// that cannot march rays starting on a surface (the bisection baselines).
pub fn check_any_hit_methods(methods: &[Method]) -> Result<()> {
    if let Some(m) = methods.iter().find(|m| matches!(m, Method::LinearBisection | Method::Raa)) {
        anyhow::bail!("--any-hit: {m} cannot march shadow and occlusion rays (they start on a surface); leave it out of --methods");
    }
    Ok(())
}

/// Runs every method on the same protocol rays and compares them. Each
/// method runs in each of `variants` that changes it (the first is the
/// default; rows of the others are marked, e.g. "no cull"). Counts and
/// accuracy come from the first repeat (marching is deterministic: the
/// later repeats only time it again).
pub fn run(ctx: &Arc<Context>, scene: &Scene, plan: &Plan, timeout: std::time::Duration) -> Result<BenchReport> {
    let Plan { methods, variants, rays, seed, repeats, camera, any_hit } = *plan;
    anyhow::ensure!(repeats >= 1, "the benchmark must run at least once");
    // The GPU's coordinates centred on the box the rays aim at (f32).
    let recentred = scene.recentred(scene.bounds.center());
    let scene = &if any_hit { with_any_hit_defaults(recentred) } else { recentred };
    let mut ray_set = match camera {
        None => protocol_rays(&scene.bounds, rays, seed),
        Some((w, h)) => camera_sample(scene, w, h, rays, seed)?,
    };
    let transparent = scene.transparency.is_some();
    anyhow::ensure!(
        !(any_hit && transparent),
        "--any-hit: {} is transparent, and transparent scenes cast no shadow rays (--opaque marches it as an opaque scene)",
        scene.source
    );
    let mut any_hit_setup = None;
    let mut owners = Vec::new();
    let mut primary_hit_rate = None;
    if any_hit {
        let (cast, first) = any_hit_rays(scene, &ray_set);
        primary_hit_rate = Some(first.iter().filter(|h| h.is_some()).count() as f64 / rays.max(1) as f64);
        anyhow::ensure!(!cast.rays.is_empty(), "--any-hit: no ray of the set hits {}, so none casts shadow or occlusion rays", scene.source);
        any_hit_setup = Some(AnyHitSetup::of(scene, &cast));
        (ray_set, owners) = (cast.rays, cast.owners);
    }
    let reference = reference_crossings(scene, &ray_set, !transparent, true);
    if let Some(setup) = &mut any_hit_setup {
        setup.reference_occluded = reference.iter().filter(|c| !c.is_empty()).count() as f64 / ray_set.len() as f64;
    }
    let options = |variant: Variant| if any_hit { light::any_hit_options(variant.options(scene)) } else { variant.options(scene) };
    let mut renderer = Renderer::with_timeout(ctx, scene, timeout)?;
    let default = variants.first().copied().unwrap_or(Variant { cull: true, quad: scene.marching.quad, generic: false });
    let mut rows: Vec<(Method, Variant)> = Vec::new();
    for &method in methods {
        let mut done: Vec<Variant> = Vec::new();
        for &variant in variants {
            if done.iter().any(|d| !variant.matters(d, method, scene)) {
                continue;
            }
            done.push(variant);
            rows.push((method, variant));
        }
    }
    let mut reports: Vec<MethodReport> = Vec::new();
    let mut times: Vec<Vec<Option<f64>>> = vec![Vec::new(); rows.len()];
    for repeat in 0..repeats {
        for (i, &(method, variant)) in rows.iter().enumerate() {
            let mut label = format!("{method}{}", variant.suffix(&default));
            if repeats > 1 {
                label.push_str(&format!(" [{}/{repeats}]", repeat + 1));
            }
            if repeat == 0 {
                let row = Row { method, variant, options: options(variant), default };
                let r = run_one(&mut renderer, scene, row, &ray_set, &owners, &reference, reports.first(), &label)?;
                times[i].push(r.ns_per_ray);
                reports.push(r);
            } else {
                let bar = progress(rays as u64, &label);
                let out = renderer.march(method, options(variant), &ray_set, |done| bar.set_position(done as u64))?;
                bar.finish_and_clear();
                times[i].push(MarchStats::of(&out.results, out.gpu_ns).ns_per_ray);
            }
        }
    }
    summarise_times(&mut reports, &times);
    let ref_hits = reference.iter().filter(|r| !r.is_empty()).count();
    Ok(BenchReport {
        scene: scene.source.clone(),
        device: ctx.info.name.clone(),
        rays,
        seed,
        camera,
        repeats,
        min_step: scene.marching.min_step,
        max_steps: scene.marching.max_steps,
        // With --any-hit, of the rays they were cast from.
        reference_hit_rate: primary_hit_rate.unwrap_or(ref_hits as f64 / rays.max(1) as f64),
        reference_crossings: transparent.then(|| reference.iter().map(Vec::len).sum::<usize>() as f64 / rays.max(1) as f64),
        methods: reports,
        index: renderer.index_stats(),
        any_hit: any_hit_setup,
    })
}

/// `scene`, casting shadow rays and `DEFAULT_AO_SAMPLES` occlusion rays
/// where it asks for neither: what an any-hit benchmark measures.
pub fn with_any_hit_defaults(mut scene: Scene) -> Scene {
    if !scene.shadows && scene.ao.is_none() {
        scene.shadows = true;
        scene.ao = Some(crate::scene::Ao { samples: DEFAULT_AO_SAMPLES, distance: scene.default_ao_distance() });
    }
    scene
}

/// One row of the benchmark: a method, the variant it runs in and the
/// march options that makes.
struct Row {
    method: Method,
    variant: Variant,
    options: MarchOptions,
    default: Variant,
}

/// The any-hit rays of `bench --any-hit`: the scene's shadow and occlusion
/// rays ([`light::spawn`]) cast from the f64 reference's first hit of each
/// of `primary`, with the field's gradient there as the normal; every
/// method marches these same rays.
pub fn any_hit_rays(scene: &Scene, primary: &[GpuRay]) -> (light::AnyHitRays, Vec<Option<f64>>) {
    let field = Field::new(scene);
    let first = reference_hits(scene, primary, true);
    let hits: Vec<Option<(f64, DVec3)>> = first
        .iter()
        .copied()
        .zip(primary)
        .map(|(hit, r)| {
            let ray = Ray::from_gpu(r);
            hit.map(|t| (t, field.value_gradient(ray.o + t * ray.d).1))
        })
        .collect();
    (light::spawn(scene, primary, &hits), first)
}

/// What `bench --any-hit` cast.
#[derive(Clone, Debug, Serialize)]
pub struct AnyHitSetup {
    pub shadow_rays: usize,
    pub ao_rays: usize,
    /// How far occlusion rays look (`null`: no occlusion rays).
    pub ao_distance: Option<f64>,
    /// How far off the surface each starts.
    pub start_offset: f64,
    /// The fraction of them the reference finds occluded.
    pub reference_occluded: f64,
}

impl AnyHitSetup {
    fn of(scene: &Scene, cast: &light::AnyHitRays) -> AnyHitSetup {
        let shadows = cast.owners.iter().filter(|(_, k)| matches!(k, light::Kind::Shadow(_))).count();
        AnyHitSetup {
            shadow_rays: shadows,
            ao_rays: cast.rays.len() - shadows,
            ao_distance: scene.ao.map(|a| a.distance),
            start_offset: light::start_offset(scene),
            reference_occluded: 0.0,
        }
    }
}

/// One method's any-hit figures in `bench --any-hit`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AnyHitFigures {
    pub shadow_steps_per_ray: f64,
    pub ao_steps_per_ray: f64,
    /// The fraction of rays whose answer (occluded or not) is the
    /// reference's.
    pub agreement: f64,
    /// The others, by cause.
    pub disagreements: AnyHitDisagreements,
}

/// Compares any-hit answers with the reference's crossings: a ray is
/// occluded when the reference finds a crossing on it. A disagreement is
/// explained when that crossing lies within the minimum step of the ray's
/// start or end (a minimum step may pass it there, and f32 may start the
/// ray on the other side), or when the reference's first chord inside the
/// surface is shorter than the minimum step (a grazing ray: a step forced
/// to the minimum may pass over it, as on camera rays); the others are
/// unexplained.
pub fn any_hit_accuracy(scene: &Scene, rays: &[GpuRay], results: &[GpuResult], reference: &[Vec<f64>]) -> (Accuracy, AnyHitDisagreements) {
    let min_step = scene.marching.min_step;
    let field = Field::new(scene);
    let opts = ReferenceOptions::for_min_radius(scene.min_radius());
    let (mut a, mut d) = (Accuracy::default(), AnyHitDisagreements::default());
    for ((gpu, r), reference) in rays.iter().zip(results).zip(reference) {
        let found = light::occluded(gpu, r);
        let tr = reference.first().copied();
        if found == tr.is_some() {
            continue;
        }
        if found {
            a.false_hits += 1;
        } else {
            a.misses += 1;
        }
        let ray = Ray::from_gpu(gpu);
        let Some(tr) = tr else {
            d.unexplained += 1;
            continue;
        };
        if tr - ray.t0 <= min_step || ray.t1 - tr <= min_step {
            d.at_ends += 1;
            continue;
        }
        let all = crossings(&field, ray.o, ray.d, ray.t0, ray.t1, opts, false);
        match all.get(1) {
            Some(leave) if leave.t - tr < min_step => d.thin += 1,
            _ => d.unexplained += 1,
        }
    }
    (a, d)
}

/// The any-hit disagreements with the reference, by cause.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AnyHitDisagreements {
    /// The reference's crossing within the minimum step of the ray's
    /// start or end.
    pub at_ends: usize,
    /// Elsewhere, on a chord inside the surface shorter than the minimum
    /// step.
    pub thin: usize,
    /// Neither.
    pub unexplained: usize,
}

/// One row of the benchmark on the ray set (`owners`: what each any-hit
/// ray stands for; empty for camera and protocol rays).
#[allow(clippy::too_many_arguments)]
fn run_one(
    renderer: &mut Renderer,
    scene: &Scene,
    row: Row,
    ray_set: &[GpuRay],
    owners: &[(usize, light::Kind)],
    reference: &[Vec<f64>],
    first: Option<&MethodReport>,
    label: &str,
) -> Result<MethodReport> {
    let Row { method, variant, options, default } = row;
    let rays = ray_set.len();
    {
        let bar = progress(rays as u64, label);
        let out = renderer.march(method, options, ray_set, |done| bar.set_position(done as u64))?;
        bar.finish_and_clear();
        let stats = MarchStats::of(&out.results, out.gpu_ns);
        let (late, early) = match_window(scene.marching.min_step, scene.refine_tolerance());
        let mut any_hit = None;
        let (acc, n) = if options.any_hit {
            let (acc, disagreements) = any_hit_accuracy(scene, ray_set, &out.results, reference);
            let (mut shadow, mut ao) = ((0u64, 0u64), (0u64, 0u64));
            for ((_, kind), r) in owners.iter().zip(&out.results) {
                let tally = if matches!(kind, light::Kind::Shadow(_)) { &mut shadow } else { &mut ao };
                *tally = (tally.0 + 1, tally.1 + u64::from(r.counts[0]));
            }
            let per = |(rays, steps): (u64, u64)| if rays > 0 { steps as f64 / rays as f64 } else { 0.0 };
            let n = rays.max(1) as f64;
            let agreement = 1.0 - (acc.misses + acc.false_hits) as f64 / n;
            any_hit = Some(AnyHitFigures { shadow_steps_per_ray: per(shadow), ao_steps_per_ray: per(ao), agreement, disagreements });
            (acc, n)
        } else if scene.transparency.is_some() {
            (accuracy_all(&out.crossings, reference, late, early), reference.iter().map(Vec::len).sum::<usize>().max(1) as f64)
        } else {
            let first: Vec<Option<f64>> = reference.iter().map(|c| c.first().copied()).collect();
            (accuracy(&out.results, &first, late, early), rays.max(1) as f64)
        };
        let validity_kept =
            (method == Method::Quadratic && scene.has_gaussians() && !options.any_hit).then(|| validity_kept(scene, method, variant.quad, ray_set));
        Ok(MethodReport {
            method: format!("{method}{}", variant.suffix(&default)),
            steps_per_ray: stats.steps_per_ray,
            evals_per_ray: stats.evals_per_ray,
            refine_per_ray: stats.refine_per_ray,
            turns_per_ray: stats.turns_per_ray,
            visits_per_ray: stats.visits_per_ray,
            ns_per_ray: stats.ns_per_ray,
            ns_per_ray_runs: Vec::new(),
            ns_per_ray_min: None,
            ns_per_ray_max: None,
            hit_rate: stats.hit_rate,
            miss_rate: acc.misses as f64 / n,
            false_hit_rate: acc.false_hits as f64 / n,
            mean_abs_error: acc.mean_abs_error,
            max_abs_error: acc.max_abs_error,
            out_of_steps_rate: stats.out_of_steps_rate,
            step_ratio: first.map_or(1.0, |f| stats.steps_per_ray / f.steps_per_ray),
            time_ratio: None,
            time_ratio_min: None,
            time_ratio_max: None,
            validity_kept,
            any_hit,
        })
    }
}

/// Fills each row's time figures from `times[row][repeat]` (GPU ns per
/// ray; `None` without timestamps): the median and range over repeats, and
/// the ratio to the first row as the median of per-repeat ratios.
fn summarise_times(reports: &mut [MethodReport], times: &[Vec<Option<f64>>]) {
    let runs: Vec<Option<Vec<f64>>> = times.iter().map(|t| t.iter().copied().collect()).collect();
    for (r, ns) in reports.iter_mut().zip(&runs) {
        let Some(ns) = ns else {
            r.ns_per_ray = None;
            continue;
        };
        let (lo, hi) = range(ns);
        r.ns_per_ray = Some(median(ns));
        r.ns_per_ray_runs = ns.clone();
        (r.ns_per_ray_min, r.ns_per_ray_max) = (Some(lo), Some(hi));
        if let Some(Some(base)) = runs.first() {
            let ratios: Vec<f64> = ns.iter().zip(base).map(|(a, b)| a / b).collect();
            let (lo, hi) = range(&ratios);
            r.time_ratio = Some(median(&ratios));
            (r.time_ratio_min, r.time_ratio_max) = (Some(lo), Some(hi));
        }
    }
}

/// The mean fraction of the requested interval kept by validity intervals
/// per marching step, from the f64 mirror of the march on the first
/// `VALIDITY_SAMPLE_RAYS` rays.
fn validity_kept(scene: &Scene, method: Method, quad: QuadSettings, rays: &[GpuRay]) -> f64 {
    let field = Field::new(scene);
    let settings = MarchSettings { quad, ..MarchSettings::for_scene(scene, method) };
    let (kept, steps) = rays
        .par_iter()
        .take(VALIDITY_SAMPLE_RAYS)
        .map(|r| {
            let ray = Ray::from_gpu(r);
            if ray.misses() {
                return (0.0, 0);
            }
            let m = march(&field, method, ray.o, ray.d, ray.t0, ray.t1, settings);
            (m.kept, m.steps)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    kept / f64::from(steps.max(1))
}

/// `count` of the camera's pixel rays for a `width` x `height` frame,
/// chosen at random without repeats (seeded), in pixel order.
fn camera_sample(scene: &Scene, width: u32, height: u32, count: usize, seed: u64) -> Result<Vec<GpuRay>> {
    use rand::SeedableRng;
    let (all, pixels) = camera_rays(&scene.camera, width, height, &scene.bounds);
    let rays: Vec<(u32, GpuRay)> = all.into_iter().zip(pixels).filter_map(|(r, p)| p.map(|p| (p, r))).collect();
    anyhow::ensure!(count <= rays.len(), "--camera-rays: {count} rays asked of a {width}x{height} frame, which has {}", rays.len());
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let mut picked: Vec<(u32, GpuRay)> = rand::seq::index::sample(&mut rng, rays.len(), count).into_iter().map(|i| rays[i]).collect();
    picked.sort_by_key(|&(p, _)| p);
    Ok(picked.into_iter().map(|(_, r)| r).collect())
}

/// The report as a markdown table.
pub fn markdown(report: &BenchReport) -> String {
    let base = report.methods.first().map_or("-", |m| m.method.as_str());
    let kind = report.camera.map_or(String::new(), |(w, h)| format!(" of the camera's {w}x{h} frame"));
    let mut s = format!(
        "scene `{}`, {} rays{kind} (seed {}), minimum step {}, maximum steps {}, device {}; reference hit rate {:.4}\n\n",
        report.scene, report.rays, report.seed, report.min_step, report.max_steps, report.device, report.reference_hit_rate
    );
    if report.repeats > 1 {
        s.push_str(&format!(
            "{} repeats, interleaved: ns/ray is the median over repeats (fastest–slowest), time vs {base} the median of the \
             ratios measured within each repeat (smallest–largest).\n\n",
            report.repeats
        ));
    }
    if let Some(a) = &report.any_hit {
        s.push_str(&format!(
            "Any-hit query: {} shadow rays and {} occlusion rays{} cast from the reference's hits of these rays, each starting {:.2e} off \
             the surface; the reference finds {:.4} of them occluded. Figures are per any-hit ray; a miss is an occluded ray found \
             clear, a false hit the reverse.\n\n",
            a.shadow_rays,
            a.ao_rays,
            a.ao_distance.map_or(String::new(), |d| format!(" (looking {d} far)")),
            a.start_offset,
            a.reference_occluded
        ));
    }
    if let Some(c) = report.reference_crossings {
        s.push_str(&format!(
            "Transparent: every crossing to the box exit; the reference finds {c:.3} crossings per ray, and miss and false-hit rates are per reference crossing.\n\n"
        ));
    }
    s.push_str(&format!(
        "| method | steps/ray | evals/ray | refine/ray | ns/ray | ns/eval | ns/turn | visits/eval | hit rate | miss rate | false hits | mean err | max err | steps vs {base} | time vs {base} |\n"
    ));
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    let spread = report.repeats > 1;
    let ns = |m: &MethodReport| match (m.ns_per_ray, m.ns_per_ray_min, m.ns_per_ray_max) {
        (Some(v), Some(lo), Some(hi)) if spread => format!("{v:.1} ({lo:.0}–{hi:.0})"),
        (Some(v), ..) => format!("{v:.1}"),
        _ => "n/a".to_string(),
    };
    let ratio = |m: &MethodReport| match (m.time_ratio, m.time_ratio_min, m.time_ratio_max) {
        (Some(r), Some(lo), Some(hi)) if spread => format!("{r:.3}x ({lo:.3}–{hi:.3})"),
        (Some(r), ..) => format!("{r:.3}x"),
        _ => "n/a".to_string(),
    };
    // An any-hit query's answer is a yes or no, not a distance: its rows
    // have no error to show.
    let error = |e: f64| if report.any_hit.is_some() { "n/a".to_string() } else { format!("{e:.2e}") };
    for m in &report.methods {
        // The median time per ray over `count` units of work per ray.
        let per = |count: f64| m.ns_per_ray.filter(|_| count > 0.0).map_or("n/a".to_string(), |ns| format!("{:.1}", ns / count));
        s.push_str(&format!(
            "| {} | {:.2} | {:.1} | {:.2} | {} | {} | {} | {:.2} | {:.4} | {:.5} | {:.5} | {} | {} | {:.3}x | {} |\n",
            m.method,
            m.steps_per_ray,
            m.evals_per_ray,
            m.refine_per_ray,
            ns(m),
            per(m.evals_per_ray),
            per(m.turns_per_ray),
            m.visits_per_ray / m.evals_per_ray.max(1e-9),
            m.hit_rate,
            m.miss_rate,
            m.false_hit_rate,
            error(m.mean_abs_error),
            error(m.max_abs_error),
            m.step_ratio,
            ratio(m),
        ));
    }
    if report.any_hit.is_some() {
        s.push_str(
            "\n| method | steps/shadow ray | steps/occlusion ray | agreement | disagreements at the ends | on chords under the minimum step | unexplained |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
        );
        for m in &report.methods {
            let a = m.any_hit.unwrap_or_default();
            let d = a.disagreements;
            s.push_str(&format!(
                "| {} | {:.2} | {:.2} | {:.5} | {} | {} | {} |\n",
                m.method, a.shadow_steps_per_ray, a.ao_steps_per_ray, a.agreement, d.at_ends, d.thin, d.unexplained
            ));
        }
    }
    if let Some(i) = &report.index {
        s.push_str(&format!("\n{}\n", index_line(i)));
    }
    let mut first = true;
    for m in report.methods.iter().filter(|m| m.validity_kept.is_some()) {
        s.push_str(if std::mem::take(&mut first) { "\n" } else { "" });
        s.push_str(&format!(
            "{}: validity intervals keep {:.3} of the requested interval per step (mean; f64 mirror, first {} rays)\n",
            m.method,
            m.validity_kept.unwrap_or(1.0),
            VALIDITY_SAMPLE_RAYS.min(report.rays)
        ));
    }
    s
}

/// The spatial index in one line, for the footer of `bench`'s table.
pub fn index_line(i: &IndexStats) -> String {
    let build = if i.build_ns.is_finite() { format!("{:.3} ms", i.build_ns * 1e-6) } else { "n/a (no GPU timestamps)".into() };
    format!(
        "Spatial index: {} cells of size {:.3}, {} entries (longest list {}), {:.1} bytes per primitive; GPU build {build} per frame. \
         Every ray here walks it: rays sampled from a frame are not whole 8x8 tiles, so the camera's tile lists that `render` uses for \
         molecules and particles (its --stats say which) do not apply",
        i.cells, i.cell_size, i.entries, i.longest_list, i.bytes_per_primitive
    )
}
