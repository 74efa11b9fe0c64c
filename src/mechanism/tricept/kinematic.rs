//! The Tricept's kinematics as identification and a white-noise study ask
//! for them ([`Kinematic`]).

use super::geometry::{Geometry, Machine};
use super::jacobian::error_jacobian;
use super::kinematics::Joints;
use super::params::N_PARAMS;
use super::topology::{Tricept, N_READINGS};
use crate::error::KinematicsError;
use crate::mechanism::Kinematic;
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
