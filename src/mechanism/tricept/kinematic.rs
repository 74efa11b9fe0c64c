//! The Tricept's kinematics as identification and a white-noise study ask
//! for them ([`Kinematic`]).

use super::geometry::{Geometry, Machine};
use super::jacobian::{error_jacobian, position_sensitivity};
use super::kinematics::Joints;
use super::params::N_PARAMS;
use super::second_class::{position_angle_sensitivity, with_angles, N_ANGLES};
use super::topology::{Tricept, N_READINGS};
use crate::error::KinematicsError;
use crate::mechanism::{AxisAngles, Kinematic};
use nalgebra::{SMatrix, SVector, Vector3};

impl Kinematic<N_PARAMS, N_READINGS> for Tricept {
    /// Leg lengths commanded (mm, the nominal IK's).
    type Command = [f64; 3];

    fn machine(layout: &Geometry, e: &SVector<f64, N_PARAMS>) -> Machine {
        Machine::with_errors(layout, e)
    }

    fn command(
        nominal: &Machine,
        r: &Vector3<f64>,
    ) -> Result<([f64; 3], Vector3<f64>), KinematicsError> {
        let pose = nominal.inverse(r)?;
        let q = std::array::from_fn(|i| pose.legs_mm[i] - nominal.dq[i]);
        Ok((q, pose.joints.as_vector()))
    }

    fn readings(
        machine: &Machine,
        command: &[f64; 3],
        guess: &Vector3<f64>,
    ) -> Result<Vector3<f64>, KinematicsError> {
        Ok(machine
            .forward(command, &Joints::from_vector(guess))?
            .as_vector())
    }

    fn error_jacobian(
        machine: &Machine,
        x: &Vector3<f64>,
    ) -> Result<SMatrix<f64, N_READINGS, N_PARAMS>, KinematicsError> {
        error_jacobian(machine, &Joints::from_vector(x))
    }

    fn position(machine: &Machine, x: &Vector3<f64>) -> Vector3<f64> {
        machine.position(&Joints::from_vector(x))
    }

    /// Its closed form, J = M⁻¹D at the nominal pose.
    fn position_sensitivity(
        layout: &Geometry,
        r: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 3, N_PARAMS>, KinematicsError> {
        position_sensitivity(&Machine::nominal(layout).inverse(r)?)
    }
}

/// The Hooke axes' yaw, pitch and skew.
impl AxisAngles<N_PARAMS, N_READINGS, N_ANGLES> for Tricept {
    fn with_angles(machine: &Machine, angles: &Vector3<f64>) -> Machine {
        with_angles(machine, angles)
    }

