//! What a study states of each identified error's spread (parameters.csv's
//! `predicted_std_mm`, docs/method.md §18): op·Σ·opᵀ for every estimator,
//! with Σ the sensors' covariance as it is — the interpolation error as
//! its kernel (i²/2)·cos(2π·(v_i − v_j)/P), not as white noise.
//!
//! The kernel depends on where each reading falls within a signal period,
//! and a machine's errors move its readings by a good part of one, so it
//! is evaluated per machine at the machine's true readings and averaged
//! over the study's first [`MACHINES`] machines (the spread over machines
//! is the mean of each machine's variance). It is rank 2 per sensor, so a
//! machine costs two operator applications per grade: no n × n matrix.
//! The rest of Σ (curves, jitter, resolution) is the same for every
//! machine and is propagated once per grade.
//!
//! What one linearisation leaves (the operator's estimate from noise-free
//! readings less the truth) varies from machine to machine and is counted
//! by its spread: over the same machines for an estimator with one
//! operator; for a grade weighted per machine, over every machine of the
//! study, which the trials record (heavy tailed: 128 machines are too few).

use super::context::{Studied, SweepContext};
use super::trial::trial_machine;
use crate::sensors::{ObservationCovariance, SensorCovariance, SensorModel};
use nalgebra::SVector;
use rayon::prelude::*;

/// Machines the interpolation kernel's share of a statement is averaged
/// over: the study's trials 0 … MACHINES − 1 (fewer when the study has
/// fewer).
pub const MACHINES: u64 = 512;

/// Machines a statement is averaged over when some grade builds its
/// operator per machine (`[sweep] gls_per_machine`).
pub const PER_MACHINE_MACHINES: u64 = 128;

/// (√variance, angular rate 2π/P) of each sensor's interpolation kernel
/// (zero for a sensor without one, or read as perfect); None when no
/// sensor of the set has one.
fn kernels<const R: usize>(sensor: &SensorModel<R>, perfect: [bool; R]) -> Option<[(f64, f64); R]> {
    let st = sensor.structured.as_ref()?;
    let k: [(f64, f64); R] = std::array::from_fn(|i| {
        let a = &st.axes[i];
        let v = a.interpolation_variance();
        if v > 0.0 && !perfect[i] {
            (v.sqrt(), std::f64::consts::TAU / a.signal_period)
        } else {
            (0.0, 0.0)
        }
    });
    k.iter().any(|t| t.0 > 0.0).then_some(k)
}

/// The sensor set without its interpolation error: the part of Σ that is
/// the same for every machine.
pub fn without_interpolation<const R: usize>(sensor: &SensorModel<R>) -> SensorModel<R> {
    let mut s = *sensor;
    if let Some(st) = s.structured.as_mut() {
        for a in st.axes.iter_mut() {
            a.interpolation = 0.0;
        }
    }
    s
}

/// Per grade: each error's variance from the interpolation kernel, mean
/// over the study's first [`MACHINES`] machines at their true readings
/// (mm²); for a grade weighted per machine, the whole variance its own
/// operators state; None for a grade not `wanted` or whose sensors have no
/// interpolation error. Deterministic: machines are summed in order.
pub fn interpolation_variances<
    M: Studied<P, R, A>,
    const P: usize,
    const R: usize,
    const A: usize,
