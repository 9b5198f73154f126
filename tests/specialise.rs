//! A pipeline's specialisation constants applied on the host (the default:
//! `isomarch_shaders::specialise` freezes them and removes the code they
//! rule out before the driver sees the module) and by the driver
//! (`ISOMARCH_SPECIALISE=driver`) make the same frames, byte for byte, and
//! the same counts: the flat march, the indexed march through the camera's
//! tile lists with shadow and occlusion rays, refraction, an HRBF, and the
//! look and tile-building kernels' passes.

use crate::common::*;

/// Every figure of a `--stats` file but the times and the memory, which
/// differ from run to run (nested objects alike).
fn counts(stats: &serde_json::Value) -> serde_json::Value {
    match stats {
        serde_json::Value::Object(object) => object
            .iter()
            .filter(|(k, _)| !k.ends_with("_ms") && !k.ends_with("_ns") && !k.starts_with("ns_") && k.as_str() != "memory")
            .map(|(k, v)| (k.clone(), counts(v)))
            .collect(),
        other => other.clone(),
    }
}

/// A render: its scene, flags and environment.
struct Case {
    what: &'static str,
    path: String,
    flags: &'static [&'static str],
    env: &'static [(&'static str, &'static str)],
}

#[test]
fn constants_applied_on_the_host_and_by_the_driver_make_the_same_frames() {
    // Where the build cannot specialise on the host (shaderc built from
    // source), both renders would take the driver's path.
    assert!(
        isomarch::gpu::specialises_on_host().unwrap(),
        "this build (or ISOMARCH_SPECIALISE) hands the constants to the driver: nothing to compare the driver's specialisation with"
    );
    let dir = scratch("specialise");
    let scene = |name: &str| repo_root().join(name).to_str().unwrap().to_string();
    // The last through the tile lists built on the GPU (tiles.comp's passes).
    let cases = [
        Case { what: "fig10 quadratic Taylor", path: scene("scenes/fig10.ron"), flags: &["--method", "quadratic-taylor"], env: &[] },
        Case { what: "fig16 refraction", path: scene("scenes/fig16.ron"), flags: &[], env: &[] },
        Case { what: "hrbf8 segment", path: scene("scenes/hrbf8.ron"), flags: &["--method", "segment"], env: &[] },
        Case {
            what: "1A8O shadows and occlusion",
            path: scene("tests/data/molecules/1A8O.pdb"),
            flags: &["--shadows", "--ao", "4"],
            env: &[("ISOMARCH_TILE_BUILD", "on")],
        },
    ];
    for Case { what, path, flags, env } in cases {
        let mut frames = Vec::new();
        for (where_, value) in [("host", None), ("driver", Some("driver"))] {
            let png = dir.join(format!("{}-{where_}.png", what.replace(' ', "_")));
            let stats = png.with_extension("json");
            let mut command = isomarch(["render", path.as_str(), "-o", png.to_str().unwrap(), "--size", "48x40", "--stats", stats.to_str().unwrap()])
                .args(flags.iter().copied())
                .envs(env.iter().copied());
            command = match value {
                Some(v) => command.env("ISOMARCH_SPECIALISE", v),
                None => command.env_remove("ISOMARCH_SPECIALISE"),
            };
            command.ok();
            let image = image::open(&png).unwrap().to_rgba8();
            frames.push((std::fs::read(&png).unwrap(), counts(&json(&stats)), image));
        }
        let (host, driver) = (&frames[0], &frames[1]);
        // A frame of one colour would agree with anything.
        let first = host.2.get_pixel(0, 0);
        let differing = host.2.pixels().filter(|p| *p != first).count();
        let pixels = (host.2.width() * host.2.height()) as usize;
        assert!(differing * 10 >= pixels, "{what}: only {differing} of {pixels} pixels differ from the corner's");
        assert_eq!(host.1, driver.1, "{what}: the counts differ between the constants applied on the host and by the driver");
        if host.0 != driver.0 {
            let worst = host.2.pixels().zip(driver.2.pixels()).map(|(a, b)| (0..4).map(|c| a[c].abs_diff(b[c])).max().unwrap()).max().unwrap();
            panic!("{what}: the frames differ between the constants applied on the host and by the driver, by up to {worst} per channel");
        }
    }
}
