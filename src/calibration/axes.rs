//! What a config's poses say (`identifiability`: the design's analysis,
//! [`analyse_poses`]) and the Hooke axes' angles in a calibration
//! (`[identification] second_class = true`): identified from the same
//! observation as the 15 errors, what the readings say of them, and the
//! refusal of poses that identify fewer of them than the config's layout
//! does.

use super::design_matrix;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::tricept::{angle_design, AxesSolver};
use crate::identify::tricept::{Estimate, LinearSolver};
use crate::identify::IdentifyOptions;
use crate::io::Source;
use crate::mechanism::tricept::second_class::{Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{Joints, Machine, NominalPoses, N_PARAMS, PARAM_NAMES};
use crate::sensors::ObservationCovariance;
use nalgebra::{DVector, Vector3};

/// The first Hooke axis's yaw and pitch and the axes' skew, identified.
#[derive(Debug, Clone)]
pub struct AxesFit {
    /// The angles' operator (and the 15-error estimate's share of them).
    pub solver: AxesSolver,
    /// Degrees.
    pub angles: Angles,
    /// Standard uncertainties, degrees (NaN where not stated).
    pub std_deg: Vector3<f64>,
    pub identifiable: [bool; N_ANGLES],
}

impl AxesFit {
    /// What identify says of them, one sentence.
    pub fn in_words(&self) -> String {
        let each: Vec<String> = ANGLE_NAMES
            .iter()
            .enumerate()
            .map(|(k, n)| match (self.identifiable[k], self.std_deg[k]) {
                (false, _) => format!("{n} not identifiable (0 written)"),
                (true, sd) if sd.is_finite() => format!("{n} = {:.5}° ± {sd:.5}°", self.angles[k]),
                (true, _) => format!("{n} = {:.5}°", self.angles[k]),
            })
            .collect();
        format!(
            "Hooke axes, identified with the 15 errors: {}; the guide's twist cannot be told from the 15 errors and is not identified",
            each.join(", ")
        )
    }
}

/// What the readings say of the Hooke axes' angles (`second_class =
/// true`): `identifiability` prints it, identify's identifiability.json
/// holds it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct HookeAxes {
    /// Rank of the 18-unknown design.
    pub rank: usize,
    pub names: [&'static str; N_ANGLES],
    pub identifiable: [bool; N_ANGLES],
    /// Share of each angle's weighted column the 15 errors cannot imitate.
    pub outside_span: [f64; N_ANGLES],
    /// Standard deviation of each estimate under the declared sensors, °
    /// (null for an angle the readings do not identify).
    pub predicted_std_deg: [Option<f64>; N_ANGLES],
}

impl HookeAxes {
    /// From the 15-error operator and the angles' at the poses `joints`.
    /// `sigma`: the readings' covariance (a calibration's stated one, or
    /// the declared sensors' at nominal poses when there are no readings).
    pub fn of(
        solver: &LinearSolver,
        ext: &AxesSolver,
        sigma: &crate::sensors::ObservationCovariance,
    ) -> Self {
        let sd = ext.predicted_std(solver, sigma);
        let identifiable = ext.identifiable();
        HookeAxes {
            rank: ext.rank(solver),
            names: ANGLE_NAMES,
            identifiable,
            outside_span: ext.outside_span(solver),
            predicted_std_deg: std::array::from_fn(|k| identifiable[k].then_some(sd[N_PARAMS + k])),
        }
    }

    /// The joint design's rank in words, the 15 errors' alone being
    /// `errors_rank`.
    pub fn rank_in_words(&self, errors_rank: usize) -> String {
        format!(
            "with the Hooke axes: rank {} of {} (the 15 errors' {} and {} of the {} angles)",
            self.rank,
            N_PARAMS + N_ANGLES,
            errors_rank,
            self.rank - errors_rank,
            N_ANGLES
        )
    }

    /// What `identifiability` says of them, one sentence.
    pub fn in_words(&self) -> String {
        let each: Vec<String> = (0..N_ANGLES)
            .map(|k| {
                format!(
                    "{} {} ({:.0} % of its effect unlike any error's; σ {})",
                    self.names[k],
                    if self.identifiable[k] {
                        "identifiable"
                    } else {
                        "NOT identifiable"
                    },
                    100.0 * self.outside_span[k],
                    match self.predicted_std_deg[k] {
                        Some(sd) => format!("{sd:.5}°"),
                        None => "n/a".into(),
                    }
                )
            })
            .collect();
        format!(
            "With the Hooke axes (second_class = true): rank {} of {}; {}. The guide's twist is not among them: it moves the readings as the 15 errors do.\n",
            self.rank,
            N_PARAMS + N_ANGLES,
            each.join("; ")
        )
    }
}

/// What `identifiability` says of a config's poses: how many, the
/// design's rows and its analysis under the config's estimator (the
/// readings' own rank: no fixed error or prior), and with `second_class =
/// true` what they say of the Hooke axes.
pub struct PoseAnalysis {
    pub poses: usize,
    pub rows: usize,
    pub analysis: crate::identify::Identifiability,
    pub axes: Option<HookeAxes>,
}

/// The analysis of the config's poses ([`PoseAnalysis`]).
pub fn analyse_poses(cfg: &Config) -> Result<PoseAnalysis> {
    let poses = cfg.nominal_poses()?;
    let h = design_matrix(&cfg.nominal(), &poses)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let solver = cfg
        .identification
        .method
        .solver(
            (&cfg.sensors, &poses.joints),
            &h,
            cfg.identification.rank_tolerance,
            (&Default::default(), &PARAM_NAMES),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let axes = match cfg.identification.second_class {
        true => Some(stated(cfg, &poses, &h, &solver)?),
        false => None,
    };
    Ok(PoseAnalysis {
        poses: poses.len(),
        rows: h.nrows(),
        analysis: solver.analysis,
        axes,
    })
}

/// The Hooke axes' angles with the 15 errors from the same observation `l`
/// (one linearisation at the nominal poses) and its stated covariance
/// `sigma`: `estimate` becomes the 15 of the joint fit, with their
/// uncertainties.
pub(super) fn identify_axes(
    cfg: &Config,
    poses: &NominalPoses,
    solver: &LinearSolver,
    (l, sigma): (&DVector<f64>, &crate::sensors::ObservationCovariance),
    estimate: &mut Estimate,
    options: &IdentifyOptions<N_PARAMS>,
    file: Source,
) -> Result<AxesFit> {
    let at_line = |e: crate::error::PoseError| {
        Error::csv(
            file.name,
            format!("line {}: {}", file.line(e.index), e.source),
        )
    };
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints).map_err(at_line)?;
    let ext = AxesSolver::new(solver, &h3, options.rank_tolerance)
        .map_err(|why| Error::config(&cfg.source, format!("identification.second_class {why}")))?;
    // As for the 15 errors: fewer angles than the config's own layout
    // identifies are refused, naming them.
    let reach = layout_angles(cfg, options.rank_tolerance);
    let seen = ext.identifiable();
    if let Some(reach) = reach {
        let lost: Vec<&str> = (0..N_ANGLES)
            .filter(|&k| reach[k] && !seen[k])
            .map(|k| ANGLE_NAMES[k])
            .collect();
        if !lost.is_empty() {
            return Err(Error::csv(
                file.name,
                format!(
                    "{} poses identify the 15 errors but not the Hooke axes' {} that the config's pose layout identifies (second_class = true): log more poses spread over the workspace (design-poses proposes a set), or identify without second_class",
                    poses.len(),
                    lost.join(", ")
                ),
            ));
        }
    }
    let x = ext.apply(l.as_slice(), &estimate.values);
    let (std, rms) = ext.uncertainties(solver, l, &x, sigma);
    estimate.values = x.errors;
    for k in 0..N_PARAMS {
        if estimate.identifiable[k] {
            estimate.std_mm[k] = std[k];
        }
    }
    estimate.residual_rms = rms;
    estimate.dof = l.len().saturating_sub(ext.rank(solver));
    let identifiable = ext.identifiable();
    Ok(AxesFit {
        angles: x.angles,
        std_deg: Vector3::from_fn(|i, _| {
            if identifiable[i] {
                std[N_PARAMS + i]
            } else {
                f64::NAN
            }
        }),
        identifiable,
        solver: ext,
    })
}

/// Which Hooke-axis angles the config's own pose layout identifies (with
/// OLS; None when the layout cannot be built).
fn layout_angles(cfg: &Config, rank_tolerance: f64) -> Option<[bool; N_ANGLES]> {
    let nominal = cfg.nominal();
    let poses = cfg.nominal_poses().ok()?;
    let h = design_matrix(&nominal, &poses).ok()?;
    let h3 = angle_design(&nominal, &Angles::zeros(), &poses.joints).ok()?;
    let base = LinearSolver::unweighted(&h, rank_tolerance);
    AxesSolver::new(&base, &h3, rank_tolerance)
        .ok()
        .map(|e| e.identifiable())
}

/// What the declared sensors let the readings at `poses` say of the Hooke
/// axes' angles, beside the 15 errors' operator `solver` of design `h`:
/// stated at the nominal readings, or, where the datasheets' interpolation
/// error varies within a signal period, averaged over the machines a study
/// draws, each weighted and stated at its own readings as identify would.
pub(super) fn stated(
    cfg: &Config,
    poses: &NominalPoses,
    h: &nalgebra::DMatrix<f64>,
    solver: &LinearSolver,
) -> Result<HookeAxes> {
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let fail =
        |why: String| Error::config(&cfg.source, format!("identification.second_class {why}"));
    let ext = AxesSolver::new(solver, &h3, cfg.identification.rank_tolerance).map_err(fail)?;
    let stated = cfg.sensors.stated_covariances();
    let at_nominal = HookeAxes::of(
        solver,
        &ext,
        &ObservationCovariance::new(&stated, &poses.joints),
    );
    let varies = cfg.sensors.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0)
    });
    if !varies {
        return Ok(at_nominal);
    }
    // As identify would state it on each machine: weighted and stated at
    // that machine's readings.
    let method = cfg.identification.method;
    let tol = cfg.identification.rank_tolerance;
    let mut sum = [0.0; N_ANGLES];
    let machines = over_machines(cfg, poses, |measured| {
        let solver = method
            .solver(
                (&cfg.sensors, measured),
                h,
                tol,
                (&Default::default(), &PARAM_NAMES),
            )
            .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
        let ext = AxesSolver::new(&solver, &h3, tol).map_err(fail)?;
        let x = HookeAxes::of(
            &solver,
            &ext,
            &ObservationCovariance::new(&stated, measured),
        );
        for (s, sd) in sum.iter_mut().zip(&x.predicted_std_deg) {
            *s += sd.map_or(0.0, |x| x * x);
        }
        Ok(())
    })?;
    if machines == 0 {
        return Ok(at_nominal);
    }
    Ok(HookeAxes {
        predicted_std_deg: std::array::from_fn(|k| {
            at_nominal.predicted_std_deg[k].map(|_| (sum[k] / f64::from(machines)).sqrt())
        }),
        ..at_nominal
    })
}

