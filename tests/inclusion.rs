//! Proof of the forward inclusion functions: on the GPU (bounds probe) and
//! on the f64 mirror, with the same cases, each bound is exact at t0 and
//! contains dense f64 samples of the field over its interval; the GPU's
//! Taylor bounds equal the f64 closed forms.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::field::Field;
use isomarch::field::bound::Bound;
use isomarch::field::bounds::Order;
use isomarch::field::fold::field_bound;
use isomarch::field::quad::{QuadSettings, ValidityScope};
use isomarch::layout::GpuRay;
use isomarch::render::rays::{Ray, protocol_rays};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::{Primitive, Scene};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

const DEFAULT: QuadSettings = QuadSettings { extension: true, validity: ValidityScope::Significant };

/// Every inclusion method with a forward bound of its own; the Taylor and
/// bottom-up quadratic ones also without the per-primitive extension of
/// compact kernels, and bottom-up quadratic with validity intervals for
/// every Gaussian.
const INCLUSION: [(Method, QuadSettings); 10] = [
    (Method::LinearTaylor, DEFAULT),
    (Method::LinearTaylor, QuadSettings { extension: false, ..DEFAULT }),
    (Method::QuadraticTaylor, DEFAULT),
    (Method::QuadraticTaylor, QuadSettings { extension: false, ..DEFAULT }),
    (Method::Linear, DEFAULT),
    (Method::Quadratic, DEFAULT),
    (Method::Quadratic, QuadSettings { extension: false, ..DEFAULT }),
    (Method::Quadratic, QuadSettings { validity: ValidityScope::Every, ..DEFAULT }),
    (Method::QuadraticRelaxedT0, DEFAULT),
    (Method::QuadraticRelaxedMax, DEFAULT),
];

/// `(ray, t0, t1)` queries drawn where the field varies: on protocol rays,
/// t0 uniform on the ray's interval, t1 a random length further; queries
/// that meet no support are kept only up to a third of the set.
fn cases(scene: &Scene, seed: u64, n: usize) -> Vec<GpuRay> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut out = Vec::new();
    let mut away = 0;
    for r in protocol_rays(&scene.bounds, 50 * n, seed) {
        let ray = Ray::from_gpu(&r);
        if ray.misses() || out.len() == n {
            continue;
        }
        let t0 = rng.random_range(ray.t0..=ray.t1);
        let t1 = (t0 + rng.random_range(0.0..=4.0) * rng.random::<f64>()).min(ray.t1);
        let q = GpuRay { o: [r.o[0], r.o[1], r.o[2], t0 as f32], d: [r.d[0], r.d[1], r.d[2], t1 as f32] };
        if !meets_support(scene, &q) {
            if 3 * away >= out.len() {
                continue;
            }
            away += 1;
        }
        out.push(q);
    }
    assert_eq!(out.len(), n, "too few queries");
    out
}

/// Does any compact support, or a Gaussian's bounding radius, meet the query?
fn meets_support(scene: &Scene, q: &GpuRay) -> bool {
    let r = Ray::from_gpu(q);
    scene.primitives().any(|p| match p {
        Primitive::Point { center, kernel } => {
            let tc = (*center - r.o).dot(r.d).clamp(r.t0, r.t1);
            (r.o + tc * r.d - *center).length() < kernel.cutoff(scene.iso)
        }
        // Planes, HRBF terms and affine functions reach everywhere.
        _ => true,
    })
}

struct Checked {
    worst_forward: f64,
    worst_outside: f64,
}

