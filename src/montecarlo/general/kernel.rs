//! A study of any mechanism run through the one study kernel (`context`,
//! `trial`, `workspace`): each instrumentation a study of the kernel's
//! fixed sizes, its P coordinates and R readings a pose
//! ([`super::super::mechanism_study::MechanismStudy`]), which the
//! mechanism names where its commands are assembled
//! ([`KernelFn`]: the hexapod's are 33 and 12 with both encoders a
//! joint, 33 and 6 with one).
//!
//! Each study runs every trial through the runner the Tricept's sweep
//! runs ([`BlockRunner::records_only`]: blocks on a rayon pool, each
//! calibration's record gathered in trial order into a [`Partial`],
//! progress reported), in blocks sized so its buffers hold at most
//! [`RUNNER_BYTES`]; a combination's rows are read from the records.
//!
//! Every calibration target is read (so a pose count's draws are the same
//! whatever else is studied). Each combination is a grade of the kernel:
//! the first n calibration poses (the reference first), the encoder's datasheet model reading,
//! and its estimator as the kernel has it:
//! - linear: least squares once, the zeros unknown, which on the homed
//!   rows is GLS under white noise of the datasheet's σ;
//! - GLS: GLS under the datasheet's covariance (its interpolation error
//!   weighted as white, as every study of the kernel weights it, at the
//!   nominal readings);
//! - Gauss–Newton: from the linear estimate, re-linearised at each
//!   estimate's exact kinematics (a study of its own, the kernel
//!   iterating every grade of one).
//!
//! Fixed errors and a prior on the lengths are every estimator's;
//! homing cancels the encoders' zeros, so a zero held or under a prior
//! changes nothing the study judges.

use super::{Combination, Judged};
use crate::config::general::{Estimator, Sensor, Spec};
use crate::config::{ErrorDraw, Truth};
use crate::identify::general::{convention_rank, Holds};
use crate::identify::{Constraints, IdentifyOptions, Method, Solver};
use crate::mechanism::{Commanded, Homed, Kinematic, ReadingFact};
use crate::montecarlo::context::{Grade, GradeTable, MapGrid, Parts, PoseSubset, SweepContext};
use crate::montecarlo::mechanism_study::{Bounds, MechanismStudy, Setup};
use crate::montecarlo::partial::{Partial, DV_PER_CALIBRATION, ORIENTATION_PER_CALIBRATION};
use crate::montecarlo::runner::{BlockRunner, Progress, Silent};
use crate::montecarlo::sink::NoRows;
use crate::montecarlo::studied::Studied;
use crate::montecarlo::trial::Failure;
use crate::sensors::{GradeReading, SensorModel, Structured, ARCSEC_PER_RAD};
use nalgebra::SVector;
use std::sync::atomic::{AtomicU64, Ordering};

/// One instrumentation of a study, for the kernel to run: the mechanism
/// with it fitted, the calibration targets and the study. Built by
/// [`run_kernel`] only, after [`check`] has taken the study.
pub struct VariantRun<'a, M: crate::mechanism::Mechanism> {
    pub m: &'a M,
    targets: &'a [M::Target],
    spec: &'a Spec<M::Target, M::Variant>,
    threads: usize,
    progress: &'a dyn Progress,
}

