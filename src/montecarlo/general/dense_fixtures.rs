//! The dense route the hexapod's study was before the one study kernel
//! carried it, built only with the tests as the reference the kernel is
//! tested against (`kernel_tests.rs`, `mechanism_study_tests.rs`):
//! readings absolute, every zero estimated, one dense gain per
//! combination.
//!
//! Trial k is a pure function of (seed, k): stream (seed, k, 0) draws the
//! machine (each length error uniform in ±`length_bound_mm`, each angle
//! error — a reading's zero — in ±`zero_bound_deg`), put in the
//! convention's frames (what no internal sensor sees is no part of the
//! accuracy judged, as compensate judges it); stream (seed, k, 1),
//! restarted for every sensor, draws the encoders' curves, interpolation
//! phases (one per slot, fitted or not) and jitter (common random numbers:
//! sensors differ only by their datasheets). Readings come from exact
//! forward kinematics of that machine at the nominal commands, plus each
//! encoder's datasheet error (§11–§15's model) at the angle it stands at.
//! Every combination of sensor, instrumentation, pose count and estimator
//! calibrates the same machine; the errors left after compensation are
//! mapped to each judged quantity (the tool point's position; the
//! platform's orientation where targets are poses) by each workspace
//! target's exact sensitivity. Trials are gathered in trial order, so the
//! thread count cannot change a result. Every reading is an angle: the
//! sensors compared are encoders. A prior (`identification.prior_std_mm`,
//! `prior_std_deg`) is every estimator's, as identify's: rows x_c/σp = 0
//! beside the readings, weighted on the readings' scale (the linear
//! estimator's by the sensor's datasheet σ, GLS's by its covariance,
//! Gauss–Newton's as identify weights them).

#[path = "dense_gains_fixtures.rs"]
mod gains;
#[path = "dense_readings_fixtures.rs"]
mod readings;

use super::{Combination, Judged};
use crate::config::general::{Estimator, Spec};
use crate::identify::general::{identify, predict, Holds};
use crate::mechanism::general::{column_of, error_of, worst_into};
use crate::mechanism::{Mechanism, Quantity, ORIENTATION, POSITION};
use crate::montecarlo::mechanism_study::{convention_frames, drawn_errors};
use gains::{held, held_gain};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use readings::{measured, whitening};

/// A trial's machine in each variant's convention frames, and each
/// combination's estimate of it (every error of the mechanism).
pub type Estimates = (Vec<DVector<f64>>, Vec<DVector<f64>>);

/// What one instrumentation shares over a study.
struct Variant<M> {
    m: M,
    /// The convention's free directions (errors × f).
    free: DMatrix<f64>,
    /// f × errors: a drawn machine's coordinates in the free directions, its
    /// errors put in the convention's frames (to first order: the invisible
    /// part removed along the design's null space; `free` times them is
    /// the convention's machine).
    to_free: DMatrix<f64>,
    /// 3QW × f: every workspace target's sensitivity in the free
    /// directions, stacked (Q judged quantities: tool position mm,
    /// rotation rad; target after target).
    judge: DMatrix<f64>,
    /// Per pose count: the linear estimator's gain (f × readings).
    gain: Vec<DMatrix<f64>>,
    /// Per sensor, per pose count: GLS's gain (empty unless studied).
    gls_gain: Vec<Vec<DMatrix<f64>>>,
    /// With fixed errors (`Spec::fixed`), what each gain adds (f): the
    /// fixed values less the gain times their part of the readings; empty
    /// without. Per pose count, and per sensor and pose count.
    offset: Vec<DVector<f64>>,
    gls_offset: Vec<Vec<DVector<f64>>>,
    /// With a prior: the linear estimator's gain and offset per sensor
    /// (its weight is each sensor's σ), per pose count; empty without.
    prior_gain: Vec<Vec<DMatrix<f64>>>,
    prior_offset: Vec<Vec<DVector<f64>>>,
    /// The fixed errors this variant has and the prior, as holds for
    /// Gauss–Newton.
    holds: Holds,
    /// Nominal readings at every target, degrees.
    nominal: Vec<f64>,
    /// Readings a pose, and each one's zero among the errors.
    per: usize,
    zeros: Vec<Option<usize>>,
}

/// A study made ready to run: its combinations in row order and what the
/// trials share.
pub struct Prepared<'a, M: Mechanism> {
    spec: &'a Spec<M::Target, M::Variant>,
    targets: &'a [M::Target],
    variants: Vec<Variant<M>>,
    /// Per workspace target, 3Q × errors: d(tool position mm, rotation
    /// rad)/d(error).
    sensitivity: Vec<DMatrix<f64>>,
    pub combinations: Vec<Combination<M::Variant>>,
    /// Where position and orientation are among the judged quantities.
    at: (Option<usize>, Option<usize>),
}