/// Checks forward and containment for `bounds` on `queries`; errors are
/// relative to `scale` (the largest kernel weight sum of a group).
fn check(field: &Field, method: Method, queries: &[GpuRay], bounds: &[Bound], scale: f64) -> Checked {
    let mut c = Checked { worst_forward: 0.0, worst_outside: 0.0 };
    for (q, b) in queries.iter().zip(bounds) {
        let r = Ray::from_gpu(q);
        for x in [b.v, b.a_lo, b.b_lo, b.a_hi, b.b_hi, b.e_hi, b.t_valid] {
            assert!(x.is_finite(), "non-finite bound {b:?} on {r:?}");
        }
        assert!(b.t_valid > r.t0 || r.t1 <= r.t0 || b.t_valid >= r.t1, "{method}: empty validity interval {b:?} on {r:?}");
        // Only the relaxed-t0 upper bound may start above the value.
        if method == Method::QuadraticRelaxedT0 {
            assert!(b.e_hi >= 0.0, "{method}: upper bound starts below the value: {b:?}");
        } else {
            assert!(b.e_hi == 0.0, "{method}: not forward: {b:?}");
        }
        let f0 = field.value(r.o + r.t0 * r.d);
        c.worst_forward = c.worst_forward.max((b.v - f0).abs() / scale);
        let len = (b.t_valid - r.t0).max(0.0);
        for i in 0..=200 {
            let tau = len * f64::from(i) / 200.0;
            let f = field.value(r.o + (r.t0 + tau) * r.d);
            let outside = (b.lo(tau) - f).max(f - b.hi(tau)).max(0.0);
            c.worst_outside = c.worst_outside.max(outside / scale);
        }
    }
    c
}

fn scale(scene: &Scene) -> f64 {
    Field::new(scene).groups.iter().map(|g| g.iter().map(|p| p.magnitude()).sum::<f64>()).fold(0.0, f64::max)
}

fn gpu_bounds(r: &mut Renderer, method: Method, options: MarchOptions, queries: &[GpuRay]) -> Vec<Bound> {
    r.probe_bounds(method, options, queries)
        .unwrap()
        .iter()
        .map(|g| Bound {
            v: g.lo[0].into(),
            a_lo: g.lo[1].into(),
            b_lo: g.lo[2].into(),
            a_hi: g.hi[1].into(),
            b_hi: g.hi[2].into(),
            e_hi: g.hi[3].into(),
            t_valid: g.lo[3].into(),
        })
        .collect()
}

fn f64_bounds(field: &Field, method: Method, quad: QuadSettings, queries: &[GpuRay]) -> Vec<Bound> {
    queries
        .iter()
        .map(|q| {
            let r = Ray::from_gpu(q);
            field_bound(field, method, quad, r.o, r.d, r.t0, r.t1).expect("an inclusion method")
        })
        .collect()
}

fn all_scenes() -> Vec<(String, Scene)> {
    let mut v: Vec<(String, Scene)> = (0..3u64)
        .flat_map(|seed| [false, true].map(|max| (format!("seed {seed} max={max}"), random_scene(seed, max, Method::QuadraticTaylor))))
        .collect();
    v.push(("plane".into(), plane_scene(false)));
    for (seed, max) in [(0u64, false), (1, true)] {
        v.push((format!("hrbf {seed} max={max}"), random_hrbf_scene(seed, max, Method::QuadraticTaylor)));
    }
    v
}

/// Where bounds come from: the GPU's shaders, or their f64 mirror. A suite
/// that holds for both is written once, taking the backend, and
/// instantiated for each by [`per_backend!`], so that a failure names its
/// backend (`inclusion::bounds_contain_the_field::gpu`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Backend {
    Gpu,
    F64,
}

/// `mod SUITE { fn gpu(); fn f64(); }`: the suite `SUITE(Backend)` as a
/// test per backend.
macro_rules! per_backend {
    ($suite:ident) => {
        mod $suite {
            #[test]
            fn gpu() {
                super::$suite(super::Backend::Gpu)
            }

            #[test]
            fn f64() {
                super::$suite(super::Backend::F64)
            }
        }
    };
}

per_backend!(bounds_contain_the_field);

