//! The view from the command line (`--turn`, `--zoom`, `--fov`): a turn of
//! the camera is the world turned back, and a blob's disc has the size the
//! perspective gives it, through the binary.

use std::path::PathBuf;

use crate::common::*;
use glam::{DQuat, DVec3};
use isomarch::Method;
use isomarch::render::offscreen::{RenderJob, render_frame};
use isomarch::scene::Primitive;
use isomarch::scene::turn::{Turn, ViewAxis};

/// Five compact blobs about the origin (not symmetric about the vertical),
/// one light, the bounds their supports'.
fn blobs() -> isomarch::scene::Scene {
    let centres = [(0.0, 0.0, 0.0), (1.6, 0.4, 0.2), (-0.8, 1.1, 0.9), (0.3, -1.2, -1.4), (-1.5, -0.3, 0.6)];
    let prims: Vec<Primitive> = centres.iter().map(|&(x, y, z)| compact(DVec3::new(x, y, z), 1.3)).collect();
    scene(vec![prims], 0.5, Method::QuadraticTaylor, 1e-3)
}

/// `--turn y:90` moves the camera a quarter about the vertical through
/// the target: the image is the world (blobs and light) turned a quarter
/// back, byte for byte; and the binary's flags render the library's turned
/// camera byte for byte.
#[test]
fn a_turn_of_the_camera_is_the_world_turned_back() {
    let ctx = gpu();
    let base = blobs();
    let turn = Turn { axis: ViewAxis::Y, degrees: 90.0 };
    let mut turned = base.clone();
    turned.camera = base.camera.turned(turn);
    let back = DQuat::from_axis_angle(DVec3::Y, -90f64.to_radians());
    let mut world = base.clone();
    for group in &mut world.groups {
        for p in group.iter_mut() {
            if let Primitive::Point { center, .. } = p {
                *center = back * *center;
            }
        }
    }
    for l in &mut world.lights {
        l.direction = back * l.direction;
    }
    world.bounds = world.support_bounds();
    let frame = |s: &isomarch::scene::Scene| {
        let job = RenderJob::new(s.clone(), Method::QuadraticTaylor, (64, 64), PathBuf::new(), std::time::Duration::from_secs(300));
        render_frame(&ctx, &job).unwrap().0.shaded()
    };
    let (a, b, still) = (frame(&turned), frame(&world), frame(&base));
    let differing = |x: &image::RgbImage, y: &image::RgbImage| {
        x.pixels().zip(y.pixels()).filter(|(p, q)| p.0.iter().zip(q.0).any(|(u, v)| u.abs_diff(v) > 8)).count()
    };
    assert!(differing(&a, &still) > 100, "a quarter turn changes nothing: the blobs look the same from the side");
    // Byte for byte: the rays differ in their last bits at most, which no
    // 8-bit pixel of this frame shows (measured: 0 pixels differ).
    let d = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
    assert!(d == 0, "the camera turned a quarter differs from the world turned back in {d} pixels");
    assert_no_validation(&ctx);
    // Through the binary, on a scene file: the library's turned camera.
    let dir = scratch("view-turn");
    let (flag, turned_file) = (dir.join("flag.png"), dir.join("turned.png"));
    run_ok(&["render", "scenes/fig10.ron", "--size", "48x48", "--turn", "y:90", "--turn", "x:20", "-o", flag.to_str().unwrap()]);
    let mut fig10 = isomarch::scene::Scene::load(&repo_root().join("scenes/fig10.ron")).unwrap();
    fig10.camera = fig10.camera.turned(turn).turned(Turn { axis: ViewAxis::X, degrees: 20.0 });
    let job = RenderJob::new(fig10.clone(), fig10.marching.method, (48, 48), turned_file.clone(), std::time::Duration::from_secs(300));
    let shown = render_frame(&ctx, &job).unwrap().0.shaded();
    assert!(image::open(&flag).unwrap().to_rgb8() == shown, "--turn y:90 --turn x:20 renders otherwise than the camera turned so");
}

/// A blob sphere of radius ρ at the target, seen from distance d with a
/// vertical field of view φ on H pixels, is a disc of radius
/// tan(asin(ρ/d)) / tan(φ/2) · H/2 pixels: by its covered area, within a
/// pixel, as given, with `--zoom 2` (d halved) and with `--fov 20`.
/// A compact blob of support `radius` at the origin (iso 0.5, black
/// background) seen by `camera` (a camera block's fields), lit by `lights`
/// (a `lights: [..],` line, or nothing).
fn ball_scene(camera: &str, radius: f64, lights: &str) -> String {
    format!(
        r#"Scene(
    camera: ({camera}),
    background: (0.0, 0.0, 0.0),
    {lights}
    iso: 0.5,
    marching: (method: "quadratic-taylor", min_step: 0.001),
    groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: {radius:?}))])],
)"#
    )
}

