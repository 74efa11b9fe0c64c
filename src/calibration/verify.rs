//! `verify`: an identified model against a fresh log, position by the
//! passive limb against where the model puts the tool.

use super::check_targets;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::io::Source;
use crate::mechanism::tricept::Reading;
use crate::mechanism::tricept::{Joints, Machine};
use nalgebra::Vector3;

/// One row of a verification: where the log's passive limb says the tool
/// was, against where the identified model says it should be.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VerifyRow {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// Expected position: the target (compensated commands), or the
    /// identified machine at the nominal commands.
    pub expected_x_mm: f64,
    pub expected_y_mm: f64,
    pub expected_z_mm: f64,
    /// Position measured by the passive limb's readings.
    pub measured_x_mm: f64,
    pub measured_y_mm: f64,
    pub measured_z_mm: f64,
    pub error_mm: f64,
}

impl VerifyRow {
    /// A target, where the model puts the tool and where it was measured.
    fn new(target: &Vector3<f64>, expected: &Vector3<f64>, measured: &Vector3<f64>) -> Self {
        VerifyRow {
            x_mm: target.x,
            y_mm: target.y,
            z_mm: target.z,
            expected_x_mm: expected.x,
            expected_y_mm: expected.y,
            expected_z_mm: expected.z,
            measured_x_mm: measured.x,
            measured_y_mm: measured.y,
            measured_z_mm: measured.z,
            error_mm: (measured - expected).norm(),
        }
    }
}

/// Check an identified model against a fresh log of the machine. With
/// `nominal_commands` false the log was taken with the commands `compensate`
/// wrote for its targets, so the tool should be at each target; with it
/// true the log was taken with the nominal commands (as a calibration log
/// is), and the identified machine at those commands says where the tool
/// should be. Either way the passive limb's readings say where it was —
/// relative to the reference pose (the first row), where the sensors were
/// homed: the log's readings are taken back to absolute joints by the
/// offset at which the identified model puts the reference, so a constant
/// offset no reading can see (an unidentifiable error) is not measured.
pub fn verify(
    cfg: &Config,
    identified: &Machine,
    readings: &[Reading],
    nominal_commands: bool,
    file: Source,
) -> Result<Vec<VerifyRow>> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    let expected_joints = |k: usize, r: &Reading| -> Result<Joints> {
        if !nominal_commands {
            // The identified machine's limb at the target (with identified
            // Hooke axes, their rotations; else the ideal limb's).
            return identified
                .inverse(&r.target)
                .map(|p| p.joints)
                .map_err(|e| Error::csv(file.name, format!("line {}: {e}", file.line(k))));
        }
        let bad = |e: crate::error::KinematicsError| {
            Error::csv(file.name, format!("line {}: {e}", file.line(k)))
        };
        let pose = nominal.inverse(&r.target).map_err(bad)?;
        let q = nominal.commands(&r.target).map_err(bad)?;
        identified.forward(&q, &pose.joints).map_err(|e| {
            Error::csv(
                file.name,
                format!(
                    "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                    file.line(k)
                ),
            )
        })
    };
    let Some(first) = readings.first() else {
        return Ok(Vec::new());
    };
    let offset = expected_joints(0, first)?.as_vector() - first.joints.as_vector();
    readings
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let expected =
                expected_position(&nominal, identified, &r.target, nominal_commands, file, k)?;
            // The passive limb's readings through the identified machine's
            // own axes (the ideal limb's when none were identified).
            let measured =
                identified.position(&Joints::from_vector(&(r.joints.as_vector() + offset)));
            Ok(VerifyRow::new(&r.target, &expected, &measured))
        })
        .collect()
}

/// Where the identified model says the tool is for `target` (row `k` of
/// `file`): the target itself with compensated commands, the identified
/// machine at the nominal commands with `nominal_commands`.
fn expected_position(
    nominal: &Machine,
    identified: &Machine,
    target: &Vector3<f64>,
    nominal_commands: bool,
    file: Source,
    k: usize,
) -> Result<Vector3<f64>> {
    if !nominal_commands {
        return Ok(*target);
    }
    let bad = |e: crate::error::KinematicsError| {
        Error::csv(file.name, format!("line {}: {e}", file.line(k)))
    };
    let pose = nominal.inverse(target).map_err(bad)?;
    let q = nominal.commands(target).map_err(bad)?;
    let j = identified.forward(&q, &pose.joints).map_err(|e| {
        Error::csv(
            file.name,
            format!(
                "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                file.line(k)
            ),
        )
    })?;
    Ok(identified.position(&j))
}

/// What a check by the passive limb cannot see (docs/method.md §18): every
/// row is a difference to the reference pose, so an error the identified
/// model makes there is shared by every row and never measured. Its size
/// from the identification's uncertainty, at the reference pose.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Untested {
    /// 95 % bound of the identified model's position error at the
    /// reference pose, mm (None when nothing bounds it).
    pub bound_mm: Option<f64>,
    /// Errors that move the tool but that the identification left
    /// unbounded (not identified, or without an uncertainty where the
    /// others state one).
    pub unbounded: Vec<&'static str>,
    /// Where the uncertainty came from: "covariance" (identify's, beside
    /// identified.csv), "standard uncertainties" (identified.csv's, their
    /// correlations bounded by the worst case) or "none".
    pub source: &'static str,
}

