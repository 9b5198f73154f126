//! Shadows and ambient occlusion (`--shadows`, `--ao N`) against closed
//! forms and the f64 reference, through the binary, for every method that
//! marches them.

use crate::common::*;
use glam::DVec3;
use isomarch::scene::Scene;

/// Every method that marches shadow and occlusion rays: the conservative
/// methods of Algorithm 1 (the bisection baselines refuse rays that start
/// on a surface).
const METHODS: [&str; 8] =
    ["sphere", "segment", "linear-taylor", "quadratic-taylor", "linear", "quadratic", "quadratic-relaxed-t0", "quadratic-relaxed-max"];

/// A plane y = 0 seen from above; with `sphere`, a compact blob of R = 2
/// at (0, 6, 0) over it (their supports apart, so the blob's surface is the
/// sphere of radius 2·sqrt(1 - 0.5^(1/3))). One white light.
fn scene_text(method: &str, sphere: bool, light: DVec3) -> String {
    scene_with_lights(method, sphere, &[(light, 1.0)])
}

/// [`scene_text`] with white lights from each of `lights`, each (its
/// direction, its intensity).
fn scene_with_lights(method: &str, sphere: bool, lights: &[(DVec3, f64)]) -> String {
    let blob = if sphere { "Point(center: (0.0, 6.0, 0.0), kernel: Compact(radius: 2.0))," } else { "" };
    let lights: Vec<String> = lights.iter().map(|(l, i)| format!("(direction: ({}, {}, {}), intensity: {i})", l.x, l.y, l.z)).collect();
    format!(
        r#"Scene(
    camera: (eye: (0.0, 30.0, 0.0), target: (0.0, 0.0, 0.0), up: (0.0, 0.0, -1.0), fov_y: 40.0, resolution: (128, 128)),
    background: (0.0, 0.0, 0.0),
    ambient: (0.2, 0.2, 0.2),
    surface: (0.8, 0.8, 0.8),
    lights: [{}],
    iso: 0.5,
    bounds: Some((min: (-14.0, -1.5, -14.0), max: (14.0, 10.5, 14.0))),
    marching: (method: "{method}", min_step: 0.01),
    groups: [(primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: 0.0, radius: 1.0), {blob}])],
)"#,
        lights.join(", ")
    )
}

fn red(exr: &std::path::Path) -> Vec<f32> {
    exr_channel(&exr::prelude::read_all_flat_layers_from_file(exr).unwrap(), "R")
}

#[test]
fn a_plane_alone_is_not_occluded_and_casts_no_shadow() {
    let dir = scratch("light-plane");
    for method in METHODS {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method, false, DVec3::new(0.3, 1.0, 0.2).normalize())).unwrap();
        let plain = dir.join(format!("{method}.png"));
        run_ok(&["render", path.to_str().unwrap(), "-o", plain.to_str().unwrap()]);
        let lit = dir.join(format!("{method}-lit.png"));
        run_ok(&["render", path.to_str().unwrap(), "-o", lit.to_str().unwrap(), "--shadows", "--ao", "16", "--ao-distance", "50"]);
        // AO exactly 1 and no shadow: not one ray of 16 per pixel, nor the
        // shadow ray, finds a crossing, so nothing is taken away.
        assert!(std::fs::read(&plain).unwrap() == std::fs::read(&lit).unwrap(), "{method}: the plane darkened itself");
    }
}

