//! Bad scene input: a one-line error naming the file and field, a non-zero
//! exit, no panic and no output file.

use crate::common::*;
use isomarch::scene::Scene;

const GOOD: &str = r#"Scene(
    camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0), resolution: (16, 16)),
    iso: 0.5,
    groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))])],
)"#;

/// Parses `text` (a variant of GOOD) and returns the error's text.
fn error_of(text: &str) -> String {
    match Scene::parse(text, "bad.ron") {
        Ok(_) => panic!("accepted a bad scene:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(message: &str, parts: &[&str]) {
    assert!(!message.contains('\n'), "error is not one line: {message}");
    for p in parts {
        assert!(message.contains(p), "error {message:?} does not mention {p:?}");
    }
}

#[test]
fn good_scene_parses() {
    let s = Scene::parse(GOOD, "good.ron").unwrap();
    assert_eq!(s.primitive_count(), 1);
    assert_eq!(s.camera.width, 16);
}

#[test]
fn unknown_field_is_rejected_with_its_position() {
    let e = error_of(&GOOD.replace("iso: 0.5,", "iso: 0.5, colour: 3,"));
    assert_mentions(&e, &["bad.ron", "line 3", "colour"]);
}

#[test]
fn nan_is_rejected() {
    let e = error_of(&GOOD.replace("iso: 0.5", "iso: NaN"));
    assert_mentions(&e, &["bad.ron", "iso", "positive and finite"]);
}

#[test]
fn infinity_is_rejected() {
    let e = error_of(&GOOD.replace("center: (0.0, 0.0, 0.0)", "center: (0.0, inf, 0.0)"));
    assert_mentions(&e, &["bad.ron", "groups[0].primitives[0].center[1]", "finite"]);
}

#[test]
fn non_positive_radius_is_rejected() {
    let e = error_of(&GOOD.replace("radius: 2.0", "radius: -1.0"));
    assert_mentions(&e, &["bad.ron", "groups[0].primitives[0].kernel.radius", "positive", "-1"]);
    let e = error_of(&GOOD.replace("radius: 2.0", "radius: 0.0"));
    assert_mentions(&e, &["kernel.radius", "positive"]);
}

#[test]
fn empty_scene_is_rejected() {
    let e = error_of(&GOOD.replace("[(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))])]", "[]"));
    assert_mentions(&e, &["bad.ron", "groups", "no groups"]);
    let e = error_of(&GOOD.replace("Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))", ""));
    assert_mentions(&e, &["groups[0].primitives", "empty"]);
}

#[test]
fn unreadable_file_is_reported() {
    let e = Scene::load(std::path::Path::new("/nonexistent/scene.ron")).unwrap_err().to_string();
    assert_mentions(&e, &["/nonexistent/scene.ron", "cannot read"]);
}

#[test]
fn more_primitives_than_the_device_holds_is_an_error() {
    let ctx = gpu();
    let per_prim = size_of::<isomarch::layout::GpuPrimitive>() as u64;
    let n = (ctx.info.max_storage_buffer_range / per_prim + 1) as usize;
    let mut s = Scene::parse(GOOD, "huge.ron").unwrap();
    s.groups[0] = vec![s.groups[0][0]; n];
    let e = isomarch::render::Renderer::new(&ctx, &s).err().expect("an oversized scene was accepted").to_string();
    assert_mentions(&e, &["huge.ron", "groups", &n.to_string(), "at most"]);
    assert_no_validation(&ctx);
}

#[test]
fn the_binary_fails_cleanly_and_writes_nothing() {
    let dir = scratch("bad-input");
    let cases = [
        ("unknown-field", GOOD.replace("iso: 0.5,", "iso: 0.5, colour: 3,")),
        ("nan", GOOD.replace("iso: 0.5", "iso: NaN")),
        ("radius", GOOD.replace("radius: 2.0", "radius: -2.0")),
        ("empty", GOOD.replace("Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))", "")),
    ];
    for (name, text) in cases {
        let scene = dir.join(format!("{name}.ron"));
        std::fs::write(&scene, text).unwrap();
        let out = dir.join(format!("{name}.png"));
        let stderr = isomarch(["render"]).arg(&scene).arg("-o").arg(&out).fails_in_one_line();
        assert!(!stderr.contains("panicked"), "{name}: panicked: {stderr}");
        assert!(stderr.contains(&scene.display().to_string()), "{name}: file not named: {stderr}");
        assert!(!out.exists(), "{name}: an output file was written");
    }
    let missing = isomarch(["render", "/nonexistent.ron", "-o"]).arg(dir.join("x.png")).output();
    assert_eq!(missing.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&missing.stderr);
    assert!(stderr.starts_with("error: /nonexistent.ron: cannot read: ") && !stderr.contains("(file)"), "{stderr}");
    assert!(!dir.join("x.png").exists());
    let leftovers: Vec<_> =
        std::fs::read_dir(&dir).unwrap().filter_map(|e| e.ok()).filter(|e| e.path().extension().is_some_and(|x| x != "ron")).collect();
    assert!(leftovers.is_empty(), "left files behind: {leftovers:?}");
}

/// Type errors name the format's own words (`Camera`, `Kernel`), never
/// the reader's types (`CameraFile`, `KernelFile`), through the binary.
#[test]
fn type_errors_name_the_formats_words_not_the_readers_types() {
    let dir = scratch("type-errors");
    let cases = [
        ("camera", GOOD.replace("camera: (eye: (0.0, 0.0, 8.0), target: (0.0, 0.0, 0.0), resolution: (16, 16))", "camera: 5"), "Camera"),
        ("kernel", GOOD.replace("kernel: Compact(radius: 2.0)", "kernel: Blob(radius: 2.0)"), "Kernel"),
        ("primitive", GOOD.replace("Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))", "Dot(center: (0.0, 0.0, 0.0))"), "Primitive"),
        ("marching", GOOD.replace("iso: 0.5,", "iso: 0.5, marching: 5,"), "Marching"),
    ];
    for (name, text, word) in cases {
        let scene = dir.join(format!("{name}.ron"));
        std::fs::write(&scene, text).unwrap();
        let run = isomarch(["render"]).arg(&scene).arg("-o").arg(dir.join("x.png")).output();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{name}: {stderr}");
        assert!(stderr.contains(&format!("`{word}`")) || stderr.contains(&format!("'{word}'")), "{name}: does not name {word}: {stderr}");
        assert!(!stderr.contains("File`") && !stderr.contains("File'"), "{name}: names a reader type: {stderr}");
    }
}

/// `tradeoff` sweeps a scene file; given a molecule it says so and how to
/// make one, rather than what RON's parser found in a PDB.
#[test]
fn tradeoff_given_a_molecule_says_it_takes_scene_files() {
    let out = isomarch(["tradeoff", "tests/data/molecules/1A8O.pdb", "--quick"]).current_dir(repo_root()).output();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("tradeoff takes a scene file (.ron)") && stderr.contains("isomarch scene tests/data/molecules/1A8O.pdb -o"), "{stderr}");
    assert!(!stderr.contains("Expected struct"), "{stderr}");
}

/// The command line's own error paths: a window without a display is one
/// line that says how to get one; a size of zero is refused before any
/// work; an output directory that does not exist yet is made.
#[test]
fn the_command_line_refuses_what_it_cannot_do_and_makes_what_it_can() {
    let dir = scratch("cli-paths");
    let scene = repo_root().join("scenes/default.ron");
    let stderr = isomarch(["view"]).arg(&scene).env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY").env_remove("WAYLAND_SOCKET").fails_in_one_line();
    assert!(stderr.contains("no display") && stderr.contains("Xvfb"), "view without a display: {stderr}");
    // winit's own source location is not the user's business.
    assert!(!stderr.contains(".cargo") && !stderr.contains(".rs:"), "view without a display names a source file: {stderr}");
    let zero = isomarch(["render"]).arg(&scene).arg("-o").arg(dir.join("zero.png")).args(["--size", "0x0"]).output();
    let stderr = String::from_utf8_lossy(&zero.stderr);
    assert_eq!(zero.status.code(), Some(2), "--size 0x0: {stderr}");
    assert!(stderr.contains("'0x0'") && stderr.contains("1..=16384"), "--size 0x0: {stderr}");
    assert!(!dir.join("zero.png").exists());
    let nested = dir.join("not").join("yet").join("made.png");
    isomarch(["render"]).arg(&scene).arg("-o").arg(&nested).args(["--size", "16x16"]).ok();
    assert_eq!(image::open(&nested).unwrap().to_rgb8().dimensions(), (16, 16));
}

#[test]
fn bad_motion_and_transparency_are_rejected() {
    let moving = |motion: &str| GOOD.replace("kernel: Compact(radius: 2.0))", &format!("kernel: Compact(radius: 2.0), motion: Some({motion}))"));
    let e = error_of(&moving("Sine(axis: (0.0, 1.0, 0.0), amplitude: 1.0, period: 0.0)"));
    assert_mentions(&e, &["bad.ron", "groups[0].primitives[0].motion.period", "positive"]);
    let e = error_of(&moving("Keyframes([(1.0, (0.0, 0.0, 0.0)), (0.5, (1.0, 0.0, 0.0))])"));
    assert_mentions(&e, &["bad.ron", "groups[0].primitives[0].motion[1]", "increase"]);
    let e = error_of(&moving("Keyframes([])"));
    assert_mentions(&e, &["bad.ron", "motion", "at least one"]);
    let e = error_of(&GOOD.replace("resolution: (16, 16))", "resolution: (16, 16), path: Some(Orbit(period: -2.0)))"));
    assert_mentions(&e, &["bad.ron", "camera.path.period", "positive"]);
    let e = error_of(&GOOD.replace("resolution: (16, 16))", "resolution: (16, 16), samples: 0)"));
    assert_mentions(&e, &["bad.ron", "camera.samples", "1..=4096"]);
    let four = Scene::parse(&GOOD.replace("resolution: (16, 16))", "resolution: (16, 16), samples: 4)"), "ok.ron").unwrap();
    assert_eq!(four.camera.samples, 4);
    let e = error_of(&GOOD.replace("iso: 0.5,", "iso: 0.5, transparency: Some((opacity: 1.5)),"));
    assert_mentions(&e, &["bad.ron", "transparency.opacity", "[0, 1]"]);
    // And a good one poses: a keyframed blob moves, an orbiting camera turns.
    let s = Scene::parse(
        &moving("Keyframes([(0.0, (0.0, 0.0, 0.0)), (2.0, (2.0, 0.0, 0.0))])")
            .replace("resolution: (16, 16))", "resolution: (16, 16), path: Some(Orbit(period: 8.0)))"),
        "good.ron",
    )
    .unwrap();
    let posed = s.at_time(1.0);
    assert!(matches!(posed.groups[0][0], isomarch::scene::Primitive::Point { center, .. } if center == glam::DVec3::new(1.0, 0.0, 0.0)));
    assert!((posed.camera.eye - s.camera.eye).length() > 1.0 && (posed.camera.eye.length() - s.camera.eye.length()).abs() < 1e-9);
}

/// Every optional field of docs/scene-format.md, as (its name in the
/// format, GOOD's text to replace, the replacement with the value written
/// plain, the same with `Some(..)`): both spellings must give one scene,
/// and not GOOD's.
const OPTIONAL_FIELDS: &[(&str, &str, &str, &str)] = &[
    ("weight", "Compact(radius: 2.0)", "Compact(radius: 2.0, weight: 2.0)", "Compact(radius: 2.0, weight: Some(2.0))"),
    ("weight", "Compact(radius: 2.0)", "Gaussian(r: 1.0, s: 2.0, weight: 3.0)", "Gaussian(r: 1.0, s: 2.0, weight: Some(3.0))"),
    (
        "weight",
        "iso: 0.5,",
        "iso: 0.5, bounds: (min: (-3.0, -3.0, -3.0), max: (3.0, 3.0, 3.0)), groups: [(primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: -1.0, radius: 0.5, weight: 2.0)])],",
        "iso: 0.5, bounds: (min: (-3.0, -3.0, -3.0), max: (3.0, 3.0, 3.0)), groups: [(primitives: [Plane(normal: (0.0, 1.0, 0.0), offset: -1.0, radius: 0.5, weight: Some(2.0))])],",
    ),
    ("path", "resolution: (16, 16))", "resolution: (16, 16), path: Orbit(period: 8.0))", "resolution: (16, 16), path: Some(Orbit(period: 8.0)))"),
    (
        "path",
        "resolution: (16, 16))",
        "resolution: (16, 16), path: Keyframes([(0.0, (0.0, 0.0, 8.0)), (1.0, (1.0, 0.0, 8.0))]))",
        "resolution: (16, 16), path: Some(Keyframes([(0.0, (0.0, 0.0, 8.0)), (1.0, (1.0, 0.0, 8.0))])))",
    ),
    ("near", "resolution: (16, 16))", "resolution: (16, 16), clip: (near: 7.0))", "resolution: (16, 16), clip: (near: Some(7.0)))"),
    ("far", "resolution: (16, 16))", "resolution: (16, 16), clip: (far: 9.0))", "resolution: (16, 16), clip: (far: Some(9.0)))"),
    ("transparency", "iso: 0.5,", "iso: 0.5, transparency: (opacity: 0.3),", "iso: 0.5, transparency: Some((opacity: 0.3)),"),
    ("ao", "iso: 0.5,", "iso: 0.5, ao: (samples: 4, distance: 2.0),", "iso: 0.5, ao: Some((samples: 4, distance: 2.0)),"),
    ("ior", "iso: 0.5,", "iso: 0.5, transparency: (ior: 1.4),", "iso: 0.5, transparency: (ior: Some(1.4)),"),
    ("growth", "iso: 0.5,", "iso: 0.5, marching: (growth: 2.5),", "iso: 0.5, marching: (growth: Some(2.5)),"),
    ("refine", "iso: 0.5,", "iso: 0.5, marching: (refine: \"bisection\"),", "iso: 0.5, marching: (refine: Some(\"bisection\")),"),
    (
        "color",
        "kernel: Compact(radius: 2.0))",
        "kernel: Compact(radius: 2.0), color: (0.2, 0.3, 0.9))",
        "kernel: Compact(radius: 2.0), color: Some((0.2, 0.3, 0.9)))",
    ),
    (
        "bounds",
        "iso: 0.5,",
        "iso: 0.5, bounds: (min: (-3.0, -3.0, -3.0), max: (3.0, 3.0, 3.0)),",
        "iso: 0.5, bounds: Some((min: (-3.0, -3.0, -3.0), max: (3.0, 3.0, 3.0))),",
    ),
    (
        "motion",
        "Compact(radius: 2.0))",
        "Compact(radius: 2.0), motion: Sine(axis: (0.0, 1.0, 0.0), amplitude: 0.5, period: 2.0))",
        "Compact(radius: 2.0), motion: Some(Sine(axis: (0.0, 1.0, 0.0), amplitude: 0.5, period: 2.0)))",
    ),
    (
        "motion",
        "Compact(radius: 2.0))",
        "Compact(radius: 2.0), motion: Keyframes([(0.0, (0.0, 0.0, 0.0)), (2.0, (1.0, 0.0, 0.0))]))",
        "Compact(radius: 2.0), motion: Some(Keyframes([(0.0, (0.0, 0.0, 0.0)), (2.0, (1.0, 0.0, 0.0))])))",
    ),
    (
        "radius_scale",
        "Compact(radius: 2.0))",
        "Compact(radius: 2.0), radius_scale: Sine(amplitude: 0.2, period: 2.0))",
        "Compact(radius: 2.0), radius_scale: Some(Sine(amplitude: 0.2, period: 2.0)))",
    ),
    (
        "radius_scale",
        "Compact(radius: 2.0))",
        "Compact(radius: 2.0), radius_scale: Keyframes([(0.0, 1.0), (2.0, 1.5)]))",
        "Compact(radius: 2.0), radius_scale: Some(Keyframes([(0.0, 1.0), (2.0, 1.5)])))",
    ),
    (
        "margin",
        "Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))",
        "Hrbf(points: [((1.0, 0.0, 0.0), (1.0, 0.0, 0.0)), ((-1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)), ((0.0, 1.0, 0.0), (0.0, 1.0, 0.0))], margin: 0.5)",
        "Hrbf(points: [((1.0, 0.0, 0.0), (1.0, 0.0, 0.0)), ((-1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)), ((0.0, 1.0, 0.0), (0.0, 1.0, 0.0))], margin: Some(0.5))",
    ),
];

#[test]
fn every_optional_field_takes_its_value_plain_or_as_some() {
    let good = Scene::parse(GOOD, "good.ron").unwrap();
    for &(field, from, plain, some) in OPTIONAL_FIELDS {
        assert_eq!(GOOD.matches(from).count(), 1, "{field}: {from:?} is not once in GOOD");
        // The Plane case replaces GOOD's groups: drop the originals after the new ones.
        let edit = |to: &str| {
            let text = GOOD.replacen(from, to, 1);
            if to.contains("Plane(") {
                text.replacen("    groups: [(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))])],\n", "", 1)
            } else {
                text
            }
        };
        let a = Scene::parse(&edit(plain), "plain.ron").unwrap_or_else(|e| panic!("{field} written plain refused: {e}"));
        let b = Scene::parse(&edit(some), "some.ron").unwrap_or_else(|e| panic!("{field} written as Some(..) refused: {e}"));
        assert_eq!((a.source.clone(), b.source.clone()), ("plain.ron".to_string(), "some.ron".to_string()));
        let (a, b) = (Scene { source: String::new(), ..a }, Scene { source: String::new(), ..b });
        assert_eq!(a, b, "{field}: the two spellings give different scenes");
        assert_ne!(a, Scene { source: String::new(), ..good.clone() }, "{field}: the value was not read");
    }
}

/// The list above covers every optional field the format has, and the
/// format document names each of them.
#[test]
fn the_optional_fields_tested_are_every_option_in_the_format() {
    let source = std::fs::read_to_string(repo_root().join("src/scene/file.rs")).unwrap();
    let doc = std::fs::read_to_string(repo_root().join("docs/scene-format.md")).unwrap();
    let mut in_format: Vec<&str> =
        source.lines().filter(|l| l.contains(": Option<")).map(|l| l.trim().trim_start_matches("pub ").split(':').next().unwrap()).collect();
    in_format.sort();
    in_format.dedup();
    let mut tested: Vec<&str> = OPTIONAL_FIELDS.iter().map(|c| c.0).collect();
    tested.dedup();
    tested.sort();
    tested.dedup();
    assert_eq!(tested, in_format, "an optional field of src/scene/file.rs has no test of both spellings");
    for field in in_format {
        assert!(doc.contains(&format!("{field}:")), "docs/scene-format.md does not show `{field}`");
    }
}

/// The format document's example is a scene that loads, written as the
/// document recommends (plain optional values).
#[test]
fn the_format_documents_example_loads() {
    let doc = std::fs::read_to_string(repo_root().join("docs/scene-format.md")).unwrap();
    let start = doc.find("```ron\n").expect("docs/scene-format.md has no ```ron example") + "```ron\n".len();
    let end = start + doc[start..].find("```").unwrap();
    let s = Scene::parse(&doc[start..end], "docs/scene-format.md").unwrap_or_else(|e| panic!("{e}"));
    assert!(s.transparency.is_some_and(|t| t.ior.is_some()), "the example's transparency or ior was lost");
    assert_eq!(s.marching.growth, Some(2.0));
    let a = &s.animation;
    assert!(a.camera.is_some() && a.primitives.len() == 1 && a.radii.len() == 1, "the example's path, motion or radius_scale was lost");
}

#[test]
fn a_syntax_error_inside_a_field_names_its_path() {
    let e = error_of(&GOOD.replace("Compact(radius: 2.0)", "Compact(radius: 2.0, weight: true)"));
    assert_mentions(&e, &["bad.ron", "line 4", "groups[0].primitives[0].kernel.weight", "Expected float"]);
    let e = error_of(&GOOD.replace("iso: 0.5,", "iso: 0.5, transparency: (ior: \"glass\"),"));
    assert_mentions(&e, &["bad.ron", "line 3", "transparency.ior"]);
    let e = error_of(&GOOD.replace("resolution: (16, 16)", "resolution: (16, 16.5)"));
    assert_mentions(&e, &["bad.ron", "line 2", "camera.resolution"]);
    // Outside any field there is no path, only the position.
    let e = error_of(&format!("{GOOD} trailing"));
    assert_mentions(&e, &["bad.ron", "line 5", "trailing"]);
}
