//! The per-calibration records of a range of whole blocks (their binary
//! codec, `partial.bin`, is `store`'s). Any number of errors a
//! calibration: the error sums are flat, `errors` numbers per block and
//! grade.

use super::outcome::{Failure, Outcome};
use super::trial::{Studied, SweepContext};

/// The per-calibration records of a range of whole blocks: everything the
/// summary needs. A single run is one partial; the shards of a sharded run
/// are partials over consecutive block ranges, and [`finalize`] of their
/// concatenation gives exactly the bytes of the single run (sums run in the
/// same order: per-trial values in trial order, parameter-error sums per
/// block, then over blocks).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Partial {
    pub first_trial: u64,
    pub trials: u64,
    pub grades: usize,
    /// Errors a calibration estimates (the length of each error sum).
    pub errors: usize,
    pub volumetric: bool,
    /// Is the orientation error judged ([`Partial::orientation`] held)?
    pub oriented: bool,
    /// μ0 per trial.
    pub mu0: Vec<f64>,
    /// μ per trial × grade (NaN when forward kinematics failed).
    pub mu: Vec<f64>,
    /// [`Failure::code`] per trial × grade.
    pub failure: Vec<u8>,
    /// Rank of the design per grade.
    pub rank: Vec<u8>,
    /// (dV after max, dV after mean, dV before max) per trial × grade, when volumetric.
    pub dv: Vec<f64>,
    /// (orientation error before max, after max; rad) per trial × grade,
    /// when oriented.
    pub orientation: Vec<f64>,
    /// Σ(estimate − truth) and Σ(estimate − truth)² per block × grade,
    /// `errors` numbers each.
    pub block_err_sum: Vec<f64>,
    pub block_err_sq: Vec<f64>,
    /// Σ of the error budget ([`Outcome::budget`]) per block × grade, and
    /// the calibrations counted in it (NaN budgets are left out).
    pub block_budget: Vec<[f64; BUDGET_TERMS]>,
    pub block_budget_n: Vec<u64>,
    /// Σ and Σ² of the linearisation error (the trial's
    /// [`super::trial::Scratch::linearisation`], for the context's
    /// `recorded` grades; zero for the others) per block × grade, and the
    /// calibrations counted in them (`errors` numbers each).
    pub block_lin_sum: Vec<f64>,
    pub block_lin_sq: Vec<f64>,
    pub block_lin_n: Vec<u64>,
}

/// Terms summed for the error budget: μ, then [`Outcome::budget`].
pub const BUDGET_TERMS: usize = 5;

/// Volumetric values stored per calibration: dV after compensation (max and
/// mean over the workspace grid), dV before (max), dV after (p95), worst
/// ISO 9283 AP after.
pub const DV_PER_CALIBRATION: usize = 5;

/// Orientation values stored per calibration when oriented: the largest
/// orientation error over the workspace before and after compensation.
pub const ORIENTATION_PER_CALIBRATION: usize = 2;