/// A mechanism's sizes in the kernel: runs [`VariantRun::run`] at the
/// coordinates and readings of the instrumentation it is given.
pub type KernelFn<M> = fn(&VariantRun<'_, M>) -> Result<Vec<Vec<Judged>>, String>;

/// Every trial of every combination of `spec` on `m`, in combination
/// order (sensor, instrumentation, poses, estimator), each
/// instrumentation through the kernel at the sizes `sizes` gives: the
/// combinations and out[k][c]. Reports nothing ([`run_reporting`]).
#[allow(clippy::type_complexity)]
pub fn run_kernel<M: Commanded>(
    m: &M,
    targets: &[M::Target],
    spec: &Spec<M::Target, M::Variant>,
    threads: usize,
    sizes: KernelFn<M>,
) -> Result<(Vec<Combination<M::Variant>>, Vec<Vec<Judged>>), String> {
    run_reporting(m, targets, spec, (threads, &Silent), sizes)
}

/// [`run_kernel`], reporting its progress in machines to `progress`
/// (each instrumentation's studies, one for linear and GLS and one for
/// Gauss–Newton, run every machine in turn).
#[allow(clippy::type_complexity)]
pub fn run_reporting<M: Commanded>(
    m: &M,
    targets: &[M::Target],
    spec: &Spec<M::Target, M::Variant>,
    (threads, progress): (usize, &dyn Progress),
    sizes: KernelFn<M>,
) -> Result<(Vec<Combination<M::Variant>>, Vec<Vec<Judged>>), String> {
    check(m, targets, spec)?;
    let combinations = combinations(spec);
    let mut per_variant = Vec::with_capacity(spec.variants.len());
    let per = spec.pose_counts.len() * spec.estimators.len();
    let studies = (spec.estimators.iter().any(|&e| e != Estimator::GaussNewton) as u64)
        + (spec.estimators.contains(&Estimator::GaussNewton) as u64);
    // Every study runs every machine: progress is told in machines.
    let progress = &Machines {
        to: progress,
        studies: studies * spec.variants.len() as u64,
        run: AtomicU64::new(0),
    };
    progress.to.start(spec.trials, 0);
    for &v in &spec.variants {
        let fitted = m.with_variant(v);
        let judged = sizes(&VariantRun {
            m: &fitted,
            targets,
            spec,
            threads,
            progress,
        })
        .inspect_err(|_| progress.to.finish())?;
        let want = spec.sensors.len() * per;
        if judged.len() as u64 != spec.trials || judged.iter().any(|t| t.len() != want) {
            progress.to.finish();
            return Err(format!(
                "the study kernel gave the {} ({}) other than {} trials of {want} combinations",
                m.name(),
                m.variant_name(v),
                spec.trials
            ));
        }
        per_variant.push(judged);
    }
    progress.to.finish();
    // A variant's own order: sensor, poses, estimator. Each trial's rows
    // are taken from the variants as they are merged, so the results are
    // held once (what `result_bytes` counts), not twice.
    let mut rows: Vec<_> = per_variant.into_iter().map(Vec::into_iter).collect();
    let mut out = Vec::with_capacity(spec.trials as usize);
    for _ in 0..spec.trials {
        let trial: Vec<Vec<Judged>> = rows
            .iter_mut()
            .map(|r| r.next().unwrap_or_default())
            .collect();
        out.push(
            (combinations.iter().enumerate())
                .map(|(ci, c)| {
                    let vi = (ci / per) % spec.variants.len();
                    trial[vi]
                        .get(c.sensor * per + ci % per)
                        .copied()
                        .unwrap_or_default()
                })
                .collect(),
        );
    }
    Ok((combinations, out))
}

/// A study's progress in machines, told by studies that each run every
/// machine: `studies` trials run are one machine.
struct Machines<'p> {
    to: &'p dyn Progress,
    studies: u64,
    /// Trials run by every study so far.
    run: AtomicU64,
}

impl Progress for Machines<'_> {
    fn advance(&self, trials: u64) {
        let before = self.run.fetch_add(trials, Ordering::Relaxed);
        let n = self.studies.max(1);
        let machines = (before + trials) / n - before / n;
        if machines > 0 {
            self.to.advance(machines);
        }
    }
}

/// What the kernel refuses of a study of `m` over `targets` calibration
/// poses, before any work, in a sentence naming the key: a pose count
/// outside 1 to the poses listed, and what homing makes meaningless (a
/// fixed reading's zero, a prior on the zeros). The study homes its
/// readings at the reference pose, where a zero cancels, so it cannot say
/// what measuring one buys.
pub fn check<M: crate::mechanism::Mechanism>(
    m: &M,
    targets: &[M::Target],
    spec: &Spec<M::Target, M::Variant>,
) -> Result<(), String> {
    if spec
        .pose_counts
        .iter()
        .any(|&n| n > targets.len() || n == 0)
    {
        return Err(format!(
            "sweep.pose_counts must be 1 to the {} poses of poses.list",
            targets.len()
        ));
    }
    if spec.prior_std_deg.is_some() {
        return Err("identification.prior_std_deg: the study homes its readings at the reference pose, where the encoders' zeros cancel, so a prior on them is not in its rows; leave it out of a study (identify holds it)".into());
    }
    let names = m.error_names();
    for &(j, _) in &spec.fixed {
        let zero = spec.variants.iter().any(|&v| {
            let mv = m.with_variant(v);
            (0..mv.reading_facts().len()).any(|k| mv.zero_of(k) == Some(j))
        });
        if zero {
            return Err(format!("identification.fix.{}: the study homes its readings at the reference pose, where an encoder's zero cancels, so it cannot price measuring one; fix leg offsets only in a study (identify holds a fixed zero)", names[j]));
        }
    }
    // Each pose count's poses must determine the free errors, as identify
    // requires of a log: a study of a count that cannot would price a
    // calibration no one can run (its minimum-norm fit leaves the errors
    // the poses do not see as they were, or worse). A prior on the lengths
    // determines what the poses do not, as identify takes it.
    if spec.prior_std_mm.is_none() {
        let holds = Holds {
            fixed: spec.fixed.clone(),
            ..Holds::default()
        };
        for &v in &spec.variants {
            let mv = m.with_variant(v);
            for &n in &spec.pose_counts {
                let (rank, free) = convention_rank(&mv, &targets[..n], RANK_TOLERANCE, &holds)?;
                if rank < free {
                    return Err(format!(
                        "sweep.pose_counts: the first {n} poses of poses.list determine {rank} of the {free} free errors with {} per {} (got {n}): leave that count out, or list more poses, spread over the workspace",
                        m.variant_words(v)[0],
                        m.words().joint,
                    ));
                }
            }
        }
    }
    Ok(())
}

