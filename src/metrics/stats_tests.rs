//! Tests of [`super`]: kept beside it, out of its file.
use super::*;

#[test]
fn quantiles_match_numpy_type7() {
    let v = [1.0, 2.0, 3.0, 4.0, 10.0];
    assert_eq!(quantile_sorted(&v, 0.5), 3.0);
    assert!((quantile_sorted(&v, 0.95) - 8.8).abs() < 1e-12);
    assert_eq!(quantile_sorted(&v, 0.0), 1.0);
    assert_eq!(quantile_sorted(&v, 1.0), 10.0);
}

#[test]
fn selection_gives_the_sorted_values() {
    let v: Vec<f64> = (0..1001)
        .map(|k| ((k * 7919) % 1001) as f64 * 0.37)
        .collect();
    let mut sorted = v.clone();
    sorted.sort_unstable_by(f64::total_cmp);
    let mut w = v.clone();
    let (q, lo, hi) = quantile_with_ci95(&mut w, 0.95);
    assert_eq!(q, quantile_sorted(&sorted, 0.95));
    assert_eq!((lo, hi), quantile_ci95(&sorted, 0.95));
    // Between order statistics (n = 20: h = 18.05), with the limits.
    for n in [20usize, 59, 100] {
        let v: Vec<f64> = (0..n).map(|k| ((k * 37) % n) as f64 * 1.5).collect();
        let mut sorted = v.clone();
        sorted.sort_unstable_by(f64::total_cmp);
        let want = quantile_sorted(&sorted, 0.95);
        let (q, lo, hi) = quantile_with_ci95(&mut v.clone(), 0.95);
        let (q2, up) = quantile_with_upper95(&mut v.clone(), 0.95);
        assert_eq!((q, q2), (want, want), "n {n}");
        assert_eq!((lo, hi), quantile_ci95(&sorted, 0.95), "n {n}");
        assert_eq!(up, quantile_upper95(&sorted, 0.95), "n {n}");
    }
    // Type 7 by hand: 0, 1.5, …, 28.5 at p = 0.95: 27 + 0.05 × 1.5.
    let (q, _) = quantile_with_upper95(
        &mut (0..20).map(|k| k as f64 * 1.5).collect::<Vec<_>>(),
        0.95,
    );
    assert!((q - 27.075).abs() < 1e-12, "{q}");
}

#[test]
fn unsorted_quantile_equals_the_sorted_one() {
    for n in [1usize, 2, 3, 20, 985, 1000] {
        let v: Vec<f64> = (0..n)
            .map(|k| ((k * 7919 + 13) % 1009) as f64 * 0.37)
            .collect();
        let mut sorted = v.clone();
        sorted.sort_unstable_by(f64::total_cmp);
        for p in [0.0, 0.05, 0.5, 0.95, 1.0] {
            let mut w = v.clone();
            assert_eq!(
                quantile_unsorted(&mut w, p),
                quantile_sorted(&sorted, p),
                "n {n} p {p}"
            );
        }
    }
    assert!(quantile_unsorted(&mut [], 0.5).is_nan());
}

#[test]
fn similar_arrays_give_each_its_own_quantile() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(5);
    let mut q = SimilarQuantiles::default();
    for n in [1usize, 2, 7, 245, 985] {
        let base: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
        // Arrays alike, then unlike, with ties, and of another length.
        for step in 0..12 {
            let v: Vec<f64> = match step % 4 {
                0 | 1 => base
                    .iter()
                    .map(|x| x * (1.0 + 0.01 * step as f64))
                    .collect(),
                2 => (0..n).map(|_| rng.random_range(0.0..1.0)).collect(),
                _ => base.iter().map(|x| (x * 4.0).round() / 4.0).collect(),
            };
            for p in [0.5, 0.95, 1.0] {
                let bits: Vec<u64> = v.iter().map(|x| x.to_bits()).collect();
                let mut copy = v.clone();
                assert_eq!(
                    q.quantile(&bits, p),
                    quantile_unsorted(&mut copy, p),
                    "n {n} step {step} p {p}"
                );
            }
        }
        let shorter: Vec<u64> = base[..n / 2].iter().map(|x| x.to_bits()).collect();
        let mut copy = base[..n / 2].to_vec();
        let want = quantile_unsorted(&mut copy, 0.95);
        let got = q.quantile(&shorter, 0.95);
        assert!(got == want || (got.is_nan() && want.is_nan()), "n {n}");
    }
}

