//! Sensor noise: how a datasheet grade becomes the noise of one averaged
//! reading (docs/method.md §5), and the homing of incremental sensors. This file is
//! the only place where noise enters a reading; a new noise model is one arm
//! of [`GradeReading`] here (its name in [`GradeReading::parse`]) and its
//! draw in [`SensorModel::draw`].

use nalgebra::SVector;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;

use super::covariance::SensorCovariance;
use super::normal::Normals;
use super::structured::Structured;
use crate::mechanism::{Quantity, ReadingFact};

/// Arc-seconds in one radian.
pub use crate::mechanism::ARCSEC_PER_RAD;

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

/// The noise of one sensor set: a sensor in each of a mechanism's `R`
/// reading slots, named by the slots' facts; the angle readings' encoders
/// share one grade, the length readings' scales another.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorModel<const R: usize> {
    /// The reading slots, in the order of every reading vector: what each
    /// reads (an angle or a length) and its sensor's name.
    pub slots: &'static [ReadingFact; R],
    /// Encoder grade, arc-seconds (every angle slot).
    pub encoder_arcsec: f64,
    /// Linear-scale grade, µm (every length slot).
    pub scale_um: f64,
    /// Samples averaged per reading.
    pub samples: u32,
    pub reading: GradeReading,
    /// Datasheet models of the sensors (docs/method.md §11), when the config has them;
    /// then they, not `reading`, make the readings.
    pub structured: Option<Structured<R>>,
}

impl<const R: usize> SensorModel<R> {
    /// Per-sample noise parameter (σ for Gaussian, bound for uniform) of
    /// each reading in the model's units (rad, mm): the encoders' grade for
    /// an angle, the scale's for a length.
    fn sample_scale(&self) -> SVector<f64, R> {
        SVector::from_fn(|k, _| {
            let q = self.slots[k].quantity;
            let grade = match q {
                Quantity::Angle => self.encoder_arcsec,
                Quantity::Length => self.scale_um,
            };
            q.from_sensor(grade)
        })
    }

    /// Standard deviation of one averaged reading of each slot (rad, mm)
    /// (for structured sensors the σ of [`Structured::sigma`]).
    pub fn reading_sigma(&self) -> SVector<f64, R> {
        if let Some(s) = &self.structured {
            return s.sigma(self.samples);
        }
        let per_sample = match self.reading {
            GradeReading::Sigma => 1.0,
            GradeReading::Uniform => 1.0 / 3f64.sqrt(),
        };
        self.sample_scale() * per_sample / (self.samples as f64).sqrt()
    }

    /// The per-component scale of this sensor set's noise: an averaged
    /// reading's noise is `unit_scale() ⊙ unit_draw()` (σ of the reading for
    /// the Gaussian reading, the per-sample bound for the uniform one).
    #[inline]
    pub fn unit_scale(&self) -> SVector<f64, R> {
        match self.reading {
            GradeReading::Sigma => self.reading_sigma(),
            GradeReading::Uniform => self.sample_scale(),
        }
    }

