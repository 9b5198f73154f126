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

/// `--outline-jump F` in closed form: an orthographic view (height 4,
/// 64x64) of a sphere of radius ρ = 2·sqrt(1 − cbrt(0.5)) about the
/// origin in front of a plane slab whose front face lies at z = −3.548,
/// the eye at z = 10, the bounds' view depths 7 to 16 (a depth range of 9).
/// Every pixel hits the sphere or the plane. With `--outline 6
/// --outline-jump 0.44` a sphere pixel is outlined exactly when a plane
/// pixel lies within 6 pixels (in x and y) and the plane is farther than
/// it by more than 0.44 × 9 = 3.96: the sphere's front at radius r lies
/// sqrt(ρ² − r²) before its centre, so the rim (r above 0.804) stays
/// unoutlined next to the plane while the band inside it is outlined.
/// Pixels within 0.01 of a decision are left out.
#[test]
fn an_outline_jump_outlines_only_steps_deeper_than_its_fraction_of_the_depth_range() {
    let dir = scratch("view-jump");
    let path = dir.join("step.ron");
    std::fs::write(
        &path,
        r#"Scene(
    camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), resolution: (64, 64), projection: Orthographic(height: 4.0)),
    background: (0.0, 0.0, 0.0),
    surface: (0.8, 0.5, 0.3),
    lights: [(direction: (0.3, 0.5, 1.0))],
    iso: 0.5,
    bounds: Some((min: (-10.0, -10.0, -6.0), max: (10.0, 10.0, 3.0))),
    marching: (method: "quadratic-taylor", min_step: 0.001),
    groups: [(primitives: [
        Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0)),
        Plane(normal: (0.0, 0.0, 1.0), offset: -4.0, radius: 1.0),
    ])],
)"#,
    )
    .unwrap();
    let png = dir.join("jump.png");
    isomarch(["render", path.to_str().unwrap(), "-o", png.to_str().unwrap()])
        .args(["--outline", "6", "--outline-jump", "0.44", "--outline-color", "#00ff00"])
        .ok();
    let img = image::open(&png).unwrap().to_rgb8();
    let shell = (1.0 - 0.5f64.cbrt()).sqrt();
    let (rho, plane_depth) = (2.0 * shell, 10.0 - (-4.0 + shell));
    let threshold = 0.44 * 9.0;
    // The pixel's centre, scene units from the axis.
    let r = |x: i64, y: i64| ((x as f64 + 0.5) / 16.0 - 2.0).hypot((y as f64 + 0.5) / 16.0 - 2.0);
    let (mut outlined, mut rim, mut plain) = (0, 0, 0);
    for (x, y, p) in img.enumerate_pixels() {
        let (x, y) = (i64::from(x), i64::from(y));
        let green = p.0 == [0, 255, 0];
        let at = format!("pixel ({x}, {y}) at {:.4} from the axis, the sphere's radius {rho:.4}", r(x, y));
        if r(x, y) > rho + 0.01 {
            assert!(!green, "{at}: a plane pixel is outlined (nothing within 6 pixels is farther)");
            plain += 1;
            continue;
        }
        if r(x, y) > rho - 0.01 {
            continue;
        }
        let jump = plane_depth - (10.0 - (rho * rho - r(x, y).powi(2)).sqrt());
        if (jump - threshold).abs() < 0.01 {
            continue;
        }
        let window =
            || (x - 6..=x + 6).flat_map(move |u| (y - 6..=y + 6).map(move |v| (u, v))).filter(|&(u, v)| (0..64).contains(&u) && (0..64).contains(&v));
        let sure_plane = window().any(|(u, v)| r(u, v) > rho + 0.01);
        let maybe_plane = window().any(|(u, v)| r(u, v) > rho - 0.01);
        if jump > threshold && sure_plane {
            assert!(green, "{at}: the plane lies {jump:.4} behind, beyond 0.44 of the depth range ({threshold:.2}), within 6 pixels, but no outline");
            outlined += 1;
        } else if jump < threshold && sure_plane {
            assert!(!green, "{at}: the plane lies only {jump:.4} behind (the threshold {threshold:.2}), yet outlined");
            rim += 1;
        } else if !maybe_plane {
            assert!(!green, "{at}: no plane within 6 pixels, yet outlined");
            plain += 1;
        }
    }
    // Counted in f64: 388 outlined, 108 rim pixels, 3544 others.
    assert!(outlined > 300 && rim > 80 && plain > 3000, "{outlined} pixels outlined, {rim} rim pixels not, {plain} others");
}