/// Every forward bound is exact at t0 and contains dense samples of the
/// field over its valid interval: in f64 to rounding (1e-12 forward, 1e-9
/// outside), on the GPU to a few f32 ulps of the field's scale amplified
/// along τ (2e-6 and 2e-5).
fn bounds_contain_the_field(backend: Backend) {
    let ctx = (backend == Backend::Gpu).then(gpu);
    let (forward_tol, outside_tol) = match backend {
        Backend::Gpu => (2e-6, 2e-5),
        Backend::F64 => (1e-12, 1e-9),
    };
    for (name, s) in all_scenes() {
        let field = Field::new(&s);
        let queries = cases(&s, 11, 400);
        let meeting = queries.iter().filter(|q| meets_support(&s, q)).count();
        assert!(2 * meeting >= queries.len(), "{name}: only {meeting} of {} queries meet a support", queries.len());
        let mut renderer = ctx.as_ref().map(|ctx| Renderer::new(ctx, &s).unwrap());
        let sc = scale(&s);
        for (method, quad) in INCLUSION {
            let bounds = match &mut renderer {
                Some(r) => gpu_bounds(r, method, MarchOptions { quad, ..MarchOptions::for_scene(&s) }, &queries),
                None => f64_bounds(&field, method, quad, &queries),
            };
            let c = check(&field, method, &queries, &bounds, sc);
            assert!(c.worst_forward < forward_tol, "{name} {method} {quad:?} {backend:?}: forward error {:e}", c.worst_forward);
            assert!(c.worst_outside < outside_tol, "{name} {method} {quad:?} {backend:?}: a sample lies {:e} outside", c.worst_outside);
        }
    }
    if let Some(ctx) = ctx {
        assert_no_validation(&ctx);
    }
}

#[test]
fn gpu_bounds_equal_the_f64_mirror() {
    let ctx = gpu();
    let (mut kept, mut validity) = (Vec::new(), Vec::new());
    for (name, s) in all_scenes() {
        let field = Field::new(&s);
        let queries = cases(&s, 5, 300);
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let sc = scale(&s);
        for (method, quad) in INCLUSION {
            let g = gpu_bounds(&mut renderer, method, MarchOptions { quad, ..MarchOptions::for_scene(&s) }, &queries);
            let e = f64_bounds(&field, method, quad, &queries);
            for ((q, g), e) in queries.iter().zip(&g).zip(&e) {
                let len = f64::from(q.d[3] - q.o[3]).max(1e-3);
                // Compare the bounds' values across the interval, relative
                // to the field's scale.
                for tau in [0.0, 0.5 * len, len] {
                    let dl = (g.lo(tau) - e.lo(tau)).abs();
                    let dh = (g.hi(tau) - e.hi(tau)).abs();
                    // f32 error: relative to the field's scale and to the
                    // size of the bound's own terms.
                    let terms = e.e_hi + e.a_lo.abs().max(e.a_hi.abs()) * tau + e.b_lo.abs().max(e.b_hi.abs()) * tau * tau;
                    let tol = 1e-4 * (sc * (1.0 + len * len) + terms);
                    assert!(dl.max(dh) < tol, "{name} {method} {quad:?}: GPU {g:?} vs f64 {e:?} at τ={tau} on {q:?}");
                }
                // The GPU shortens the interval where the f64 mirror does.
                let requested = f64::from(q.d[3] - q.o[3]);
                assert!(
                    (g.t_valid - e.t_valid).abs() <= 1e-4 * (1.0 + requested),
                    "{name} {method} {quad:?}: valid to {} on the GPU, {} in f64",
                    g.t_valid,
                    e.t_valid
                );
                if requested > 0.0 {
                    let fraction = (e.t_valid - f64::from(q.o[3])) / requested;
                    if method == Method::Quadratic {
                        validity.push(fraction);
                    } else {
                        kept.push(fraction);
                    }
                }
            }
        }
    }
    let mean = kept.iter().sum::<f64>() / kept.len() as f64;
    // These bounds need no validity interval: the whole interval is kept.
    println!("mean fraction of the requested interval kept without validity intervals: {mean:.4}");
    assert!(mean == 1.0, "bounds without validity intervals kept only {mean} of their intervals");
    // Gaussians' validity intervals (Appendix B) shorten some queries.
    let mean = validity.iter().sum::<f64>() / validity.len() as f64;
    println!("mean fraction kept by the validity intervals of `quadratic`: {mean:.4}");
    assert!(mean < 1.0 && mean > 0.2, "validity intervals kept {mean} of the requested intervals");
    assert_no_validation(&ctx);
}

