//! The trial kernel (docs/method.md §10 `sweep`): trial k draws one true machine,
//! computes its exact readings at every pose once (the mechanism's forward
//! kinematics, [`Studied::actual`]: the cost, shared by all grades), then
//! draws one unit noise per reading,
//! shared by every grade (common random numbers). With white-noise sensors
//! and one linearisation every estimate is linear in that draw, so each
//! operator is applied once to the exact observation and once to each
//! sensor's noise ([`crate::identify::Solver::apply_split`]) and a grade's estimate is
//! their combination with its own σ; otherwise each grade's observation is
//! formed and identified in full. Which of these a study takes, and what
//! its grades share, is its [`TrialPlan`] (`plan.rs`), decided once. A
//! trial is a pure function of (context, k): no allocation, no shared
//! mutable state.

pub use super::context::{Grade, MapGrid, Studied, SweepContext};
pub use super::outcome::{Failure, Outcome};
pub use super::plan::{AxisSharing, KernelPath, NoiseGroup, TrialPlan};
use super::streams::{stream, trial_errors};
use super::workspace::{self, Workspace};
use crate::config::ErrorDraw;
use crate::identify::{estimate_of, Split};
use crate::metrics::{mu, mu0};
use crate::sensors::{homed_unit_noise, observation_into, MachineDraws};
use nalgebra::{DVector, SVector};

/// Per-worker buffers, reused across trials (no allocation per pose).
pub struct Scratch<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize> {
    /// The true machine's readings at every calibration pose.
    actual: Vec<SVector<f64, R>>,
    /// The mechanism's own buffers for forward kinematics.
    kinematics: M::Buffers,
    /// The workspace judgement's buffers.
    ws: Workspace<P>,
    /// Truth − estimate of each grade's calibration.
    residual: Vec<SVector<f64, P>>,
    l0: Vec<f64>,
    /// The trial's homed unit noise, shared by every grade (see
    /// [`homed_unit_noise`]).
    dz: Vec<f64>,
    /// Each operator's estimate split by noise source (fast path).
    splits: Vec<Split<P, R>>,
    /// Each sensor set's reading errors as rows of l − l0 (sensor-major;
    /// every path but the white-noise fast one).
    e: Vec<f64>,
    /// Noisy observations l0 + e, formed for tests ([`Scratch::observation`]).
    l: Vec<f64>,
    /// One machine's draws for datasheet sensors, shared by the sensor sets
    /// that draw alike.
    draws: MachineDraws<R>,
    /// op·l0 of each grade that is the first of its operator.
    exact: Vec<SVector<f64, P>>,
    /// The parts of unquantised datasheet errors as rows of l (curve,
    /// interpolation, jitter), and each first grade's op·part by sensor.
    parts: Vec<f64>,
    part_splits: Vec<[[SVector<f64, P>; R]; 3]>,
    /// Each grade's op·e by sensor (general path, one linearisation).
    sensor_splits: Vec<[SVector<f64, P>; R]>,
    /// A pose subset's rows of l0, of the noise and of an observation.
    l0_sub: Vec<f64>,
    dz_sub: Vec<f64>,
    l_sub: Vec<f64>,
    /// Each grade's linearisation error in this trial, where it records
    /// one (a grade weighted per machine).
    linearisation: Vec<Option<SVector<f64, P>>>,
    /// Each grade's estimate − truth in this trial (zero where forward
    /// kinematics failed).
    error: Vec<SVector<f64, P>>,
    /// Each grade's identified second-class unknowns (zero unless
    /// identified).
    angles: Vec<SVector<f64, A>>,
}

impl<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize> Scratch<M, P, R, A> {
    /// Grade `gi`'s linearisation error in the last trial (zero where the
    /// grade records none or the trial failed).
    pub fn linearisation(&self, gi: usize) -> SVector<f64, P> {
        self.linearisation[gi].unwrap_or_else(SVector::<f64, P>::zeros)
    }

    /// Grade `gi`'s estimate − truth in the last trial, mm (zero where
    /// forward kinematics failed).
    pub fn error(&self, gi: usize) -> SVector<f64, P> {
        self.error[gi]
    }