    /// One averaged reading's noise in units of [`SensorModel::unit_scale`]:
    /// Gaussian, a standard normal a slot (exactly the distribution of the
    /// mean of `samples` draws once scaled by σ/√samples); uniform, the mean
    /// of `samples` draws uniform in [−1, 1]. It does not depend on the grade,
    /// so every grade of a trial can share it (common random numbers).
    #[inline]
    pub fn unit_draw<G: Rng + ?Sized>(&self, rng: &mut G) -> SVector<f64, R> {
        match self.reading {
            GradeReading::Sigma => SVector::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)),
            GradeReading::Uniform => {
                let mut acc = SVector::<f64, R>::zeros();
                for _ in 0..self.samples {
                    for k in 0..R {
                        acc[k] += rng.random_range(-1.0..=1.0);
                    }
                }
                acc / self.samples as f64
            }
        }
    }

    /// Each sensor's σ of the part of a reading drawn afresh at each
    /// reading (rad, mm): a datasheet axis's jitter and quantisation
    /// ([`super::structured::Axis::fresh_sigma`]), the paper's grade
    /// whole. What repeats of a pose average.
    pub fn fresh_sigma(&self) -> SVector<f64, R> {
        match &self.structured {
            Some(st) => SVector::from_fn(|k, _| st.axes[k].fresh_sigma(self.samples)),
            None => self.reading_sigma(),
        }
    }

    /// The sensors in words, as the readings are made: each datasheet
    /// axis by its accuracy ±a ("psi4 encoder datasheet ±2.5″"), the others
    /// by the paper's reading of their grade ("theta4 encoder 1.5″"); with
    /// no datasheet at all, "encoder 0.8″, scale 0.5 µm".
    pub fn in_words(&self) -> String {
        let Some(st) = &self.structured else {
            return format!(
                "encoder {}″, scale {} µm",
                self.encoder_arcsec, self.scale_um
            );
        };
        // The grade in the datasheet's unit, without conversion noise.
        let clean = |x: f64| (x * 1e9).round() / 1e9;
        self.slots
            .iter()
            .zip(st.axes.iter().zip(st.from_section))
            .map(|(r, (axis, sheet))| {
                let (unit, sym, grade) = match r.quantity {
                    Quantity::Angle => (ARCSEC_PER_RAD, "″", self.encoder_arcsec),
                    Quantity::Length => (1e3, " µm", self.scale_um),
                };
                let name = r.sensor_ascii;
                match sheet {
                    true => format!("{name} datasheet ±{}{sym}", clean(axis.accuracy * unit)),
                    false => format!("{name} {grade}{sym}"),
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// One averaged reading's noise: `unit_scale() ⊙ unit_draw()`.
    #[inline]
    pub fn draw<G: Rng + ?Sized>(&self, rng: &mut G) -> SVector<f64, R> {
        self.unit_scale().component_mul(&self.unit_draw(rng))
    }
}

impl<const R: usize> SensorModel<R> {
    /// Each slot's sensor's covariance under this set's model: the
    /// datasheet curves when it has them, else white noise of
    /// [`SensorModel::reading_sigma`].
    pub fn covariances(&self) -> [SensorCovariance; R] {
        match &self.structured {
            Some(st) => {
                std::array::from_fn(|k| SensorCovariance::of_axis(&st.axes[k], self.samples))
            }
            None => {
                let s = self.reading_sigma();
                std::array::from_fn(|k| SensorCovariance::white(s[k]))
            }
        }
    }

    /// This set with its interpolation errors weighted as white noise (no
    /// assumed coherence): what a study's estimators use, weighting at the
    /// nominal readings (docs/method.md §18).
    pub fn white_interpolation(&self) -> SensorModel<R> {
        let mut s = *self;
        if let Some(st) = s.structured.as_mut() {
            for a in st.axes.iter_mut() {
                a.weight_coherence = 0.0;
            }
        }
        s
    }

    /// Each sensor's covariance for what the tool states (uncertainties,
    /// χ², held-out spreads, predicted accuracy): as
    /// [`SensorModel::covariances`] with the interpolation error's kernel
    /// ([`SensorCovariance::stated_of_axis`]); evaluate it at the measured
    /// readings.
    pub fn stated_covariances(&self) -> [SensorCovariance; R] {
        match &self.structured {
            Some(st) => {
                std::array::from_fn(|k| SensorCovariance::stated_of_axis(&st.axes[k], self.samples))
            }
            None => self.covariances(),
        }
    }
}

/// Noise of homed incremental sensors at `poses` poses: the reference
/// reading's noise n_0 is drawn first (homing reads it), then n_j for
/// j = 1 … poses−1 in pose order; `f(j, n_j, n_0)` receives each. Every
/// simulated reading (`simulate`, the sweep's trials) draws its noise here,
/// so the same stream gives the same noise whatever consumes it.
#[inline]
pub fn homed_noise<const R: usize, G: Rng + ?Sized>(
    sensor: &SensorModel<R>,
    rng: &mut G,
    poses: usize,
    mut f: impl FnMut(usize, SVector<f64, R>, SVector<f64, R>),
) {
    let n0 = sensor.draw(rng);
    for j in 1..poses {
        f(j, sensor.draw(rng), n0);
    }
}

/// The homed noise of every row of l in units of the sensor's
/// [`SensorModel::unit_scale`]: `out[R(j−1) + c] = u_j[c] − u_0[c]`, drawn
/// in the order [`homed_noise`] draws (reference first), so that row r of a
/// grade's noisy observation is `l0[r] + unit_scale[r mod R] · out[r]`.
/// Normal draws (the paper's reading) come through [`Normals::fill`]: the
/// same draws as [`SensorModel::unit_draw`], in the same order, with the
/// ziggurat's common case in the loop.
#[inline]
pub fn homed_unit_noise<const R: usize, G: Rng + Clone>(
    sensor: &SensorModel<R>,
    rng: &mut G,
    out: &mut [f64],
) {
    if sensor.reading == GradeReading::Sigma {
        homed_unit_normals::<R, G>(rng, out);
        return;
    }
    let u0 = sensor.unit_draw(rng);
    for row in out.chunks_exact_mut(R) {
        let d = sensor.unit_draw(rng) - u0;
        row.copy_from_slice(d.as_slice());
    }
}

/// Homed standard-normal noise of a pose set with `N` readings a pose:
/// `out[N(j−1) + c] = u_j[c] − u_0[c]`, the reference's `u_0` drawn first
/// (the mechanism's Gaussian readings in [`homed_unit_noise`], any
/// topology's white-noise study in `montecarlo::generic`).
#[inline]
pub fn homed_unit_normals<const N: usize, R: Rng + Clone>(rng: &mut R, out: &mut [f64]) {
    let mut u0 = [0.0; N];
    Normals::get().fill(rng, &mut u0);
    Normals::get().fill(rng, out);
    for row in out.chunks_exact_mut(N) {
        for (x, u) in row.iter_mut().zip(u0) {
            *x -= u;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{N_READINGS, SLOTS};
    use nalgebra::Vector3;
    use rand::SeedableRng;

    fn model(reading: GradeReading, samples: u32) -> SensorModel<N_READINGS> {
        SensorModel {
            slots: SLOTS,
            encoder_arcsec: 2.0,
            scale_um: 0.5,
            samples,
            reading,
            structured: None,
        }
    }

    /// Sample mean and standard deviation of each component of `n` draws.
    fn moments(
        s: &SensorModel<N_READINGS>,
        n: usize,
    ) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(11);
        let (mut sum, mut sq, mut max) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
        for _ in 0..n {
            let d: Vector3<f64> = s.draw(&mut rng);
            sum += d;
            sq += d.component_mul(&d);
            max = max.sup(&d.abs());
        }
        let mean = sum / n as f64;
        let var = sq / n as f64 - mean.component_mul(&mean);
        (mean, var.map(f64::sqrt), max)
    }

    #[test]
    fn every_noise_model_has_its_stated_sigma() {
        let n = 200_000;
        for reading in [GradeReading::Sigma, GradeReading::Uniform] {
            for samples in [1, 3] {
                let s = model(reading, samples);
                let (mean, sd, max) = moments(&s, n);
                let want = s.reading_sigma();
                for k in 0..3 {
                    // Standard error of a standard deviation: σ/√(2n) ≈ 0.16 %.
                    let rel = sd[k] / want[k] - 1.0;
                    assert!(
                        rel.abs() < 0.01,
                        "{reading:?} x{samples} row {k}: sd {} vs {}",
                        sd[k],
                        want[k]
                    );
                    assert!(mean[k].abs() < 5.0 * want[k] / (n as f64).sqrt());
                }
                if reading == GradeReading::Uniform {
                    // A mean of uniform draws never leaves the ±grade bound.
                    let bound = Vector3::new(2.0 / ARCSEC_PER_RAD, 2.0 / ARCSEC_PER_RAD, 0.5e-3);
                    assert!((0..3).all(|k| max[k] <= bound[k]));
                    if samples == 1 {
                        assert!((0..3).all(|k| max[k] > 0.99 * bound[k]));
                    }
                }
            }
        }
    }

    #[test]
    fn stated_sigma_is_the_grade_reading() {
        let s = model(GradeReading::Sigma, 1).reading_sigma();
        assert!((s.x * ARCSEC_PER_RAD - 2.0).abs() < 1e-12 && (s.z - 0.5e-3).abs() < 1e-18);
        let u = model(GradeReading::Uniform, 3).reading_sigma();
        assert!((u.z - 0.5e-3 / 3f64.sqrt() / 3f64.sqrt()).abs() < 1e-18);
        assert_eq!(GradeReading::parse("uniform"), Some(GradeReading::Uniform));
        assert_eq!(GradeReading::parse("sigma"), Some(GradeReading::Sigma));
        assert_eq!(GradeReading::parse("bound"), None);
    }

    #[test]
    fn homing_shares_the_reference_noise() {
        // l_j = n_j − n_0: Var = 2σ², Cov(l_j, l_k) = σ² for j ≠ k.
        let s = model(GradeReading::Sigma, 1);
        let sigma = s.reading_sigma().z;
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(5);
        let n = 100_000;
        let (mut v1, mut c12) = (0.0, 0.0);
        for _ in 0..n {
            let mut d = [0.0; 2];
            homed_noise(&s, &mut rng, 3, |j, nj, n0| d[j - 1] = (nj - n0).z);
            v1 += d[0] * d[0];
            c12 += d[0] * d[1];
        }
        let (v1, c12) = (
            v1 / n as f64 / (sigma * sigma),
            c12 / n as f64 / (sigma * sigma),
        );
        assert!((v1 - 2.0).abs() < 0.03, "variance {v1} σ²");
        assert!((c12 - 1.0).abs() < 0.03, "covariance {c12} σ²");
    }
}
