//! Summary statistics of a sweep: means with Student-t confidence intervals
//! (statrs), quantiles by linear interpolation between order statistics
//! (Hyndman–Fan type 7, numpy's default) and distribution-free confidence
//! intervals of quantiles from the binomial distribution of order statistics.

use statrs::distribution::{Binomial, ContinuousCDF, DiscreteCDF, StudentsT};

/// Mean and the half-width of its 95 % confidence interval.
pub fn mean_ci95(v: &[f64]) -> (f64, f64) {
    let n = v.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    if n < 2 {
        return (mean, f64::INFINITY);
    }
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    let t = StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(1.96);
    (mean, t * (var / n as f64).sqrt())
}

/// Order-statistic indices (lo, hi) and weight of the type-7 p-quantile of n values.
fn quantile_at(n: usize, p: f64) -> (usize, usize, f64) {
    let h = (n - 1) as f64 * p;
    let lo = h.floor() as usize;
    (lo, (lo + 1).min(n - 1), h - lo as f64)
}

/// The smallest k in `0..n` for which `pred` holds, `pred` being false
/// then true along `0..n`; None when it never holds.
fn first_true(n: usize, pred: impl Fn(usize) -> bool) -> Option<usize> {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        match pred(mid) {
            true => hi = mid,
            false => lo = mid + 1,
        }
    }
    (lo < n).then_some(lo)
}

/// P(Bin(n, p) ≤ k).
fn binomial_cdf(n: usize, p: f64, k: usize) -> f64 {
    match Binomial::new(p, n as u64) {
        Ok(b) => b.cdf(k as u64),
        Err(_) => f64::NAN,
    }
}

/// Index into n sorted values of the order statistic that is a one-sided
/// upper `conf` confidence limit of the p-quantile ξ, distribution-free:
/// the (k+1)-th smallest value is at least ξ exactly when at most k values
/// fall below ξ, which has probability P(Bin(n, p) ≤ k); the limit is the
/// smallest k where that reaches `conf`. None when not even the largest
/// value is a limit (1 − pⁿ < conf: a p95 needs 59 values for 95 %).
pub fn quantile_upper_index(n: usize, p: f64, conf: f64) -> Option<usize> {
    if n == 0 || 1.0 - p.powi(n.min(i32::MAX as usize) as i32) < conf {
        return None;
    }
    // The largest value qualifies; the search stays below it.
    Some(first_true(n - 1, |k| binomial_cdf(n, p, k) >= conf).unwrap_or(n - 1))
}

/// Index of the order statistic that is a one-sided lower `conf` limit of
/// the p-quantile: the (k+1)-th smallest value is at most ξ with
/// probability 1 − P(Bin(n, p) ≤ k); the limit is the largest k where that
/// is at least `conf`. None when not even the smallest value is one
/// ((1 − p)ⁿ > 1 − conf).
pub fn quantile_lower_index(n: usize, p: f64, conf: f64) -> Option<usize> {
    if n == 0 || (1.0 - p).powi(n.min(i32::MAX as usize) as i32) > 1.0 - conf {
        return None;
    }
    // The first k that no longer qualifies, less one. The pre-check above
    // decides existence: at a confidence reached exactly ((1 − p)ⁿ = 1 − conf)
    // the two can disagree in the last bit, and the smallest value stands.
    Some(first_true(n, |k| binomial_cdf(n, p, k) > 1.0 - conf).map_or(n - 1, |k| k.max(1) - 1))
}

/// The fewest values for which the p-quantile has a one-sided upper `conf`
/// limit: the smallest n with 1 − pⁿ ≥ conf (59 for p = conf = 0.95).
pub fn values_for_upper_limit(p: f64, conf: f64) -> usize {
    (1..usize::MAX)
        .find(|&n| quantile_upper_index(n, p, conf).is_some())
        .unwrap_or(usize::MAX)
}

/// Order-statistic indices of the two-sided 95 % confidence interval of
/// the p-quantile (each end a one-sided 97.5 % limit), where they exist.
fn quantile_ci_at(n: usize, p: f64) -> (Option<usize>, Option<usize>) {
    (
        quantile_lower_index(n, p, 0.975),
        quantile_upper_index(n, p, 0.975),
    )
}