    /// Grade `gi`'s identified second-class unknowns in the last trial
    /// (zero where the study does not identify them).
    pub fn second_class(&self, gi: usize) -> SVector<f64, A> {
        self.angles[gi]
    }

    pub fn new(ctx: &SweepContext<M, P, R, A>) -> Self {
        Scratch {
            actual: vec![SVector::zeros(); ctx.poses()],
            kinematics: ctx.mech.buffers(),
            ws: Workspace::new(ctx),
            residual: vec![SVector::<f64, P>::zeros(); ctx.grades.len()],
            l0: vec![0.0; ctx.rows()],
            dz: vec![0.0; ctx.rows()],
            splits: vec![Split::<P, R>::default(); ctx.grades.len()],
            e: vec![0.0; ctx.rows() * ctx.sensors.len()],
            l: vec![0.0; ctx.rows() * ctx.sensors.len()],
            draws: {
                let mut d = MachineDraws::default();
                d.anchor_at(ctx.mech.nominal());
                d
            },
            exact: vec![SVector::<f64, P>::zeros(); ctx.grades.len()],
            parts: vec![0.0; 3 * ctx.rows()],
            part_splits: vec![[[SVector::<f64, P>::zeros(); R]; 3]; ctx.grades.len()],
            sensor_splits: vec![[SVector::<f64, P>::zeros(); R]; ctx.grades.len()],
            l0_sub: vec![0.0; ctx.rows()],
            dz_sub: vec![0.0; ctx.rows()],
            l_sub: vec![0.0; ctx.rows()],
            linearisation: vec![None; ctx.grades.len()],
            error: vec![SVector::<f64, P>::zeros(); ctx.grades.len()],
            angles: vec![SVector::zeros(); ctx.grades.len()],
        }
    }

    /// The noisy observation of sensor grade `s` in the last trial.
    pub fn observation(&self, s: usize) -> &[f64] {
        let m = self.l0.len();
        &self.l[s * m..(s + 1) * m]
    }

    /// Write every sensor set's noisy observation l0 + e of the last trial
    /// (the white-noise fast path forms none; tests read them here).
    pub fn form_observations(&mut self, ctx: &SweepContext<M, P, R, A>) {
        let m = self.l0.len();
        match &ctx.plan.path {
            KernelPath::WhiteNoise { .. } => white_errors(ctx, &self.dz, &mut self.e),
            KernelPath::DatasheetParts => {
                for (sensor, e) in ctx.sensors.iter().zip(self.e.chunks_exact_mut(m)) {
                    let Some(st) = &sensor.structured else {
                        continue;
                    };
                    let amp = st.axes.map(|a| a.linear_amplitudes(sensor.samples));
                    for (r, x) in e.iter_mut().enumerate() {
                        let a = &amp[r % R];
                        *x = (0..3).map(|c| a[c] * self.parts[c * m + r]).sum();
                    }
                }
            }
            KernelPath::PerSensor { axes, .. } | KernelPath::GaussNewton { axes } => {
                // The axes a set shares with an earlier one that no estimate read.
                for (i, of) in axes.axis_of.iter().enumerate() {
                    for k in (0..R).filter(|&k| of[k] < i) {
                        let (done, rest) = self.e.split_at_mut(i * m);
                        copy_axis::<R>(&done[of[k] * m..(of[k] + 1) * m], k, &mut rest[..m]);
                    }
                }
            }
        }
        for (l, e) in self.l.chunks_exact_mut(m).zip(self.e.chunks_exact(m)) {
            for r in 0..m {
                l[r] = self.l0[r] + e[r];
            }
        }
    }
}

/// Trial k's true machine: its P errors (those measured elsewhere,
/// `[identification] fix`, are the machine's) and the machine the
/// mechanism makes of them (with its second-class errors).
pub fn trial_machine<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    k: u64,
) -> (SVector<f64, P>, M::Machine) {
    let own = match ctx.draw {
        ErrorDraw::Random => ctx.mech.draw(ctx.seed, k),
        ErrorDraw::Fixed => None,
    };
    let mut truth_e =
        own.unwrap_or_else(|| trial_errors(ctx.draw, &ctx.fixed_errors, ctx.bound_mm, ctx.seed, k));
    for (e, f) in truth_e.iter_mut().zip(&ctx.options.constraints.fixed) {
        if let Some(v) = f {
            *e = *v;
        }
    }
    let truth = ctx.mech.machine(&truth_e, k);
    (truth_e, truth)
}

