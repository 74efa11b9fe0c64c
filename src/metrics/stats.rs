//! Summary statistics of a sweep: means with Student-t confidence intervals
//! (statrs), quantiles by linear interpolation between order statistics
//! (Hyndman–Fan type 7, numpy's default) and distribution-free confidence
//! intervals of quantiles from the binomial distribution of order statistics.

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

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

/// Order-statistic indices of the 95 % CI of the p-quantile (normal
/// approximation to the binomial).
fn quantile_ci_at(n: usize, p: f64) -> (usize, usize) {
    let z = Normal::standard().inverse_cdf(0.975);
    let nf = n as f64;
    let half = z * (nf * p * (1.0 - p)).sqrt();
    let lo = ((nf * p - half).floor().max(1.0) as usize).min(n) - 1;
    let hi = ((nf * p + half).ceil().max(1.0) as usize).min(n) - 1;
    (lo, hi)
}

/// Quantile p of sorted data (type 7).
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let (lo, hi, w) = quantile_at(sorted.len(), p);
    sorted[lo] + w * (sorted[hi] - sorted[lo])
}

/// 95 % confidence interval of the p-quantile from order statistics of
/// sorted data: (low, high).
pub fn quantile_ci95(sorted: &[f64], p: f64) -> (f64, f64) {
    if sorted.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let (lo, hi) = quantile_ci_at(sorted.len(), p);
    (sorted[lo], sorted[hi])
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

/// The p-quantile and its 95 % CI of unsorted data by selection — the same
/// values as [`quantile_sorted`] and [`quantile_ci95`] without a sort.
pub fn quantile_with_ci95(v: &mut [f64], p: f64) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let (lo, hi, w) = quantile_at(v.len(), p);
    let (a, b) = (kth(v, lo), kth(v, hi));
    let (clo, chi) = quantile_ci_at(v.len(), p);
    (a + w * (b - a), kth(v, clo), kth(v, chi))
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

    #[test]
    fn mean_ci_uses_student_t() {
        let (m, h) = mean_ci95(&[1.0, 2.0, 3.0]);
        assert_eq!(m, 2.0);
        // t(0.975, 2) = 4.3027, s = 1, n = 3
        assert!((h - 4.302_652_7 / 3f64.sqrt()).abs() < 1e-5, "{h}");
    }
}
