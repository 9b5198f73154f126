//! Anti-aliasing (`render --samples N`) against the closed form: a straight
//! edge's pixels hold its analytic coverage within 1/N, for every method.

use crate::common::*;
use glam::DVec3;
use isomarch::scene::Scene;

/// A plane facing the camera, cut by the scene's box at x = EDGE: a
/// straight vertical edge. The one light lies in the plane, so the surface
/// is its ambient colour everywhere.
const EDGE: f64 = 0.37;

fn scene_text(method: &str) -> String {
    format!(
        r#"Scene(
    camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (40, 8)),
    background: (0.1, 0.1, 0.1),
    ambient: (0.8, 0.8, 0.8),
    surface: (1.0, 1.0, 1.0),
    lights: [(direction: (1.0, 0.0, 0.0))],
    iso: 0.5,
    bounds: Some((min: (-100.0, -100.0, -2.0), max: ({EDGE}, 100.0, 2.0))),
    marching: (method: "{method}", min_step: 0.001),
    groups: [(primitives: [Plane(normal: (0.0, 0.0, 1.0), offset: 0.0, radius: 1.0)])],
)"#
    )
}

/// The edge's position in pixels from the left of the 40x8 image of the
/// scene at `path`: the plane's depth from the f64 reference field by
/// bisection, then a pinhole looking down -z at it (screen x is linear in
/// world x).
fn edge_in_pixels(path: &std::path::Path) -> f64 {
    let (w, h) = (40u32, 8u32);
    let scene = Scene::load(path).unwrap();
    let field = isomarch::field::Field::new(&scene);
    let (mut lo, mut hi) = (0.0, 1.9);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if field.value(DVec3::new(0.0, 0.0, mid)) > 0.0 { lo = mid } else { hi = mid }
    }
    let z = 0.5 * (lo + hi);
    let half_w = (15f64.to_radians()).tan() * f64::from(w) / f64::from(h);
    (EDGE / (10.0 - z) / half_w + 1.0) * f64::from(w) / 2.0
}

#[test]
fn an_edges_pixels_hold_its_analytic_coverage_within_one_over_n() {
    let dir = scratch("antialias");
    let (w, h) = (40u32, 8u32);
    for method in ["quadratic-taylor", "segment", "sphere", "linear-taylor", "quadratic"] {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method)).unwrap();
        let edge = edge_in_pixels(&path);
        for n in [1u32, 4, 16] {
            let exr_path = dir.join(format!("{method}-{n}.exr"));
            run_ok(&["render", path.to_str().unwrap(), "-o", exr_path.to_str().unwrap(), "--samples", &n.to_string()]);
            let exr = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
            let red = exr_channel(&exr, "R");
            let (inside, outside) = (0.8f64, 0.1f64);
            let mut partial = 0;
            for y in 0..h {
                for x in 0..w {
                    let coverage = (edge - f64::from(x)).clamp(0.0, 1.0);
                    let got = f64::from(red[(y * w + x) as usize]);
                    // One sample (the pixel's centre) is all or nothing:
                    // the surface's colour where the centre is left of the
                    // edge, the background's where it is right of it (a
                    // centre within 1e-3 of the edge may go either way).
                    let centre = f64::from(x) + 0.5;
                    let (want, tolerance) = if n > 1 {
                        (outside + coverage * (inside - outside), (inside - outside) / f64::from(n) + 1e-5)
                    } else if (centre - edge).abs() < 1e-3 {
                        (0.5 * (inside + outside), 0.5 * (inside - outside) + 1e-5)
                    } else {
                        (if centre < edge { inside } else { outside }, 1e-5)
                    };
                    assert!(
                        (got - want).abs() <= tolerance,
                        "{method}, {n} samples, pixel ({x}, {y}): {got} where the edge's coverage {coverage:.4} gives {want:.4} (tolerance {tolerance:.4})"
                    );
                    partial += usize::from(got > outside + 1e-4 && got < inside - 1e-4);
                }
            }
            // The edge runs through one column: its pixels are partly
            // covered once there is more than one sample.
            assert_eq!(partial, if n == 1 { 0 } else { h as usize }, "{method}, {n} samples: partly covered pixels");
        }
    }
}

