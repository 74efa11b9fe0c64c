//! The UP limb's second-class errors as identification parameters
//! (`[identification] second_class = true`): the first Hooke axis's yaw and
//! pitch and the axes' skew, in degrees, beside the 15 geometric errors.
//! The guide's twist is not among them: it moves the readings exactly as
//! the 15 errors can, so no reading identifies it
//! (`tests/second_class_identifiability.rs`).
//!
//! The readings' derivatives with respect to the three angles come from the
//! closure equations f(x, α) = 0 at fixed commands: dx/dα = −M⁻¹·∂f/∂α,
//! with M the closure's analytic Jacobian in the joints and ∂f/∂α by
//! central differences of f at fixed joints (smooth, no iteration inside).

use super::geometry::{Machine, SecondClass};
use super::kinematics::{invert3, Joints, Pose};
use crate::error::KinematicsError;
use nalgebra::{Matrix3, Vector3};

/// Number of identifiable second-class angles.
pub const N_ANGLES: usize = 3;

/// Their names (identified.csv rows; the unit is degrees).
pub const ANGLE_NAMES: [&str; N_ANGLES] =
    ["hooke_axis1_yaw", "hooke_axis1_pitch", "hooke_axes_skew"];

/// The Tricept's identified model: its 15 errors, then the Hooke axes'
/// angles.
pub const UNKNOWNS: crate::mechanism::Unknowns<{ super::N_PARAMS }, N_ANGLES> =
    crate::mechanism::Unknowns {
        errors: super::PARAM_NAMES,
        angles: ANGLE_NAMES,
        angles_are: "the Hooke axes' angles",
        angle_is: "Hooke-axis misalignment",
        angles_turn: "the passive limb's Hooke axes",
        axes: "Hooke axes",
        beyond: "the guide's twist",
    };

/// The three angles (yaw, pitch, skew) in degrees.
pub type Angles = Vector3<f64>;

/// The angles a machine's second-class errors hold (zero for ideal axes),
/// and its guide twist in degrees.
pub fn angles_of(m: &Machine) -> (Angles, f64) {
    match &m.second {
        None => (Angles::zeros(), 0.0),
        Some(s) => {
            let a1 = s.axis1.into_inner();
            let a2 = s.axis2.into_inner();
            let yaw = a1.y.atan2(a1.x).to_degrees();
            let pitch = (-a1.z).asin().to_degrees();
            let skew = (-a2.x).atan2(a2.y).to_degrees();
            let twist = s.twist[(1, 0)].atan2(s.twist[(0, 0)]).to_degrees();
            (Angles::new(yaw, pitch, skew), twist)
        }
    }
}

/// `m` with its Hooke axes set to `angles` (degrees); the guide's twist is
/// kept (zero on an identified machine).
pub fn with_angles(m: &Machine, angles: &Angles) -> Machine {
    let (_, twist) = angles_of(m);
    let ideal = angles.iter().all(|&a| a == 0.0) && twist == 0.0;
    Machine {
        second: if ideal {
            None
        } else {
            Some(SecondClass::from_angles_deg(
                angles.x, angles.y, angles.z, twist,
            ))
        },
        ..*m
    }
}

/// Step of the central differences in degrees.
const H_DEG: f64 = 1e-4;

/// ∂(ψ4 rad, θ4 rad, q4 mm)/∂(yaw, pitch, skew in degrees) of machine `m`
/// with its Hooke axes at `angles`, in the configuration `j` (a solution of
/// its forward kinematics at the commands it was driven with).
pub fn angle_jacobian(
    m: &Machine,
    angles: &Angles,
    j: &Joints,
) -> Result<Matrix3<f64>, KinematicsError> {
    let at = with_angles(m, angles);
    // The closure's derivatives at fixed joints do not depend on the
    // commands (they enter f as constants): any will do.
    let q_cmd = [0.0; 3];
    let (_, mj) = at.closure(&q_cmd, j);
    let inv = invert3(&mj).ok_or(KinematicsError::Singular {
        psi_deg: j.psi_rad.to_degrees(),
        theta_deg: j.theta_rad.to_degrees(),
        q4_mm: j.q4_mm,
        condition: f64::INFINITY,
    })?;
    let mut df = Matrix3::zeros();
    for c in 0..N_ANGLES {
        let mut up = *angles;
        let mut down = *angles;
        up[c] += H_DEG;
        down[c] -= H_DEG;
        let fp = with_angles(m, &up).closure(&q_cmd, j).0;
        let fm = with_angles(m, &down).closure(&q_cmd, j).0;
        df.set_column(c, &((fp - fm) / (2.0 * H_DEG)));
    }
    Ok(-inv * df)
}