/// The relative singular-value tolerance below which a pose count's
/// design is taken as rank-deficient ([`check`]): identify's default
/// (`identification.rank_tolerance`).
const RANK_TOLERANCE: f64 = 1e-9;

/// Any `Kinematic` topology's sizes in the kernel, through `Homed`: its
/// P errors (every one free: a topology whose gauge holds some is
/// refused by [`MechanismStudy`] in a sentence) and its R readings.
pub fn homed_sizes<T, const P: usize, const R: usize>(
    v: &VariantRun<'_, Homed<'_, T, P, R>>,
) -> Result<Vec<Vec<Judged>>, String>
where
    T: Kinematic<P, R>,
    T::Layout: Sync,
    T::Machine: Sync,
{
    let slots: &'static [ReadingFact; R] = T::READINGS.try_into().map_err(|_| {
        format!(
            "the {} names {} readings, not {R}",
            T::NAME,
            T::READINGS.len()
        )
    })?;
    v.run::<P, R>(slots)
}

/// A study's combinations in row order: sensor, instrumentation, pose
/// count, estimator.
pub fn combinations<T, V: Copy>(spec: &Spec<T, V>) -> Vec<Combination<V>> {
    let mut out = Vec::new();
    for sensor in 0..spec.sensors.len() {
        for &variant in &spec.variants {
            for &poses in &spec.pose_counts {
                for &estimator in &spec.estimators {
                    out.push(Combination {
                        sensor,
                        variant,
                        poses,
                        estimator,
                    });
                }
            }
        }
    }
    out
}