/// `--samples` is checked (1 to 4096), the scene's `camera.samples` is the
/// default, and `--frames` renders each frame with the samples a single
/// frame takes.
#[test]
fn samples_are_checked_defaulted_from_the_scene_and_kept_in_batches() {
    let dir = scratch("aa-samples");
    let path = dir.join("edge.ron");
    std::fs::write(&path, scene_text("quadratic-taylor")).unwrap();
    let p = path.to_str().unwrap();
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    for bad in ["0", "4097"] {
        let err = isomarch(["render", p, "-o", &out("bad.png"), "--samples", bad]).fails_in_one_line();
        assert!(err.contains("--samples must be 1 to 4096") && err.contains(bad), "{err}");
    }
    assert!(!dir.join("bad.png").exists());
    // 4096 is allowed.
    isomarch(["render", p, "-o", &out("most.png"), "--samples", "4096", "--size", "4x2"]).ok();
    // camera.samples: 4 in the file renders as --samples 4, and the flag
    // still overrides it.
    let with_four = dir.join("edge4.ron");
    std::fs::write(&with_four, scene_text("quadratic-taylor").replace("resolution: (40, 8)", "resolution: (40, 8), samples: 4")).unwrap();
    isomarch(["render", with_four.to_str().unwrap(), "-o", &out("file4.png")]).ok();
    isomarch(["render", p, "-o", &out("flag4.png"), "--samples", "4"]).ok();
    isomarch(["render", p, "-o", &out("flag1.png")]).ok();
    isomarch(["render", with_four.to_str().unwrap(), "-o", &out("file4-flag1.png"), "--samples", "1"]).ok();
    let bytes = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert!(bytes("file4.png") == bytes("flag4.png"), "camera.samples 4 renders otherwise than --samples 4");
    assert!(bytes("file4-flag1.png") == bytes("flag1.png"), "--samples 1 does not override camera.samples");
    assert!(bytes("flag4.png") != bytes("flag1.png"), "4 samples and 1 give the same image");
    // A batch frame with --samples 4 is the single frame with them.
    isomarch(["render", p, "-o", &out("f_#.png"), "--frames", "0..1", "--samples", "4"]).ok();
    assert!(bytes("f_0.png") == bytes("flag4.png"), "--frames renders with other samples than a single frame");
}