/// Trial k: one true machine, every grade. Writes one outcome per grade.
pub fn run_trial<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    k: u64,
    s: &mut Scratch<M, P, R, A>,
    out: &mut [Outcome],
) {
    s.linearisation.fill(None);
    s.error.fill(SVector::<f64, P>::zeros());
    s.angles.fill(SVector::zeros());
    let (truth_e, truth) = trial_machine(ctx, k);
    let m0 = mu0(&truth_e);
    let fk = ctx
        .mech
        .actual(&truth, &truth_e, &mut s.kinematics, &mut s.actual);
    if fk.is_err() {
        out.fill(Outcome::forward_kinematics_failed(m0));
        return;
    }
    let dv_before_max = workspace::before_max(ctx, &truth, &truth_e);
    let turned = !ctx.orientation.points.is_empty();
    let orientation = |e: &SVector<f64, P>| match turned {
        true => workspace::first_order_max(&ctx.orientation, e),
        false => f64::NAN,
    };
    let orientation_before_max = orientation(&truth_e);
    observation_into(ctx.mech.nominal(), &s.actual, &mut s.l0);
    // Common random numbers: every grade reads the same draws of stream 1,
    // scaled by its own grade.
    let split_of = &ctx.plan.split_of;
    match &ctx.plan.path {
        KernelPath::WhiteNoise { .. } => {
            homed_unit_noise(&ctx.sensors[0], &mut stream(ctx.seed, k, 1), &mut s.dz);
            zero_perfect(ctx.perfect, &mut s.dz);
            for (gi, &first) in split_of.iter().enumerate() {
                if first == gi {
                    let sub = &ctx.subsets[ctx.grades[gi].subset];
                    let l0 = sub.rows_of(&s.l0, &mut s.l0_sub);
                    let dz = sub.rows_of(&s.dz, &mut s.dz_sub);
                    s.splits[gi] = ctx.solvers[gi].apply_split(l0, dz);
                }
            }
        }
        KernelPath::DatasheetParts => datasheet_parts(ctx, k, s),
        KernelPath::PerSensor { axes, .. } => {
            sensor_errors(ctx, axes, k, s);
            for (gi, &first) in split_of.iter().enumerate() {
                if first == gi {
                    let sub = &ctx.subsets[ctx.grades[gi].subset];
                    let l0 = sub.rows_of(&s.l0, &mut s.l0_sub);
                    ctx.solvers[gi].apply(l0, &mut s.exact[gi]);
                }
            }
        }
        KernelPath::GaussNewton { axes } => sensor_errors(ctx, axes, k, s),
    }
    for (gi, (g, o)) in ctx.grades.iter().zip(out.iter_mut()).enumerate() {
        let (est, failure, budget) = match &ctx.plan.path {
            KernelPath::WhiteNoise { .. } => {
                let scale = ctx.sensors[g.sensor_index].unit_scale();
                let split = &s.splits[split_of[gi]];
                let est = split.estimate(&scale);
                (
                    est,
                    Failure::None,
                    budget(&truth_e, (&split.exact, &split.noise), &scale, &est),
                )
            }
            KernelPath::DatasheetParts => {
                let split = datasheet_split(ctx, gi, s);
                let unit = SVector::<f64, R>::repeat(1.0);
                let est = split.estimate(&unit);
                (
                    est,
                    Failure::None,
                    budget(&truth_e, (&split.exact, &split.noise), &unit, &est),
                )
            }
            KernelPath::PerSensor {
                sensor_split_of, ..
            } => per_sensor_calibration(ctx, sensor_split_of[gi], gi, s, &truth_e),
            KernelPath::GaussNewton { .. } => iterated_calibration(ctx, gi, s, &truth_e),
        };
        // The second-class unknowns, when identified (else zero).
        let angles = s.angles[gi];
        if ctx.volumetric() {
            s.residual[gi] = truth_e - est;
        }
        let acc = workspace::exact_after(ctx, &truth, &est, &angles, &mut s.ws);
        s.error[gi] = est - truth_e;
        *o = Outcome {
            mu: mu(&truth_e, &est),
            mu0: m0,
            rank: ctx.solvers[gi].analysis.rank as u8,
            failure,
            dv_after_max: acc.max,
            dv_after_mean: acc.mean,
            dv_after_p95: acc.p95,
            ap_after_max: acc.ap_max,
            dv_before_max,
            orientation_before_max,
            orientation_after_max: orientation(&(truth_e - est)),
            budget,
        };
    }
    if ctx.volumetric() && !ctx.exact {
        workspace::first_order_after(ctx, &s.residual, &s.splits, &mut s.ws, out);
    }
}