    fn position_angle_sensitivity(
        nominal: &Machine,
        r: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 3, N_ANGLES>, KinematicsError> {
        position_angle_sensitivity(nominal, &nominal.inverse(r)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::poses::pattern;
    use crate::mechanism::tricept::NominalPoses;
    use crate::mechanism::PoseSet;

    #[test]
    fn commands_and_readings_invert_each_other_on_any_machine() {
        let g = Geometry::paper();
        let e = SVector::<f64, N_PARAMS>::from_fn(|i, _| 0.3 * ((i as f64) * 0.9).cos());
        let m = Tricept::machine(&g, &e);
        for r in pattern(
            &crate::mechanism::tricept::poses::paper_workspace(),
            2,
            &[0.5, 1.0],
            6,
        ) {
            let (q, x) = Tricept::command(&m, &r).unwrap();
            let back = Tricept::readings(&m, &q, &x).unwrap();
            assert!((back - x).amax() < 1e-9, "{r}: {:e}", (back - x).amax());
            // The machine's own leg offsets are taken off its commands.
            let legs = m.inverse(&r).unwrap().legs_mm;
            assert!((0..3).all(|i| (q[i] - (legs[i] - m.dq[i])).abs() < 1e-12));
        }
    }

    /// The closed-form sensitivities equal central differences of exact
    /// forward kinematics at the nominal commands: of every error, and of
    /// every Hooke-axis angle.
    #[test]
    fn sensitivities_are_forward_kinematics_differentiated() {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let r = Vector3::new(60.0, -40.0, 1040.0);
        let s = Tricept::position_sensitivity(&g, &r).unwrap();
        let sa = Tricept::position_angle_sensitivity(&nominal, &r).unwrap();
        let (q, guess) = Tricept::command(&nominal, &r).unwrap();
        let at = |m: &Machine| Tricept::position(m, &Tricept::readings(m, &q, &guess).unwrap());
        let h = 1e-5;
        for c in 0..N_PARAMS {
            let e = |x: f64| SVector::<f64, N_PARAMS>::from_fn(|i, _| if i == c { x } else { 0.0 });
            let d =
                (at(&Tricept::machine(&g, &e(h))) - at(&Tricept::machine(&g, &e(-h)))) / (2.0 * h);
            assert!(
                (s.column(c) - d).amax() < 1e-6,
                "error {c}: {} vs {d}",
                s.column(c)
            );
        }
        assert!(s.amax() > 0.5);
        for c in 0..N_ANGLES {
            let a = |x: f64| Vector3::from_fn(|i, _| if i == c { x } else { 0.0 });
            let d = (at(&Tricept::with_angles(&nominal, &a(1e-4)))
                - at(&Tricept::with_angles(&nominal, &a(-1e-4))))
                / 2e-4;
            // A degree of the axes moves the tool by micrometres at most:
            // agreement relative to the motion.
            assert!(d.amax() > 1e-7, "angle {c} moves the tool");
            assert!(
                (sa.column(c) - d).amax() < 1e-3 * d.amax(),
                "angle {c}: {} vs {d}",
                sa.column(c)
            );
        }
    }

    #[test]
    fn a_pose_set_is_the_mechanisms_nominal_poses() {
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let targets = crate::mechanism::tricept::poses::paper_targets();
        let set = PoseSet::<Tricept, N_PARAMS, N_READINGS>::new(&nominal, &targets).unwrap();
        let poses = NominalPoses::new(&nominal, &targets).unwrap();
        assert_eq!((set.len(), set.is_empty()), (targets.len(), false));
        assert_eq!(set.rows(), 3 * (targets.len() - 1));
        assert_eq!(set.commands, poses.commands);
        assert!(set
            .nominal
            .iter()
            .zip(&poses.joints)
            .all(|(a, j)| *a == j.as_vector()));
        let empty = PoseSet::<Tricept, N_PARAMS, N_READINGS>::new(&nominal, &[]).unwrap();
        assert!(empty.is_empty() && empty.rows() == 0);
        empty.observation_into(&[], &mut []);
        let printed = format!("{:?}", set.clone());
        assert!(printed.starts_with("PoseSet { targets: [") && printed.ends_with(", .. }"));
        // Readings of an erroneous machine equal the mechanism's own
        // routine's; the observation is eq. 10 with homing, written out.
        let e = SVector::<f64, N_PARAMS>::from_fn(|i, _| 0.05 * (i as f64 - 7.0));
        let truth = Machine::with_errors(&g, &e);
        let mut a = vec![Vector3::zeros(); set.len()];
        set.actual_into(&truth, &mut a).unwrap();
        let mut b = vec![Vector3::zeros(); set.len()];
        poses.actual_joints_into(&truth, &mut b).unwrap();
        assert_eq!(a, b);
        let mut l = vec![0.0; set.rows()];
        set.observation_into(&a, &mut l);
        for j in 1..set.len() {
            for c in 0..3 {
                let n = |k: usize| poses.joints[k].as_vector()[c];
                let want = (b[j][c] - b[0][c]) - (n(j) - n(0));
                assert_eq!(l[3 * (j - 1) + c], want);
            }
        }
    }
}
