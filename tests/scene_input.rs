//! Bad scene input: a one-line error naming the file and field, a non-zero
//! exit, no panic and no output file.

mod common;

use std::process::Command;

use common::*;
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
    let e = error_of(&GOOD.replace(
        "[(primitives: [Point(center: (0.0, 0.0, 0.0), kernel: Compact(radius: 2.0))])]",
        "[]",
    ));
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
        let run = Command::new(bin()).arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{name}: exit status {}", run.status);
        assert_eq!(run.status.code(), Some(1), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{name}: panicked: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{name}: not one line: {stderr}");
        assert!(stderr.contains(&scene.display().to_string()), "{name}: file not named: {stderr}");
        assert!(!out.exists(), "{name}: an output file was written");
    }
    let missing = Command::new(bin()).args(["render", "/nonexistent.ron", "-o"]).arg(dir.join("x.png")).output().unwrap();
    assert_eq!(missing.status.code(), Some(1));
    assert!(!dir.join("x.png").exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().filter_map(|e| e.ok()).filter(|e| e.path().extension().is_some_and(|x| x != "ron")).collect();
    assert!(leftovers.is_empty(), "left files behind: {leftovers:?}");
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
    let e = error_of(&GOOD.replace("iso: 0.5,", "iso: 0.5, transparency: Some((opacity: 1.5)),"));
    assert_mentions(&e, &["bad.ron", "transparency.opacity", "[0, 1]"]);
    // And a good one poses: a keyframed blob moves, an orbiting camera turns.
    let s = Scene::parse(
        &moving("Keyframes([(0.0, (0.0, 0.0, 0.0)), (2.0, (2.0, 0.0, 0.0))])").replace("resolution: (16, 16))", "resolution: (16, 16), path: Some(Orbit(period: 8.0)))"),
        "good.ron",
    )
    .unwrap();
    let posed = s.at_time(1.0);
    assert!(matches!(posed.groups[0][0], isomarch::scene::Primitive::Point { center, .. } if center == glam::DVec3::new(1.0, 0.0, 0.0)));
    assert!((posed.camera.eye - s.camera.eye).length() > 1.0 && (posed.camera.eye.length() - s.camera.eye.length()).abs() < 1e-9);
}
