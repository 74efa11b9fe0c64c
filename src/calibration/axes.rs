//! The Hooke axes' angles in a calibration (`[identification]
//! second_class = true`): identified from the same observation as the 15
//! errors, what the readings say of them, and the refusal of poses that
//! identify fewer of them than the config's layout does.

use super::design_matrix;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::tricept::{angle_design, AxesSolver};
use crate::identify::tricept::{Estimate, LinearSolver};
use crate::identify::IdentifyOptions;
use crate::io::data_line;
use crate::mechanism::tricept::second_class::{Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{NominalPoses, N_PARAMS};
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
    file: &str,
) -> Result<AxesFit> {
    let at_line = |e: crate::error::PoseError| {
        Error::csv(file, format!("line {}: {}", data_line(e.index), e.source))
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
                file,
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