#[test]
fn a_spheres_shadow_on_a_plane_is_its_analytic_ellipse_within_a_pixel() {
    let dir = scratch("light-shadow");
    // Tilted so that the shadow falls clear of the blob as the camera sees it.
    let l = DVec3::new(0.6, 1.0, 0.2).normalize();
    let (w, h) = (128usize, 128usize);
    let centre = DVec3::new(0.0, 6.0, 0.0);
    let radius = 2.0 * (1.0 - 0.5f64.powf(1.0 / 3.0)).sqrt();
    for method in METHODS {
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, scene_text(method, true, l)).unwrap();
        let scene = Scene::load(&path).unwrap();
        // The plane's surface height, from the f64 reference field.
        let field = isomarch::field::Field::new(&scene);
        let (mut lo, mut hi) = (0.0, 1.4);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if field.value(DVec3::new(12.0, mid, 12.0)) > 0.0 { lo = mid } else { hi = mid }
        }
        let y = 0.5 * (lo + hi);
        // Where each pixel centre's ray meets the plane, and whether the
        // light's ray from there meets the sphere.
        let half = (20f64.to_radians()).tan();
        let ground = |x: f64, z: f64| -> (DVec3, bool, bool) {
            let (sx, sy) = ((2.0 * (x + 0.5) / w as f64 - 1.0) * half, (1.0 - 2.0 * (z + 0.5) / h as f64) * half);
            let d = DVec3::new(sx, -1.0, -sy);
            let q = DVec3::new(0.0, 30.0, 0.0) + (30.0 - y) * d;
            let v = centre - q;
            let s = v.dot(l).max(0.0);
            let shadowed = (v - s * l).length() < radius;
            // The camera's ray passes the blob's support: the pixel may show it.
            let u = d.normalize();
            let c = centre - DVec3::new(0.0, 30.0, 0.0);
            let seen = (c - c.dot(u) * u).length() < 2.0;
            (q, shadowed, seen)
        };
        let exr = dir.join(format!("{method}.exr"));
        run_ok(&["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--shadows"]);
        let red = red(&exr);
        let shade_only = 0.8 * 0.2;
        let (mut inside, mut outside) = (0, 0);
        for z in 1..h - 1 {
            for x in 1..w - 1 {
                let around: Vec<(DVec3, bool, bool)> = (-1..=1)
                    .flat_map(|dz| (-1..=1).map(move |dx| (dx, dz)))
                    .map(|(dx, dz)| ground((x as i32 + dx) as f64, (z as i32 + dz) as f64))
                    .collect();
                if around.iter().any(|g| g.2) {
                    continue;
                }
                let v = f64::from(red[z * w + x]);
                if around.iter().all(|g| g.1) {
                    inside += 1;
                    assert!((v - shade_only).abs() < 2e-3, "{method}: pixel ({x}, {z}) lies a pixel inside the shadow but is lit: {v}");
                } else if around.iter().all(|g| !g.1) {
                    outside += 1;
                    assert!(v > shade_only + 0.3, "{method}: pixel ({x}, {z}) lies a pixel outside the shadow but is dark: {v}");
                }
            }
        }
        assert!(inside > 30 && outside > 5000, "{method}: {inside} pixels checked in the shadow, {outside} outside");
    }
}

