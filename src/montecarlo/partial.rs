//! The per-calibration records of a range of whole blocks, and their binary
//! codec (`partial.bin`, the block log of `--resume`).

use super::outcome::{Failure, Outcome};
use super::trial::SweepContext;
use crate::model::{ErrorVector, N_PARAMS};

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
    pub volumetric: bool,
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
    /// Σ(estimate − truth) and Σ(estimate − truth)² per block × grade.
    pub block_err_sum: Vec<ErrorVector>,
    pub block_err_sq: Vec<ErrorVector>,
    /// Σ of the error budget ([`Outcome::budget`]) per block × grade, and
    /// the calibrations counted in it (NaN budgets are left out).
    pub block_budget: Vec<[f64; BUDGET_TERMS]>,
    pub block_budget_n: Vec<u64>,
}

/// Terms summed for the error budget: μ, then [`Outcome::budget`].
pub const BUDGET_TERMS: usize = 5;

const PARTIAL_MAGIC: &[u8; 8] = b"TCPART03";

/// Volumetric values stored per calibration: dV after compensation (max and
/// mean over the workspace grid), dV before (max), dV after (p95), worst
/// ISO 9283 AP after.
pub const DV_PER_CALIBRATION: usize = 5;

impl Partial {
    pub fn new(ctx: &SweepContext, first_trial: u64) -> Self {
        Partial {
            first_trial,
            grades: ctx.grades.len(),
            volumetric: ctx.volumetric(),
            rank: ctx.solvers.iter().map(|s| s.analysis.rank as u8).collect(),
            ..Default::default()
        }
    }