/// Machines a statement without readings averages the interpolation
/// error's kernel over.
const STATED_MACHINES: u64 = 64;

/// Call `each` with the homed true readings of each of [`STATED_MACHINES`]
/// machines drawn as the study draws them (`[sweep] errors`,
/// `error_bound`, `seed`): the interpolation error's kernel depends on
/// where within its signal period each reading falls, which a machine's
/// errors move by a good part of a period, so a statement without
/// readings averages over them. Returns how many machines reached every
/// pose.
fn over_machines(
    cfg: &Config,
    poses: &NominalPoses,
    mut each: impl FnMut(&[Joints]) -> Result<()>,
) -> Result<u32> {
    let sw = &cfg.sweep;
    let mut actual = vec![nalgebra::Vector3::zeros(); poses.len()];
    let mut machines = 0u32;
    for k in 0..STATED_MACHINES {
        let e =
            crate::montecarlo::trial_errors(sw.errors, &cfg.errors, sw.error_bound_mm, sw.seed, k);
        let machine = Machine::with_errors(&cfg.geometry, &e);
        if poses.actual_joints_into(&machine, &mut actual).is_err() {
            continue;
        }
        // Homed at the reference, as the controller reports them.
        let j0 = poses.joints[0].as_vector();
        let measured: Vec<Joints> = actual
            .iter()
            .map(|a| Joints::from_vector(&(j0 + a - actual[0])))
            .collect();
        each(&measured)?;
        machines += 1;
    }
    Ok(machines)
}