/// `--transparent-background`: at the edge above (a straight vertical
/// edge, where each of 16 samples stands in its own column), alpha is the
/// pixel's analytic coverage within 1/16 (and half an 8-bit level); the
/// covered part keeps the surface's colour (not blended with the
/// background), the rest is fully transparent. The EXR holds the same
/// coverage in A. `--background` colours the misses.
#[test]
fn a_transparent_background_holds_the_edges_coverage_in_alpha() {
    let dir = scratch("aa-alpha");
    let (w, h) = (40u32, 8u32);
    let path = dir.join("edge.ron");
    std::fs::write(&path, scene_text("quadratic-taylor")).unwrap();
    let edge = edge_in_pixels(&path);
    let png = dir.join("alpha.png");
    let exr = dir.join("alpha.exr");
    for out in [&png, &exr] {
        run_ok(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--samples", "16", "--transparent-background"]);
    }
    let img = image::open(&png).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8, "an RGBA PNG");
    let img = img.to_rgba8();
    let layers = exr::prelude::read_all_flat_layers_from_file(&exr).unwrap();
    let a = exr_channel(&layers, "A");
    let rgb = ["R", "G", "B"].map(|c| exr_channel(&layers, c));
    let surface = isomarch::output::srgb(0.8);
    let mut partial = 0;
    for y in 0..h {
        for x in 0..w {
            let coverage = (edge - f64::from(x)).clamp(0.0, 1.0);
            let p = img.get_pixel(x, y).0;
            let alpha = f64::from(p[3]) / 255.0;
            assert!(
                (alpha - coverage).abs() <= 1.0 / 16.0 + 0.5 / 255.0 + 1e-9,
                "pixel ({x}, {y}): alpha {alpha} where the coverage is {coverage:.4}"
            );
            let i = (y * w + x) as usize;
            assert!((f64::from(a[i]) - coverage).abs() <= 1.0 / 16.0 + 1e-6, "EXR pixel ({x}, {y})");
            // The EXR's colour is premultiplied: the surface's 0.8 times the
            // share of samples that hit (none of the background's 0.1).
            for (channel, values) in ["R", "G", "B"].iter().zip(&rgb) {
                let want = 0.8 * f64::from(a[i]);
                assert!(
                    (f64::from(values[i]) - want).abs() <= 1e-5,
                    "EXR pixel ({x}, {y}): {channel} {} where 0.8 x alpha {} is {want:.6} (premultiplied)",
                    values[i],
                    a[i]
                );
            }
            if p[3] > 0 {
                assert!(p[..3].iter().all(|&c| c.abs_diff(surface) <= 1), "pixel ({x}, {y}): {p:?} is not the surface's colour {surface}");
            } else {
                assert_eq!(p, [0, 0, 0, 0]);
            }
            partial += usize::from(p[3] > 0 && p[3] < 255);
        }
    }
    assert_eq!(partial, h as usize, "one column of partly covered pixels");
    // --background: misses take it (sRGB as given), hits do not change.
    let red = dir.join("red.png");
    run_ok(&["render", path.to_str().unwrap(), "-o", red.to_str().unwrap(), "--background", "#ff8000"]);
    let red = image::open(&red).unwrap().to_rgb8();
    assert_eq!(red.get_pixel(w - 1, 0).0, [0xFF, 0x80, 0x00]);
    assert_eq!(red.get_pixel(0, 0).0, [surface; 3]);
    // A CSS name (navy is #000080) and linear r,g,b (written as sRGB),
    // and a colour that is none refused in one line.
    let srgb = isomarch::output::srgb;
    for (given, want) in [("navy", [0x00, 0x00, 0x80]), ("0.2,0.4,0.6", [srgb(0.2), srgb(0.4), srgb(0.6)])] {
        let png = dir.join("bg.png");
        run_ok(&["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--background", given]);
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.get_pixel(w - 1, 0).0, want, "--background {given}");
        assert_eq!(img.get_pixel(0, 0).0, [surface; 3], "--background {given} changed a hit");
    }
    let err = isomarch(["render", path.to_str().unwrap(), "-o", dir.join("bad.png").to_str().unwrap(), "--background", "navvy"]).fails_in_one_line();
    assert!(err.contains("--background \"navvy\" is no colour"), "{err}");
    assert!(!dir.join("bad.png").exists(), "a refused --background wrote an image");
}