/// Quantile p of sorted data (type 7).
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let (lo, hi, w) = quantile_at(sorted.len(), p);
    sorted[lo] + w * (sorted[hi] - sorted[lo])
}

/// Two-sided 95 % confidence interval of the p-quantile from order
/// statistics of sorted data: (low, high), each None where it does not
/// exist at this many values.
pub fn quantile_ci95(sorted: &[f64], p: f64) -> (Option<f64>, Option<f64>) {
    let (lo, hi) = quantile_ci_at(sorted.len(), p);
    (lo.map(|k| sorted[k]), hi.map(|k| sorted[k]))
}

/// One-sided upper 95 % confidence limit of the p-quantile of sorted data;
/// None where it does not exist at this many values.
pub fn quantile_upper95(sorted: &[f64], p: f64) -> Option<f64> {
    quantile_upper_index(sorted.len(), p, 0.95).map(|k| sorted[k])
}

/// The k-th smallest value, by selection (O(n); reorders `v`).
fn kth(v: &mut [f64], k: usize) -> f64 {
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}

/// The p-quantile (type 7) of unsorted data by selection (reorders `v`);
/// NaN for no data.
pub fn quantile_unsorted(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let (lo, hi, w) = quantile_at(v.len(), p);
    let b = kth(v, hi);
    // After selecting the hi-th value, the lo-th (= hi − 1) is the largest
    // of the values before it.
    let a = if hi == lo {
        b
    } else {
        v[..hi].iter().cloned().fold(f64::NEG_INFINITY, |m, x| {
            if x.total_cmp(&m).is_gt() {
                x
            } else {
                m
            }
        })
    };
    a + w * (b - a)
}

/// The p-quantile of a run of arrays of non-negative, non-NaN values given
/// by their bit patterns (`f64::to_bits`, whose integer order is then their
/// order) that resemble one another — one
/// machine's dV over the same grid after calibrations with different
/// sensors. An array's top values are sought at or above a threshold that
/// the points holding the previous array's top values all reach, so the
/// selection runs on a few dozen values rather than the whole array. Each
/// value is exactly [`quantile_unsorted`]'s, whatever the arrays.
#[derive(Debug, Clone, Default)]
pub struct SimilarQuantiles {
    /// Where the previous array had its n − lo largest values.
    top: Vec<u32>,
    /// (value bits, position) at or above the threshold.
    candidates: Vec<(u64, u32)>,
}

impl SimilarQuantiles {
    /// The p-quantile (type 7) of `bits`; NaN for no data.
    pub fn quantile(&mut self, bits: &[u64], p: f64) -> f64 {
        let n = bits.len();
        if n == 0 {
            return f64::NAN;
        }
        let (lo, hi, w) = quantile_at(n, p);
        let m = n - lo;
        // At least m values reach the smallest of this array's values at the
        // previous top's m points, so the m largest are all among them.
        // (None of it when the previous array was of another size.)
        let threshold = match self.top.len() == m {
            true => self
                .top
                .iter()
                .try_fold(u64::MAX, |t, &i| bits.get(i as usize).map(|&b| t.min(b)))
                .unwrap_or(0),
            false => 0,
        };
        self.candidates.clear();
        for (i, &b) in bits.iter().enumerate() {
            if b >= threshold {
                self.candidates.push((b, i as u32));
            }
        }
        // Ascending, the candidates are the array's top values in order:
        // index k holds rank lo, k + 1 rank hi.
        let k = self.candidates.len() - m;
        let a = self.candidates.select_nth_unstable(k).1 .0;
        let b = match hi == lo {
            true => a,
            false => self.candidates[k + 1..]
                .iter()
                .map(|c| c.0)
                .min()
                .unwrap_or(a),
        };
        self.top.clear();
        self.top.extend(self.candidates[k..].iter().map(|c| c.1));
        let (a, b) = (f64::from_bits(a), f64::from_bits(b));
        a + w * (b - a)
    }
}

/// The p-quantile and its two-sided 95 % CI of unsorted data by selection
/// — the same values as [`quantile_sorted`] and [`quantile_ci95`] without a
/// sort.
pub fn quantile_with_ci95(v: &mut [f64], p: f64) -> (f64, Option<f64>, Option<f64>) {
    if v.is_empty() {
        return (f64::NAN, None, None);
    }
    let (lo, hi, w) = quantile_at(v.len(), p);
    let (a, b) = (kth(v, lo), kth(v, hi));
    let (clo, chi) = quantile_ci_at(v.len(), p);
    (
        a + w * (b - a),
        clo.map(|k| kth(v, k)),
        chi.map(|k| kth(v, k)),
    )
}

