//! The one loop over primitives on the GPU: its dispatch on the primitive's
//! kind is exhaustive (a kind the shaders do not know poisons every
//! evaluation with NaN instead of falling through to another kind's code),
//! and its point evaluations (value, gradient, segment tracing's slope
//! bound) equal the f64 mirror.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::field::Field;
use isomarch::layout::GpuRay;
use isomarch::render::rays::{Ray, protocol_rays};
use isomarch::render::{MarchOptions, Renderer, gpu_primitives};

/// A ray down the z axis through both blobs, on t in [3, 7].
const THROUGH: GpuRay = GpuRay { o: [0.1, 0.2, 5.0, 3.0], d: [0.0, 0.0, -1.0, 7.0] };

#[test]
fn an_unknown_primitive_kind_poisons_every_evaluation_with_nan() {
    let ctx = gpu();
    let s = scene(vec![vec![compact(DVec3::ZERO, 2.0), compact(DVec3::new(0.5, 0.0, 0.0), 1.5)]], 0.5, Method::QuadraticTaylor, 1e-3);
    let mut renderer = Renderer::new(&ctx, &s).unwrap();
    let queries = [THROUGH];
    for &method in Method::ALL {
        let b = renderer.probe_bounds(method, MarchOptions::for_scene(&s), &queries).unwrap()[0];
        assert!(b.lo[0].is_finite() && b.hi.iter().all(|x| x.is_finite()), "{method}: known kinds give {b:?}");
    }
    let mut prims = gpu_primitives(&s);
    // No such kind: the compact kernel's code must not take it.
    prims[1].ids[0] = 7;
    renderer.upload_raw_primitives(&prims).unwrap();
    for &method in Method::ALL {
        let b = renderer.probe_bounds(method, MarchOptions::for_scene(&s), &queries).unwrap()[0];
        assert!(b.lo[0].is_nan(), "{method}: an unknown kind gave the value {b:?}, not NaN");
        match method {
            Method::Sphere | Method::FieldInversion | Method::FieldInversionDynamol => {
                assert!(b.hi[..3].iter().all(|x| x.is_nan()), "{method}: gradient {b:?}")
            }
            Method::Segment => assert!(b.hi[1].is_nan(), "{method}: Lipschitz bound {b:?}"),
            Method::Raa => assert!(b.hi[0].is_nan(), "{method}: range {b:?}"),
            _ => assert!(b.lo[1].is_nan() && b.hi[1].is_nan(), "{method}: slopes {b:?}"),
        }
    }
    assert_no_validation(&ctx);
}

#[test]
fn gpu_values_gradients_and_segment_slopes_equal_the_f64_mirror() {
    let ctx = gpu();
    // Random blobs (sum, max) and a plane slab with blobs (the plane's
    // branch of the segment bound).
    for (seed, s) in [
        (1u64, random_scene(1, false, Method::Segment)),
        (2, random_scene(2, true, Method::Segment)),
        (3, plane_scene(false)),
        (4, random_hrbf_scene(4, true, Method::Segment)),
    ] {
        let field = Field::new(&s);
        let scale = field.groups.iter().map(|g| g.iter().map(|p| p.magnitude()).sum::<f64>()).fold(0.0, f64::max);
        let lipschitz = field.lipschitz();
        let queries: Vec<GpuRay> = protocol_rays(&s.bounds, 400, seed)
            .into_iter()
            .filter(|r| !Ray::from_gpu(r).misses())
            .map(|r| {
                let ray = Ray::from_gpu(&r);
                let mid = 0.5 * (ray.t0 + ray.t1);
                GpuRay { o: [r.o[0], r.o[1], r.o[2], mid as f32], d: [r.d[0], r.d[1], r.d[2], (mid + 0.7).min(ray.t1) as f32] }
            })
            .collect();
        assert!(queries.len() >= 200, "seed {seed}: {} rays meet the bounds", queries.len());
        let mut renderer = Renderer::new(&ctx, &s).unwrap();
        let sphere = renderer.probe_bounds(Method::Sphere, MarchOptions::for_scene(&s), &queries).unwrap();
        let segment = renderer.probe_bounds(Method::Segment, MarchOptions::for_scene(&s), &queries).unwrap();
        let (mut inside, mut sloped) = (0, 0);
        for ((q, v), l) in queries.iter().zip(&sphere).zip(&segment) {
            let r = Ray::from_gpu(q);
            let p = r.o + r.t0 * r.d;
            let (f, grad) = field.value_gradient(p);
            // f32 arithmetic on values of size `scale`.
            assert!((f64::from(v.lo[0]) - f).abs() < 1e-5 * scale, "seed {seed}: f {} vs {f}", v.lo[0]);
            assert!((f64::from(l.lo[0]) - f).abs() < 1e-5 * scale, "seed {seed}: segment's f {} vs {f}", l.lo[0]);
            let g = DVec3::new(v.hi[0].into(), v.hi[1].into(), v.hi[2].into());
            assert!((g - grad).length() < 1e-4 * (lipschitz + grad.length()), "seed {seed}: gradient {g} vs {grad}");
            let lambda = field.segment_lipschitz(r.o, r.d, r.t0, r.t1);
            assert!((f64::from(l.hi[1]) - lambda).abs() < 1e-4 * lipschitz, "seed {seed}: λ {} vs {lambda}", l.hi[1]);
            inside += usize::from(f > 0.0);
            sloped += usize::from(lambda > 0.0);
        }
        // The comparison saw both sides of the surface and real slopes.
        assert!(inside > 0 && inside < queries.len() && sloped > queries.len() / 4, "seed {seed}: {inside} inside, {sloped} sloped");
    }
    assert_no_validation(&ctx);
}