/// Every sensor set's reading errors in trial k, as rows of l − l0 (every
/// path but the white-noise fast one). White noise: σ ⊙ the shared unit
/// draw. Datasheet sensors: one machine's draws (stream 1, afresh for a set
/// that draws otherwise than the last), then each set's errors from them.
fn sensor_errors<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    axes: &AxisSharing<R>,
    k: u64,
    s: &mut Scratch<M, P, R, A>,
) {
    let m = ctx.rows();
    if ctx.sensors.iter().all(|x| x.structured.is_none()) {
        homed_unit_noise(&ctx.sensors[0], &mut stream(ctx.seed, k, 1), &mut s.dz);
        white_errors(ctx, &s.dz, &mut s.e);
        zero_perfect(ctx.perfect, &mut s.e);
        return;
    }
    s.draws.clear();
    for (i, sensor) in ctx.sensors.iter().enumerate() {
        let (done, rest) = s.e.split_at_mut(i * m);
        let e = &mut rest[..m];
        match &sensor.structured {
            Some(st) => {
                // An axis some earlier set reads alike is copied from it,
                // when an estimate reads it (else only for the tests'
                // observations, see [`Scratch::form_observations`]).
                let of = axes.axis_of[i];
                for axis in (0..R).filter(|&k| of[k] < i && axes.rows_read[i][k]) {
                    copy_axis::<R>(&done[of[axis] * m..(of[axis] + 1) * m], axis, e);
                }
                let own = std::array::from_fn(|axis| of[axis] == i);
                if own.iter().any(|&a| a) {
                    let class = axes.draw_class[i];
                    s.draws.prepare(class, st, sensor.samples, &s.actual, || {
                        stream(ctx.seed, k, 1)
                    });
                    s.draws.homed_errors(st, sensor.samples, own, e);
                }
            }
            None => {
                homed_unit_noise(sensor, &mut stream(ctx.seed, k, 1), &mut s.dz);
                scaled_noise_into(&sensor.unit_scale(), &s.dz, e);
            }
        }
    }
    zero_perfect(ctx.perfect, &mut s.e);
}

/// Zero the rows of the sensors marked perfect (row r is sensor r mod R):
/// the deciding metric's error budget reads those sensors exactly.
#[inline]
fn zero_perfect<const R: usize>(perfect: [bool; R], rows: &mut [f64]) {
    if perfect.iter().any(|&p| p) {
        for (r, x) in rows.iter_mut().enumerate() {
            if perfect[r % R] {
                *x = 0.0;
            }
        }
    }
}

/// Rows of axis k (r mod R = k) from `from` into `e`.
fn copy_axis<const R: usize>(from: &[f64], k: usize, e: &mut [f64]) {
    for (t, f) in e.chunks_exact_mut(R).zip(from.chunks_exact(R)) {
        t[k] = f[k];
    }
}