/// The order statistics of ranks `ks` (0-based) of `v`, in the order asked,
/// by one recursive selection: the middle rank splits the data, each side
/// holds the ranks below or above it (reorders `v`). The values a sort
/// would give, in about n·log(len ks) comparisons instead of n per rank.
pub fn order_statistics(v: &mut [f64], ks: &[usize]) -> Vec<f64> {
    let mut ranks: Vec<usize> = ks.iter().copied().filter(|&k| k < v.len()).collect();
    ranks.sort_unstable();
    ranks.dedup();
    let mut values = vec![f64::NAN; ranks.len()];
    select_into(v, 0, &ranks, &mut values);
    ks.iter()
        .map(|k| ranks.binary_search(k).map_or(f64::NAN, |i| values[i]))
        .collect()
}

/// [`order_statistics`] of distinct ascending `ks` in `v`, whose first
/// element has rank `offset` in the whole.
fn select_into(v: &mut [f64], offset: usize, ks: &[usize], out: &mut [f64]) {
    if ks.is_empty() {
        return;
    }
    let mid = ks.len() / 2;
    let k = ks[mid] - offset;
    let (left, kth, right) = v.select_nth_unstable_by(k, f64::total_cmp);
    out[mid] = *kth;
    select_into(left, offset, &ks[..mid], &mut out[..mid]);
    select_into(right, offset + k + 1, &ks[mid + 1..], &mut out[mid + 1..]);
}

/// What a sweep reports of one distribution across machines: the 5th,
/// 50th and 95th percentiles (type 7), the two-sided 95 % interval and the
/// one-sided upper 95 % limit of the 95th (None where they do not exist).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Percentiles {
    pub p05: f64,
    pub p50: f64,
    pub p95: f64,
    pub p95_ci: (Option<f64>, Option<f64>),
    pub p95_upper: Option<f64>,
}

impl Percentiles {
    /// All of them from one selection (reorders `v`); NaN and None for no
    /// data. The same values as [`quantile_unsorted`], [`quantile_with_ci95`]
    /// and [`quantile_with_upper95`] one by one.
    pub fn of(v: &mut [f64]) -> Self {
        let n = v.len();
        if n == 0 {
            return Percentiles {
                p05: f64::NAN,
                p50: f64::NAN,
                p95: f64::NAN,
                p95_ci: (None, None),
                p95_upper: None,
            };
        }
        let at = [0.05, 0.5, 0.95].map(|p| quantile_at(n, p));
        let (lo, hi) = quantile_ci_at(n, 0.95);
        let up = quantile_upper_index(n, 0.95, 0.95);
        let mut ks: Vec<usize> = at.iter().flat_map(|&(a, b, _)| [a, b]).collect();
        ks.extend(lo.iter().chain(&hi).chain(&up));
        let got = order_statistics(v, &ks);
        let q = |i: usize| {
            let w = at[i].2;
            got[2 * i] + w * (got[2 * i + 1] - got[2 * i])
        };
        let mut extra = got[6..].iter();
        let mut next = |k: Option<usize>| k.and_then(|_| extra.next().copied());
        let ci_lo = next(lo);
        let ci_hi = next(hi);
        Percentiles {
            p05: q(0),
            p50: q(1),
            p95: q(2),
            p95_ci: (ci_lo, ci_hi),
            p95_upper: next(up),
        }
    }
}

/// The p-quantile and its one-sided upper 95 % limit of unsorted data by
/// selection — [`quantile_sorted`] and [`quantile_upper95`] without a sort.
pub fn quantile_with_upper95(v: &mut [f64], p: f64) -> (f64, Option<f64>) {
    if v.is_empty() {
        return (f64::NAN, None);
    }
    let (lo, hi, w) = quantile_at(v.len(), p);
    let (a, b) = (kth(v, lo), kth(v, hi));
    let limit = quantile_upper_index(v.len(), p, 0.95).map(|k| kth(v, k));
    (a + w * (b - a), limit)
}

#[cfg(test)]
mod tests {
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
                let same =
                    |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
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
}