/// `--outline 3` on the edge above, the edge's column e and its coverage c
/// taken from the geometry (`edge_in_pixels`), every pixel of every row
/// checked. One sample (a pixel hits where its centre is left of the edge):
/// the three hit columns next to the edge take the outline's colour, the
/// hits before them keep the surface's, and every miss keeps the
/// background's (no outline drawn outside the edge). With 16 samples, in
/// linear light (EXR), per sample: column e's hits all outlined and its
/// misses background (its green share is its coverage, within 1/16), the
/// two columns before it all outline, column e - 3 outlined where a sample
/// of column e within 3 rows misses (at least 1 - c of its samples, within
/// 1/16), the columns before it the surface and the columns after it the
/// background, exactly.
#[test]
fn an_outline_is_drawn_its_width_inside_the_surfaces_edge() {
    let dir = scratch("aa-outline");
    let (w, h) = (40u32, 8u32);
    let path = dir.join("edge.ron");
    std::fs::write(&path, scene_text("quadratic-taylor")).unwrap();
    let edge = edge_in_pixels(&path);
    let (e, c) = (edge.floor() as u32, edge.fract());
    // The edge well inside a column and away from its centre, so that one
    // sample's side of it is sure and the columns below are the cases named.
    assert!((0.1..0.9).contains(&c) && (c - 0.5).abs() > 0.01 && (4..w - 1).contains(&e), "the edge at {edge} pixels");
    let png = dir.join("outline.png");
    run_ok(&["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--outline", "3", "--outline-color", "#00ff00"]);
    let img = image::open(&png).unwrap().to_rgb8();
    let (surface, background) = ([isomarch::output::srgb(0.8); 3], [isomarch::output::srgb(0.1); 3]);
    // The last column whose centre is left of the edge.
    let last = if c > 0.5 { e } else { e - 1 };
    for y in 0..h {
        for x in 0..w {
            let want = if x > last {
                background
            } else if x + 3 > last {
                [0, 255, 0]
            } else {
                surface
            };
            assert_eq!(img.get_pixel(x, y).0, want, "pixel ({x}, {y}), the edge at {edge:.4} pixels, the last hit column {last}");
        }
    }
    // 16 samples, in linear light: the outline green (0, 1, 0), the
    // surface 0.8, the background 0.1.
    let exr_path = dir.join("outline16.exr");
    run_ok(&["render", path.to_str().unwrap(), "-o", exr_path.to_str().unwrap(), "--outline", "3", "--outline-color", "#00ff00", "--samples", "16"]);
    let layers = exr::prelude::read_all_flat_layers_from_file(&exr_path).unwrap();
    let [red, green, blue] = ["R", "G", "B"].map(|ch| exr_channel(&layers, ch));
    let close = |got: f32, want: f64| (f64::from(got) - want).abs() <= 1e-5;
    let n = 16.0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (r, g, b) = (red[i], green[i], blue[i]);
            let at = format!("pixel ({x}, {y}) = ({r}, {g}, {b}), the edge at {edge:.4} pixels");
            if x > e {
                assert!(close(r, 0.1) && close(g, 0.1) && close(b, 0.1), "{at}: not the background");
            } else if x == e {
                // Hits outlined, misses background: G = k + 0.1 (1 - k),
                // R = B = 0.1 (1 - k), k the share of samples that hit.
                let k = (f64::from(g) - 0.1) / 0.9;
                assert!((k - c).abs() <= 1.0 / n + 1e-5, "{at}: {k:.4} of the edge column outlined, its coverage {c:.4}");
                assert!(close(r, 0.1 * (1.0 - k)) && close(b, 0.1 * (1.0 - k)), "{at}: not outline and background");
            } else if x + 2 >= e {
                assert!(close(r, 0.0) && close(g, 1.0) && close(b, 0.0), "{at}: not the outline");
            } else if x + 3 == e {
                // Outline on a share f of samples, the surface on the rest.
                let f = 1.0 - f64::from(r) / 0.8;
                assert!(f >= 1.0 - c - 1.0 / n - 1e-5 && f <= 1.0 + 1e-5, "{at}: {f:.4} outlined, at least {:.4} expected", 1.0 - c);
                assert!(close(g, 0.8 + 0.2 * f) && close(b, f64::from(r)), "{at}: not outline and surface");
            } else {
                assert!(close(r, 0.8) && close(g, 0.8) && close(b, 0.8), "{at}: not the surface");
            }
        }
    }
    // `--outline` without a width is 1 (docs/commands.md): the same bytes
    // as `--outline 1`, whose one outline column is the last hit's alone.
    let (alone, one) = (dir.join("outline-alone.png"), dir.join("outline-1.png"));
    run_ok(&["render", path.to_str().unwrap(), "-o", alone.to_str().unwrap(), "--outline", "--outline-color", "#00ff00"]);
    run_ok(&["render", path.to_str().unwrap(), "-o", one.to_str().unwrap(), "--outline", "1", "--outline-color", "#00ff00"]);
    assert!(std::fs::read(&alone).unwrap() == std::fs::read(&one).unwrap(), "--outline alone renders otherwise than --outline 1");
    let alone = image::open(&alone).unwrap().to_rgb8();
    for y in 0..h {
        for x in 0..w {
            let want = if x > last {
                background
            } else if x == last {
                [0, 255, 0]
            } else {
                surface
            };
            assert_eq!(alone.get_pixel(x, y).0, want, "--outline alone: pixel ({x}, {y}), the last hit column {last}");
        }
    }
    let err = isomarch(["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--outline", "0"]).fails_in_one_line();
    assert!(err.contains("--outline takes a width of 1 to 64 pixels"), "{err}");
    let err = isomarch(["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--outline-jump", "0.1"]).fails_in_one_line();
    assert!(err.contains("--outline-jump and") || err.contains("which was not given"), "{err}");
}