impl<M: Commanded> VariantRun<'_, M> {
    /// Every trial of this instrumentation's combinations (sensor, pose
    /// count, estimator), through the kernel at P coordinates and R
    /// readings a pose read by `slots`: out[k][c]. Err: a sentence.
    pub fn run<const P: usize, const R: usize>(
        &self,
        slots: &'static [ReadingFact; R],
    ) -> Result<Vec<Vec<Judged>>, String> {
        let spec = self.spec;
        let iterated = spec.estimators.contains(&Estimator::GaussNewton);
        let once: Vec<Estimator> = (spec.estimators.iter().copied())
            .filter(|&e| e != Estimator::GaussNewton)
            .collect();
        let names_owned = self.m.error_names();
        let names: Vec<&str> = names_owned.iter().map(String::as_str).collect();
        let linear = match once.is_empty() {
            true => None,
            false => Some(self.context::<P, R>(slots, &names, &once, 1)?),
        };
        let gauss = match iterated {
            true => Some(self.context::<P, R>(
                slots,
                &names,
                &[Estimator::GaussNewton],
                spec.iterations.max(2),
            )?),
            false => None,
        };
        // Where each of this instrumentation's combinations is: which
        // study, which grade.
        let mut at = Vec::new();
        for si in 0..spec.sensors.len() {
            for ni in 0..spec.pose_counts.len() {
                for &e in &spec.estimators {
                    at.push(match e {
                        Estimator::GaussNewton => (1, grade_of(ni, si, 0, 1, spec)),
                        _ => {
                            let ei = once.iter().position(|&o| o == e).unwrap_or(0);
                            (0, grade_of(ni, si, ei, once.len(), spec))
                        }
                    });
                }
            }
        }
        // Each study runs every trial through the runner (the same
        // machines and draws: a trial's are derived from the seed and its
        // number), then each combination is read from its records.
        let records = |c: &Option<Study<'_, M, P, R>>| c.as_ref().map(|c| self.records(c));
        let (a, b) = (records(&linear).transpose()?, records(&gauss).transpose()?);
        let judged_at = |(which, gi): (usize, usize), k: usize| match which {
            0 => a.as_ref().map(|p| judged(p, k * p.grades + gi)),
            _ => b.as_ref().map(|p| judged(p, k * p.grades + gi)),
        };
        Ok((0..spec.trials as usize)
            .map(|k| {
                at.iter()
                    .map(|&w| judged_at(w, k).unwrap_or_default())
                    .collect()
            })
            .collect())
    }

    /// Every trial of study `c` through the block runner on this run's
    /// threads, reporting to its progress: their records. Err: a
    /// sentence (a drawn machine whose forward kinematics failed names its
    /// trial).
    fn records<S: Studied<P, R, 0>, const P: usize, const R: usize>(
        &self,
        c: &SweepContext<S, P, R, 0>,
    ) -> Result<Partial, String> {
        if !c.volumetric() {
            return Err("the study judges each machine over its workspace, and has none".into());
        }
        let mut none = NoRows;
        let trials = self.spec.trials;
        let block = (RUNNER_BYTES / BlockRunner::bytes_per_trial(c, false).max(1))
            .min(usize::try_from(trials).unwrap_or(usize::MAX));
        let mut runner = BlockRunner::records_only(c, block, self.threads, &mut none)
            .map_err(|e| e.to_string())?;
        runner.partial.reserve(usize::try_from(trials).unwrap_or(0));
        runner.report_to(self.progress);
        runner.run_trials(trials).map_err(|e| e.to_string())?;
        let p = std::mem::take(&mut runner.partial);
        let g = p.grades.max(1);
        match (0..p.failure.len()).find(|&i| p.failure_at(i) == Failure::ForwardKinematics) {
            Some(i) => Err(format!(
                "trial {}: forward kinematics of the drawn machine failed at a calibration pose",
                i / g
            )),
            None => Ok(p),
        }
    }

    /// The kernel's study of this instrumentation for `estimators` (none
    /// Gauss–Newton, or Gauss–Newton alone at `iterations`): grades pose
    /// count, then sensor, then estimator.
    fn context<'s, const P: usize, const R: usize>(
        &'s self,
        slots: &'static [ReadingFact; R],
        names: &'s [&'s str],
        estimators: &[Estimator],
        iterations: usize,
    ) -> Result<Study<'s, M, P, R>, String> {
        let spec = self.spec;
        // Every calibration target is read, whatever pose counts are
        // studied, so a machine's readings (and a pose count's draws) are
        // the same in any study of the config: a what-if of one pose count
        // reruns the chosen row to the bit.
        let most = self.targets.len();
        if self.m.reading_facts() != slots.to_vec() {
            return Err(format!(
                "the study's reading slots are not the {}'s readings",
                self.m.name()
            ));
        }
        if slots
            .iter()
            .any(|f| f.quantity != crate::mechanism::Quantity::Angle)
        {
            return Err("the study compares encoders: every reading must be an angle".into());
        }
        // The first n poses, the reference first.
        let subsets: Vec<PoseSubset> = (spec.pose_counts.iter())
            .map(|&n| PoseSubset {
                poses: (0..n).collect(),
                rows: (0..R * n.saturating_sub(1)).collect(),
                full: n == most,
            })
            .collect();
        let (mech, grids) = MechanismStudy::<M, P, R>::new(Setup {
            m: self.m,
            names,
            targets: &self.targets[..most],
            subsets: &subsets,
            workspace: &spec.workspace,
            tool: spec.tool_mm,
            exact: false,
            bounds: Some(Bounds {
                length_mm: spec.length_bound_mm,
                angle_deg: spec.zero_bound_deg,
            }),
        })?;
        let h = mech.design()?;
        let mut constraints = Constraints::<P> {
            prior_std_mm: spec.prior_std_mm,
            ..Constraints::default()
        };
        // A fixed error this instrumentation lacks (an encoder not
        // fitted) has no coordinate; [`check`] refused a zero.
        for &(j, v) in &spec.fixed {
            if let Some(c) = mech.coordinate_of(j) {
                constraints.fixed[c] = Some(v);
            }
        }
        let options = IdentifyOptions::<P> {
            method: Method::Gls,
            iterations,
            constraints,
            ..IdentifyOptions::default()
        };
        let model = |axis: &crate::sensors::Axis, structured: bool| SensorModel::<R> {
            slots,
            encoder_arcsec: axis.sigma(spec.samples) * ARCSEC_PER_RAD,
            scale_um: 0.0,
            samples: spec.samples,
            reading: GradeReading::Sigma,
            structured: structured.then_some(Structured {
                axes: [*axis; R],
                from_section: [true; R],
            }),
        };
        let reading: Vec<SensorModel<R>> = (spec.sensors.iter())
            .map(|s: &Sensor| model(s.truth.as_ref().unwrap_or(&s.axis), true))
            .collect();
        let assumed: Vec<SensorModel<R>> =
            spec.sensors.iter().map(|s| model(&s.axis, true)).collect();
        let mut table = GradeTable {
            grades: Vec::new(),
            solvers: Vec::new(),
            split_of: Vec::new(),
        };
        for (pi, sub) in subsets.iter().enumerate() {
            let h_sub = h.rows(0, sub.rows.len()).into_owned();
            let nominal = &mech.nominal()[..sub.poses.len()];
            for (si, s) in spec.sensors.iter().enumerate() {
                for &e in estimators {
                    let weighted = match e {
                        Estimator::Gls => assumed[si].white_interpolation(),
                        _ => model(&s.axis, false),
                    };
                    let solver: Solver<P, R> = Method::Gls
                        .solver(
                            (&weighted, nominal),
                            &h_sub,
                            options.rank_tolerance,
                            (&options.constraints, mech.names()),
                        )
                        .map_err(|why| {
                            format!(
                                "sweep: {} at the first {} poses: {why}",
                                s.name,
                                sub.poses.len()
                            )
                        })?;
                    table.split_of.push(table.grades.len());
                    table.grades.push(Grade {
                        encoder_arcsec: assumed[si].encoder_arcsec,
                        scale_um: 0.0,
                        method: Method::Gls,
                        sensor_index: si,
                        product: si,
                        truth: Truth::DATASHEET,
                        pose_count: sub.poses.len(),
                        subset: pi,
                    });
                    table.solvers.push(solver);
                }
            }
        }
        SweepContext::assemble(Parts {
            mech,
            h,
            h_second: None,
            subsets,
            table,
            assumed,
            sensors: reading,
            products: None,
            options,
            gls_per_machine: Some(false),
            draw: ErrorDraw::Random,
            fixed_errors: SVector::zeros(),
            bound_mm: 0.0,
            seed: spec.seed,
            perfect: [false; R],
            grids: (grids.position, MapGrid::default()),
            orientation: grids.orientation,
            exact: false,
        })
    }
}