/// Two lights, each casting the sphere's shadow on its own side: where the
/// plane is shadowed from one light alone it is lit by exactly the other
/// light's terms (its render alone), so a shadow that took away the wrong
/// light's terms, or both, shows.
#[test]
fn a_pixel_shadowed_from_one_of_two_lights_keeps_the_others_terms() {
    let dir = scratch("light-two");
    // The second at half the first's intensity, so that their terms differ.
    let (l1, l2) = ((DVec3::new(0.6, 1.0, 0.2).normalize(), 1.0), (DVec3::new(-0.5, 1.0, -0.4).normalize(), 0.5));
    let ambient_only = 0.8 * 0.2;
    for method in ["quadratic-taylor", "segment"] {
        let render = |name: &str, lights: &[(DVec3, f64)]| -> Vec<f32> {
            let path = dir.join(format!("{method}-{name}.ron"));
            std::fs::write(&path, scene_with_lights(method, true, lights)).unwrap();
            let exr = dir.join(format!("{method}-{name}.exr"));
            run_ok(&["render", path.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--shadows"]);
            red(&exr)
        };
        let (both, first, second) = (render("both", &[l1, l2]), render("first", &[l1]), render("second", &[l2]));
        // Shadowed: the ambient term alone (the shadow takes the light's
        // terms away in f64 from a base colour kept to 11 bits, so within
        // 2e-3, as the ellipse test allows).
        let shadowed = |alone: &[f32], i: usize| (f64::from(alone[i]) - ambient_only).abs() < 2e-3;
        let (mut from_first, mut from_second) = (0, 0);
        for i in 0..both.len() {
            let (in_first, in_second) = (shadowed(&first, i), shadowed(&second, i));
            if in_first && !in_second {
                from_first += 1;
                assert!(
                    (both[i] - second[i]).abs() < 2e-3,
                    "{method}: pixel {i} shadowed from the first light: {} with both, {} by the second alone",
                    both[i],
                    second[i]
                );
            } else if in_second && !in_first {
                from_second += 1;
                assert!(
                    (both[i] - first[i]).abs() < 2e-3,
                    "{method}: pixel {i} shadowed from the second light: {} with both, {} by the first alone",
                    both[i],
                    first[i]
                );
            }
        }
        assert!(from_first > 30 && from_second > 30, "{method}: {from_first} and {from_second} pixels shadowed from one light alone");
    }
}

#[test]
fn at_the_foot_of_a_wall_half_the_cosine_weighted_hemisphere_is_occluded() {
    // Two slabs at a right angle, as the max of two groups (no blend at the
    // corner): a floor |y| < h and a wall |x| < h, h = sqrt(1 - 0.5^(1/3))
    // for R = 1 at iso 0.5. Seen from straight above; the box reaches 60
    // units out so that rays towards the wall meet it before they leave.
    let dir = scratch("light-wall");
    let h = (1.0 - 0.5f64.powf(1.0 / 3.0)).sqrt();
    let (w, x0, x1) = (64usize, 0.0, 4.0);
    let samples = 32u32;
    // Each pixel's occluded fraction is a count over the 32 rays of its own
    // rotation: the error for a half of the hemisphere cut by a plane
    // through the normal is the largest over rotations of |count/N - 1/2|,
    // computed here from the renderer's own directions.
    let mut sampling = 0.0f64;
    for key in 0..20_000u32 {
        let toward = (0..samples).filter(|&k| isomarch::render::light::ao_direction(DVec3::Y, k, key.wrapping_mul(2_654_435_761)).x < 0.0);
        sampling = sampling.max((toward.count() as f64 / f64::from(samples) - 0.5).abs());
    }
    // 3/32 for these 32 rays (docs/lighting.md).
    assert!(sampling <= 3.0 / f64::from(samples), "the R2 set's half-plane error {sampling} is more than 3/N");
    for method in METHODS {
        let text = format!(
            r#"Scene(
    camera: (eye: ({c}, 40.0, 0.0), target: ({c}, 0.0, 0.0), up: (0.0, 0.0, -1.0), fov_y: {fov}, resolution: ({w}, {w})),
    background: (0.0, 0.0, 0.0),
    ambient: (1.0, 1.0, 1.0),
    surface: (0.5, 0.5, 0.5),
    lights: [(direction: (0.0, 1.0, 0.0), intensity: 0.0)],
    iso: 0.5,
    bounds: Some((min: (-60.0, -2.0, -60.0), max: (60.0, 60.0, 60.0))),
    marching: (method: "{method}", min_step: 0.01),
    groups: [
        (primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: 0.0, radius: 1.0)]),
        (primitives: [Plane(normal: (1.0, 0.0, 0.0), offset: 0.0, radius: 1.0)]),
    ],
)"#,
            c = 0.5 * (x0 + x1),
            fov = 2.0 * (0.5 * (x1 - x0) / (40.0 - h)).atan().to_degrees(),
        );
        let path = dir.join(format!("{method}.ron"));
        std::fs::write(&path, text).unwrap();
        let (plain, lit) = (dir.join(format!("{method}.exr")), dir.join(format!("{method}-ao.exr")));
        run_ok(&["render", path.to_str().unwrap(), "-o", plain.to_str().unwrap()]);
        let n = samples.to_string();
        run_ok(&["render", path.to_str().unwrap(), "-o", lit.to_str().unwrap(), "--ao", &n, "--ao-distance", "1000"]);
        // Occlusion rays that look 1 unit far: the floor more than 1 from
        // the wall's face is not occluded at all.
        let near = dir.join(format!("{method}-ao-near.exr"));
        run_ok(&["render", path.to_str().unwrap(), "-o", near.to_str().unwrap(), "--ao", &n, "--ao-distance", "1"]);
        let (plain, lit, near) = (red(&plain), red(&lit), red(&near));
        // The floor column nearest the wall's face x = h: its pixel centres
        // lie delta from it, and rays towards the wall that pass over it
        // (leaving the box first) are at most (4/pi) delta / 58 of the
        // cosine-weighted measure.
        let pixel = (x1 - x0) / w as f64;
        let column = (0..w).find(|&i| x0 + (i as f64 + 0.5) * pixel > h).unwrap();
        let delta = x0 + (column as f64 + 0.5) * pixel - h;
        let lost = 4.0 / std::f64::consts::PI * delta / 58.0;
        let mut checked = 0;
        for row in 2..w - 2 {
            let i = row * w + column;
            assert!((f64::from(plain[i]) - 0.5).abs() < 1e-3, "{method}: pixel ({column}, {row}) is not the floor: {}", plain[i]);
            let ao = f64::from(lit[i]) / f64::from(plain[i]);
            assert!(
                (ao - 0.5).abs() <= sampling + lost + 1e-4,
                "{method}: AO {ao} at ({column}, {row}), {delta} from the wall; 0.5 within {sampling} (sampling) + {lost} (the box)"
            );
            checked += 1;
        }
        assert!(checked >= 60, "{checked} pixels checked");
        let (mut free, mut shaded) = (0, 0);
        for row in 2..w - 2 {
            for col in column..w {
                let (i, x) = (row * w + col, x0 + (col as f64 + 0.5) * pixel);
                if x - h > 1.0 + 1e-3 {
                    assert_eq!(
                        near[i],
                        plain[i],
                        "{method}: pixel ({col}, {row}) lies {} from the wall, beyond --ao-distance 1, but is occluded",
                        x - h
                    );
                    free += 1;
                } else if col == column {
                    // Beside the wall, most of its half of the hemisphere is within reach.
                    let ao = f64::from(near[i]) / f64::from(plain[i]);
                    assert!(ao < 0.65, "{method}: AO {ao} at ({col}, {row}) beside the wall with --ao-distance 1");
                    shaded += 1;
                }
            }
        }
        assert!(free > 1000 && shaded >= 60, "{method}: {free} pixels beyond the reach, {shaded} beside the wall");
    }
}