/// `--transparent-background` at one sample (the pixel's centre): alpha is
/// the coverage of one sample, 0 or 255 and nothing between, 255 exactly
/// where the centre lies left of the edge (from the geometry); a covered
/// pixel's colour is the opaque render's, byte for byte, an uncovered one
/// (0, 0, 0, 0). The EXR's A is 0 or 1 and its colour premultiplied.
#[test]
fn a_transparent_background_at_one_sample_is_all_or_nothing() {
    let dir = scratch("aa-alpha-one");
    let (w, h) = (40u32, 8u32);
    let path = dir.join("edge.ron");
    std::fs::write(&path, scene_text("quadratic-taylor")).unwrap();
    let edge = edge_in_pixels(&path);
    assert!((edge.fract() - 0.5).abs() > 0.01, "the edge at {edge} pixels passes through a pixel's centre");
    let (png, exr, opaque) = (dir.join("alpha.png"), dir.join("alpha.exr"), dir.join("opaque.png"));
    for out in [&png, &exr] {
        run_ok(&["render", path.to_str().unwrap(), "-o", out.to_str().unwrap(), "--transparent-background"]);
    }
    run_ok(&["render", path.to_str().unwrap(), "-o", opaque.to_str().unwrap()]);
    let (img, opaque) = (image::open(&png).unwrap(), image::open(&opaque).unwrap().to_rgb8());
    assert_eq!(img.color(), image::ColorType::Rgba8, "an RGBA PNG");
    let img = img.to_rgba8();
    let layers = exr::prelude::read_all_flat_layers_from_file(&exr).unwrap();
    let (a, red) = (exr_channel(&layers, "A"), exr_channel(&layers, "R"));
    let mut covered = 0;
    for y in 0..h {
        for x in 0..w {
            let p = img.get_pixel(x, y).0;
            let hit = f64::from(x) + 0.5 < edge;
            if hit {
                assert_eq!(
                    p,
                    [opaque.get_pixel(x, y)[0], opaque.get_pixel(x, y)[1], opaque.get_pixel(x, y)[2], 255],
                    "pixel ({x}, {y}), the edge at {edge:.4}"
                );
            } else {
                assert_eq!(p, [0, 0, 0, 0], "pixel ({x}, {y}), the edge at {edge:.4}");
            }
            let i = (y * w + x) as usize;
            let want = if hit { 1.0 } else { 0.0 };
            assert!(a[i] == want && (red[i] - 0.8 * want).abs() <= 1e-5, "EXR pixel ({x}, {y}): A {} R {}, the edge at {edge:.4}", a[i], red[i]);
            covered += usize::from(hit);
        }
    }
    assert!(covered >= 8 * 20 && covered < (w * h) as usize, "{covered} pixels covered");
}