/// P(Bin(n, p) ≤ k) by summing the probabilities one by one: a route
/// independent of statrs's incomplete beta function.
fn cdf_by_sum(n: usize, p: f64, k: usize) -> f64 {
    let ln_pmf = |j: usize| {
        let ln_choose: f64 = (0..j)
            .map(|i| ((n - i) as f64).ln() - ((i + 1) as f64).ln())
            .sum();
        ln_choose + j as f64 * p.ln() + (n - j) as f64 * (1.0 - p).ln()
    };
    (0..=k).map(|j| ln_pmf(j).exp()).sum()
}

#[test]
fn limit_indices_are_the_binomial_ones() {
    for n in [1usize, 2, 20, 58, 59, 60, 71, 72, 100, 400, 3000] {
        for p in [0.5, 0.95] {
            for conf in [0.95, 0.975] {
                let up = quantile_upper_index(n, p, conf);
                match up {
                    Some(k) => {
                        assert!(cdf_by_sum(n, p, k) >= conf, "n {n} p {p} {conf}");
                        assert!(k == 0 || cdf_by_sum(n, p, k - 1) < conf, "n {n} p {p}");
                    }
                    None => assert!(cdf_by_sum(n, p, n - 1) < conf, "n {n} p {p}"),
                }
                match quantile_lower_index(n, p, conf) {
                    Some(k) => {
                        assert!(1.0 - cdf_by_sum(n, p, k) >= conf, "n {n} p {p} {conf}");
                        assert!(k + 1 == n || 1.0 - cdf_by_sum(n, p, k + 1) < conf);
                    }
                    None => assert!(1.0 - cdf_by_sum(n, p, 0) < conf, "n {n} p {p}"),
                }
            }
        }
    }
    // The numbers: a p95's upper 95 % limit needs 59 values, the
    // top of its two-sided 95 % interval 72; below, there is none.
    assert_eq!(values_for_upper_limit(0.95, 0.95), 59);
    assert_eq!(values_for_upper_limit(0.95, 0.975), 72);
    assert_eq!(quantile_upper_index(58, 0.95, 0.95), None);
    assert_eq!(quantile_upper_index(59, 0.95, 0.95), Some(58));
    assert_eq!(quantile_upper95(&[1.0; 20], 0.95), None);
    assert_eq!(quantile_ci95(&[], 0.5), (None, None));
    // A limit that reaches its confidence exactly exists (1 − 0.5¹ = 0.5).
    assert_eq!(quantile_upper_index(1, 0.5, 0.5), Some(0));
    assert_eq!(quantile_lower_index(1, 0.5, 0.5), Some(0));
    // At p close to 1 every value qualifies as a lower limit: the last.
    assert_eq!(quantile_lower_index(1, 0.95, 0.95), Some(0));
    assert_eq!(quantile_lower_index(3, 0.999, 0.5), Some(2));
    // 59 values: the largest is the p95's upper 95 % limit.
    let v: Vec<f64> = (0..59).map(|k| k as f64).collect();
    assert_eq!(quantile_upper95(&v, 0.95), Some(58.0));
    assert_eq!(quantile_ci95(&v, 0.95), (Some(51.0), None));
    // The search: the first k that holds, or none.
    assert_eq!(first_true(5, |_| false), None);
    assert_eq!(first_true(5, |k| k >= 3), Some(3));
    assert_eq!(first_true(5, |_| true), Some(0));
    assert_eq!(first_true(0, |_| true), None);
}