>(
    ctx: &SweepContext<M, P, R, A>,
    wanted: &[bool],
    trials: u64,
) -> Vec<Option<SVector<f64, P>>> {
    let g = ctx.grades.len();
    let kern: Vec<Option<[(f64, f64); R]>> = ctx
        .sensors
        .iter()
        .map(|s| kernels(s, ctx.perfect))
        .collect();
    let needed: Vec<bool> = (0..g)
        .map(|gi| wanted[gi] && kern[ctx.grades[gi].sensor_index].is_some())
        .collect();
    if !needed.iter().any(|&x| x) {
        return vec![None; g];
    }
    // A grade weighted per machine states each machine's own operator's
    // spread: an operator per machine, so fewer machines.
    let per_machine = (0..g).any(|gi| needed[gi] && ctx.per_machine[gi]);
    let machines = if per_machine {
        PER_MACHINE_MACHINES
    } else {
        MACHINES
    }
    .min(trials.max(1));
    let per_machine: Vec<Option<Vec<[SVector<f64, P>; 3]>>> = (0..machines)
        .into_par_iter()
        .map(|k| machine_variances(ctx, k, &kern, &needed))
        .collect();
    let mut sum = vec![[SVector::<f64, P>::zeros(); 3]; g];
    let mut count = 0usize;
    for v in per_machine.into_iter().flatten() {
        count += 1;
        for (s, x) in sum.iter_mut().zip(&v) {
            for (a, b) in s.iter_mut().zip(x) {
                *a += b;
            }
        }
    }
    (0..g)
        .map(|gi| {
            (needed[gi] && count > 0).then(|| {
                let n = count as f64;
                let [var, bias, bias_sq] = sum[gi].map(|x| x / n);
                // What one linearisation leaves varies from machine to
                // machine: its spread over the same machines (a grade
                // weighted per machine: over all the study's machines, from
                // its trials, added by the summary).
                var + (bias_sq - bias.component_mul(&bias)).map(|x| x.max(0.0))
            })
        })
        .collect()
}