/// Unquantised datasheet sensors that draw alike (see
/// [`KernelPath::DatasheetParts`]): trial k's machine draws once, and
/// each operator's estimate of each part of the errors, split by sensor.
fn datasheet_parts<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    k: u64,
    s: &mut Scratch<M, P, R, A>,
) {
    let Some(st) = &ctx.sensors[0].structured else {
        return;
    };
    let m = ctx.rows();
    s.draws.clear();
    s.draws.draw(
        st,
        ctx.sensors[0].samples,
        &mut stream(ctx.seed, k, 1),
        &s.actual,
    );
    {
        let (h, rest) = s.parts.split_at_mut(m);
        let (i, z) = rest.split_at_mut(m);
        s.draws.linear_parts([h, i, z]);
    }
    zero_perfect(ctx.perfect, &mut s.parts[..3 * m]);
    for (gi, &first) in ctx.plan.split_of.iter().enumerate() {
        if first != gi {
            continue;
        }
        let sub = &ctx.subsets[ctx.grades[gi].subset];
        let solver = &ctx.solvers[gi];
        solver.apply(sub.rows_of(&s.l0, &mut s.l0_sub), &mut s.exact[gi]);
        for c in 0..3 {
            let part = sub.rows_of(&s.parts[c * m..(c + 1) * m], &mut s.dz_sub);
            s.part_splits[gi][c] = solver.apply_by_sensor(part);
        }
    }
}

/// Grade `gi`'s estimate split by sensor on the datasheet-linear path: its
/// operator's op·l0, and per sensor Σ amplitude · op·part.
fn datasheet_split<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    s: &Scratch<M, P, R, A>,
) -> Split<P, R> {
    let g = &ctx.grades[gi];
    let first = ctx.plan.split_of[gi];
    let sensor = &ctx.sensors[g.sensor_index];
    let mut noise = [SVector::<f64, P>::zeros(); R];
    if let Some(st) = &sensor.structured {
        for (k, n) in noise.iter_mut().enumerate() {
            let amp = st.axes[k].linear_amplitudes(sensor.samples);
            for (c, &a) in amp.iter().enumerate() {
                n.axpy(a, &s.part_splits[first][c][k], 1.0);
            }
        }
    }
    Split {
        exact: s.exact[first],
        noise,
    }
}

/// Every sensor set's white-noise errors σ ⊙ dz from the shared unit draw.
fn white_errors<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    dz: &[f64],
    e: &mut [f64],
) {
    for (sensor, e) in ctx.sensors.iter().zip(e.chunks_exact_mut(dz.len())) {
        scaled_noise_into(&sensor.unit_scale(), dz, e);
    }
}

/// A sensor set's errors from the shared unit noise: σ ⊙ dz (row r belongs
/// to sensor r mod R).
#[inline]
fn scaled_noise_into<const R: usize>(sigma: &SVector<f64, R>, dz: &[f64], out: &mut [f64]) {
    for (r, (o, d)) in out.iter_mut().zip(dz).enumerate() {
        *o = sigma[r % R] * d;
    }
}

/// The error budget of one calibration from its estimate split by noise
/// source (scaled by `scale`): μ with every sensor perfect, then with each
/// sensor alone perfect. Its columns are the Tricept's three sensors (the
/// ψ4 and θ4 encoders, the scale: [`Outcome::budget`]); a mechanism of
/// other than three readings a pose states no budget (NaN: the summary's
/// budget rows are empty).
#[inline]
fn budget<const P: usize, const R: usize>(
    truth: &SVector<f64, P>,
    (exact, noise): (&SVector<f64, P>, &[SVector<f64, P>; R]),
    scale: &SVector<f64, R>,
    est: &SVector<f64, P>,
) -> [f64; 4] {
    if R != 3 {
        return [f64::NAN; 4];
    }
    let without = |k: usize| mu(truth, &(est - noise[k] * scale[k]));
    [mu(truth, exact), without(0), without(1), without(2)]
}

/// Grade `gi`'s pose subset of its sensor set's errors `e` (every set's,
/// sensor-major), through `buf`.
fn grade_errors<'a, M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    e: &'a [f64],
    buf: &'a mut [f64],
) -> &'a [f64] {
    let g = &ctx.grades[gi];
    let m = ctx.rows();
    let set = &e[g.sensor_index * m..(g.sensor_index + 1) * m];
    ctx.subsets[g.subset].rows_of(set, buf)
}

