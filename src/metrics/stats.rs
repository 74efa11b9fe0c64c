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

/// One-sided lower 95 % confidence limit of the p-quantile of sorted data;
/// None where it does not exist at this many values.
pub fn quantile_lower95(sorted: &[f64], p: f64) -> Option<f64> {
    quantile_lower_index(sorted.len(), p, 0.95).map(|k| sorted[k])
}

/// The one-sided 95 % upper confidence limit of the p-quantile of sorted
/// values (None when there are too few).
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
/// The one-at-a-time route the tests hold [`Percentiles::of`] to.
#[cfg(test)]
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
#[path = "stats_tests.rs"]
mod tests;