#[test]
fn zoom_and_field_of_view_size_a_spheres_disc() {
    let dir = scratch("view-zoom");
    let path = dir.join("ball.ron");
    std::fs::write(&path, ball_scene("eye: (0.0, 0.0, 12.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96)", 2.0, "")).unwrap();
    let rho = 2.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    for (flags, d, fov) in [(&[][..], 12.0f64, 30.0f64), (&["--zoom", "2"][..], 6.0, 30.0), (&["--fov", "20"][..], 12.0, 20.0)] {
        let png = dir.join("ball.png");
        isomarch(["render", path.to_str().unwrap(), "-o", png.to_str().unwrap()]).args(flags).ok();
        let img = image::open(&png).unwrap().to_rgb8();
        let covered = img.pixels().filter(|p| p.0.iter().any(|&c| c > 0)).count() as f64;
        let measured = (covered / std::f64::consts::PI).sqrt();
        let expected = (rho / d).asin().tan() / (0.5 * fov).to_radians().tan() * 48.0;
        assert!((measured - expected).abs() < 1.0, "{flags:?}: a disc of radius {measured:.2} pixels, expected {expected:.2}");
    }
    for (flag, value, says) in [("--zoom", "0", "--zoom must be a positive factor"), ("--fov", "180", "--fov must be between 0 and 180 degrees")] {
        let err = isomarch(["render", path.to_str().unwrap(), "-o", dir.join("x.png").to_str().unwrap(), flag, value]).fails_in_one_line();
        assert!(err.contains(says), "{err}");
    }
}

