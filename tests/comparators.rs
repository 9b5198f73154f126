//! The comparators every reference test relies on (`bench::accuracy` for
//! first hits, `bench::accuracy_all` for every crossing), on hand-made
//! hits, misses, late and early crossings. No GPU.

use isomarch::bench::{Accuracy, accuracy, accuracy_all};
use isomarch::layout::{FLAG_HIT, FLAG_OUT_OF_STEPS, GpuResult};

/// A result that hits at `t` (`None`: no hit, its distance field left at
/// -1 as the shader writes it).
fn result(t: Option<f32>) -> GpuResult {
    match t {
        Some(t) => GpuResult { hit: [0.0, 0.0, 1.0, t], counts: [5, 9, 2, FLAG_HIT], ..Default::default() },
        None => GpuResult { hit: [0.0, 0.0, 0.0, -1.0], counts: [5, 9, 0, 0], ..Default::default() },
    }
}

/// `accuracy` of one ray.
fn one(t: Option<f32>, reference: Option<f64>, late: f64, early: f64) -> Accuracy {
    accuracy(&[result(t)], &[reference], late, early)
}

fn counts(a: Accuracy) -> (usize, usize) {
    (a.misses, a.false_hits)
}

#[test]
fn accuracy_classifies_hand_made_first_hits() {
    // Powers of two, so every sum and difference below is exact.
    let (late, early) = (0.25, 0.125);
    assert_eq!(counts(one(Some(1.0), Some(1.0), late, early)), (0, 0), "on the reference");
    assert_eq!(counts(one(Some(1.25), Some(1.0), late, early)), (0, 0), "late by exactly `late`");
    assert_eq!(counts(one(Some(1.25 + 1e-6), Some(1.0), late, early)), (1, 0), "later than `late`: a miss");
    assert_eq!(counts(one(Some(0.875), Some(1.0), late, early)), (0, 0), "early by exactly `early`");
    assert_eq!(counts(one(Some(0.875 - 1e-6), Some(1.0), late, early)), (0, 1), "earlier than `early`: a false hit");
    assert_eq!(counts(one(None, Some(1.0), late, early)), (1, 0), "no hit where the reference has one");
    assert_eq!(counts(one(Some(2.0), None, late, early)), (0, 1), "a hit where the reference has none");
    assert_eq!(counts(one(None, None, late, early)), (0, 0), "both miss");
    // The late and early allowances are not interchangeable.
    assert_eq!(counts(one(Some(1.25), Some(1.0), early, late)), (1, 0));
    assert_eq!(counts(one(Some(0.875), Some(1.0), 0.0, 0.0)), (0, 1));
    // Without FLAG_HIT the distance means nothing, whatever it holds.
    let mut flagged_off = result(Some(1.0));
    flagged_off.counts[3] = FLAG_OUT_OF_STEPS;
    assert_eq!(counts(accuracy(&[flagged_off], &[Some(1.0)], late, early)), (1, 0), "a distance without FLAG_HIT is no hit");
    assert_eq!(counts(accuracy(&[flagged_off], &[None], late, early)), (0, 0));
}

#[test]
fn accuracy_sums_over_rays_and_measures_errors_where_both_hit() {
    let results: Vec<GpuResult> = [Some(1.0), Some(2.5), Some(3.0), None, Some(5.0), None, Some(0.5)].map(result).to_vec();
    let reference = [Some(1.0), Some(2.0), Some(3.25), Some(4.0), None, None, Some(0.5)];
    let a = accuracy(&results, &reference, 0.25, 0.5);
    // 2.5 against 2.0: late by 0.5 > 0.25, a miss; 3.0 against 3.25: early
    // by 0.25 <= 0.5, fine; no hit against 4.0: a miss; 5.0 against none:
    // a false hit.
    assert_eq!(counts(a), (2, 1), "{a:?}");
    // Errors over the rays that both hit: 0, 0.5, 0.25, 0.
    assert_eq!(a.max_abs_error, 0.5, "{a:?}");
    assert!((a.mean_abs_error - 0.75 / 4.0).abs() < 1e-12, "{a:?}");
    // Only as many rays as both sides have.
    assert_eq!(counts(accuracy(&results[..2], &reference, 0.25, 0.5)), (1, 0));
    let none = accuracy(&[], &[], 0.1, 0.1);
    assert_eq!(none, Accuracy::default());
}

#[test]
fn accuracy_all_matches_crossings_in_order() {
    let (late, early) = (0.25, 0.125);
    let all = |found: &[f32], reference: &[f64]| counts(accuracy_all(&[found.to_vec()], &[reference.to_vec()], late, early));
    assert_eq!(all(&[1.0, 2.0], &[1.0, 2.0]), (0, 0), "every crossing found");
    assert_eq!(all(&[1.25, 1.875], &[1.0, 2.0]), (0, 0), "late and early within the allowances");
    assert_eq!(all(&[1.0], &[1.0, 2.0]), (1, 0), "the leaving crossing missed");
    assert_eq!(all(&[2.0], &[1.0, 2.0]), (1, 0), "the entering crossing missed");
    assert_eq!(all(&[1.0, 1.5, 2.0], &[1.0, 2.0]), (0, 1), "a crossing the reference does not have, between two it has");
    assert_eq!(all(&[0.5, 1.0], &[1.0]), (0, 1), "an early crossing before a matched one");
    assert_eq!(all(&[1.5], &[1.0]), (1, 1), "one crossing too late: a miss and a false crossing");
    assert_eq!(all(&[0.75], &[1.0]), (1, 1), "one crossing too early: a false crossing and a miss");
    assert_eq!(all(&[3.0], &[]), (0, 1), "a crossing where the reference has none");
    assert_eq!(all(&[], &[1.0, 2.0, 3.0]), (3, 0), "nothing found");
    assert_eq!(all(&[], &[]), (0, 0));
    // One found crossing cannot stand for two reference crossings.
    assert_eq!(all(&[1.0], &[1.0, 1.125]), (1, 0));
    assert_eq!(all(&[1.0, 1.125], &[1.0, 1.125]), (0, 0));
    // Over rays: counts add, errors are over matched crossings only.
    let found = vec![vec![1.0f32, 2.5], vec![], vec![0.5]];
    let reference = vec![vec![1.0, 2.25], vec![4.0], vec![]];
    let a = accuracy_all(&found, &reference, late, early);
    assert_eq!(counts(a), (1, 1), "{a:?}");
    assert_eq!(a.max_abs_error, 0.25);
    assert!((a.mean_abs_error - 0.125).abs() < 1e-12, "{a:?}");
}