    /// Append one block of outcomes (trial-major, grade-minor).
    pub fn push_block(&mut self, outcomes: &[Outcome]) {
        let g = self.grades;
        let mut sum = vec![ErrorVector::zeros(); g];
        let mut sq = vec![ErrorVector::zeros(); g];
        let mut budget = vec![[0.0; BUDGET_TERMS]; g];
        let mut budget_n = vec![0u64; g];
        for trial in outcomes.chunks(g) {
            self.mu0.push(trial[0].mu0);
            for (k, o) in trial.iter().enumerate() {
                self.mu.push(o.mu);
                let code = o.failure.code();
                self.failure.push(code);
                if self.volumetric {
                    self.dv.extend([
                        o.dv_after_max,
                        o.dv_after_mean,
                        o.dv_before_max,
                        o.dv_after_p95,
                        o.ap_after_max,
                    ]);
                }
                if o.failure != Failure::ForwardKinematics {
                    sum[k] += o.error;
                    sq[k] += o.error.component_mul(&o.error);
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
    }

    /// Append the records of the partial that follows this one.
    pub fn append(&mut self, next: &Partial) {
        self.trials += next.trials;
        self.mu0.extend_from_slice(&next.mu0);
        self.mu.extend_from_slice(&next.mu);
        self.failure.extend_from_slice(&next.failure);
        self.dv.extend_from_slice(&next.dv);
        self.block_err_sum.extend_from_slice(&next.block_err_sum);
        self.block_err_sq.extend_from_slice(&next.block_err_sq);
        self.block_budget.extend_from_slice(&next.block_budget);
        self.block_budget_n.extend_from_slice(&next.block_budget_n);
    }

    /// The length of [`Partial::to_bytes`] for these dimensions (u128: no
    /// overflow whatever a damaged header says).
    pub fn encoded_len(trials: u64, grades: u64, volumetric: bool, blocks: u64) -> u128 {
        let (t, g, b) = (trials as u128, grades as u128, blocks as u128);
        let calib = t * g;
        8 + 5 * 8
            + g
            + 8 * t
            + 8 * calib
            + if volumetric {
                8 * DV_PER_CALIBRATION as u128 * calib
            } else {
                0
            }
            + calib
            + 2 * b * g * N_PARAMS as u128 * 8
            + b * g * (BUDGET_TERMS as u128 + 1) * 8
    }

    /// Binary form (little-endian), for shards.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b =
            Vec::with_capacity(64 + self.mu.len() * 9 + self.mu0.len() * 8 + self.dv.len() * 8);
        b.extend_from_slice(PARTIAL_MAGIC);
        for v in [
            self.first_trial,
            self.trials,
            self.grades as u64,
            self.volumetric as u64,
            (self.block_err_sum.len() / self.grades.max(1)) as u64,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.rank);
        for v in self.mu0.iter().chain(&self.mu).chain(&self.dv) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.failure);
        for e in self.block_err_sum.iter().chain(&self.block_err_sq) {
            for v in e.iter() {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in self.block_budget.iter().flatten() {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for n in &self.block_budget_n {
            b.extend_from_slice(&n.to_le_bytes());
        }
        b
    }

    /// The failure of calibration `k` (trial-major, grade-minor).
    pub fn failure_at(&self, k: usize) -> Failure {
        Failure::from_code(self.failure[k]).unwrap_or(Failure::ForwardKinematics)
    }

    /// Parse [`Partial::to_bytes`]; `None` when the bytes are not a complete partial.
    pub fn from_bytes(b: &[u8]) -> Option<Self> {
        let mut pos = 0usize;
        let mut take = |n: usize| -> Option<&[u8]> {
            let s = b.get(pos..pos.checked_add(n)?)?;
            pos += n;
            Some(s)
        };
        if take(8)? != PARTIAL_MAGIC {
            return None;
        }
        let mut u = || -> Option<u64> { Some(u64::from_le_bytes(take(8)?.try_into().ok()?)) };
        let (first_trial, trials, grades, volumetric, blocks) =
            (u()?, u()?, u()? as usize, u()? != 0, u()? as usize);
        let calib = (trials as usize).checked_mul(grades)?;
        let rank = take(grades)?.to_vec();
        let f64s = |s: &[u8]| -> Vec<f64> {
            s.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                .collect()
        };
        let mu0 = f64s(take((trials as usize).checked_mul(8)?)?);
        let mu = f64s(take(calib.checked_mul(8)?)?);
        let dv = if volumetric {
            f64s(take(calib.checked_mul(8 * DV_PER_CALIBRATION)?)?)
        } else {
            Vec::new()
        };
        let failure = take(calib)?.to_vec();
        let vecs = |n: usize,
                    take: &mut dyn FnMut(usize) -> Option<Vec<u8>>|
         -> Option<Vec<ErrorVector>> {
            let raw = take(n.checked_mul(grades)?.checked_mul(N_PARAMS * 8)?)?;
            Some(
                f64s(&raw)
                    .chunks_exact(N_PARAMS)
                    .map(ErrorVector::from_column_slice)
                    .collect(),
            )
        };
        let mut take_vec = |n: usize| take(n).map(|s| s.to_vec());
        let block_err_sum = vecs(blocks, &mut take_vec)?;
        let block_err_sq = vecs(blocks, &mut take_vec)?;
        let cells = blocks.checked_mul(grades)?;
        let block_budget = f64s(&take_vec(cells.checked_mul(BUDGET_TERMS * 8)?)?)
            .chunks_exact(BUDGET_TERMS)
            .map(|c| [c[0], c[1], c[2], c[3], c[4]])
            .collect();
        let block_budget_n = take_vec(cells.checked_mul(8)?)?
            .chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect();
        if pos != b.len() {
            return None;
        }
        Some(Partial {
            first_trial,
            trials,
            grades,
            volumetric,
            mu0,
            mu,
            failure,
            rank,
            dv,
            block_err_sum,
            block_err_sq,
            block_budget,
            block_budget_n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(first_trial: u64, volumetric: bool) -> Partial {
        let mut p = Partial {
            first_trial,
            grades: 2,
            volumetric,
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
                error: ErrorVector::from_fn(|i, _| (i * 7 + k) as f64 * 1e-3),
                dv_after_max: 0.1 + k as f64,
                dv_after_mean: 0.05 + k as f64,
                dv_before_max: 1.0 + k as f64,
                dv_after_p95: 0.09 + k as f64,
                ap_after_max: 0.07 + k as f64,
                budget: [0.001 * k as f64, 0.02, 0.03, 0.04 + k as f64],
            })
            .collect();
        p.push_block(&outcomes);
        p
    }

    #[test]
    fn codec_round_trips_and_rejects_damage() {
        for volumetric in [false, true] {
            let p = sample(8192, volumetric);
            assert_eq!(p.trials, 3);
            let bytes = p.to_bytes();
            assert_eq!(
                Partial::encoded_len(3, 2, volumetric, 1),
                bytes.len() as u128
            );
            assert_eq!(Partial::from_bytes(&bytes), Some(p.clone()));
            assert_eq!(Partial::from_bytes(&bytes[..bytes.len() - 1]), None);
            let mut longer = bytes.clone();
            longer.push(0);
            assert_eq!(Partial::from_bytes(&longer), None);
            let mut magic = bytes.clone();
            magic[0] ^= 1;
            assert_eq!(Partial::from_bytes(&magic), None);
        }
    }

    #[test]
    fn blocks_keep_failures_and_error_sums() {
        let p = sample(0, false);
        assert_eq!(p.failure_at(0), Failure::None);
        assert_eq!(p.failure_at(1), Failure::NotConverged);
        assert_eq!(p.failure_at(2), Failure::ForwardKinematics);
        assert_eq!(p.mu0, vec![0.25, 0.251, 0.252]);
        // Sums skip the calibrations whose forward kinematics failed (k = 2, 5).
        let grade0: Vec<usize> = vec![0, 4];
        let expect: f64 = grade0.iter().map(|&k| (k) as f64 * 1e-3).sum();
        assert!((p.block_err_sum[0][0] - expect).abs() < 1e-15);
        let mut q = sample(3, false);
        q.first_trial = 3;
        let mut joined = p.clone();
        joined.append(&q);
        assert_eq!(joined.trials, 6);
        assert_eq!(joined.block_err_sum.len(), 4);
    }
}
