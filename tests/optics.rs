//! A dielectric blob sphere traced through its reflections and refractions
//! (`render::optics::trace`, on the GPU) against the closed form of a
//! sphere: Fresnel at both interfaces, Beer-Lambert over the chord, and the
//! `max_depth` cut-off, for rays at two heights.

use crate::common::*;
use glam::DVec3;
use isomarch::Method;
use isomarch::render::optics::{Dielectric, environment, trace};
use isomarch::render::rays::clipped_ray;
use isomarch::render::{MarchOptions, Renderer};
use isomarch::scene::{Light, Scene, Transparency};

/// Unpolarised Fresnel reflectance from the angles, written independently
/// of `optics::fresnel`: rs = -sin(θi - θt)/sin(θi + θt), rp = tan(θi -
/// θt)/tan(θi + θt), for light going from index n1 to n2.
fn fresnel_by_angles(theta_i: f64, n1: f64, n2: f64) -> f64 {
    let theta_t = (n1 / n2 * theta_i.sin()).asin();
    let rs = -(theta_i - theta_t).sin() / (theta_i + theta_t).sin();
    let rp = (theta_i - theta_t).tan() / (theta_i + theta_t).tan();
    0.5 * (rs * rs + rp * rp)
}

/// The colour `trace` should give a ray along +x at height `h` through a
/// sphere of radius `rho` at the origin (all in the z = 0 plane).
///
/// Depth 0 hits the entry point: a specular highlight, a reflected path
/// (weight reflectivity·R1) that leaves, and a refracted one (1 - R1) that
/// crosses the chord 2ρ cos θt. With `max_depth` 1 the refracted path,
/// still bouncing at the exit, takes the environment ahead (inside
/// direction) after Beer-Lambert over the chord. With 2 it splits at the
/// exit: out (1 - R2), deviated by 2(θi - θt), and back inside
/// (reflectivity·R2), which crosses a second chord of the same length and
/// then takes the environment ahead.
fn closed_form(scene: &Scene, m: &Dielectric, rho: f64, h: f64) -> DVec3 {
    let d = DVec3::X;
    let (theta_i, theta_t) = ((h / rho).asin(), (h / rho / m.ior).asin());
    let p1 = DVec3::new(-(rho * rho - h * h).sqrt(), h, 0.0);
    let n1 = p1 / rho;
    let r1 = fresnel_by_angles(theta_i, 1.0, m.ior);
    let mut c = DVec3::ZERO;
    if m.max_depth == 0 {
        return environment(scene, d);
    }
    for l in &scene.lights {
        let half = (l.direction - d).normalize();
        c += m.reflectivity * r1 * l.color * n1.dot(half).max(0.0).powf(96.0);
    }
    c += m.reflectivity * r1 * environment(scene, d - 2.0 * d.dot(n1) * n1);
    // Inside: the refracted direction turns from -n1 towards d by θt.
    let inside = DVec3::new((theta_t - theta_i).cos(), (theta_t - theta_i).sin(), 0.0);
    let chord = 2.0 * rho * theta_t.cos();
    let through = (1.0 - r1) * (-m.absorption * chord).exp();
    if m.max_depth == 1 {
        return c + through * environment(scene, inside);
    }
    assert_eq!(m.max_depth, 2, "the closed form goes two bounces deep");
    let p2 = p1 + chord * inside;
    let n2 = p2 / rho;
    let r2 = fresnel_by_angles(theta_t, m.ior, 1.0);
    let out = DVec3::new((2.0 * (theta_t - theta_i)).cos(), (2.0 * (theta_t - theta_i)).sin(), 0.0);
    let back = inside - 2.0 * inside.dot(n2) * n2;
    c + through * (1.0 - r2) * environment(scene, out) + through * m.reflectivity * r2 * (-m.absorption * chord).exp() * environment(scene, back)
}

/// A dense glass (flint-like), so that the reflected share is large enough
/// for a wrong reflectivity or Fresnel factor to show well above the
/// tolerance (normal incidence reflects ((n - 1)/(n + 1))² = 11%).
const IOR: f64 = 2.0;

/// Largest colour error per channel.
const TOLERANCE: f64 = 5e-4;

#[test]
fn a_dielectric_sphere_reflects_and_transmits_its_closed_form() {
    let ctx = gpu();
    let (r_support, iso) = (2.0, 0.5);
    let rho = r_support * (1.0 - f64::cbrt(iso)).sqrt();
    let mut s = scene(vec![vec![compact(DVec3::ZERO, r_support)]], iso, Method::QuadraticTaylor, 1e-4);
    // A sky that changes with direction, so directions are checked too.
    s.background = DVec3::new(0.5, 0.6, 0.7);
    s.camera.up = DVec3::Y;
    // A light off the plane of the rays: its disc is not seen and its
    // highlight is tiny, but both are in the closed form.
    s.lights = vec![Light { direction: DVec3::new(0.0, 0.6, -0.8), color: DVec3::ONE }];
    let absorption = DVec3::new(0.1, 0.3, 0.6);
    let rays: Vec<_> = [0.3, 0.8].iter().map(|&k| clipped_ray(DVec3::new(-5.0, k * rho, 0.0), DVec3::X, &s.bounds)).collect();
    let mut checked = Vec::new();
    for max_depth in [1, 2] {
        for reflectivity in [1.0, 0.5] {
            s.transparency = Some(Transparency { opacity: 1.0, absorption, ior: Some(IOR), max_depth, reflectivity });
            let material = Dielectric { ior: IOR, absorption, max_depth, reflectivity };
            let mut renderer = Renderer::new(&ctx, &s).unwrap();
            let traced = trace(&mut renderer, Method::QuadraticTaylor, MarchOptions::for_scene(&s), &rays, material).unwrap();
            for (i, k) in [0.3, 0.8].into_iter().enumerate() {
                let expected = closed_form(&s, &material, rho, k * rho);
                let got = traced.color[i];
                let err = (got - expected).abs().max_element();
                // Hit points and normals come from the f32 march (measured
                // errors up to 1.5e-4 of a colour near 0.3).
                eprintln!("depth {max_depth}, reflectivity {reflectivity}, h = {k} ρ: error {err:.2e}");
                assert!(
                    err < TOLERANCE,
                    "depth {max_depth}, reflectivity {reflectivity}, h = {k} ρ: traced {got}, closed form {expected} (error {err:e})"
                );
                checked.push(expected);
            }
        }
    }
    // The cases differ from each other by more than five tolerances.
    for (i, a) in checked.iter().enumerate() {
        for b in &checked[i + 1..] {
            assert!((*a - *b).abs().max_element() > 5.0 * TOLERANCE, "two cases give {a} and {b}: the test cannot tell them apart");
        }
    }
    assert_no_validation(&ctx);
}