/// Machine k's kernel variances for each needed grade, and for a grade
/// weighted per machine what its operator makes of the noise-free readings
/// less the truth (the linearisation's error) and its square (None when
/// forward kinematics fails at some pose: the trial itself records that
/// failure).
fn machine_variances<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    k: u64,
    kern: &[Option<[(f64, f64); R]>],
    needed: &[bool],
) -> Option<Vec<[SVector<f64, P>; 3]>> {
    let (truth_e, truth) = trial_machine(ctx, k);
    let mut actual = vec![SVector::<f64, R>::zeros(); ctx.poses()];
    let mut buf = ctx.mech.buffers();
    ctx.mech
        .actual(&truth, &truth_e, &mut buf, &mut actual)
        .ok()?;
    let m = ctx.rows();
    // The noise-free observation: the true readings, homed.
    let mut true_l = vec![0.0; m];
    crate::sensors::observation_into(ctx.mech.nominal(), &actual, &mut true_l);
    // Per sensor set: the homed kernel columns √v·(cos ωv_j − cos ωv_0) and
    // √v·(sin ωv_j − sin ωv_0) as rows of l (row R(j−1)+k sensor k).
    let columns: Vec<Option<[Vec<f64>; 2]>> = kern
        .iter()
        .map(|kn| {
            let kn = kn.as_ref()?;
            let mut c = vec![0.0; m];
            let mut s = vec![0.0; m];
            for r in 0..m {
                let (j, a) = (r / R + 1, r % R);
                let (amp, rate) = kn[a];
                if amp > 0.0 {
                    let (s1, c1) = (rate * actual[j][a]).sin_cos();
                    let (s0, c0) = (rate * actual[0][a]).sin_cos();
                    c[r] = amp * (c1 - c0);
                    s[r] = amp * (s1 - s0);
                }
            }
            Some([c, s])
        })
        .collect();
    let mut buf = vec![0.0; m];
    let mut masked = vec![0.0; m];
    // A grade weighted per machine is stated as identify states a log: at
    // the readings its sensors reported in this machine's trial.
    let reported = (0..ctx.grades.len())
        .any(|gi| needed[gi] && ctx.per_machine[gi])
        .then(|| {
            let mut s = super::trial::Scratch::new(ctx);
            let mut outcomes = vec![super::outcome::Outcome::default(); ctx.grades.len()];
            super::trial::run_trial(ctx, k, &mut s, &mut outcomes);
            s.form_observations(ctx);
            s
        });
    let mut out = vec![[SVector::<f64, P>::zeros(); 3]; ctx.grades.len()];
    for (gi, grade) in ctx.grades.iter().enumerate() {
        if !needed[gi] {
            continue;
        }
        if let (true, Some(trial)) = (ctx.per_machine[gi], &reported) {
            // The readings' share of the statement, with this machine's own
            // operator (at the readings its sensors reported) under the
            // stated Σ at those readings: what identify states for this
            // machine's log.
            let sub = &ctx.subsets[grade.subset];
            let mut measured = vec![0.0; sub.rows.len()];
            let lm = sub.rows_of(trial.observation(grade.sensor_index), &mut measured);
            let joints = super::per_machine::reported_joints(ctx, gi, lm);
            let solver = super::per_machine::solver_at(ctx, gi, &joints)?;
            let sigma = ObservationCovariance::new(
                &ctx.sensors[grade.sensor_index].stated_covariances(),
                &joints,
            );
            let sd = solver.predicted_std_under(&sigma);
            // The part of the estimate the readings' errors do not make,
            // one linearisation's own error, is recorded by every trial
            // (heavy tailed: these machines are too few for its spread).
            out[gi] = [
                sd.component_mul(&sd),
                SVector::<f64, P>::zeros(),
                SVector::<f64, P>::zeros(),
            ];
            continue;
        }
        let solver = &ctx.solvers[gi];
        // What the grade's one operator makes of this machine's noise-free
        // readings, less the truth: one linearisation's own error, which
        // varies from machine to machine (with fine sensors it is most of
        // an error's spread: WLS's dyB3 on the shipped catalogue study ran
        // 15× a statement without it). Gauss–Newton iterates it away.
        if ctx.options.iterations <= 1 {
            let sub = &ctx.subsets[grade.subset];
            let mut lbuf = vec![0.0; sub.rows.len()];
            let l = sub.rows_of(&true_l, &mut lbuf);
            let mut exact = SVector::<f64, P>::zeros();
            solver.apply(l, &mut exact);
            if let Some(ext) = ctx.second_class_solvers.get(gi) {
                exact = ext.apply(l, &exact).errors;
            }
            let bias = exact - truth_e;
            out[gi][1] = bias;
            out[gi][2] = bias.component_mul(&bias);
        }
        // An interpolation error of finite coherence: its kernel under the
        // envelope at this machine's true readings, in the factored form.
        if let Some(st) = ctx.sensors[grade.sensor_index]
            .structured
            .as_ref()
            .filter(|st| st.axes.iter().any(|a| a.coherence > 0.0))
        {
            let sub = &ctx.subsets[grade.subset];
            let l = sub.rows_of(&true_l, &mut buf);
            let joints = super::per_machine::reported_joints(ctx, gi, l);
            let covs: [SensorCovariance; R] = std::array::from_fn(|a| {
                match ctx.perfect[a] {
                    true => None,
                    false => SensorCovariance::interpolation_at_truth(&st.axes[a]),
                }
                .unwrap_or_else(|| SensorCovariance::white(0.0))
            });
            let sigma = ObservationCovariance::new(&covs, &joints);
            let sd = match ctx.second_class_solvers.get(gi) {
                Some(ext) => SVector::<f64, P>::from_iterator(
                    ext.predicted_std(solver, &sigma).into_iter().take(P),
                ),
                None => solver.predicted_std_under(&sigma),
            };
            out[gi][0] = sd.component_mul(&sd);
            continue;
        }
        let Some(cols) = &columns[grade.sensor_index] else {
            continue;
        };
        let sub = &ctx.subsets[grade.subset];
        for col in cols {
            let e = sub.rows_of(col, &mut buf);
            match ctx.second_class_solvers.get(gi) {
                // The P errors' share of the (P + A)-unknown operator, sensor
                // by sensor (their interpolation errors are independent).
                Some(ext) => {
                    for a in 0..R {
                        let rows = e.len();
                        for (r, x) in masked[..rows].iter_mut().enumerate() {
                            *x = if r % R == a { e[r] } else { 0.0 };
                        }
                        let mut base = SVector::<f64, P>::zeros();
                        solver.apply(&masked[..rows], &mut base);
                        let x = ext.apply(&masked[..rows], &base);
                        out[gi][0] += x.errors.component_mul(&x.errors);
                    }
                }
                None => {
                    for x in solver.apply_by_sensor(e) {
                        out[gi][0] += x.component_mul(&x);
                    }
                }
            }
        }
    }
    Some(out)
}