impl Partial {
    pub fn new<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
        ctx: &SweepContext<M, P, R, A>,
        first_trial: u64,
    ) -> Self {
        Partial {
            first_trial,
            grades: ctx.grades.len(),
            errors: ctx.errors(),
            volumetric: ctx.volumetric(),
            oriented: ctx.oriented(),
            rank: ctx.solvers.iter().map(|s| s.analysis.rank as u8).collect(),
            ..Default::default()
        }
    }

    /// A partial of each calibration's records alone, from trial 0
    /// (`errors` 0: no per-block sums of the estimates' errors, no
    /// budget, no linearisation sums, no blocks counted).
    pub fn records_only<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
        ctx: &SweepContext<M, P, R, A>,
    ) -> Self {
        Partial {
            errors: 0,
            ..Partial::new(ctx, 0)
        }
    }

    /// Reserve exactly the records of `trials` more trials (no doubling
    /// past what a counted study needs).
    pub fn reserve(&mut self, trials: usize) {
        let calibrations = trials * self.grades;
        self.mu0.reserve_exact(trials);
        self.mu.reserve_exact(calibrations);
        self.failure.reserve_exact(calibrations);
        if self.volumetric {
            self.dv.reserve_exact(calibrations * DV_PER_CALIBRATION);
        }
        if self.oriented {
            self.orientation
                .reserve_exact(calibrations * ORIENTATION_PER_CALIBRATION);
        }
    }

    /// Append one block of outcomes and their estimates − truth
    /// (trial-major, grade-minor, [`Partial::errors`] numbers each, one
    /// after the other) and the linearisation errors of grades `recorded`
    /// (trial-major, one vector per recorded grade, as many numbers).
    pub fn push_block(
        &mut self,
        outcomes: &[Outcome],
        err: &[f64],
        lin: &[f64],
        recorded: &[usize],
    ) {
        let p = self.errors;
        if p == 0 {
            self.push_records(outcomes);
            return;
        }
        assert_eq!(
            err.len(),
            outcomes.len() * p,
            "a block's error vectors are the partial's size"
        );
        let g = self.grades;
        let mut sum = vec![0.0; g * p];
        let mut sq = vec![0.0; g * p];
        let mut budget = vec![[0.0; BUDGET_TERMS]; g];
        let mut budget_n = vec![0u64; g];
        let mut lin_sum = vec![0.0; g * p];
        let mut lin_sq = vec![0.0; g * p];
        let mut lin_n = vec![0u64; g];
        let r = recorded.len().max(1);
        // Each error's sum and sum of squares, number by number.
        let add = |sum: &mut [f64], sq: &mut [f64], x: &[f64]| {
            for ((s, q), &v) in sum.iter_mut().zip(sq.iter_mut()).zip(x) {
                *s += v;
                *q += v * v;
            }
        };
        for (t, (trial, errs)) in outcomes.chunks(g).zip(err.chunks(g * p)).enumerate() {
            self.mu0.push(trial[0].mu0);
            for (j, &gi) in recorded.iter().enumerate() {
                if trial[gi].failure != Failure::ForwardKinematics {
                    let at = (t * r + j) * p;
                    let range = gi * p..(gi + 1) * p;
                    add(
                        &mut lin_sum[range.clone()],
                        &mut lin_sq[range],
                        &lin[at..at + p],
                    );
                    lin_n[gi] += 1;
                }
            }
            for (k, (o, e)) in trial.iter().zip(errs.chunks(p)).enumerate() {
                self.push_calibration(o);
                if o.failure != Failure::ForwardKinematics {
                    let range = k * p..(k + 1) * p;
                    add(&mut sum[range.clone()], &mut sq[range], e);
                    if o.mu.is_finite() && o.budget.iter().all(|b| b.is_finite()) {
                        budget[k][0] += o.mu;
                        for (acc, b) in budget[k][1..].iter_mut().zip(o.budget) {
                            *acc += b;
                        }
                        budget_n[k] += 1;
                    }
                }
            }
            self.trials += 1;
        }
        self.block_err_sum.extend(sum);
        self.block_err_sq.extend(sq);
        self.block_budget.extend(budget);
        self.block_budget_n.extend(budget_n);
        self.block_lin_sum.extend(lin_sum);
        self.block_lin_sq.extend(lin_sq);
        self.block_lin_n.extend(lin_n);
    }

    /// Append one block's records alone (a [`Partial::records_only`]).
    fn push_records(&mut self, outcomes: &[Outcome]) {
        for trial in outcomes.chunks(self.grades.max(1)) {
            self.mu0.push(trial[0].mu0);
            for o in trial {
                self.push_calibration(o);
            }
            self.trials += 1;
        }
    }

    /// One calibration's records: μ, its failure, its workspace and
    /// orientation errors where judged.
    fn push_calibration(&mut self, o: &Outcome) {
        self.mu.push(o.mu);
        self.failure.push(o.failure.code());
        if self.volumetric {
            self.dv.extend([
                o.dv_after_max,
                o.dv_after_mean,
                o.dv_before_max,
                o.dv_after_p95,
                o.ap_after_max,
            ]);
        }
        if self.oriented {
            let both: [f64; ORIENTATION_PER_CALIBRATION] =
                [o.orientation_before_max, o.orientation_after_max];
            self.orientation.extend(both);
        }
    }

    /// Append the records of the partial that follows this one.
    pub fn append(&mut self, next: &Partial) {
        assert_eq!(
            (self.grades, self.errors, self.oriented),
            (next.grades, next.errors, next.oriented),
            "a partial follows one of its own study"
        );
        self.trials += next.trials;
        self.mu0.extend_from_slice(&next.mu0);
        self.mu.extend_from_slice(&next.mu);
        self.failure.extend_from_slice(&next.failure);
        self.dv.extend_from_slice(&next.dv);
        self.orientation.extend_from_slice(&next.orientation);
        self.block_err_sum.extend_from_slice(&next.block_err_sum);
        self.block_err_sq.extend_from_slice(&next.block_err_sq);
        self.block_budget.extend_from_slice(&next.block_budget);
        self.block_budget_n.extend_from_slice(&next.block_budget_n);
        self.block_lin_sum.extend_from_slice(&next.block_lin_sum);
        self.block_lin_sq.extend_from_slice(&next.block_lin_sq);
        self.block_lin_n.extend_from_slice(&next.block_lin_n);
    }

    /// Blocks held.
    pub fn blocks(&self) -> usize {
        self.block_budget_n.len() / self.grades.max(1)
    }

    /// The failure of calibration `k` (trial-major, grade-minor).
    pub fn failure_at(&self, k: usize) -> Failure {
        Failure::from_code(self.failure[k]).unwrap_or(Failure::ForwardKinematics)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Errors a calibration of [`sample`] estimates: any number, not a
    /// mechanism's.
    pub(crate) const SAMPLE_ERRORS: usize = 4;

    /// Three trials of two grades, every field set (a codec's test data);
    /// oriented ones judge orientation too.
    pub(crate) fn sample(first_trial: u64, volumetric: bool, oriented: bool) -> Partial {
        type E = nalgebra::SVector<f64, SAMPLE_ERRORS>;
        let mut p = Partial {
            first_trial,
            grades: 2,
            errors: SAMPLE_ERRORS,
            volumetric,
            oriented,
            rank: vec![14, 15],
            ..Default::default()
        };
        let outcomes: Vec<Outcome> = (0..6)
            .map(|k| Outcome {
                mu: 0.01 * k as f64,
                mu0: 0.25 + 0.001 * (k / 2) as f64,
                rank: 14,
                failure: [
                    Failure::None,
                    Failure::NotConverged,
                    Failure::ForwardKinematics,
                ][k % 3],
                dv_after_max: 0.1 + k as f64,
                dv_after_mean: 0.05 + k as f64,
                dv_before_max: 1.0 + k as f64,
                orientation_before_max: 1e-4 * (k + 1) as f64,
                orientation_after_max: 1e-6 * (k + 1) as f64,
                dv_after_p95: 0.09 + k as f64,
                ap_after_max: 0.07 + k as f64,
                budget: [0.001 * k as f64, 0.02, 0.03, 0.04 + k as f64],
            })
            .collect();
        let err: Vec<E> = (0..6)
            .map(|k| E::from_fn(|i, _| (i * 7 + k) as f64 * 1e-3))
            .collect();
        // Grade 1 records its linearisation: one vector a trial.
        let lin: Vec<E> = (0..3)
            .map(|t| E::from_fn(|i, _| (i + 3 * t) as f64 * 1e-4))
            .collect();
        let flat = |v: Vec<E>| -> Vec<f64> { v.iter().flat_map(|x| x.iter().copied()).collect() };
        p.push_block(&outcomes, &flat(err), &flat(lin), &[1]);
        p
    }

    #[test]
    fn blocks_keep_failures_and_error_sums() {
        let p = sample(0, false, true);
        assert_eq!(p.failure_at(0), Failure::None);
        assert_eq!(p.failure_at(1), Failure::NotConverged);
        assert_eq!(p.failure_at(2), Failure::ForwardKinematics);
        assert_eq!(p.mu0, vec![0.25, 0.251, 0.252]);
        // Sums skip the calibrations whose forward kinematics failed (k = 2, 5).
        let grade0: Vec<usize> = vec![0, 4];
        let expect: f64 = grade0.iter().map(|&k| (k) as f64 * 1e-3).sum();
        assert!((p.block_err_sum[0] - expect).abs() < 1e-15);
        // Error 1 of grade 1: calibrations 1 and 3 (5 failed).
        let expect: f64 = [1, 3].iter().map(|&k| (7 + k) as f64 * 1e-3).sum();
        assert!((p.block_err_sum[SAMPLE_ERRORS + 1] - expect).abs() < 1e-15);
        let sq: f64 = [1, 3]
            .iter()
            .map(|&k| ((7 + k) as f64 * 1e-3).powi(2))
            .sum();
        assert!((p.block_err_sq[SAMPLE_ERRORS + 1] - sq).abs() < 1e-18);
        // Grade 1's linearisation: trials 0 and 1 (trial 2's forward
        // kinematics failed); grade 0 records none.
        assert_eq!((p.block_lin_n[0], p.block_lin_n[1]), (0, 2));
        assert!((p.block_lin_sum[SAMPLE_ERRORS] - 3e-4).abs() < 1e-18);
        assert!((p.block_lin_sq[SAMPLE_ERRORS + 1] - (1e-8 + 16e-8)).abs() < 1e-18);
        let mut q = sample(3, false, true);
        q.first_trial = 3;
        let mut joined = p.clone();
        joined.append(&q);
        assert_eq!(joined.trials, 6);
        assert_eq!(joined.blocks(), 2);
        assert_eq!(joined.block_err_sum.len(), 2 * 2 * SAMPLE_ERRORS);
        // Orientation before and after, per calibration, in trial order.
        assert_eq!(joined.orientation.len(), 12 * ORIENTATION_PER_CALIBRATION);
        assert_eq!(joined.orientation[..4], [1e-4, 1e-6, 2e-4, 2e-6]);
        assert_eq!(joined.orientation[12..14], [1e-4, 1e-6]);
        assert!(sample(0, true, false).orientation.is_empty());
    }
}
