//! Scenes with planes, marched: a slab alone against its closed form, and
//! slabs with blobs (sum and max of groups) against the f64 reference.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::bench::reference_hits;
use isomarch::layout::{FLAG_HIT, FLAG_OUT_OF_STEPS};
use isomarch::output::MarchStats;
use isomarch::render::rays::{Ray, camera_rays, protocol_rays};
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::{Aabb, Primitive};

/// Where `o + t u` (t in [t0, t1]) first enters the slab |n·p - offset| <=
/// half, and the outward normal there; `None` when it does not within
/// [t0, t1]. A ray starting inside hits at t0.
fn slab_entry(n: DVec3, offset: f64, half: f64, ray: &Ray) -> Option<(f64, DVec3)> {
    let s0 = n.dot(ray.o + ray.t0 * ray.d) - offset;
    let sigma = n.dot(ray.d);
    if s0.abs() <= half {
        return Some((ray.t0, DVec3::ZERO));
    }
    // Approaching the face on s0's side.
    if s0 * sigma >= 0.0 {
        return None;
    }
    let t = ray.t0 + (s0.abs() - half) / sigma.abs();
    (t <= ray.t1).then_some((t, s0.signum() * n))
}

#[test]
fn a_plane_slab_alone_is_hit_at_its_closed_form_crossing() {
    let ctx = gpu();
    let (radius, iso) = (1.0, 0.5);
    // A tilted slab: the kernel w (1 - s²/R²)³ reaches iso at |s| = R sqrt(1 - iso^(1/3)).
    let n = DVec3::new(0.3, 0.9, -0.2).normalize();
    let offset = 0.4;
    let half = radius * (1.0 - f64::cbrt(iso)).sqrt();
    let mut s = scene(vec![vec![Primitive::Plane { normal: n, offset, radius, weight: 1.0 }]], iso, Method::Segment, 1e-4 * radius);
    s.bounds = Aabb { min: DVec3::splat(-3.0), max: DVec3::splat(3.0) };
    s.bounds_explicit = true;
    s.camera.eye = DVec3::new(1.0, 6.0, 7.0);
    let (rays, pixels) = camera_rays(&s.camera, 64, 64, &s.bounds);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    // Refinement stops within 1e-4 R; f32 adds a few ulps of t near 8.
    let tol = 2e-4 * radius + 1e-5;
    for &method in Method::CONSERVATIVE {
        let out = renderer.march(method, MarchOptions::for_scene(&s), &rays, |_| {}).unwrap().results;
        let (mut hits, mut misses) = (0, 0);
        for ((gpu_ray, res), pixel) in rays.iter().zip(&out).zip(&pixels) {
            let ray = Ray::from_gpu(gpu_ray);
            if pixel.is_none() || ray.misses() {
                continue;
            }
            let hit = res.counts[3] & FLAG_HIT != 0;
            assert_eq!(res.counts[3] & FLAG_OUT_OF_STEPS, 0, "{method}: out of steps");
            match slab_entry(n, offset, half, &ray) {
                // Within 1e-3 of the box's far side: either way.
                Some((t, _)) if (ray.t1 - t).abs() < 1e-3 => {}
                Some((t, normal)) => {
                    assert!(hit, "{method}: missed the slab, which the ray enters at {t}");
                    let err = f64::from(res.hit[3]) - t;
                    assert!(err.abs() <= tol, "{method}: hit at {} but the slab is at {t} (error {err:e} > {tol:e})", res.hit[3]);
                    if normal != DVec3::ZERO {
                        let got = DVec3::new(res.hit[0].into(), res.hit[1].into(), res.hit[2].into());
                        assert!(got.dot(normal) > 0.999, "{method}: normal {got}, the slab's is {normal}");
                    }
                    hits += 1;
                }
                None => {
                    assert!(!hit, "{method}: hit at {} but the ray never enters the slab", res.hit[3]);
                    misses += 1;
                }
            }
        }
        assert!(hits > 1000 && misses > 200, "{method}: {hits} hits and {misses} misses: the view does not frame the slab");
    }
    assert_no_validation(&ctx);
}

#[test]
fn planes_with_blobs_find_the_references_first_crossing() {
    let ctx = gpu();
    let mut report = Vec::new();
    for max_of_groups in [false, true] {
        let s = plane_scene(max_of_groups);
        let rays = protocol_rays(&s.bounds, 512, 5);
        let reference = reference_hits(&s, &rays, false);
        let ref_hits = reference.iter().filter(|r| r.is_some()).count();
        assert!(ref_hits > 150 && ref_hits < 450, "max={max_of_groups}: {ref_hits} reference hits of 512");
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let options = MarchOptions { shade: false, ..MarchOptions::for_scene(&s) };
        let tol = 2.0 * s.refine_tolerance() + 1e-5;
        for &method in Method::CONSERVATIVE {
            let out = renderer.march(method, options, &rays, |_| {}).unwrap().results;
            let acc = isomarch::bench::accuracy(&out, &reference, tol, tol);
            let stats = MarchStats::of(&out, None);
            if acc.misses + acc.false_hits > 0 || stats.out_of_steps_rate > 0.0 {
                report.push(format!(
                    "max={max_of_groups} {method}: {} missed or late, {} early or false, {} out of steps (max error {:e})",
                    acc.misses, acc.false_hits, stats.out_of_steps_rate, acc.max_abs_error
                ));
            }
        }
    }
    assert!(report.is_empty(), "disagreements with the f64 reference:\n{}", report.join("\n"));
    assert_no_validation(&ctx);
}