/// `isomarch scene` with view flags writes the camera they make: the file
/// renders what `render` makes of the molecule with the same flags, byte
/// for byte (and not what it makes without them).
#[test]
fn a_scene_written_with_view_flags_renders_as_the_flags_do() {
    let dir = scratch("view-scene");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let flags = ["--turn", "y:90", "--zoom", "1.5", "--turn", "z:30", "--fov", "25"];
    let ron = dir.join("turned.ron");
    isomarch(["scene", pdb.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
    let render = |input: &std::path::Path, extra: &[&str], name: &str| -> Vec<u8> {
        let png = dir.join(name);
        isomarch(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64x64"]).args(extra).ok();
        std::fs::read(png).unwrap()
    };
    let from_file = render(&ron, &[], "file.png");
    assert_eq!(from_file, render(&pdb, &flags, "flags.png"), "the scene file's camera is not the flags'");
    assert_ne!(from_file, render(&pdb, &[], "plain.png"), "the flags changed nothing");
    // A camera given whole (resolution, clipping and all) is written whole.
    let camera = dir.join("camera.ron");
    std::fs::write(
        &camera,
        "(eye: (60.0, 30.0, 90.0), target: (19.0, 37.0, 17.0), up: (0.0, 1.0, 0.0), fov_y: 20.0, resolution: (48, 40), clip: (near: Some(80.0)))\n",
    )
    .unwrap();
    let whole = dir.join("whole.ron");
    isomarch(["scene", pdb.to_str().unwrap(), "-o", whole.to_str().unwrap(), "--camera", camera.to_str().unwrap(), "--turntable", "8"]).ok();
    let render_sized = |input: &std::path::Path, extra: &[&str], name: &str| -> Vec<u8> {
        let png = dir.join(name);
        isomarch(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap()]).args(extra).ok();
        std::fs::read(png).unwrap()
    };
    let with_camera = render_sized(&pdb, &["--camera", camera.to_str().unwrap(), "--turntable", "8"], "camera.png");
    assert_eq!(render_sized(&whole, &[], "whole.png"), with_camera, "scene --camera and render --camera differ");
    // The file's camera is used, not the molecule's own: its resolution,
    // and a view that is not the plain render's at that size.
    let shown = image::load_from_memory(&with_camera).unwrap();
    assert_eq!((shown.width(), shown.height()), (48, 40), "render --camera does not take the camera's resolution");
    let plain = dir.join("plain-48x40.png");
    isomarch(["render", pdb.to_str().unwrap(), "-o", plain.to_str().unwrap(), "--size", "48x40", "--turntable", "8"]).ok();
    let plain = image::open(&plain).unwrap().to_rgb8();
    let differing = shown.to_rgb8().pixels().zip(plain.pixels()).filter(|(p, q)| p != q).count();
    assert!(differing > 200, "render --camera differs from the molecule's own camera in only {differing} of 1920 pixels");
}

/// Orthographic projection in closed form: a sphere of radius ρ renders as
/// a disc of ρ/h·H pixels (view height h, image height H) whatever the
/// eye's distance, within a pixel; the scene file's `projection` is the
/// flag's, byte for byte; on 1A8O's camera rays, `bench --camera-rays` against
/// the f64 reference on the same parallel rays: no miss, no false hit.
#[test]
fn an_orthographic_view_draws_a_sphere_its_size_at_any_distance() {
    let dir = scratch("view-ortho");
    let rho = 2.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    let ball = |d: f64, projection: &str| -> std::path::PathBuf {
        let path = dir.join(format!("ball-{d}-{}.ron", projection.len()));
        let camera = format!("eye: (0.0, 0.0, {d:.1}), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96){projection}");
        std::fs::write(&path, ball_scene(&camera, 2.0, "")).unwrap();
        path
    };
    let radius = |png: &std::path::Path| -> f64 {
        let img = image::open(png).unwrap().to_rgb8();
        (img.pixels().filter(|p| p.0.iter().any(|&c| c > 0)).count() as f64 / std::f64::consts::PI).sqrt()
    };
    for (d, h) in [(12.0, 5.0), (100.0, 5.0), (12.0, 6.0), (3000.0, 6.0)] {
        let png = dir.join("ortho.png");
        isomarch(["render", ball(d, "").to_str().unwrap(), "-o", png.to_str().unwrap(), "--ortho", &h.to_string()]).ok();
        let (measured, expected) = (radius(&png), rho / h * 96.0);
        assert!((measured - expected).abs() < 1.0, "eye at {d}, height {h}: a disc of radius {measured:.2} pixels, expected {expected:.2}");
    }
    // The file's projection renders as the flag.
    let (file, flag) = (dir.join("file.png"), dir.join("flag.png"));
    isomarch(["render", ball(30.0, ", projection: Orthographic(height: 8.0)").to_str().unwrap(), "-o", file.to_str().unwrap()]).ok();
    isomarch(["render", ball(30.0, "").to_str().unwrap(), "-o", flag.to_str().unwrap(), "--ortho", "8"]).ok();
    assert_eq!(std::fs::read(&file).unwrap(), std::fs::read(&flag).unwrap());
    // Without a height: the perspective view's height at the target,
    // h = 2 d tan(15°), pixel by pixel. The eye at d = 10 makes h = 5.36
    // and a disc of 16 pixels' radius; every pixel whose centre lies more
    // than 0.01 (0.18 pixels) inside the sphere's outline hits and every
    // pixel more than 0.01 outside misses, so a height 2% off fails (15%
    // passed the disc's area within a pixel).
    let (d, png) = (10.0, dir.join("ortho-default.png"));
    isomarch(["render", ball(d, "").to_str().unwrap(), "-o", png.to_str().unwrap(), "--ortho"]).ok();
    let h = 2.0 * d * 15f64.to_radians().tan();
    let img = image::open(&png).unwrap().to_rgb8();
    let mut inside = 0;
    for (x, y, p) in img.enumerate_pixels() {
        // The pixel's centre on the view plane, scene units from the axis.
        let (sx, sy) = ((f64::from(x) + 0.5) / 96.0 - 0.5, 0.5 - (f64::from(y) + 0.5) / 96.0);
        let r = h * sx.hypot(sy);
        let hit = p.0.iter().any(|&c| c > 0);
        assert!(r >= rho - 0.01 || hit, "--ortho alone: pixel ({x}, {y}) at {r:.4} from the axis, inside the sphere's {rho:.4}, missed");
        assert!(r <= rho + 0.01 || !hit, "--ortho alone: pixel ({x}, {y}) at {r:.4} from the axis, outside the sphere's {rho:.4}, hit");
        inside += usize::from(r < rho - 0.01);
    }
    assert!(inside > 700, "--ortho alone: only {inside} pixels inside the disc");
    let err = isomarch(["render", ball(30.0, "").to_str().unwrap(), "-o", flag.to_str().unwrap(), "--ortho=0"]).fails_in_one_line();
    assert!(err.contains("--ortho takes the view's height"), "{err}");
    // The f64 reference on the same parallel rays.
    let bench = dir.join("bench.json");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    isomarch(["bench", pdb.to_str().unwrap(), "--camera-rays", "40x40", "--rays", "1600", "--ortho", "--methods", "quadratic-taylor,segment"])
        .args(["--json", bench.to_str().unwrap()])
        .ok();
    let report = json(&bench);
    assert!(report["reference_hit_rate"].as_f64().unwrap() > 0.3, "{report}");
    for row in report["methods"].as_array().unwrap() {
        assert_eq!((row["miss_rate"].as_f64(), row["false_hit_rate"].as_f64()), (Some(0.0), Some(0.0)), "{row}");
    }
}

/// Depth cueing in closed form: a plane tilted in depth, inside bounds
/// whose corners span view depths 5 to 15 from the eye. Each pixel's
/// colour with `--depth-cue 0.2:0.8` is its colour without, blended toward
/// the background by the share (z − 7)/6 clamped to [0, 1], z the depth of
/// the surface on the pixel's ray (found from the f64 field by bisection),
/// within one 8-bit level.
#[test]
fn depth_cueing_blends_a_tilted_plane_by_its_depth() {
    let dir = scratch("view-cue");
    let path = dir.join("tilted.ron");
    std::fs::write(
        &path,
        r#"Scene(
    camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), fov_y: 40.0, resolution: (48, 48)),
    background: (0.9, 0.5, 0.1),
    ambient: (0.6, 0.6, 0.6),
    surface: (0.2, 0.4, 0.8),
    lights: [(direction: (0.0, 0.0, 1.0))],
    iso: 0.5,
    bounds: Some((min: (-5.0, -5.0, -5.0), max: (5.0, 5.0, 5.0))),
    marching: (method: "quadratic-taylor", min_step: 0.001),
    groups: [(primitives: [Plane(normal: (0.0, -0.8, -0.6), offset: 0.0, radius: 1.0)])],
)"#,
    )
    .unwrap();
    let (plain, cued) = (dir.join("plain.png"), dir.join("cued.png"));
    isomarch(["render", path.to_str().unwrap(), "-o", plain.to_str().unwrap()]).ok();
    isomarch(["render", path.to_str().unwrap(), "-o", cued.to_str().unwrap(), "--depth-cue", "0.2:0.8"]).ok();
    let (plain, cued) = (image::open(&plain).unwrap().to_rgb8(), image::open(&cued).unwrap().to_rgb8());
    let scene = isomarch::scene::Scene::load(&path).unwrap();
    let field = isomarch::field::Field::new(&scene);
    let (w, h) = (48u32, 48u32);
    let half = 20f64.to_radians().tan();
    let bg = [0.9f32, 0.5, 0.1];
    let linear = isomarch::molecule::elements::linear;
    let (mut checked, mut blended) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let d =
                DVec3::new((2.0 * (f64::from(x) + 0.5) / f64::from(w) - 1.0) * half, (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(h)) * half, -1.0)
                    .normalize();
            let eye = DVec3::new(0.0, 0.0, 10.0);
            // The first crossing inside the bounds (the plane's field is a
            // slab about it): a scan in steps of 1e-3, then bisection.
            let Some((t0, t1)) = scene.bounds.clip_ray(eye, d) else { continue };
            let Some(k) = (0..=((t1 - t0) / 1e-3) as usize).find(|&k| field.value(eye + (t0 + 1e-3 * k as f64) * d) > 0.0) else { continue };
            if k == 0 {
                continue;
            }
            let (mut lo, mut hi) = (t0 + 1e-3 * (k - 1) as f64, t0 + 1e-3 * k as f64);
            for _ in 0..100 {
                let m = 0.5 * (lo + hi);
                if field.value(eye + m * d) > 0.0 { hi = m } else { lo = m }
            }
            let z = hi * -d.z; // depth along the view direction (-z)
            let share = ((z - 7.0) / 6.0).clamp(0.0, 1.0);
            let (p, c) = (plain.get_pixel(x, y).0, cued.get_pixel(x, y).0);
            for k in 0..3 {
                let want = isomarch::output::srgb((linear(p[k]) * (1.0 - share) + f64::from(bg[k]) * share) as f32);
                assert!(c[k].abs_diff(want) <= 1, "pixel ({x}, {y}), depth {z:.3}, share {share:.3}: channel {k} is {}, expected {want}", c[k]);
            }
            checked += 1;
            blended += usize::from(share > 0.05 && share < 0.95);
        }
    }
    assert!(checked > 1000 && blended > 200, "{checked} pixels on the plane, {blended} partly blended");
    // `--depth-cue` without a value is 0.5:1 (docs/commands.md): the same
    // bytes, and a blend that shows (the plane reaches beyond half the
    // depth range).
    let (alone, half) = (dir.join("cue-alone.png"), dir.join("cue-half.png"));
    isomarch(["render", path.to_str().unwrap(), "-o", alone.to_str().unwrap(), "--depth-cue"]).ok();
    isomarch(["render", path.to_str().unwrap(), "-o", half.to_str().unwrap(), "--depth-cue", "0.5:1"]).ok();
    let alone_bytes = std::fs::read(&alone).unwrap();
    assert!(alone_bytes == std::fs::read(&half).unwrap(), "--depth-cue alone renders otherwise than --depth-cue 0.5:1");
    let alone = image::load_from_memory(&alone_bytes).unwrap().to_rgb8();
    let changed = alone.pixels().zip(plain.pixels()).filter(|(p, q)| p != q).count();
    assert!(changed > 100, "--depth-cue alone changed only {changed} pixels");
}

