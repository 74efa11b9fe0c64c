//! `verify`: an identified model against a fresh log, position by the
//! passive joints' readings against where the model puts the tool, for any
//! [`Kinematic`] mechanism whose log rows are [`LogRow`]s (the Tricept's
//! is its passive limb); and what such a check cannot see.

use crate::error::{Error, KinematicsError, Result};
use crate::io::Source;
use crate::mechanism::{AxisAngles, Kinematic, LogRow, Reach, Unknowns};
use crate::store::inputs::IdentifiedModel;
use nalgebra::{SVector, Vector3};

/// Is every target reachable by the nominal machine (`reach`)? The error
/// names the line of `file`.
pub fn check_targets<T: Kinematic<P, R>, const P: usize, const R: usize>(
    reach: &Reach<T, P, R>,
    targets: &[Vector3<f64>],
    file: Source,
) -> Result<()> {
    for (k, r) in targets.iter().enumerate() {
        reach.check(r).map_err(|why| {
            Error::csv(
                file.name,
                format!(
                    "line {}: target ({}, {}, {}) mm is not reachable: {why}",
                    file.line(k),
                    r.x,
                    r.y,
                    r.z
                ),
            )
        })?;
    }
    Ok(())
}

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
pub fn verify<T, L, const P: usize, const R: usize>(
    reach: &Reach<T, P, R>,
    identified: &T::Machine,
    readings: &[L],
    nominal_commands: bool,
    file: Source,
) -> Result<Vec<VerifyRow>>
where
    T: Kinematic<P, R>,
    L: LogRow<R>,
{
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target()).collect();
    check_targets(reach, &targets, file)?;
    let nominal = reach.homed.nominal();
    let bad = |k: usize| {
        move |e: KinematicsError| Error::csv(file.name, format!("line {}: {e}", file.line(k)))
    };
    let expected_readings = |k: usize, target: &Vector3<f64>| -> Result<SVector<f64, R>> {
        if !nominal_commands {
            // The identified machine's joints at the target (with
            // identified second-class axes, their rotations).
            return T::command(identified, target).map(|c| c.1).map_err(bad(k));
        }
        nominal_readings::<T, P, R>(nominal, identified, target, file, k)
    };
    let Some(first) = readings.first() else {
        return Ok(Vec::new());
    };
    let offset = expected_readings(0, &first.target())? - first.readings();
    readings
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let target = r.target();
            let expected =
                expected::<T, P, R>(nominal, identified, &target, nominal_commands, (file, k))?;
            // The log's readings through the identified machine's own
            // axes (the ideal ones when none were identified).
            let measured = T::position(identified, &(r.readings() + offset));
            Ok(VerifyRow::new(&target, &expected, &measured))
        })
        .collect()
}

/// Where the identified model says the tool is for `target` (row `k` of
/// `file`): the target itself with compensated commands, the identified
/// machine at the nominal commands with `nominal_commands`.
fn expected<T: Kinematic<P, R>, const P: usize, const R: usize>(
    nominal: &T::Machine,
    identified: &T::Machine,
    target: &Vector3<f64>,
    nominal_commands: bool,
    (file, k): (Source, usize),
) -> Result<Vector3<f64>> {
    if !nominal_commands {
        return Ok(*target);
    }
    let x = nominal_readings::<T, P, R>(nominal, identified, target, file, k)?;
    Ok(T::position(identified, &x))
}