/// Zooming an orthographic view shrinks its height and leaves the eye
/// (src/scene/turn.rs; the viewer's wheel does the same): a scene file's
/// `Orthographic(height: 8.0)` with `--zoom 2` renders as the same file at
/// height 4, byte for byte, a disc of ρ/4·96 pixels' radius within a pixel.
#[test]
fn zooming_an_orthographic_view_halves_its_height() {
    let dir = scratch("view-ortho-zoom");
    let rho = 2.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    let file = |height: f64| -> std::path::PathBuf {
        let path = dir.join(format!("ball-{height}.ron"));
        let camera = format!(
            "eye: (0.0, 0.0, 30.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96), projection: Orthographic(height: {height:?})"
        );
        std::fs::write(&path, ball_scene(&camera, 2.0, "")).unwrap();
        path
    };
    let render = |input: &std::path::Path, extra: &[&str], name: &str| -> Vec<u8> {
        let png = dir.join(name);
        isomarch(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap()]).args(extra).ok();
        std::fs::read(png).unwrap()
    };
    let zoomed = render(&file(8.0), &["--zoom", "2"], "zoomed.png");
    assert!(zoomed == render(&file(4.0), &[], "four.png"), "--zoom 2 of a view 8 high renders otherwise than a view 4 high");
    let img = image::load_from_memory(&zoomed).unwrap().to_rgb8();
    let measured = (img.pixels().filter(|p| p.0.iter().any(|&c| c > 0)).count() as f64 / std::f64::consts::PI).sqrt();
    let expected = rho / 4.0 * 96.0;
    assert!((measured - expected).abs() < 1.0, "--zoom 2: a disc of radius {measured:.2} pixels, expected {expected:.2}");
}

/// `--camera FILE` is the camera whole and drops the scene's camera path:
/// 1A8O with `--turntable 4` at time 1 (a quarter orbit) renders as at
/// time 0 under `--camera`, byte for byte. The turns come after the
/// camera, whatever the order on the command line: `--turn y:90 --camera
/// FILE` renders the file's camera turned by the library, byte for byte,
/// and not the file's camera alone.
#[test]
fn a_camera_file_drops_the_scenes_path_and_the_turns_come_after_it() {
    let dir = scratch("view-camera-path");
    let camera = dir.join("camera.ron");
    std::fs::write(&camera, "(eye: (60.0, 30.0, 90.0), target: (19.0, 37.0, 17.0), up: (0.0, 1.0, 0.0), fov_y: 20.0, resolution: (48, 40))\n")
        .unwrap();
    let cam = camera.to_str().unwrap();
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let render = |extra: &[&str], name: &str| -> Vec<u8> {
        let png = dir.join(name);
        isomarch(["render", pdb.to_str().unwrap(), "-o", png.to_str().unwrap()]).args(extra).ok();
        std::fs::read(png).unwrap()
    };
    let still = render(&["--camera", cam], "still.png");
    let later = render(&["--camera", cam, "--turntable", "4", "--time", "1"], "later.png");
    assert!(later == still, "--camera keeps the turntable's path: time 1 differs from the file's camera");
    // fig10 (no path) from a camera of its own: the turn given before
    // --camera still applies to it.
    let fig10 = repo_root().join("scenes/fig10.ron");
    let camera = dir.join("fig10-camera.ron");
    std::fs::write(&camera, "(eye: (12.0, 4.0, 10.0), target: (0.0, 0.5, 0.0), fov_y: 40.0, resolution: (48, 40))\n").unwrap();
    let png = dir.join("turned.png");
    isomarch(["render", fig10.to_str().unwrap(), "-o", png.to_str().unwrap(), "--turn", "y:90", "--camera", camera.to_str().unwrap()]).ok();
    let turned = image::open(&png).unwrap().to_rgb8();
    let mut scene = isomarch::scene::Scene::load(&fig10).unwrap();
    let file = isomarch::scene::Camera::load(&camera).unwrap();
    let shown = |scene: &isomarch::scene::Scene, ctx: &std::sync::Arc<isomarch::gpu::Context>| {
        let job = RenderJob::new(scene.clone(), scene.marching.method, (48, 40), PathBuf::new(), std::time::Duration::from_secs(300));
        render_frame(ctx, &job).unwrap().0.shaded()
    };
    let ctx = gpu();
    scene.camera = file.clone();
    let unturned = shown(&scene, &ctx);
    let background = unturned.get_pixel(0, 0).0;
    let shapes = unturned.pixels().filter(|p| p.0 != background).count();
    assert!(shapes > 300, "fig10 covers only {shapes} pixels of its own camera's view");
    scene.camera = file.turned(Turn { axis: ViewAxis::Y, degrees: 90.0 });
    assert!(turned == shown(&scene, &ctx), "--turn y:90 --camera FILE renders otherwise than the file's camera turned");
    let differing = turned.pixels().zip(unturned.pixels()).filter(|(p, q)| p != q).count();
    assert!(differing > 200, "--turn y:90 --camera FILE differs from the file's camera alone in only {differing} pixels: the turn was lost");
    assert_no_validation(&ctx);
}