/// Clipping in closed form: a sphere of radius ρ = 3·sqrt(1 − cbrt(0.5))
/// about the origin, the eye 12 away, `--clip near:12` (the plane through
/// the centre). Cut faces are capped: from the front the sphere shows a
/// disc of radius ρ/12/tan(15°)·48 pixels whose every pixel is hit on the
/// plane (depth 12 along the view, from the depth AOV) with the plane's
/// normal, facing the camera. `bench` against the f64 reference on the
/// same clipped camera rays: no miss, no false hit, the sphere and 1A8O.
#[test]
fn a_clipped_sphere_shows_its_cap_on_the_cutting_plane() {
    let dir = scratch("view-clip");
    let path = dir.join("ball.ron");
    let camera = "eye: (0.0, 0.0, 12.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96)";
    std::fs::write(&path, ball_scene(camera, 3.0, "lights: [(direction: (0.3, 0.8, 0.5))],")).unwrap();
    let exr = dir.join("cut.exr");
    isomarch(["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--clip", "near:12", "--aov", "depth,normal"]).ok();
    let image = exr::prelude::read_all_flat_layers_from_file(&exr).unwrap();
    let (depth, nz) = (exr_channel(&image, "Z"), exr_channel(&image, "normal.Z"));
    let rho = 3.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    let half = 15f64.to_radians().tan();
    let mut hits = 0;
    for y in 0..96u32 {
        for x in 0..96u32 {
            let i = (y * 96 + x) as usize;
            let (sx, sy) = ((2.0 * (f64::from(x) + 0.5) / 96.0 - 1.0) * half, (1.0 - 2.0 * (f64::from(y) + 0.5) / 96.0) * half);
            let d = DVec3::new(sx, sy, -1.0).normalize();
            // Where the ray meets the plane z = 0: inside the disc or not.
            let t = 12.0 / -d.z;
            let r = (t * d).truncate().length();
            if !depth[i].is_finite() {
                assert!(r > rho - 0.05, "pixel ({x}, {y}) missed at {r:.3} from the centre, inside the cap of radius {rho:.3}");
                continue;
            }
            hits += 1;
            assert!(r < rho + 0.05, "pixel ({x}, {y}) hit at {r:.3} from the centre, outside the cap");
            assert!((f64::from(depth[i]) - t).abs() < 1e-4 * t, "pixel ({x}, {y}): depth {} where the plane is at {t:.5}", depth[i]);
            assert!(nz[i] > 0.9999, "pixel ({x}, {y}): normal z {} is not the plane's, facing the camera", nz[i]);
        }
    }
    // Shadows and occlusion see what the clipping kept: a cap faces the
    // removed side, so none of its rays is shadowed or occluded.
    let (lit, plain) = (dir.join("lit.png"), dir.join("plain.png"));
    isomarch(["render", path.to_str().unwrap(), "-o", lit.to_str().unwrap(), "--clip", "near:12", "--shadows", "--ao", "8"]).ok();
    isomarch(["render", path.to_str().unwrap(), "-o", plain.to_str().unwrap(), "--clip", "near:12"]).ok();
    assert_eq!(image::open(&lit).unwrap().to_rgb8(), image::open(&plain).unwrap().to_rgb8(), "the cap is shadowed or occluded by what was cut away");
    let disc = rho / 12.0 / half * 48.0;
    let measured = (f64::from(hits) / std::f64::consts::PI).sqrt();
    assert!((measured - disc).abs() < 1.0, "a cap of radius {measured:.2} pixels, expected {disc:.2}");
    for (input, clip) in [(path.clone(), "near:12"), (repo_root().join("tests/data/molecules/1A8O.pdb"), "near:80,far:120")] {
        let bench = dir.join("bench.json");
        isomarch([
            "bench",
            input.to_str().unwrap(),
            "--camera-rays",
            "40x40",
            "--rays",
            "1600",
            "--clip",
            clip,
            "--methods",
            "quadratic-taylor,segment",
        ])
        .args(["--json", bench.to_str().unwrap()])
        .ok();
        let report = json(&bench);
        assert!(report["reference_hit_rate"].as_f64().unwrap() > 0.1, "{report}");
        for row in report["methods"].as_array().unwrap() {
            assert_eq!((row["miss_rate"].as_f64(), row["false_hit_rate"].as_f64()), (Some(0.0), Some(0.0)), "{clip}: {row}");
        }
    }
    for bad in ["near:5,far:4", "near", "side:3", "near:x"] {
        let err = isomarch(["render", path.to_str().unwrap(), "-o", dir.join("x.png").to_str().unwrap(), "--clip", bad]).fails_in_one_line();
        assert!(err.contains("--clip"), "{bad}: {err}");
    }
}

