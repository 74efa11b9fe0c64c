//! Tests of the summary: the linearisation's spread, failed maps, the
//! workspace columns.
use super::{failures_as_worst, workspace, Samples};
use crate::metrics::{stats, DvSummary};

/// The linearisation's spread from the trials' sums: the sample
/// variance of what they recorded (1, 2, 3, 4 and 10, 10, 10, 14 in
/// two errors: 5/3 and 4); none from fewer than two.
#[test]
fn the_linearisation_variance_is_the_sample_variance() {
    type ErrorVector = nalgebra::SVector<f64, 15>;
    let mut s = Samples::<15>::default();
    for (x, y) in [(1.0, 10.0), (2.0, 10.0), (3.0, 10.0), (4.0, 14.0)] {
        let mut e = ErrorVector::zeros();
        e[0] = x;
        e[1] = y;
        s.lin_sum += e;
        s.lin_sq += e.component_mul(&e);
        s.lin_n += 1;
    }
    let v = s.linearisation_variance().unwrap();
    assert!(
        (v[0] - 5.0 / 3.0).abs() < 1e-12 && (v[1] - 4.0).abs() < 1e-12,
        "{v:?}"
    );
    assert_eq!(v[2], 0.0);
    let one = Samples::<15> {
        lin_n: 1,
        ..Samples::default()
    };
    assert!(one.linearisation_variance().is_none());
}

/// Each workspace column from its own series; a failed map (NaN) is
/// counted, left out of the mean and worst in the percentiles.
#[test]
fn workspace_columns_come_from_their_series() {
    let nan = f64::NAN;
    let mut s = Samples::<15> {
        dv_max: vec![0.3, nan, 0.1, 0.2, nan],
        dv_mean: vec![0.2, nan, 0.05, 0.11],
        dv_before: vec![1.0, 3.0, 2.0, 4.0],
        dv_p95: vec![0.25, nan, 0.12, 0.2],
        ap_max: vec![0.5, 0.4, nan, 0.45],
        ..Samples::default()
    };
    let q = |v: &[f64], p: f64| Some(stats::quantile_sorted(v, p));
    let up = |v: &[f64]| stats::quantile_upper95(v, 0.95);
    let inf = f64::INFINITY;
    let (max, before) = ([0.1, 0.2, 0.3, inf, inf], [1.0, 2.0, 3.0, 4.0]);
    let (p95, ap) = ([0.12, 0.2, 0.25, inf], [0.4, 0.45, 0.5, inf]);
    let (w, _) = workspace(&mut s);
    let expected = DvSummary {
        dv_after_max_median: q(&max, 0.5),
        dv_after_max_p95: q(&max, 0.95),
        dv_after_mean_mean: Some((0.2 + 0.05 + 0.11) / 3.0),
        dv_before_max_median: q(&before, 0.5),
        dv_after_max_p95_ci_high: up(&max),
        dv_after_p95_median: q(&p95, 0.5),
        dv_after_p95_p95: q(&p95, 0.95),
        dv_after_p95_p95_ci_high: up(&p95),
        ap_after_max_median: q(&ap, 0.5),
        ap_after_max_p95: q(&ap, 0.95),
        ap_after_max_p95_ci_high: up(&ap),
        dv_failed: Some(2),
    };
    assert_eq!(format!("{w:?}"), format!("{expected:?}"));
}

#[test]
fn failed_maps_count_against_the_percentiles() {
    let judged: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
    // One failure in 101: the p95 and its limit are still numbers, and
    // no smaller than without it.
    let mut v = judged.clone();
    v.push(f64::NAN);
    failures_as_worst(&mut v);
    let p95 = stats::quantile_sorted(&v, 0.95);
    let up = stats::quantile_upper95(&v, 0.95).unwrap();
    assert!(p95.is_finite() && p95 >= stats::quantile_sorted(&judged, 0.95));
    assert!(up.is_finite());
    // Ten failures in 110: more than 5 % are not within any X.
    let mut v = judged.clone();
    v.extend([f64::NAN; 10]);
    failures_as_worst(&mut v);
    assert!(!stats::quantile_sorted(&v, 0.95).is_finite());
    assert!(!stats::quantile_upper95(&v, 0.95).unwrap().is_finite());
    // The median is unaffected by a few.
    assert!(stats::quantile_sorted(&v, 0.5).is_finite());
}