/// Many small studies of a known distribution (uniform on [0, 1], whose
/// p-quantile is p): each limit holds the true quantile as often as the
/// binomial says, and that is at least the stated confidence.
#[test]
fn quantile_limits_have_their_stated_coverage() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(17);
    let reps = 4000;
    for (n, p) in [(59usize, 0.95), (100, 0.95), (400, 0.95), (25, 0.5)] {
        let (mut upper, mut two, mut lower) = (0, 0, 0);
        let mut v = vec![0.0; n];
        for _ in 0..reps {
            v.iter_mut().for_each(|x| *x = rng.random_range(0.0..1.0));
            let (_, lo, hi) = quantile_with_ci95(&mut v, p);
            let (_, up) = quantile_with_upper95(&mut v, p);
            v.sort_unstable_by(f64::total_cmp);
            upper += up.is_some_and(|u| u >= p) as usize;
            let (lo, hi) = (lo.unwrap_or(f64::NAN), hi.unwrap_or(f64::NAN));
            two += (lo <= p && p <= hi) as usize;
            lower += quantile_lower_index(n, p, 0.95).is_some_and(|k| v[k] <= p) as usize;
        }
        let stated = |k: Option<usize>| k.map_or(0.0, |k| cdf_by_sum(n, p, k));
        let want_up = stated(quantile_upper_index(n, p, 0.95));
        let (l2, h2) = (
            quantile_lower_index(n, p, 0.975),
            quantile_upper_index(n, p, 0.975),
        );
        let want_two = match (l2, h2) {
            (Some(l), Some(h)) => stated(Some(h)) - stated(Some(l)),
            _ => 0.0,
        };
        let want_low = 1.0 - stated(quantile_lower_index(n, p, 0.95));
        for (got, want, conf, what) in [
            (upper, want_up, 0.95, "upper"),
            (two, want_two, 0.95, "two-sided"),
            (lower, want_low, 0.95, "lower"),
        ] {
            let got = got as f64 / reps as f64;
            let se = (want * (1.0 - want) / reps as f64).sqrt();
            if what == "two-sided" && n < 72 && p == 0.95 {
                // Its top does not exist below 72 values: never claimed.
                assert_eq!(got, 0.0, "n {n}");
                continue;
            }
            assert!(want >= conf, "{what} n {n}: stated {want}");
            assert!(
                (got - want).abs() <= 4.0 * se + 1e-9,
                "{what} n {n}: {got} vs {want}"
            );
        }
        // Not needlessly wide: the next order statistic down would
        // fall short (checked by the binomial test above); here, at a
        // p95, within 2.5 points of the stated confidence.
        assert!(p != 0.95 || want_up < 0.975, "n {n}: {want_up}");
    }
}

/// The mean's Student-t interval covers the mean of normal data 95 % of
/// the time, at 5 values as at 40.
#[test]
fn mean_interval_has_its_stated_coverage() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(3);
    let normal = Normal::new(2.0, 0.5).unwrap();
    let reps = 20000;
    for n in [5usize, 40] {
        let covered = (0..reps)
            .filter(|_| {
                let v: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
                let (m, h) = mean_ci95(&v);
                (m - 2.0).abs() <= h
            })
            .count() as f64
            / reps as f64;
        let se = (0.95 * 0.05 / reps as f64).sqrt();
        assert!((covered - 0.95).abs() < 4.0 * se, "n {n}: {covered}");
    }
}

/// One selection gives every percentile and limit the one-by-one
/// functions give, whatever the data (ties, zeros, infinities, NaN).
#[test]
fn percentiles_of_one_selection_equal_the_one_by_one_values() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(9);
    for n in [0usize, 1, 2, 3, 19, 20, 58, 59, 72, 100, 1001, 5000] {
        for kind in 0..4 {
            let v: Vec<f64> = (0..n)
                .map(|_| match kind {
                    0 => rng.random_range(0.0..1.0),
                    1 => (rng.random_range(0.0..1.0f64) * 5.0).round(),
                    2 => [0.0, f64::INFINITY, 1.0][rng.random_range(0..3usize)],
                    _ => [f64::NAN, 2.0, 0.5][rng.random_range(0..3usize)],
                })
                .collect();
            let p = Percentiles::of(&mut v.clone());
            let (q95, lo, hi) = quantile_with_ci95(&mut v.clone(), 0.95);
            let (_, up) = quantile_with_upper95(&mut v.clone(), 0.95);
            let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            let same_opt = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) => same(a, b),
                (None, None) => true,
                _ => false,
            };
            assert!(same(p.p95, q95), "n {n} kind {kind}");
            assert!(same(p.p50, quantile_unsorted(&mut v.clone(), 0.5)), "n {n}");
            assert!(
                same(p.p05, quantile_unsorted(&mut v.clone(), 0.05)),
                "n {n}"
            );
            assert!(
                same_opt(p.p95_ci.0, lo) && same_opt(p.p95_ci.1, hi),
                "n {n} {kind}"
            );
            assert!(same_opt(p.p95_upper, up), "n {n} kind {kind}");
        }
    }
    // Ranks asked twice or out of range.
    let mut v = vec![3.0, 1.0, 2.0];
    let got = order_statistics(&mut v, &[2, 0, 2, 7, 3]);
    assert_eq!(&got[..3], &[3.0, 1.0, 3.0]);
    assert!(got[3].is_nan() && got[4].is_nan());
}

#[test]
fn mean_ci_uses_student_t() {
    let (m, h) = mean_ci95(&[1.0, 2.0, 3.0]);
    assert_eq!(m, 2.0);
    // t(0.975, 2) = 4.3027, s = 1, n = 3
    assert!((h - 4.302_652_7 / 3f64.sqrt()).abs() < 1e-5, "{h}");
}