/// `far` clipping in closed form: the sphere of radius ρ = 3·sqrt(1 −
/// cbrt(0.5)) = 1.37 about the origin, the eye 12 away, `--clip far:11`
/// (nothing farther than 11 from the eye's plane along the view). Far cuts
/// are not capped: a pixel hits where its ray meets the sphere first at a
/// view depth of at most 11, at that distance (the depth AOV), and misses
/// where the sphere's front lies beyond 11 or the ray passes it by, every
/// pixel 0.005 from either boundary checked. The front of the sphere
/// reaches 10.63, so the far plane cuts the disc down to a cap of about 15
/// pixels' radius (the unclipped disc has 21).
#[test]
fn a_far_clip_cuts_a_sphere_from_behind() {
    let dir = scratch("view-far");
    let path = dir.join("ball.ron");
    let camera = "eye: (0.0, 0.0, 12.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96)";
    std::fs::write(&path, ball_scene(camera, 3.0, "lights: [(direction: (0.3, 0.8, 0.5))],")).unwrap();
    let exr = dir.join("far.exr");
    isomarch(["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--clip", "far:11", "--aov", "depth"]).ok();
    let depth = exr_channel(&exr::prelude::read_all_flat_layers_from_file(&exr).unwrap(), "Z");
    let rho = 3.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    let (eye, far) = (DVec3::new(0.0, 0.0, 12.0), 11.0);
    let half = 15f64.to_radians().tan();
    let (mut hits, mut cut) = (0, 0);
    for y in 0..96u32 {
        for x in 0..96u32 {
            let i = (y * 96 + x) as usize;
            let (sx, sy) = ((2.0 * (f64::from(x) + 0.5) / 96.0 - 1.0) * half, (1.0 - 2.0 * (f64::from(y) + 0.5) / 96.0) * half);
            let d = DVec3::new(sx, sy, -1.0).normalize();
            // |eye + t d| = ρ: t = -b - sqrt(b² - c), b = eye·d, c = |eye|² - ρ².
            let (b, c) = (eye.dot(d), eye.length_squared() - rho * rho);
            let disc = b * b - c;
            // Where the ray meets the sphere first, and that point's view depth.
            let first = (disc > 0.0).then(|| -b - disc.sqrt());
            let at = format!("pixel ({x}, {y}): depth {}", depth[i]);
            match first {
                Some(t) if (t * -d.z - far).abs() < 0.005 => {}
                Some(t) if t * -d.z < far => {
                    // Grazing rays (the chord under 0.1) may go either way.
                    if disc.sqrt() < 0.05 {
                        continue;
                    }
                    assert!((f64::from(depth[i]) - t).abs() < 1e-3, "{at}, where the sphere's front is at {t:.5}, before the far plane");
                    hits += 1;
                }
                Some(t) => {
                    assert!(!depth[i].is_finite(), "{at}, where the sphere's front lies at view depth {:.4}, beyond far:11", t * -d.z);
                    cut += 1;
                }
                None => assert!(disc > -0.01 || !depth[i].is_finite(), "{at}, where the ray passes the sphere by"),
            }
        }
    }
    assert!(hits > 500 && cut > 400, "{hits} pixels kept before the far plane, {cut} cut away behind it");
}