/// Grade `gi` on [`KernelPath::PerSensor`]: the estimate is op·l0 (shared
/// by the grades of an operator) + op·e of its sensor set's errors e, split
/// by sensor for the budget; a sensor whose rows an earlier grade of this
/// operator read alike (`shared`) shares that grade's op·e.
fn per_sensor_calibration<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    shared: [usize; R],
    gi: usize,
    s: &mut Scratch<M, P, R, A>,
    truth: &SVector<f64, P>,
) -> (SVector<f64, P>, Failure, [f64; 4]) {
    let e = grade_errors(ctx, gi, &s.e, &mut s.dz_sub);
    // The operator of the first grade that shares it (the same values, and
    // one copy stays in the cache across the grades). The parts are formed
    // where they are kept, not moved through a split.
    let first = ctx.plan.split_of[gi];
    let solver = &ctx.solvers[first];
    let (done, rest) = s.sensor_splits.split_at_mut(gi);
    let noise = &mut rest[0];
    solver.apply_sensors(e, shared.map(|gj| gj >= gi), noise);
    for k in (0..R).filter(|&k| shared[k] < gi) {
        noise[k] = done[shared[k]][k];
    }
    let exact = &s.exact[first];
    let unit = SVector::<f64, R>::repeat(1.0);
    let est = estimate_of(exact, noise, &unit);
    (
        est,
        Failure::None,
        budget(truth, (exact, noise), &unit, &est),
    )
}

/// Grade `gi` on [`KernelPath::GaussNewton`]: identification from l0 + e
/// of its sensor set's errors e, without a budget.
fn iterated_calibration<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    s: &mut Scratch<M, P, R, A>,
    truth: &SVector<f64, P>,
) -> (SVector<f64, P>, Failure, [f64; 4]) {
    let sub = &ctx.subsets[ctx.grades[gi].subset];
    let e = grade_errors(ctx, gi, &s.e, &mut s.dz_sub);
    let l0 = sub.rows_of(&s.l0, &mut s.l0_sub);
    let n = l0.len();
    for r in 0..n {
        s.l_sub[r] = l0[r] + e[r];
    }
    let (est, failure, exact) = calibrate(ctx, gi, &s.l_sub[..n], l0);
    // What this machine's own operator makes of its noise-free readings,
    // less the truth: one linearisation's error, whose spread over the
    // study's machines its statement counts ([`super::statement`]).
    s.linearisation[gi] = exact.map(|x| x - truth);
    // The second-class unknowns beside the P errors (`second_class =
    // true`): the P-error estimate corrected by what it read of them.
    match ctx.second_class_solvers.get(gi) {
        Some(ext) => {
            let x = ext.apply(&s.l_sub[..n], &est);
            s.angles[gi] = x.angles;
            (x.errors, failure, [f64::NAN; 4])
        }
        None => (est, failure, [f64::NAN; 4]),
    }
}

/// One calibration of grade `gi` from its observation `l`: the prebuilt
/// operator, then Gauss–Newton when the study iterates.
fn calibrate<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    l: &[f64],
    l0: &[f64],
) -> (SVector<f64, P>, Failure, Option<SVector<f64, P>>) {
    let solver = &ctx.solvers[gi];
    let mut est = SVector::<f64, P>::zeros();
    if ctx.per_machine[gi] {
        let (est, exact) = super::per_machine::calibrate(ctx, gi, l, l0);
        return (est, Failure::None, Some(exact));
    }
    if ctx.options.iterations <= 1 {
        solver.apply(l, &mut est);
        return (est, Failure::None, None);
    }
    let lv = DVector::from_column_slice(l);
    let subset = ctx.grades[gi].subset;
    match ctx.mech.iterate(subset, solver, &lv, &ctx.options) {
        Some((e, true)) => (e, Failure::None, None),
        Some((e, false)) => (e, Failure::NotConverged, None),
        None => {
            solver.apply(l, &mut est);
            (est, Failure::NotConverged, None)
        }
    }
}

#[cfg(test)]
#[path = "trial_tests.rs"]
pub(super) mod tests;

#[cfg(test)]
#[path = "trial_datasheet_tests.rs"]
mod datasheet_tests;