impl<'a, M: Mechanism> Prepared<'a, M> {
    /// Ready `spec` on `machine` (its geometry; its instrumentation is the
    /// study's axis, `spec.variants`) over `targets` (the config's poses,
    /// the first `n` of them for pose count n). Err names what cannot be
    /// studied.
    pub fn new(
        machine: &M,
        targets: &'a [M::Target],
        spec: &'a Spec<M::Target, M::Variant>,
    ) -> Result<Self, String> {
        let most = spec.pose_counts.iter().copied().max().unwrap_or(0);
        if most > targets.len() || spec.pose_counts.contains(&0) {
            return Err(format!(
                "sweep.pose_counts must be 1 to the {} poses of poses.list",
                targets.len()
            ));
        }
        let errors = machine.error_names().len();
        let zero = vec![0.0; errors];
        let mut variants = Vec::new();
        for &enc in &spec.variants {
            let m = machine.with_variant(enc);
            if m.reading_facts()
                .iter()
                .any(|f| f.quantity != Quantity::Angle)
            {
                return Err("the study compares encoders: every reading must be an angle".into());
            }
            let (free, to_free) = convention_frames(&m, targets)?;
            let present = m.present();
            // The fixed errors this variant has, by their free column.
            let holds = Holds {
                fixed: spec
                    .fixed
                    .iter()
                    .copied()
                    .filter(|(j, _)| present.contains(j))
                    .collect(),
                prior_std_mm: spec.prior_std_mm,
                prior_std_deg: spec.prior_std_deg,
            };
            // The prior's 1/σp of each free coordinate (0: none), mm or
            // degrees as its error.
            let prior: Vec<f64> = (0..free.ncols())
                .map(|c| {
                    holds
                        .prior_std(&m, error_of(&free, c))
                        .map_or(0.0, |sp| 1.0 / sp)
                })
                .collect();
            let has_prior = prior.iter().any(|&p| p > 0.0);
            // Each sensor's datasheet σ of one reading, degrees.
            let sigma_deg =
                |s: &crate::config::general::Sensor| s.axis.sigma(spec.samples).to_degrees();
            let fixed: Vec<(usize, f64)> = holds
                .fixed
                .iter()
                .filter_map(|&(j, v)| column_of(&free, j).map(|c| (c, v)))
                .collect();
            let mut gain = Vec::new();
            let mut offset = Vec::new();
            for &n in &spec.pose_counts {
                let a = m.design(&zero, &targets[..n])? * &free;
                // With a prior the linear gain is per sensor (below).
                if has_prior {
                    continue;
                }
                let (g, o) = held_gain(&a, None, &fixed, &[]).ok_or_else(|| {
                    format!(
                        "sweep.pose_counts: the first {n} poses ({} readings) do not determine the {} free errors with {enc:?} (got {n}): list more poses",
                        a.nrows(),
                        a.ncols(),
                    )
                })?;
                gain.push(g);
                offset.push(o);
            }
            let mut prior_gain = Vec::new();
            let mut prior_offset = Vec::new();
            if has_prior {
                for sensor in &spec.sensors {
                    let s = sigma_deg(sensor);
                    let weights: Vec<f64> = prior.iter().map(|p| s * p).collect();
                    let mut per_count = Vec::new();
                    let mut offsets = Vec::new();
                    for &n in &spec.pose_counts {
                        let a = m.design(&zero, &targets[..n])? * &free;
                        let (g, o) = held_gain(&a, None, &fixed, &weights).ok_or_else(|| {
                            format!("sweep: the first {n} poses and the prior do not determine the free errors with {enc:?}")
                        })?;
                        per_count.push(g);
                        offsets.push(o);
                    }
                    prior_gain.push(per_count);
                    prior_offset.push(offsets);
                }
            }
            let nominal = predict(&m, &zero, targets)?.as_slice().to_vec();
            let mut gls_gain = Vec::new();
            let mut gls_offset = Vec::new();
            if spec.estimators.contains(&Estimator::Gls) {
                for sensor in &spec.sensors {
                    let mut per_count = Vec::new();
                    let mut offsets = Vec::new();
                    for &n in &spec.pose_counts {
                        let a = m.design(&zero, &targets[..n])? * &free;
                        let rows = a.nrows();
                        let w = whitening(&sensor.axis, spec.samples, &nominal[..rows], m.reading_facts().len())
                            .ok_or_else(|| format!("sweep: {}'s datasheet covariance is not positive definite at the first {n} poses", sensor.name))?;
                        let (g, o) = held_gain(&a, Some(&w), &fixed, &prior).ok_or_else(|| {
                            format!("sweep.pose_counts: the first {n} poses do not determine the free errors under {}'s weighting", sensor.name)
                        })?;
                        per_count.push(g);
                        offsets.push(o);
                    }
                    gls_gain.push(per_count);
                    gls_offset.push(offsets);
                }
            }
            let per = m.reading_facts().len();
            variants.push(Variant {
                zeros: (0..per).map(|k| m.zero_of(k)).collect(),
                per,
                m,
                free,
                to_free,
                judge: DMatrix::zeros(0, 0),
                gain,
                gls_gain,
                offset,
                gls_offset,
                prior_gain,
                prior_offset,
                holds,
                nominal,
            });
        }
        let sensitivity = spec
            .workspace
            .iter()
            .enumerate()
            .map(|(w, pose)| {
                machine
                    .sensitivity(pose, &spec.tool_mm)
                    .map_err(|e| format!("workspace pose {}: {e}", w + 1))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let rows = 3 * machine.judged().len();
        for v in variants.iter_mut() {
            let mut stacked = DMatrix::zeros(rows * sensitivity.len(), v.free.ncols());
            for (w, s) in sensitivity.iter().enumerate() {
                stacked.rows_mut(rows * w, rows).copy_from(&(s * &v.free));
            }
            v.judge = stacked;
        }
        let combinations = super::kernel::combinations(spec);
        let judged = machine.judged();
        if judged.len() > 2 {
            return Err(
                "the study judges a tool point's position and a platform's orientation, no more"
                    .into(),
            );
        }
        let at = |q| judged.iter().position(|j| *j == q);
        Ok(Prepared {
            spec,
            targets,
            variants,
            sensitivity,
            combinations,
            at: (at(POSITION), at(ORIENTATION)),
        })
    }

    /// Trial k of every combination, in combination order. Err when the
    /// machine cannot reach a target (forward kinematics fails).
    pub fn trial(&self, k: u64) -> Result<Vec<Judged>, String> {
        let (machines, estimates) = self.free_estimates(k)?;
        let before: Vec<(f64, f64)> = machines
            .iter()
            .zip(&self.variants)
            .map(|(u, v)| self.worst(&(&v.judge * u)))
            .collect();
        let mut out = Vec::with_capacity(self.combinations.len());
        let mut d = DVector::zeros(0);
        for (c, est) in self.combinations.iter().zip(&estimates) {
            let vi = self.variant_of(c);
            d.clone_from(&machines[vi]);
            d -= est;
            let after = self.worst(&(&self.variants[vi].judge * &d));
            out.push(Judged {
                position_before: before[vi].0,
                orientation_before: before[vi].1,
                position_after: after.0,
                orientation_after: after.1,
            });
        }
        Ok(out)
    }

    fn variant_of(&self, c: &Combination<M::Variant>) -> usize {
        self.spec
            .variants
            .iter()
            .position(|&p| p == c.variant)
            .unwrap_or(0)
    }

    /// The largest position (mm) and orientation (″; 0 where not judged)
    /// error of stacked target errors.
    fn worst(&self, x: &DVector<f64>) -> (f64, f64) {
        let judged = self.variants[0].m.judged();
        let mut w = [0.0; 2];
        worst_into(judged, x, &mut w[..judged.len()]);
        let (p, o) = self.at;
        (p.map_or(0.0, |i| w[i]), o.map_or(0.0, |i| w[i]))
    }

    /// Trial k's machine in each variant's convention frames (every
    /// error), and each combination's estimate of it.
    pub fn estimates(&self, k: u64) -> Result<Estimates, String> {
        let (machines, estimates) = self.free_estimates(k)?;
        let machines = machines
            .iter()
            .zip(&self.variants)
            .map(|(u, v)| &v.free * u)
            .collect();
        let estimates = estimates
            .iter()
            .zip(&self.combinations)
            .map(|(u, c)| &self.variants[self.variant_of(c)].free * u)
            .collect();
        Ok((machines, estimates))
    }

    /// [`Prepared::estimates`] in each variant's free directions.
    fn free_estimates(&self, k: u64) -> Result<Estimates, String> {
        let spec = self.spec;
        let most = spec.pose_counts.iter().copied().max().unwrap_or(0);
        let drawn = DVector::from_column_slice(&draw_errors(&self.variants[0].m, spec, k));
        // Per variant: the machine and its exact readings.
        let mut machines = Vec::with_capacity(self.variants.len());
        let mut exact = Vec::with_capacity(self.variants.len());
        for v in &self.variants {
            // Absent encoders' zeros have zero columns in to_free.
            let u = &v.to_free * &drawn;
            let e = &v.free * &u;
            let mut readings = Vec::with_capacity(v.nominal.len());
            v.m.readings_into(e.as_slice(), &self.targets[..most], &mut readings)?;
            // The angle each encoder stands at: its reading less its zero.
            let angles: Vec<f64> = readings
                .iter()
                .enumerate()
                .map(|(i, x)| (x - v.zeros[i % v.per].map_or(0.0, |z| e[z])).to_radians())
                .collect();
            machines.push(u);
            exact.push((readings, angles));
        }
        // Each sensor's readings once per variant, at every pose: a pose
        // count reads the first of them (its draws come first).
        let mut read: Vec<Vec<Option<Vec<f64>>>> =
            vec![vec![None; self.variants.len()]; spec.sensors.len()];
        let mut estimates = Vec::with_capacity(self.combinations.len());
        for c in &self.combinations {
            let vi = self.variant_of(c);
            let v = &self.variants[vi];
            let (readings, angles) = &exact[vi];
            let measured = read[c.sensor][vi].get_or_insert_with(|| {
                let s = &spec.sensors[c.sensor];
                measured(
                    s.truth.as_ref().unwrap_or(&s.axis),
                    (spec.seed, spec.samples),
                    k,
                    readings,
                    angles,
                    (&v.m, v.per),
                )
            });
            let rows = v.per * c.poses;
            let ni = spec
                .pose_counts
                .iter()
                .position(|&n| n == c.poses)
                .unwrap_or(0);
            estimates.push(match c.estimator {
                Estimator::Linear => {
                    let y = DVector::from_fn(rows, |i, _| measured[i] - v.nominal[i]);
                    match v.prior_gain.get(c.sensor) {
                        Some(g) => held(&g[ni] * y, &v.prior_offset[c.sensor][ni]),
                        None => held(&v.gain[ni] * y, &v.offset[ni]),
                    }
                }
                Estimator::Gls => {
                    let y = DVector::from_fn(rows, |i, _| measured[i] - v.nominal[i]);
                    held(&v.gls_gain[c.sensor][ni] * y, &v.gls_offset[c.sensor][ni])
                }
                Estimator::GaussNewton => {
                    // A prior needs the readings' σ (its scale): the
                    // sensor's datasheet σ.
                    let prior = v.holds.prior_std_mm.is_some() || v.holds.prior_std_deg.is_some();
                    let sigma = match prior {
                        false => Vec::new(),
                        true => vec![spec.sensors[c.sensor].axis.sigma(spec.samples).to_degrees()],
                    };
                    let fit = identify(
                        &v.m,
                        &self.targets[..c.poses],
                        &DVector::from_column_slice(&measured[..rows]),
                        spec.iterations,
                        &sigma,
                        &v.holds,
                    )?;
                    v.free.transpose() * DVector::from_column_slice(&fit.errors)
                }
            });
        }
        Ok((machines, estimates))
    }

    /// The largest tool-point position error (mm) and orientation error (″)
    /// over the workspace of a machine whose errors are off by `d`.
    /// Each target's own sensitivity, one target at a time: the
    /// reference the stacked judgement of the trials is tested against.
    pub fn judge(&self, d: &DVector<f64>) -> (f64, f64) {
        let rows = self.sensitivity.first().map_or(0, |s| s.nrows());
        let mut stacked = DVector::zeros(rows * self.sensitivity.len());
        for (w, s) in self.sensitivity.iter().enumerate() {
            stacked.rows_mut(rows * w, rows).copy_from(&(s * d));
        }
        self.worst(&stacked)
    }

    /// Every trial of every combination on `threads` threads: out[k][c].
    pub fn run(&self, threads: usize) -> Result<Vec<Vec<Judged>>, String> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| format!("cannot start {threads} threads: {e}"))?;
        pool.install(|| {
            (0..self.spec.trials)
                .into_par_iter()
                .map(|k| self.trial(k).map_err(|e| format!("trial {k}: {e}")))
                .collect()
        })
    }
}

/// Trial k's errors before the convention: lengths uniform in ±bound mm,
/// angles (the readings' zeros) in ±bound degrees, every error of the
/// mechanism drawn whatever is fitted.
pub fn draw_errors<M: Mechanism>(m: &M, spec: &Spec<M::Target, M::Variant>, k: u64) -> Vec<f64> {
    drawn_errors(
        m,
        (spec.length_bound_mm, spec.zero_bound_deg),
        &spec.fixed,
        (spec.seed, k),
    )
}

#[cfg(test)]
#[path = "tests.rs"]
mod tests;