/// The closed-form per-primitive derivative ranges equal the ranges of
/// densely sampled derivatives (tightness of Appendix A's candidates).
#[test]
fn taylor_derivative_ranges_are_tight() {
    let s = random_scene(7, false, Method::QuadraticTaylor);
    let field = Field::new(&s);
    let h = 1e-4;
    for q in cases(&s, 3, 200) {
        let r = Ray::from_gpu(&q);
        if r.t1 - r.t0 < 0.05 {
            continue;
        }
        for p in field.groups.iter().flatten() {
            let at = |t: f64| p.kind().value(r.o + t * r.d);
            for order in [Order::Linear, Order::Quadratic] {
                let k = p.kind().taylor(r.o, r.d, r.t0, r.t1, order, false);
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for i in 0..=2000 {
                    let t = r.t0 + (r.t1 - r.t0) * f64::from(i) / 2000.0;
                    let d = match order {
                        Order::Linear => (at(t + h) - at(t - h)) / (2.0 * h),
                        Order::Quadratic => (at(t + h) - 2.0 * at(t) + at(t - h)) / (h * h),
                    };
                    lo = lo.min(d);
                    hi = hi.max(d);
                }
                let width = (k.max - k.min).max(1e-6);
                assert!(
                    k.min <= lo + 1e-3 * width + 1e-6 && k.max >= hi - 1e-3 * width - 1e-6,
                    "{order:?} range [{}, {}] misses sampled [{lo}, {hi}]",
                    k.min,
                    k.max
                );
                // Sampling on a 2000-point grid sees the extrema to within
                // a small fraction of the width.
                assert!(
                    k.min >= lo - 0.02 * width - 1e-6 && k.max <= hi + 0.02 * width + 1e-6,
                    "{order:?} range [{}, {}] wider than sampled [{lo}, {hi}]",
                    k.min,
                    k.max
                );
            }
        }
    }
}

