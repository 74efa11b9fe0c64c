//! Readings and the observation vector (docs/method.md §5–§6; paper eq. 10).
//!
//! Two encoders on the B4 Hooke joint read ψ4 and θ4, a linear scale reads
//! q4. They are incremental and homed at the reference pose (index 0) to its
//! nominal values, so at pose j the controller reports
//!   reading_j = nominal_0 + (actual_j + n_j) − (actual_0 + n_0),
//! where n are the sensor noises (the homing reading is noisy too) and the
//! actual joints come from exact forward kinematics of the erroneous machine
//! driven with nominal inverse-kinematics commands — never from the linear
//! model. The reference row itself reads nominal_0 (that is what homing does).
//!
//! The observation of eq. 10 is formed in one place,
//! [`crate::mechanism::homed_rows`] (here as [`observation_into`],
//! for every topology as `PoseSet::observation_into`):
//! l_j = (a_j − a_0) − (nominal_j − nominal_0), j ≥ 1, where a are readings
//! (`identify`), exact joints of the true machine (the sweep, before its
//! noise is added by [`noisy_observation`]) or of the current estimate
//! (Gauss–Newton).

use super::noise::{homed_noise, SensorModel};
use crate::error::PoseError;
use crate::mechanism::homed_rows;
use crate::mechanism::tricept::{Joints, Machine, NominalPoses, N_READINGS};
use nalgebra::{DVector, Vector3};
use rand::Rng;

/// One row of a readings file: the commanded target of O' and what the
/// controller reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub target: Vector3<f64>,
    pub joints: Joints,
}

/// Simulated readings of `truth` at the poses; `sensors = None` is noise-free.
pub fn simulate_readings<R: Rng + Clone>(
    poses: &NominalPoses,
    truth: &Machine,
    sensors: Option<&SensorModel<N_READINGS>>,
    rng: &mut R,
) -> Result<Vec<Reading>, PoseError> {
    let mut actual = vec![Vector3::zeros(); poses.len()];
    poses.actual_joints_into(truth, &mut actual)?;
    let nominal_0 = poses.joints[0].as_vector();
    let mut out = Vec::with_capacity(poses.len());
    out.push(Reading {
        target: poses.targets[0],
        joints: poses.joints[0],
    });
    let mut push = |k: usize, nk: Vector3<f64>, n0: Vector3<f64>| {
        let read = nominal_0 + (actual[k] + nk) - (actual[0] + n0);
        out.push(Reading {
            target: poses.targets[k],
            joints: Joints::from_vector(&read),
        });
    };
    match sensors {
        Some(SensorModel {
            structured: Some(st),
            samples,
            ..
        }) => {
            // Raw readings of the true joints; the controller reports them
            // homed at the reference: nominal_0 + (raw_k − raw_0).
            let (ph, jitter) = st.machine(rng, *samples, actual.len());
            let raw: Vec<Vector3<f64>> = actual
                .iter()
                .enumerate()
                .map(|(j, a)| st.reading(&ph, a, *samples, &jitter, j))
                .collect();
            for k in 1..poses.len() {
                let read = nominal_0 + (raw[k] - raw[0]);
                out.push(Reading {
                    target: poses.targets[k],
                    joints: Joints::from_vector(&read),
                });
            }
        }
        Some(s) => homed_noise(s, rng, poses.len(), push),
        None => (1..poses.len()).for_each(|k| push(k, Vector3::zeros(), Vector3::zeros())),
    }
    Ok(out)
}

/// l_j = (a_j − a_0) − (nominal_j − nominal_0) for j ≥ 1, written to
/// `out[3(j−1)..3j]` (equal to reading_j − nominal_j when the reference reads
/// nominal_0, as homing makes it; robust to a controller that logs a homing
/// offset).
#[inline]
pub fn observation_into(nominal: &[Joints], a: &[Vector3<f64>], out: &mut [f64]) {
    homed_rows(nominal.len(), |j| nominal[j].as_vector(), a, out);
}

/// [`observation_into`] as a new vector (3 rows per pose after the reference).
pub fn observation_vector(nominal: &[Joints], a: &[Vector3<f64>]) -> DVector<f64> {
    let mut l = DVector::zeros(3 * nominal.len().saturating_sub(1));
    observation_into(nominal, a, l.as_mut_slice());
    l
}

/// The observation the sensors report: `l0` (the noise-free observation of
/// the true machine) plus the homed noise n_j − n_0 of each row. No allocation.
#[inline]
pub fn noisy_observation<R: Rng + ?Sized>(
    sensor: &SensorModel<N_READINGS>,
    rng: &mut R,
    l0: &[f64],
    out: &mut [f64],
) {
    homed_noise(sensor, rng, l0.len() / 3 + 1, |j, nj, n0| {
        let d = nj - n0;
        for c in 0..3 {
            out[3 * (j - 1) + c] = l0[3 * (j - 1) + c] + d[c];
        }
    });
}