/// ∂O′/∂(yaw, pitch, skew in degrees) of machine `m` (its axes at zero)
/// driven with the commands of `pose` (mm per degree, first order): the
/// readings move by [`angle_jacobian`], and O′ = q4·w4 moves with them and
/// with the axes themselves.
pub fn position_angle_sensitivity(
    m: &Machine,
    pose: &Pose,
) -> Result<Matrix3<f64>, KinematicsError> {
    let j = pose.joints;
    let dx = angle_jacobian(m, &Angles::zeros(), &j)?;
    let (hooke, e_psi, e_theta) = m.hooke(j.psi_rad, j.theta_rad);
    let w4 = hooke.column(2).into_owned();
    let dr_dx =
        Matrix3::from_columns(&[j.q4_mm * e_psi.cross(&w4), j.q4_mm * e_theta.cross(&w4), w4]);
    let mut dr_da = Matrix3::zeros();
    for c in 0..N_ANGLES {
        let mut up = Angles::zeros();
        up[c] = H_DEG;
        let p = with_angles(m, &up).position(&j);
        let q = with_angles(m, &(-up)).position(&j);
        dr_da.set_column(c, &((p - q) / (2.0 * H_DEG)));
    }
    Ok(dr_dx * dx + dr_da)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{ErrorVector, Geometry, PAPER_ERRORS_MM};

    fn machine() -> Machine {
        Machine::with_errors(
            &Geometry::paper(),
            &ErrorVector::from_row_slice(&PAPER_ERRORS_MM),
        )
    }

    #[test]
    fn angles_round_trip_through_the_axes() {
        let m = Machine {
            second: Some(SecondClass::from_angles_deg(0.3, -0.2, 0.4, 0.05)),
            ..machine()
        };
        let (a, twist) = angles_of(&m);
        assert!((a - Angles::new(0.3, -0.2, 0.4)).amax() < 1e-12, "{a:?}");
        assert!((twist - 0.05).abs() < 1e-12);
        let back = with_angles(&m, &Angles::new(0.01, 0.02, -0.03));
        let (b, t) = angles_of(&back);
        assert!((b - Angles::new(0.01, 0.02, -0.03)).amax() < 1e-12);
        assert!((t - 0.05).abs() < 1e-12);
        assert!(with_angles(&machine(), &Angles::zeros()).second.is_none());
    }

    /// The Jacobian against central differences of exact forward kinematics
    /// at fixed commands (another route: Newton to 1e-11 mm each time).
    #[test]
    fn angle_jacobian_matches_forward_kinematics() {
        let m = machine();
        let nominal = Machine::nominal(&Geometry::paper());
        for (r, angles) in [
            (Vector3::new(150.0, -220.0, 720.0), Angles::zeros()),
            (
                Vector3::new(-300.0, 100.0, 840.0),
                Angles::new(0.01, -0.02, 0.015),
            ),
        ] {
            let pose = nominal.inverse(&r).unwrap();
            let q = pose.legs_mm;
            let at = with_angles(&m, &angles);
            let j = at.forward(&q, &pose.joints).unwrap();
            let jac = angle_jacobian(&m, &angles, &j).unwrap();
            let h = 1e-3;
            for c in 0..N_ANGLES {
                let (mut up, mut down) = (angles, angles);
                up[c] += h;
                down[c] -= h;
                let xp = with_angles(&m, &up).forward(&q, &j).unwrap().as_vector();
                let xm = with_angles(&m, &down).forward(&q, &j).unwrap().as_vector();
                let fd = (xp - xm) / (2.0 * h);
                let col = jac.column(c);
                assert!(
                    (fd - col).norm() < 1e-6 * col.norm(),
                    "{r:?} angle {c}: {fd:?} vs {col:?}"
                );
            }
        }
    }

    /// Against central differences of the exact forward kinematics' O′.
    #[test]
    fn position_sensitivity_matches_forward_kinematics() {
        let m = machine();
        let pose = m.inverse(&Vector3::new(-200.0, 150.0, 800.0)).unwrap();
        let s = position_angle_sensitivity(&m, &pose).unwrap();
        let q = [0, 1, 2].map(|i| pose.legs_mm[i] - m.dq[i]);
        let h = 1e-3;
        for c in 0..N_ANGLES {
            let mut up = Angles::zeros();
            up[c] = h;
            let at = |a: &Angles| {
                let mm = with_angles(&m, a);
                mm.position(&mm.forward(&q, &pose.joints).unwrap())
            };
            let fd = (at(&up) - at(&(-up))) / (2.0 * h);
            let col = s.column(c);
            assert!(
                (fd - col).norm() < 1e-5 * col.norm().max(1e-3),
                "angle {c}: {fd:?} vs {col:?}"
            );
            assert!(col.norm() > 1e-4, "angle {c} moves O′: {col:?}");
        }
    }

    #[test]
    fn inverse_with_second_class_puts_the_point_where_asked() {
        let m = Machine {
            second: Some(SecondClass::from_angles_deg(0.02, -0.01, 0.03, 0.0)),
            ..machine()
        };
        let r = Vector3::new(120.0, -80.0, 760.0);
        let pose = m.inverse(&r).unwrap();
        assert!((m.position(&pose.joints) - r).norm() < 1e-9);
        // Driven with the legs this pose needs, forward kinematics lands there.
        let q = [0, 1, 2].map(|i| pose.legs_mm[i] - m.dq[i]);
        let j = m.forward(&q, &pose.joints).unwrap();
        assert!((m.position(&j) - r).norm() < 1e-9);
    }
}