#[test]
fn degenerate_queries_give_finite_bounds_and_marches_end() {
    let ctx = gpu();
    let iso = 0.5;
    let r = 2.0;
    let radius = r * (1.0 - f64::cbrt(iso)).sqrt();
    // Two coincident blobs and a third exactly on the first's support edge.
    let s = scene(
        vec![vec![compact(DVec3::ZERO, r), compact(DVec3::ZERO, r), compact(DVec3::new(2.0 * r, 0.0, 0.0), r)]],
        iso,
        Method::QuadraticTaylor,
        1e-4,
    );
    let ray = |o: DVec3, d: DVec3, t0: f64, t1: f64| GpuRay {
        o: [o.x as f32, o.y as f32, o.z as f32, t0 as f32],
        d: [d.x as f32, d.y as f32, d.z as f32, t1 as f32],
    };
    let lone_radius = 2.0 * r * (1.0 - f64::cbrt(iso / 2.0)).sqrt();
    let queries = vec![
        ray(DVec3::new(0.0, radius, -5.0), DVec3::Z, 0.0, 10.0),      // tangent to one blob's sphere
        ray(DVec3::new(0.0, lone_radius, -5.0), DVec3::Z, 0.0, 10.0), // tangent to the doubled blob
        ray(DVec3::new(0.0, 0.0, -lone_radius), DVec3::Z, 0.0, 5.0),  // starts on the surface
        ray(DVec3::new(0.0, 0.0, -5.0), DVec3::Z, 3.0, 3.0),          // zero-length interval
        ray(DVec3::new(-r, 0.0, -5.0), DVec3::Z, 5.0, 8.0),           // t0 on a support boundary
        ray(DVec3::new(r, 0.0, 0.0), DVec3::X, 0.0, 4.0),             // along the axis through the edge blob
        ray(DVec3::new(0.0, 0.0, 0.0), DVec3::X, 0.0, 0.0),           // zero-length at a centre
    ];
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let field = Field::new(&s);
    for &(method, quad) in &INCLUSION {
        let options = MarchOptions { quad, ..MarchOptions::for_scene(&s) };
        let g = gpu_bounds(&mut renderer, method, options, &queries);
        let e = f64_bounds(&field, method, quad, &queries);
        for (b, q) in g.iter().chain(&e).zip(queries.iter().cycle()) {
            for x in [b.v, b.a_lo, b.b_lo, b.a_hi, b.b_hi] {
                assert!(x.is_finite(), "{method}: non-finite bound {b:?} for {q:?}");
            }
        }
    }
    for &method in Method::CONSERVATIVE {
        let out = renderer.march(method, MarchOptions { quad: DEFAULT, ..MarchOptions::for_scene(&s) }, &queries, |_| {}).unwrap();
        for (res, q) in out.results.iter().zip(&queries) {
            assert!(res.hit.iter().all(|x| x.is_finite()), "{method}: NaN result {res:?} for {q:?}");
            assert_eq!(res.counts[3] & isomarch::layout::FLAG_OUT_OF_STEPS, 0, "{method}: ran out of steps on {q:?}");
        }
        // The ray starting on the surface hits at once.
        assert_eq!(out.results[2].counts[3] & isomarch::layout::FLAG_HIT, isomarch::layout::FLAG_HIT, "{method}");
    }
    assert_no_validation(&ctx);
}

/// Revised affine arithmetic is not forward: its range over the interval
/// must contain the field there, on the GPU and the f64 mirror alike, and
/// the two must agree.
#[test]
fn raa_ranges_contain_the_field_on_gpu_and_f64() {
    let ctx = gpu();
    for (name, s) in all_scenes() {
        let field = Field::new(&s);
        let queries = cases(&s, 13, 300);
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let sc = scale(&s);
        let gpu = renderer.probe_bounds(Method::Raa, MarchOptions::for_scene(&s), &queries).unwrap();
        for (q, g) in queries.iter().zip(&gpu) {
            let r = Ray::from_gpu(q);
            let (lo, hi) = isomarch::field::fold::field_raa(&field, r.o, r.d, r.t0, r.t1);
            let (glo, ghi) = (f64::from(g.lo[0]), f64::from(g.hi[0]));
            assert!(lo.is_finite() && hi.is_finite() && glo.is_finite() && ghi.is_finite(), "{name}: non-finite range");
            let width = (hi - lo).abs();
            assert!(
                (glo - lo).abs() <= 1e-4 * (sc + width) && (ghi - hi).abs() <= 1e-4 * (sc + width),
                "{name}: GPU [{glo}, {ghi}] vs f64 [{lo}, {hi}]"
            );
            for i in 0..=200 {
                let t = r.t0 + (r.t1 - r.t0) * f64::from(i) / 200.0;
                let f = field.value(r.o + t * r.d);
                assert!(f >= lo - 1e-9 * sc && f <= hi + 1e-9 * sc, "{name}: f64 RAA [{lo}, {hi}] misses f = {f} at t = {t}");
                assert!(f >= glo - 2e-5 * sc && f <= ghi + 2e-5 * sc, "{name}: GPU RAA [{glo}, {ghi}] misses f = {f} at t = {t}");
            }
        }
    }
    assert_no_validation(&ctx);
}

/// Where each inclusion method's mean bound width is recorded.
fn bound_widths_path() -> std::path::PathBuf {
    repo_root().join("tests").join("data").join("bound-widths.csv")
}