/// χ₃ at 95 %: the 95th percentile of the length of a standard normal
/// 3-vector (√7.8147).
const CHI3_95: f64 = 2.795_483;

/// [`Untested`] for the model `model` (identified.csv) with the
/// identification's covariance `covariance` (unknown names and matrix, when
/// identify wrote one), at the reference pose `reference` (a log's first
/// target).
pub fn untested(
    cfg: &Config,
    model: &super::geometry::Identified,
    covariance: Option<&(Vec<String>, nalgebra::DMatrix<f64>)>,
    reference: &Vector3<f64>,
) -> Result<Untested> {
    use crate::mechanism::tricept::{N_PARAMS, PARAM_NAMES};
    let nominal = cfg.nominal();
    let pose = nominal
        .inverse(reference)
        .map_err(|e| Error::Internal(format!("the reference pose: {e}")))?;
    let s15 = crate::mechanism::tricept::jacobian::position_sensitivity(&pose)
        .map_err(|e| Error::Internal(format!("the reference pose: {e}")))?;
    let sa = crate::mechanism::tricept::second_class::position_angle_sensitivity(&nominal, &pose)
        .map_err(|e| Error::Internal(format!("the reference pose: {e}")))?;
    let moves = |k: usize| s15.column(k).norm() > 1e-9;
    let mut unbounded: Vec<&'static str> = (0..N_PARAMS)
        .filter(|&k| !model.identifiable[k] && moves(k))
        .map(|k| PARAM_NAMES[k])
        .collect();
    // The 3 × 3 covariance (or per-axis bound) of the error at the pose.
    let usable = covariance.filter(|(names, _)| {
        names.len() >= N_PARAMS && names.iter().zip(PARAM_NAMES).all(|(a, b)| a == b)
    });
    let (sigma3, source) = match usable {
        Some((names, c)) => {
            let p = names.len();
            let mut s = nalgebra::DMatrix::zeros(3, p);
            for k in 0..N_PARAMS {
                s.set_column(k, &s15.column(k));
            }
            for (k, n) in names.iter().enumerate().skip(N_PARAMS) {
                if let Some(a) = crate::mechanism::tricept::second_class::ANGLE_NAMES
                    .iter()
                    .position(|x| x == n)
                {
                    s.set_column(k, &sa.column(a));
                }
            }
            (&s * c * s.transpose(), "covariance")
        }
        None => {
            // Without correlations: |S·δ|_a ≤ Σ_k |S_ak|·σ_k on each axis.
            let mut axis = [0.0f64; 3];
            let mut any = false;
            let stated = (0..N_PARAMS).any(|k| model.std_mm[k].is_finite());
            for k in (0..N_PARAMS).filter(|&k| model.identifiable[k] && moves(k)) {
                let sd = model.std_mm[k];
                if !sd.is_finite() {
                    // One left without an uncertainty among stated ones.
                    if stated {
                        unbounded.push(PARAM_NAMES[k]);
                    }
                    continue;
                }
                any = true;
                for (a, x) in axis.iter_mut().enumerate() {
                    *x += s15[(a, k)].abs() * sd;
                }
            }
            (
                nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(
                    &axis.map(|x| x * x),
                )),
                if any {
                    "standard uncertainties"
                } else {
                    "none"
                },
            )
        }
    };
    let lmax = sigma3
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .fold(0.0f64, |a, &b| a.max(b));
    Ok(Untested {
        bound_mm: (source != "none").then_some(CHI3_95 * lmax.max(0.0).sqrt()),
        unbounded,
        source,
    })
}

/// Externally measured absolute positions (`verify --reference`): each
/// target against where the identified model says the tool should be
/// (the target with compensated commands; the identified machine at the
/// nominal commands with `nominal_commands`). Unlike the passive limb's
/// rows these see an error shared by every pose.
/// A measured position more than `max_off_mm` from its target is no
/// measurement of this tool at that target (refused naming the line).
pub fn reference_rows(
    cfg: &Config,
    identified: &Machine,
    points: &[(Vector3<f64>, Vector3<f64>)],
    nominal_commands: bool,
    (file, max_off_mm): (Source, f64),
) -> Result<Vec<VerifyRow>> {
    let targets: Vec<Vector3<f64>> = points.iter().map(|p| p.0).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    points
        .iter()
        .enumerate()
        .map(|(k, (target, measured))| {
            let off = (measured - target).norm();
            if !(off.is_finite() && off <= max_off_mm) {
                return Err(Error::csv(
                    file.name,
                    format!(
                        "line {}: the measured position is {} mm from its target, more than the {max_off_mm} mm any error of this machine may be: is it in another unit or frame?",
                        file.line(k),
                        if off.is_finite() && off < 1e6 { format!("{off:.3}") } else { format!("{off:e}") }
                    ),
                ));
            }
            let expected =
                expected_position(&nominal, identified, target, nominal_commands, file, k)?;
            Ok(VerifyRow::new(target, &expected, measured))
        })
        .collect()
}
