//! The shipped scenes: they load, and the benchmark scenes match the CSVs
//! they were built from (tests/data/benchmarks, provenance in its README;
//! the scenes are described in docs/benchmark-protocol.md).

use crate::common::*;
use glam::DVec3;
use isomarch::scene::{Kernel, Primitive, Scene};

/// A file of the benchmark scene data kept in the repository.
fn benchmark_data(file: &str) -> std::path::PathBuf {
    repo_root().join("tests/data/benchmarks").join(file)
}

/// `(group, centre, R)` rows of a benchmark CSV.
fn csv_rows(name: &str) -> Vec<(usize, DVec3, f64)> {
    let path = benchmark_data(&format!("{name}.csv"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            (v[0] as usize, DVec3::new(v[1], v[2], v[3]), v[4])
        })
        .collect()
}

fn assert_matches_csv(scene: &str, csv: &str) {
    let s = Scene::load(&repo_root().join("scenes").join(scene)).unwrap();
    let rows = csv_rows(csv);
    assert_eq!(s.iso, 0.5, "docs/benchmark-protocol.md: iso 0.5 for all scenes");
    assert_eq!(s.primitive_count(), rows.len(), "{scene}: primitive count");
    let groups = rows.iter().map(|r| r.0).max().unwrap() + 1;
    assert_eq!(s.groups.len(), groups, "{scene}: group count");
    let mut by_group = vec![Vec::new(); groups];
    for r in &rows {
        by_group[r.0].push(r);
    }
    for (g, (prims, rows)) in s.groups.iter().zip(&by_group).enumerate() {
        assert_eq!(prims.len(), rows.len(), "{scene}: group {g}");
        for (i, (p, (_, c, radius))) in prims.iter().zip(rows).enumerate() {
            match p {
                Primitive::Point { center, kernel: Kernel::Compact { radius: r, weight } } => {
                    assert!((*center - *c).length() < 1e-9, "{scene}: group {g} primitive {i}: {center} vs {c}");
                    assert!((r - radius).abs() < 1e-9 && *weight == 1.0, "{scene}: group {g} primitive {i}: R {r} vs {radius}");
                }
                other => panic!("{scene}: group {g} primitive {i} is {other:?}, not a compact point"),
            }
        }
    }
}

#[test]
fn fig10_matches_its_csv() {
    assert_matches_csv("fig10.ron", "fig10");
    let s = Scene::load(&repo_root().join("scenes/fig10.ron")).unwrap();
    assert_eq!((s.marching.min_step, s.marching.max_steps), (0.1, 1000), "docs/benchmark-protocol.md: minimum step 0.1, at most 1000 steps");
}

#[test]
fn every_shipped_scene_loads() {
    let mut n = 0;
    for entry in std::fs::read_dir(repo_root().join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 2, "found only {n} scenes");
}

/// fig10-gauss is fig10 with each compact kernel of radius R replaced by a
/// Gaussian with r = R·sqrt(1 - iso^(1/3)) (the same isolated surface) and
/// s = 2, under the same protocol.
#[test]
fn fig10_gauss_is_fig10_with_gaussian_kernels() {
    let load = |name: &str| Scene::load(&repo_root().join("scenes").join(name)).unwrap();
    let (compact, gauss) = (load("fig10.ron"), load("fig10-gauss.ron"));
    assert_eq!(gauss.iso, compact.iso);
    assert_eq!((gauss.marching.min_step, gauss.marching.max_steps), (0.1, 1000), "docs/benchmark-protocol.md: minimum step 0.1, at most 1000 steps");
    assert_eq!(gauss.groups.len(), compact.groups.len());
    let factor = (1.0 - compact.iso.cbrt()).sqrt();
    for (c, g) in compact.primitives().zip(gauss.primitives()) {
        match (c, g) {
            (
                Primitive::Point { center: cc, kernel: Kernel::Compact { radius, .. } },
                Primitive::Point { center: gc, kernel: Kernel::Gaussian { r, s, weight } },
            ) => {
                assert!((*cc - *gc).length() < 1e-9, "centre {gc} vs {cc}");
                assert!((r - radius * factor).abs() < 1e-6, "r {r} for R {radius}");
                assert_eq!(*s, 2.0);
                assert!((weight - gauss.iso * s.exp()).abs() < 1e-12, "default weight iso·e^s");
            }
            other => panic!("unexpected pair {other:?}"),
        }
    }
    assert_eq!(compact.primitive_count(), gauss.primitive_count());
}

#[test]
fn fig1_and_fig17_match_their_csvs_and_are_transparent() {
    for name in ["fig1", "fig17"] {
        assert_matches_csv(&format!("{name}.ron"), name);
        let s = Scene::load(&repo_root().join("scenes").join(format!("{name}.ron"))).unwrap();
        assert!(s.transparency.is_some(), "{name}: docs/benchmark-protocol.md renders it transparent");
        assert_eq!((s.marching.min_step, s.marching.max_steps), (0.1, 1000), "docs/benchmark-protocol.md: minimum step 0.1, at most 1000 steps");
    }
}

/// fig16: the CSV's nine blobs in one sum group with the ground slab, each
/// bobbing as y = 2.5 + 0.8 sin(2π t / 4 s + phase) with its phase from
/// fig16_phases.csv (docs/benchmark-protocol.md, "Scenes").
#[test]
fn fig16_matches_its_csvs_and_moves_as_specified() {
    let s = Scene::load(&repo_root().join("scenes/fig16.ron")).unwrap();
    let rows = csv_rows("fig16");
    let phases: Vec<f64> = std::fs::read_to_string(benchmark_data("fig16_phases.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').nth(1).unwrap().trim().parse().unwrap())
        .collect();
    assert_eq!(s.groups.len(), 1);
    assert_eq!(s.primitive_count(), rows.len() + 1, "nine blobs and the ground");
    assert!(
        matches!(s.groups[0].last(), Some(Primitive::Plane { normal, offset, radius, .. }) if *normal == DVec3::Y && *offset == 0.0 && *radius == 1.0)
    );
    for t in [0.0, 0.37, 1.0, 2.5, 3.99] {
        let posed = s.at_time(t);
        for (i, (_, c, radius)) in rows.iter().enumerate() {
            let Primitive::Point { center, kernel: Kernel::Compact { radius: r, .. } } = posed.groups[0][i] else {
                panic!("primitive {i} is not a compact point");
            };
            let y = 2.5 + 0.8 * (std::f64::consts::TAU * t / 4.0 + phases[i]).sin();
            assert!((center - DVec3::new(c.x, y, c.z)).length() < 1e-9, "blob {i} at t = {t}: {center}");
            assert_eq!(r, *radius);
        }
        // The fixed bounds hold every blob's support at every time.
        assert!(posed.support_bounds().min.cmpge(s.bounds.min).all() && posed.support_bounds().max.cmple(s.bounds.max).all());
    }
    assert_eq!((s.bounds.min.x, s.bounds.max.x, s.bounds.min.z, s.bounds.max.z), (-12.0, 12.0, -12.0, 12.0), "slab clipped to |x|, |z| <= 12");
    let centres = |t: f64| -> Vec<DVec3> {
        s.at_time(t).primitives().filter_map(|p| if let Primitive::Point { center, .. } = p { Some(*center) } else { None }).collect()
    };
    for (a, b) in centres(0.0).iter().zip(centres(4.0)) {
        assert!((*a - b).length() < 1e-9, "a 4-second loop");
    }
}