/// The bounds are checked for validity above, so a looser valid bound
/// would pass there: each method's mean width on a fixed set of intervals
/// (the f64 mirror, which the GPU's bounds equal, on `cases(scene, 17,
/// 300)` of every test scene) must stay within 2% of the record in
/// tests/data/bound-widths.csv, and so must the mean fraction of each
/// interval where the bound is valid. `UPDATE_BOUND_WIDTHS=1` rewrites it.
/// The width of a forward bound is the mean over 21 points of its valid
/// interval of hi(τ) - lo(τ); RAA's is its range; both relative to the
/// scene's largest group weight.
#[test]
fn bound_widths_stay_at_their_recorded_tightness() {
    let mut measured = Vec::new();
    for (name, s) in all_scenes() {
        let field = Field::new(&s);
        let queries = cases(&s, 17, 300);
        let sc = scale(&s);
        for (method, quad) in INCLUSION {
            let bounds = f64_bounds(&field, method, quad, &queries);
            let (mut width, mut kept) = (0.0, 0.0);
            for (q, b) in queries.iter().zip(&bounds) {
                let r = Ray::from_gpu(q);
                let len = (b.t_valid - r.t0).max(0.0);
                width += (0..=20).map(|i| b.hi(len * f64::from(i) / 20.0) - b.lo(len * f64::from(i) / 20.0)).sum::<f64>() / 21.0 / sc;
                kept += if r.t1 > r.t0 { len / (r.t1 - r.t0) } else { 1.0 };
            }
            let n = queries.len() as f64;
            let label = format!(
                "{method}{}{}",
                if quad.extension { "" } else { " no-extension" },
                if quad.validity == ValidityScope::Every { " every" } else { "" }
            );
            measured.push((name.clone(), label, width / n, kept / n));
        }
        let raa: f64 = queries
            .iter()
            .map(|q| {
                let r = Ray::from_gpu(q);
                let (lo, hi) = isomarch::field::fold::field_raa(&field, r.o, r.d, r.t0, r.t1);
                (hi - lo) / sc
            })
            .sum();
        measured.push((name.clone(), "raa".into(), raa / queries.len() as f64, 1.0));
    }
    let path = bound_widths_path();
    let rows: Vec<String> = measured.iter().map(|(scene, method, width, kept)| format!("{scene},{method},{width:.6e},{kept:.6}")).collect();
    let text = record(
        &path,
        "UPDATE_BOUND_WIDTHS",
        "# Mean width (relative to the largest group weight) and mean valid fraction of each inclusion method's\n\
         # f64 bounds on a fixed set of intervals of the test scenes of tests/inclusion.rs.\n\
         # Written by: UPDATE_BOUND_WIDTHS=1 cargo test --release --test tests bound_widths\n\
         # Checked to within 2% by that test.\n\
         scene,method,mean_width,mean_valid_fraction\n",
        &rows,
    );
    let mut expected = std::collections::HashMap::new();
    for f in record_rows(&text, &path) {
        let num = |s: &str| s.parse::<f64>().unwrap_or_else(|e| panic!("{}: {f:?}: {e}", path.display()));
        expected.insert((f[0].to_string(), f[1].to_string()), (num(f[2]), num(f[3])));
    }
    let mut failures = Vec::new();
    for (scene, method, width, kept) in &measured {
        match expected.remove(&(scene.clone(), method.clone())) {
            None => failures.push(format!("{scene} {method}: no row in the record")),
            Some((w, k)) => {
                if (width - w).abs() > 0.02 * w || (kept - k).abs() > 0.02 * k {
                    failures.push(format!(
                        "{scene} {method}: width {width:.4e} (recorded {w:.4e}, {:+.2}%), valid fraction {kept:.4} (recorded {k:.4})",
                        100.0 * (width - w) / w
                    ));
                }
            }
        }
    }
    failures.extend(expected.keys().map(|(s, m)| format!("{s} {m}: recorded but not measured")));
    assert!(failures.is_empty(), "bound widths differ from {}:\n{}", path.display(), failures.join("\n"));
}
