//! Sensor noise: how a datasheet grade becomes the noise of one averaged
//! reading (SPEC §5), and the homing of incremental sensors. This file is
//! the only place where noise enters a reading; a new noise model is one arm
//! of [`GradeReading`] here (its name in [`GradeReading::parse`]) and its
//! draw in [`SensorModel::draw`].

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

impl GradeReading {
    /// The names a config may use (`sensors.noise_model`).
    pub const NAMES: &'static str =
        "\"sigma\" (grade = standard deviation) or \"uniform\" (grade = ±bound)";

    /// The reading of a config name.
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "sigma" => Some(GradeReading::Sigma),
            "uniform" => Some(GradeReading::Uniform),
            _ => None,
        }
    }
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

/// Noise of homed incremental sensors at `poses` poses: the reference
/// reading's noise n_0 is drawn first (homing reads it), then n_j for
/// j = 1 … poses−1 in pose order; `f(j, n_j, n_0)` receives each. Every
/// simulated reading (`simulate`, the sweep's trials) draws its noise here,
/// so the same stream gives the same noise whatever consumes it.
#[inline]
pub fn homed_noise<R: Rng + ?Sized>(
    sensor: &SensorModel,
    rng: &mut R,
    poses: usize,
    mut f: impl FnMut(usize, Vector3<f64>, Vector3<f64>),
) {
    let n0 = sensor.draw(rng);
    for j in 1..poses {
        f(j, sensor.draw(rng), n0);
    }
}