#[test]
fn any_hit_answers_agree_with_the_f64_reference_ray_by_ray() {
    // bench --any-hit: shadow and occlusion rays cast from the reference's
    // hits of 1024 of the camera's rays (128x128), marched by every method
    // and compared with the reference's crossings on the same rays.
    let dir = scratch("light-reference");
    let molecule = repo_root().join("tests/data/molecules/1A8O.pdb");
    let fig10 = repo_root().join("scenes/fig10.ron");
    let fig1 = repo_root().join("scenes/fig1.ron");
    let cases: [(&str, &std::path::Path, &[&str]); 3] = [("fig10", &fig10, &[]), ("fig1", &fig1, &["--opaque"]), ("1A8O", &molecule, &[])];
    for (name, scene, extra) in cases {
        let out = dir.join(format!("{name}.json"));
        let methods = METHODS.join(",");
        let mut args = vec!["bench", scene.to_str().unwrap(), "--any-hit", "--camera-rays", "128x128", "--rays", "1024"];
        args.extend_from_slice(&["--methods", &methods, "--json", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        run_ok(&args);
        let report = json(&out);
        let setup = &report["any_hit"];
        let (shadow, ao) = (setup["shadow_rays"].as_u64().unwrap(), setup["ao_rays"].as_u64().unwrap());
        let occluded = setup["reference_occluded"].as_f64().unwrap();
        assert!(shadow > 100 && ao > 1000, "{name}: {shadow} shadow rays and {ao} occlusion rays");
        assert!(occluded > 0.02 && occluded < 0.98, "{name}: the reference finds {occluded} of the rays occluded");
        for m in report["methods"].as_array().unwrap() {
            let a = &m["any_hit"];
            let agreement = a["agreement"].as_f64().unwrap();
            let d = &a["disagreements"];
            assert!(agreement >= 0.995, "{name}, {}: {agreement} of the answers agree", m["method"]);
            assert_eq!(d["unexplained"].as_u64(), Some(0), "{name}, {}: disagreements {d}", m["method"]);
        }
    }
}

#[test]
fn shadow_and_occlusion_rays_are_counted_apart_in_the_statistics_and_the_batch_csv() {
    let dir = scratch("light-stats");
    let path = dir.join("plane.ron");
    std::fs::write(&path, scene_text("quadratic-taylor", false, DVec3::new(0.3, 1.0, 0.2).normalize())).unwrap();
    let stats = dir.join("stats.json");
    let png = dir.join("plane.png");
    let args = ["--size", "32x32", "--shadows", "--ao", "4"];
    run_ok(&[&["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--stats", stats.to_str().unwrap()][..], &args[..]].concat());
    let s = json(&stats);
    // The plane fills the frame and faces the light: every pixel casts one
    // shadow ray and four occlusion rays, apart from the camera rays.
    assert_eq!(s["rays"].as_u64(), Some(32 * 32));
    assert_eq!(s["hit_rate"].as_f64(), Some(1.0));
    let a = &s["any_hit"];
    assert_eq!((a["shadow_rays"].as_u64(), a["ao_rays"].as_u64()), (Some(32 * 32), Some(4 * 32 * 32)), "{a}");
    assert!(a["shadow_steps_per_ray"].as_f64().unwrap() >= 1.0 && a["ao_steps_per_ray"].as_f64().unwrap() >= 1.0, "{a}");
    // Without them, the section is null.
    run_ok(&["render", path.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "32x32", "--stats", stats.to_str().unwrap()]);
    assert!(json(&stats)["any_hit"].is_null());
    // The batch CSV's last three columns.
    let frames = dir.join("f_#.png");
    let csv = dir.join("frames.csv");
    run_ok(
        &[&["render", path.to_str().unwrap(), "-o", frames.to_str().unwrap(), "--frames", "0..2", "--csv", csv.to_str().unwrap()][..], &args[..]]
            .concat(),
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(header.ends_with(&["shadow_steps_per_ray", "ao_steps_per_ray", "any_hit_gpu_ms", "scene"]), "{header:?}");
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for line in lines {
        // No field before these holds a comma (the file names here do not).
        let cells: Vec<&str> = line.split(',').collect();
        let shadow: f64 = cells[at("shadow_steps_per_ray")].parse().unwrap_or_else(|_| panic!("{line}"));
        let ao: f64 = cells[at("ao_steps_per_ray")].parse().unwrap_or_else(|_| panic!("{line}"));
        assert!(shadow >= 1.0 && ao >= 1.0, "{line}");
    }
}

#[test]
fn tradeoff_sweeps_the_any_hit_query() {
    // The quick sweep (2 minimum steps x 2 step budgets) of segment and
    // quadratic Taylor on fig10's shadow and occlusion rays.
    let dir = scratch("light-tradeoff");
    let scene = repo_root().join("scenes/fig10.ron");
    run_ok(&["tradeoff", scene.to_str().unwrap(), "--any-hit", "--quick", "--rays", "512", "-o", dir.to_str().unwrap()]);
    let text = std::fs::read_to_string(dir.join("tradeoff.csv")).unwrap();
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 8, "{text}");
    let column = |name: &str| text.lines().next().unwrap().split(',').position(|c| c == name).unwrap();
    let (budget, error, oos) = (column("max_steps"), column("error"), column("out_of_steps_rate"));
    for row in &rows {
        let e: f64 = row[error].parse().unwrap();
        if row[budget] == "1000" {
            // A full budget answers as the reference does (docs/lighting.md).
            assert!(e <= 0.01 && row[oos].parse::<f64>().unwrap() == 0.0, "{row:?}");
        }
    }
    // The rays are bench --any-hit's (same seed and count): the steps of a
    // setting that equals the scene's own are the same.
    let json_path = dir.join("bench.json");
    run_ok(&["bench", scene.to_str().unwrap(), "--any-hit", "--rays", "512", "--methods", "quadratic-taylor", "--json", json_path.to_str().unwrap()]);
    let bench_steps = json(&json_path)["methods"][0]["steps_per_ray"].as_f64().unwrap();
    let own = rows.iter().find(|r| r[0] == "quadratic-taylor" && r[1] == "0.1" && r[budget] == "1000").unwrap();
    let steps: f64 = own[column("steps_per_ray")].parse().unwrap();
    assert!((steps - bench_steps).abs() < 1e-4, "tradeoff {steps} steps per ray, bench --any-hit {bench_steps}");
    // Segment tracing crawls off surfaces in minimum steps of 0.01: 32
    // steps leave some of its rays unanswered, which count as errors.
    let starved = rows.iter().find(|r| r[0] == "segment" && r[1] == "0.01" && r[budget] == "32").unwrap();
    assert!(starved[oos].parse::<f64>().unwrap() > 0.0 && starved[error].parse::<f64>().unwrap() > 0.0, "{starved:?}");
}

/// What shadows and occlusion refuse, and where they do not apply: the
/// bisection baselines refuse them in one line before any work, `--ao`
/// and `--ao-distance` are checked, a scene file's `ao.samples` too, and a
/// transparent scene says that it is drawn without them (its image the
/// same as without the flags).
#[test]
fn shadows_and_occlusion_refuse_what_they_cannot_do_and_say_what_they_skip() {
    let dir = scratch("light-refusals");
    let path = dir.join("plane.ron");
    std::fs::write(&path, scene_text("quadratic-taylor", true, DVec3::new(0.3, 1.0, 0.2).normalize())).unwrap();
    let p = path.to_str().unwrap();
    let png = dir.join("x.png");
    let o = png.to_str().unwrap();
    for method in ["raa", "linear-bisection"] {
        for flags in [&["--shadows"][..], &["--ao", "4"][..]] {
            let err = isomarch(["render", p, "-o", o, "--method", method]).args(flags).fails_in_one_line();
            assert!(err.contains(&format!("{method} cannot march shadow and occlusion rays")), "{method} {flags:?}: {err}");
            assert!(!png.exists(), "{method} {flags:?}: an image was written");
        }
    }
    for (flags, says) in [
        (&["--ao", "0"][..], "--ao must be 1 to 1024 rays per hit, got 0"),
        (&["--ao", "1025"][..], "--ao must be 1 to 1024 rays per hit, got 1025"),
        (&["--ao", "4", "--ao-distance", "0"][..], "--ao-distance must be positive, got 0"),
        (&["--ao", "4", "--ao-distance=-2"][..], "--ao-distance must be positive, got -2"),
    ] {
        let err = isomarch(["render", p, "-o", o]).args(flags).fails_in_one_line();
        assert!(err.contains(says), "{flags:?}: {err}");
    }
    for (samples, ok) in [(0, false), (1, true), (1024, true), (1025, false)] {
        let file = dir.join(format!("ao{samples}.ron"));
        let text = scene_text("quadratic-taylor", true, DVec3::Y)
            .replace("iso: 0.5,", &format!("iso: 0.5,\n    ao: Some((samples: {samples}, distance: 2.0)),"));
        std::fs::write(&file, text).unwrap();
        let run = isomarch(["render", file.to_str().unwrap(), "-o", o, "--size", "8x8"]);
        if ok {
            run.ok();
        } else {
            let err = run.fails_in_one_line();
            assert!(err.contains("ao.samples") && err.contains(&format!("got {samples}")), "{err}");
        }
    }
    // fig17 is transparent: the flags change nothing, and a line says so.
    let fig17 = repo_root().join("scenes/fig17.ron");
    let (plain, lit) = (dir.join("fig17.png"), dir.join("fig17-lit.png"));
    isomarch(["render", fig17.to_str().unwrap(), "-o", plain.to_str().unwrap(), "--size", "48x48"]).ok();
    let out = isomarch(["render", fig17.to_str().unwrap(), "-o", lit.to_str().unwrap(), "--size", "48x48", "--shadows", "--ao", "4"]).ok();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("is transparent, and transparent surfaces are drawn without shadows and ambient occlusion"), "{stderr}");
    assert!(std::fs::read(&plain).unwrap() == std::fs::read(&lit).unwrap(), "shadows changed a transparent image");
}