/// `isomarch scene` writes `--ortho`, `--clip` and `--background` into the
/// file: its camera's projection is the perspective view's height at the
/// target, its clip `near` the one given, its background the linear
/// colour given; and the file renders as the flags do, byte for byte
/// (not as the molecule does without them), its corners the background.
#[test]
fn scene_writes_the_projection_clipping_and_background_into_the_file() {
    let dir = scratch("view-scene-look");
    let pdb = repo_root().join("tests/data/molecules/1A8O.pdb");
    let flags = ["--ortho", "--clip", "near:80", "--background", "0.1,0.2,0.3"];
    let (plain_ron, ron) = (dir.join("plain.ron"), dir.join("look.ron"));
    isomarch(["scene", pdb.to_str().unwrap(), "-o", plain_ron.to_str().unwrap()]).ok();
    isomarch(["scene", pdb.to_str().unwrap(), "-o", ron.to_str().unwrap()]).args(flags).ok();
    let (plain, written) = (isomarch::scene::Scene::load(&plain_ron).unwrap(), isomarch::scene::Scene::load(&ron).unwrap());
    let c = &plain.camera;
    let height = 2.0 * (c.target - c.eye).length() * (0.5 * c.fov_y_deg.to_radians()).tan();
    assert_eq!(written.camera.projection, isomarch::scene::Projection::Orthographic { height }, "the file's projection");
    assert_eq!((written.camera.clip.near, written.camera.clip.far), (Some(80.0), None), "the file's clipping");
    assert_eq!(written.background, DVec3::new(0.1, 0.2, 0.3), "the file's background");
    assert_eq!((written.camera.eye, written.camera.target), (c.eye, c.target), "the camera moved");
    let render = |input: &std::path::Path, extra: &[&str], name: &str| -> Vec<u8> {
        let png = dir.join(name);
        isomarch(["render", input.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64x64"]).args(extra).ok();
        std::fs::read(png).unwrap()
    };
    let from_file = render(&ron, &[], "file.png");
    assert!(from_file == render(&pdb, &flags, "flags.png"), "the scene file renders otherwise than the flags");
    assert!(from_file != render(&pdb, &[], "plain.png"), "the flags changed nothing");
    let img = image::load_from_memory(&from_file).unwrap().to_rgb8();
    let srgb = isomarch::output::srgb;
    assert_eq!(img.get_pixel(0, 0).0, [srgb(0.1), srgb(0.2), srgb(0.3)], "the corner is not the background given");
    let hits = img.pixels().filter(|p| p.0 != [srgb(0.1), srgb(0.2), srgb(0.3)]).count();
    assert!(hits > 400, "only {hits} pixels show the molecule");
}

/// Clip planes in a scene file, in closed form: the sphere of radius ρ =
/// 3·sqrt(1 − cbrt(0.5)) about the origin seen from z = 12, and
/// `camera.clip.planes: [(point: (0.3, 0, 0), normal: (1, 0, -1))]`, which
/// keeps x − z >= 0.3 (world space, at 45° to the view; the eye is on the
/// side removed). Every ray enters the kept side at t0 = 12.3 / (d.x − d.z):
/// inside the sphere there it hits the cap at t0, with the plane's normal
/// turned to the eye, (−1, 0, 1)/√2; else it hits the sphere where it first
/// meets it after t0; else it misses. Every pixel 0.01 from a decision is
/// checked, depth (the AOV) within 1e-3. A file whose `near` is not before
/// its `far` is refused in one line, and so is `--clip far` not beyond the
/// file's `near`.
#[test]
fn a_clip_plane_in_a_scene_file_cuts_in_world_space_and_caps() {
    let dir = scratch("view-planes");
    let camera = |clip: &str| format!("eye: (0.0, 0.0, 12.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (96, 96), clip: ({clip})");
    let path = dir.join("planes.ron");
    let lights = "lights: [(direction: (0.3, 0.8, 0.5))],";
    std::fs::write(&path, ball_scene(&camera("planes: [(point: (0.3, 0.0, 0.0), normal: (1.0, 0.0, -1.0))]"), 3.0, lights)).unwrap();
    let exr = dir.join("planes.exr");
    isomarch(["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--aov", "depth,normal"]).ok();
    let layers = exr::prelude::read_all_flat_layers_from_file(&exr).unwrap();
    let (depth, nx, nz) = (exr_channel(&layers, "Z"), exr_channel(&layers, "normal.X"), exr_channel(&layers, "normal.Z"));
    let rho = 3.0 * (1.0 - 0.5f64.cbrt()).sqrt();
    let eye = DVec3::new(0.0, 0.0, 12.0);
    let half = 15f64.to_radians().tan();
    let cap_normal = std::f64::consts::FRAC_1_SQRT_2;
    let (mut caps, mut sphere, mut cut) = (0, 0, 0);
    for y in 0..96u32 {
        for x in 0..96u32 {
            let i = (y * 96 + x) as usize;
            let (sx, sy) = ((2.0 * (f64::from(x) + 0.5) / 96.0 - 1.0) * half, (1.0 - 2.0 * (f64::from(y) + 0.5) / 96.0) * half);
            let d = DVec3::new(sx, sy, -1.0).normalize();
            let at = format!("pixel ({x}, {y}): depth {}, normal ({}, {})", depth[i], nx[i], nz[i]);
            let (b, c) = (eye.dot(d), eye.length_squared() - rho * rho);
            let disc = b * b - c;
            let t0 = 12.3 / (d.x - d.z);
            let entry = (eye + t0 * d).length();
            if (entry - rho).abs() < 0.01 || disc.abs() < 0.01 {
                continue;
            }
            if entry < rho {
                assert!((f64::from(depth[i]) - t0).abs() < 1e-3, "{at}: the cap is at {t0:.5}");
                let normal = (f64::from(nx[i]) + cap_normal).abs().max((f64::from(nz[i]) - cap_normal).abs());
                assert!(normal < 1e-4, "{at}: the cap's normal is the plane's, towards the eye, (-0.7071, 0, 0.7071)");
                caps += 1;
            } else if disc > 0.0 && -b - disc.sqrt() > t0 + 0.01 {
                let t = -b - disc.sqrt();
                assert!((f64::from(depth[i]) - t).abs() < 1e-3, "{at}: the sphere is met at {t:.5}, past the plane");
                sphere += 1;
            } else if disc < 0.0 || -b + disc.sqrt() < t0 - 0.01 {
                assert!(!depth[i].is_finite(), "{at}: the ray meets no kept part of the sphere");
                cut += usize::from(disc > 0.0);
            }
        }
    }
    // Measured in f64: 876 cap pixels, 64 on the sphere, 330 cut away.
    assert!(caps > 600 && sphere > 40 && cut > 200, "{caps} cap pixels, {sphere} on the sphere, {cut} cut away");
    // near not before far: in the file, and merged with --clip.
    for (clip, flag, says) in [
        ("near: 12.0, far: 11.0", None, "camera.clip: near (12) must be closer than far (11)"),
        ("near: Some(12.0), far: Some(12.0)", None, "camera.clip: near (12) must be closer than far (12)"),
        ("near: 12.0", Some("far:11"), "--clip: near (12) must be closer than far (11), the scene's camera.clip included"),
    ] {
        let bad = dir.join("bad.ron");
        std::fs::write(&bad, ball_scene(&camera(clip), 3.0, lights)).unwrap();
        let png = dir.join("bad.png");
        let err = isomarch(["render", bad.to_str().unwrap(), "-o", png.to_str().unwrap()])
            .args(flag.map(|f| ["--clip", f]).iter().flatten())
            .fails_in_one_line();
        assert!(err.contains(says), "{clip} {flag:?}: {err}");
        assert!(!png.exists(), "{clip}: a refused clip wrote an image");
    }
}
