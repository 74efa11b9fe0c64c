//! What identification and a white-noise study ask of a topology's
//! kinematics, beside its facts ([`Topology`]): its machine with errors, the
//! nominal machine's commands at a target, the exact readings an erroneous
//! machine gives at those commands, and the error Jacobian of its readings.
//! P errors and R readings a pose are the trait's parameters (the
//! mechanism's: [`N_PARAMS`], [`N_READINGS`]); the same Gauss–Newton
//! (`identify::gauss_newton`) and the same operator
//! (`identify::Solver`) serve every topology.

use super::geometry::{Geometry, Machine};
use super::jacobian::error_jacobian;
use super::kinematics::Joints;
use super::params::N_PARAMS;
use super::topology::{Topology, Tricept, N_READINGS};
use crate::error::{KinematicsError, PoseError};
use nalgebra::{SMatrix, SVector, Vector3};

/// The kinematics of a topology with P errors and R readings a pose.
pub trait Kinematic<const P: usize, const R: usize>: Topology {
    /// What a pose commands the active legs (from the nominal machine's
    /// inverse kinematics).
    type Command: Clone + Send + Sync;

    /// The layout with errors `e` (mm, in [`Topology::ERROR_NAMES`] order).
    fn machine(layout: &Self::Layout, e: &SVector<f64, P>) -> Self::Machine;

    /// Inverse kinematics of the nominal machine at target `r`: the
    /// commands and the readings it gives there.
    fn command(
        nominal: &Self::Machine,
        r: &Vector3<f64>,
    ) -> Result<(Self::Command, SVector<f64, R>), KinematicsError>;

    /// Exact forward kinematics: the readings `machine` gives at `command`,
    /// solved from `guess` (the nominal machine's readings there).
    fn readings(
        machine: &Self::Machine,
        command: &Self::Command,
        guess: &SVector<f64, R>,
    ) -> Result<SVector<f64, R>, KinematicsError>;

    /// ∂readings/∂errors of `machine` in the configuration whose readings
    /// are `x` (R × P; model units: rad and mm per mm).
    fn error_jacobian(
        machine: &Self::Machine,
        x: &SVector<f64, R>,
    ) -> Result<SMatrix<f64, R, P>, KinematicsError>;
}

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
}

/// A topology's pose set: each target, the nominal machine's commands and
/// readings there (pose 0 is the reference the sensors are homed at).
pub struct PoseSet<T: Kinematic<P, R>, const P: usize, const R: usize> {
    pub targets: Vec<Vector3<f64>>,
    pub commands: Vec<T::Command>,
    pub nominal: Vec<SVector<f64, R>>,
}

// By hand: the topology is a marker type and need not be Clone or Debug.
impl<T: Kinematic<P, R>, const P: usize, const R: usize> Clone for PoseSet<T, P, R> {
    fn clone(&self) -> Self {
        PoseSet {
            targets: self.targets.clone(),
            commands: self.commands.clone(),
            nominal: self.nominal.clone(),
        }
    }
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> std::fmt::Debug for PoseSet<T, P, R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PoseSet")
            .field("targets", &self.targets)
            .field("nominal", &self.nominal)
            .finish_non_exhaustive()
    }
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> PoseSet<T, P, R> {
    /// Nominal inverse kinematics at every target; the error names the pose.
    pub fn new(nominal: &T::Machine, targets: &[Vector3<f64>]) -> Result<Self, PoseError> {
        let mut commands = Vec::with_capacity(targets.len());
        let mut readings = Vec::with_capacity(targets.len());
        for (k, r) in targets.iter().enumerate() {
            let (q, x) = T::command(nominal, r).map_err(|e| PoseError::new(k, e))?;
            commands.push(q);
            readings.push(x);
        }
        Ok(PoseSet {
            targets: targets.to_vec(),
            commands,
            nominal: readings,
        })
    }

    pub fn len(&self) -> usize {
        self.targets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Rows of the observation vector l: R for every pose but the reference.
    pub fn rows(&self) -> usize {
        R * self.len().saturating_sub(1)
    }

    /// The readings `machine` gives at every pose (exact forward
    /// kinematics from the nominal solution), written into `out`.
    pub fn actual_into(
        &self,
        machine: &T::Machine,
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError> {
        for (k, (q, guess)) in self.commands.iter().zip(&self.nominal).enumerate() {
            out[k] = T::readings(machine, q, guess).map_err(|e| PoseError::new(k, e))?;
        }
        Ok(())
    }

    /// l of readings `a` (eq. 10 with homing; [`homed_rows`]).
    pub fn observation_into(&self, a: &[SVector<f64, R>], out: &mut [f64]) {
        homed_rows(self.len(), |j| self.nominal[j], a, out);
    }
}

/// The observation of eq. 10, for every topology: l_j = (a_j − a_0) −
/// (nominal_j − nominal_0) for j ≥ 1, written to `out[R(j−1)..Rj]`, where
/// `nominal(j)` is pose j's nominal readings (n poses) and `a` the readings.
/// Equal to reading_j − nominal_j when the reference reads nominal_0, as
/// homing makes it; robust to a controller that logs a homing offset. No
/// pose, no row.
#[inline(always)]
pub fn homed_rows<const R: usize>(
    n: usize,
    nominal: impl Fn(usize) -> SVector<f64, R>,
    a: &[SVector<f64, R>],
    out: &mut [f64],
) {
    if n == 0 {
        return;
    }
    let n0 = nominal(0);
    let a0 = a[0];
    for j in 1..n {
        let d = (a[j] - a0) - (nominal(j) - n0);
        out[R * (j - 1)..R * j].copy_from_slice(d.as_slice());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::poses::{pattern, Workspace};
    use crate::model::NominalPoses;

    #[test]
    fn commands_and_readings_invert_each_other_on_any_machine() {
        let g = Geometry::paper();
        let e = SVector::<f64, N_PARAMS>::from_fn(|i, _| 0.3 * ((i as f64) * 0.9).cos());
        let m = Tricept::machine(&g, &e);
        for r in pattern(&Workspace::paper(), 2, &[0.5, 1.0], 6) {
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
        let targets = pattern(&Workspace::paper(), 3, &[0.5, 1.0], 8);
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