/// A study of an instrumentation in the kernel.
type Study<'s, M, const P: usize, const R: usize> =
    SweepContext<MechanismStudy<'s, M, P, R>, P, R, 0>;

/// The grade of pose count `ni`, sensor `si`, estimator `ei` of `of`.
fn grade_of<T, V>(ni: usize, si: usize, ei: usize, of: usize, spec: &Spec<T, V>) -> usize {
    (ni * spec.sensors.len() + si) * of + ei
}

/// Calibration `i`'s record (trial-major, grade-minor) as the study
/// judges it: position (mm) and orientation (″; 0 where not judged)
/// before and after compensation.
fn judged(p: &Partial, i: usize) -> Judged {
    let arcsec = |x: f64| if x.is_nan() { 0.0 } else { x * ARCSEC_PER_RAD };
    let dv = &p.dv[DV_PER_CALIBRATION * i..DV_PER_CALIBRATION * (i + 1)];
    let turned = |j: usize| match p.oriented {
        true => arcsec(p.orientation[ORIENTATION_PER_CALIBRATION * i + j]),
        false => 0.0,
    };
    Judged {
        position_before: dv[2],
        position_after: dv[0],
        orientation_before: turned(0),
        orientation_after: turned(1),
    }
}

/// Bytes a runner's buffers may hold, which sets its block of trials
/// (fewer where a calibration estimates many errors).
pub const RUNNER_BYTES: usize = 32 << 20;

#[cfg(test)]
#[path = "kernel_tests.rs"]
mod tests;