/// The readings the identified machine gives at the nominal commands for
/// `target` (row `k` of `file`).
fn nominal_readings<T: Kinematic<P, R>, const P: usize, const R: usize>(
    nominal: &T::Machine,
    identified: &T::Machine,
    target: &Vector3<f64>,
    file: Source,
    k: usize,
) -> Result<SVector<f64, R>> {
    let (q, guess) = T::command(nominal, target)
        .map_err(|e| Error::csv(file.name, format!("line {}: {e}", file.line(k))))?;
    T::readings(identified, &q, &guess).map_err(|e| {
        Error::csv(
            file.name,
            format!(
                "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                file.line(k)
            ),
        )
    })
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

/// [`Untested`] for the model `model` (identified.csv, its unknowns
/// named by `names`) with the identification's covariance `covariance`
/// (unknown names and matrix, when identify wrote one), at the reference
/// pose `reference` (a log's first target) of the machine `reach` holds:
/// the tool's sensitivity to each error and to each second-class angle
/// there is the mechanism's ([`Kinematic::position_sensitivity`],
/// [`AxisAngles::position_angle_sensitivity`]).
pub fn untested<T, const P: usize, const R: usize, const A: usize>(
    reach: &Reach<T, P, R>,
    names: &Unknowns<P, A>,
    model: &IdentifiedModel<P, A>,
    covariance: Option<&(Vec<String>, nalgebra::DMatrix<f64>)>,
    reference: &Vector3<f64>,
) -> Result<Untested>
where
    T: AxisAngles<P, R, A>,
{
    let at_reference = |e: KinematicsError| Error::Internal(format!("the reference pose: {e}"));
    let s15 = T::position_sensitivity(reach.homed.layout(), reference).map_err(at_reference)?;
    let sa =
        T::position_angle_sensitivity(reach.homed.nominal(), reference).map_err(at_reference)?;
    let moves = |k: usize| s15.column(k).norm() > 1e-9;
    let mut unbounded: Vec<&'static str> = (0..P)
        .filter(|&k| !model.identifiable[k] && moves(k))
        .map(|k| names.errors[k])
        .collect();
    // The 3 × 3 covariance (or per-axis bound) of the error at the pose.
    let usable = covariance.filter(|(given, _)| {
        given.len() >= P && given.iter().zip(names.errors).all(|(a, b)| a == b)
    });
    let (sigma3, source) = match usable {
        Some((given, c)) => {
            let mut s = nalgebra::DMatrix::zeros(3, given.len());
            for k in 0..P {
                s.set_column(k, &s15.column(k));
            }
            for (k, n) in given.iter().enumerate().skip(P) {
                if let Some(a) = names.angles.iter().position(|x| x == n) {
                    s.set_column(k, &sa.column(a));
                }
            }
            (&s * c * s.transpose(), "covariance")
        }
        None => {
            // Without correlations: |S·δ|_a ≤ Σ_k |S_ak|·σ_k on each axis.
            let mut axis = [0.0f64; 3];
            let mut any = false;
            let stated = (0..P).any(|k| model.std_mm[k].is_finite());
            for k in (0..P).filter(|&k| model.identifiable[k] && moves(k)) {
                let sd = model.std_mm[k];
                if !sd.is_finite() {
                    // One left without an uncertainty among stated ones.
                    if stated {
                        unbounded.push(names.errors[k]);
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
pub fn reference_rows<T: Kinematic<P, R>, const P: usize, const R: usize>(
    reach: &Reach<T, P, R>,
    identified: &T::Machine,
    points: &[(Vector3<f64>, Vector3<f64>)],
    nominal_commands: bool,
    (file, max_off_mm): (Source, f64),
) -> Result<Vec<VerifyRow>> {
    let targets: Vec<Vector3<f64>> = points.iter().map(|p| p.0).collect();
    check_targets(reach, &targets, file)?;
    let nominal = reach.homed.nominal();
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
            let expected = expected::<T, P, R>(nominal, identified, target, nominal_commands, (file, k))?;
            Ok(VerifyRow::new(target, &expected, measured))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::second_class::UNKNOWNS;
    use crate::mechanism::tricept::{Geometry, Tricept};
    use crate::mechanism::Homed;
    use nalgebra::{DMatrix, SMatrix};

    /// A covariance of the Hooke axes' angles alone bounds the tool by
    /// each angle's own sensitivity column (the Tricept's closed form at
    /// the reference pose), read by the angle's name in the covariance.
    #[test]
    fn the_angles_covariance_is_read_by_name() {
        let g = Geometry::paper();
        let reach = Reach {
            homed: Homed::<Tricept, 15, 3>::new(&g),
            max_tilt_deg: 60.0,
        };
        // Off the base's axis: at the paper's reference the axes move
        // nothing.
        let r = Vector3::new(60.0, -40.0, 1040.0);
        let model = IdentifiedModel::<15, 3> {
            errors: SVector::zeros(),
            identifiable: [true; 15],
            std_mm: [f64::NAN; 15],
            angles: Some(SVector::zeros()),
            source: ["readings"; 15],
        };
        // The angles in reverse order, each with its own variance.
        let mut names: Vec<String> = UNKNOWNS.errors.iter().map(|n| n.to_string()).collect();
        names.extend(UNKNOWNS.angles.iter().rev().map(|n| n.to_string()));
        let var = [4.0, 1.0, 0.25];
        let c = DMatrix::from_fn(
            18,
            18,
            |i, j| {
                if i == j && i >= 15 {
                    var[i - 15]
                } else {
                    0.0
                }
            },
        );
        let u = untested(&reach, &UNKNOWNS, &model, Some(&(names, c)), &r).unwrap();
        let sa = Tricept::position_angle_sensitivity(reach.homed.nominal(), &r).unwrap();
        let mut want = SMatrix::<f64, 3, 3>::zeros();
        for (k, v) in var.iter().enumerate() {
            let col = sa.column(2 - k);
            want += col * col.transpose() * *v;
        }
        let lmax = want.symmetric_eigen().eigenvalues.max();
        let want = CHI3_95 * lmax.sqrt();
        assert_eq!(u.source, "covariance");
        assert!(
            (u.bound_mm.unwrap() - want).abs() < 1e-9 * want && want > 0.0,
            "{:?} vs {want}",
            u.bound_mm
        );
    }
}
