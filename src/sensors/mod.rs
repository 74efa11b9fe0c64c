//! Passive-limb sensors and simulated readings (SPEC §5; paper eq. 10).
//!
//! Two encoders on the B4 Hooke joint read ψ4 and θ4, a linear scale reads
//! q4. They are incremental and homed at the reference pose (index 0) to its
//! nominal values, so at pose j the controller reports
//!   reading_j = nominal_0 + (actual_j + n_j) − (actual_0 + n_0),
//! where n are the sensor noises (the homing reading is noisy too) and the
//! actual joints come from exact forward kinematics of the erroneous machine
//! driven with nominal inverse-kinematics commands — never from the linear
//! model. The reference row itself reads nominal_0 (that is what homing does).

use crate::error::KinematicsError;
use crate::model::{Joints, Machine};
use nalgebra::Vector3;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;

/// Arc-seconds in one radian.
pub const ARCSEC_PER_RAD: f64 = 206_264.806_247_096_36;

/// How a sensor grade (±g″, ±s µm) turns into noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GradeReading {
    /// The paper's reading: the grade is the noise standard deviation, Gaussian.
    Sigma,
    /// The grade is a ±bound: noise uniform in [−g, g], σ = g/√3.
    Uniform,
}

/// The noise of one sensor set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel {
    /// Encoder grade, arc-seconds.
    pub encoder_arcsec: f64,
    /// Linear-scale grade, µm.
    pub scale_um: f64,
    /// Samples averaged per reading.
    pub samples: u32,
    pub reading: GradeReading,
}

impl SensorModel {
    /// Per-sample noise parameter (σ for Gaussian, bound for uniform) of
    /// (ψ4 rad, θ4 rad, q4 mm).
    fn sample_scale(&self) -> Vector3<f64> {
        let enc = self.encoder_arcsec / ARCSEC_PER_RAD;
        Vector3::new(enc, enc, self.scale_um * 1e-3)
    }

    /// Standard deviation of one averaged reading of (ψ4 rad, θ4 rad, q4 mm).
    pub fn reading_sigma(&self) -> Vector3<f64> {
        let per_sample = match self.reading {
            GradeReading::Sigma => 1.0,
            GradeReading::Uniform => 1.0 / 3f64.sqrt(),
        };
        self.sample_scale() * per_sample / (self.samples as f64).sqrt()
    }

    /// One averaged reading's noise. Gaussian: one draw with σ/√samples
    /// (exactly the distribution of the mean of `samples` draws); uniform:
    /// the mean of `samples` uniform draws.
    #[inline]
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Vector3<f64> {
        match self.reading {
            GradeReading::Sigma => {
                let s = self.reading_sigma();
                Vector3::new(
                    s.x * rng.sample::<f64, _>(StandardNormal),
                    s.y * rng.sample::<f64, _>(StandardNormal),
                    s.z * rng.sample::<f64, _>(StandardNormal),
                )
            }
            GradeReading::Uniform => {
                let b = self.sample_scale();
                let mut acc = Vector3::zeros();
                for _ in 0..self.samples {
                    for k in 0..3 {
                        acc[k] += b[k] * rng.random_range(-1.0..=1.0);
                    }
                }
                acc / self.samples as f64
            }
        }
    }
}

/// One row of a readings file: the commanded target of O' and what the
/// controller reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    pub target: Vector3<f64>,
    pub joints: Joints,
}

/// Nominal configuration and nominal-IK commands at each pose.
#[derive(Debug, Clone)]
pub struct NominalPoses {
    pub targets: Vec<Vector3<f64>>,
    pub joints: Vec<Joints>,
    pub commands: Vec<[f64; 3]>,
}

impl NominalPoses {
    /// Nominal IK at every target; the error names the pose index.
    pub fn new(
        nominal: &Machine,
        targets: &[Vector3<f64>],
    ) -> Result<Self, (usize, KinematicsError)> {
        let mut joints = Vec::with_capacity(targets.len());
        let mut commands = Vec::with_capacity(targets.len());
        for (k, r) in targets.iter().enumerate() {
            let pose = nominal.inverse(r).map_err(|e| (k, e))?;
            joints.push(pose.joints);
            commands.push([
                pose.legs_mm[0] - nominal.dq[0],
                pose.legs_mm[1] - nominal.dq[1],
                pose.legs_mm[2] - nominal.dq[2],
            ]);
        }
        Ok(NominalPoses {
            targets: targets.to_vec(),
            joints,
            commands,
        })
    }

    pub fn len(&self) -> usize {
        self.targets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Actual passive joints of `truth` at every pose (exact FK from the
    /// nominal solution), written into `out`.
    pub fn actual_joints_into(
        &self,
        truth: &Machine,
        out: &mut [Vector3<f64>],
    ) -> Result<(), (usize, KinematicsError)> {
        for (k, (q, guess)) in self.commands.iter().zip(&self.joints).enumerate() {
            out[k] = truth.forward(q, guess).map_err(|e| (k, e))?.as_vector();
        }
        Ok(())
    }
}

/// Simulated readings of `truth` at the poses; `sensors = None` is noise-free.
pub fn simulate_readings<R: Rng + ?Sized>(
    poses: &NominalPoses,
    truth: &Machine,
    sensors: Option<&SensorModel>,
    rng: &mut R,
) -> Result<Vec<Reading>, (usize, KinematicsError)> {
    let mut actual = vec![Vector3::zeros(); poses.len()];
    poses.actual_joints_into(truth, &mut actual)?;
    let noise = |rng: &mut R| sensors.map_or(Vector3::zeros(), |s| s.draw(rng));
    let nominal_0 = poses.joints[0].as_vector();
    let homed_0 = actual[0] + noise(rng);
    let mut out = Vec::with_capacity(poses.len());
    out.push(Reading {
        target: poses.targets[0],
        joints: poses.joints[0],
    });
    for k in 1..poses.len() {
        let read = nominal_0 + (actual[k] + noise(rng)) - homed_0;
        out.push(Reading {
            target: poses.targets[k],
            joints: Joints::from_vector(&read),
        });
    }
    Ok(out)
}
