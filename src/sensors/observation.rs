//! Readings and the observation vector (docs/method.md §5–§6; paper eq. 10),
//! for a mechanism of `R` readings a pose (the Tricept's: two encoders on
//! the B4 Hooke joint read ψ4 and θ4, a linear scale reads q4).
//!
//! The sensors are incremental and homed at the reference pose (index 0)
//! to its nominal values, so at pose j the controller reports
//!   reading_j = nominal_0 + (actual_j + n_j) − (actual_0 + n_0),
//! where n are the sensor noises (the homing reading is noisy too) and the
//! actual joints come from exact forward kinematics of the erroneous machine
//! driven with nominal inverse-kinematics commands — never from the linear
//! model: the mechanism computes them, [`homed_readings`] reads them. The
//! reference row itself reads nominal_0 (that is what homing does).
//!
//! The observation of eq. 10 is formed in one place,
//! [`crate::mechanism::homed_rows`] (here as [`observation_into`],
//! for every topology as `PoseSet::observation_into`):
//! l_j = (a_j − a_0) − (nominal_j − nominal_0), j ≥ 1, where a are readings
//! (`identify`), exact joints of the true machine (the sweep, before its
//! noise is added by [`noisy_observation`]) or of the current estimate
//! (Gauss–Newton).

use super::noise::{homed_noise, SensorModel};
use crate::mechanism::homed_rows;
use nalgebra::{DVector, SVector};
use rand::Rng;

/// What homed sensors report at poses whose true joints are `actual`
/// (reference first), the reference's nominal reading being `nominal_0`:
/// the reference reads `nominal_0`, pose j `nominal_0 + (a_j + n_j) −
/// (a_0 + n_0)`, datasheet sensors `nominal_0 + (raw_j − raw_0)` of their
/// raw readings of the true joints; `sensors = None` is noise-free.
pub fn homed_readings<const R: usize, G: Rng + Clone>(
    nominal_0: SVector<f64, R>,
    actual: &[SVector<f64, R>],
    sensors: Option<&SensorModel<R>>,
    rng: &mut G,
) -> Vec<SVector<f64, R>> {
    if actual.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(actual.len());
    out.push(nominal_0);
    let mut push = |k: usize, nk: SVector<f64, R>, n0: SVector<f64, R>| {
        out.push(nominal_0 + (actual[k] + nk) - (actual[0] + n0));
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
            let raw: Vec<SVector<f64, R>> = actual
                .iter()
                .enumerate()
                .map(|(j, a)| st.reading(&ph, a, *samples, &jitter, j))
                .collect();
            for k in 1..actual.len() {
                out.push(nominal_0 + (raw[k] - raw[0]));
            }
        }
        Some(s) => homed_noise(s, rng, actual.len(), push),
        None => (1..actual.len()).for_each(|k| push(k, SVector::zeros(), SVector::zeros())),
    }
    out
}

/// l_j = (a_j − a_0) − (nominal_j − nominal_0) for j ≥ 1, written to
/// `out[R(j−1)..Rj]` (equal to reading_j − nominal_j when the reference
/// reads nominal_0, as homing makes it; robust to a controller that logs a
/// homing offset).
#[inline]
pub fn observation_into<const R: usize, J: Copy + Into<SVector<f64, R>>>(
    nominal: &[J],
    a: &[SVector<f64, R>],
    out: &mut [f64],
) {
    homed_rows(nominal.len(), |j| nominal[j].into(), a, out);
}

/// [`observation_into`] as a new vector (R rows per pose after the reference).
pub fn observation_vector<const R: usize, J: Copy + Into<SVector<f64, R>>>(
    nominal: &[J],
    a: &[SVector<f64, R>],
) -> DVector<f64> {
    let mut l = DVector::zeros(R * nominal.len().saturating_sub(1));
    observation_into(nominal, a, l.as_mut_slice());
    l
}

/// The observation the sensors report: `l0` (the noise-free observation of
/// the true machine) plus the homed noise n_j − n_0 of each row. No allocation.
#[inline]
pub fn noisy_observation<const R: usize, G: Rng + ?Sized>(
    sensor: &SensorModel<R>,
    rng: &mut G,
    l0: &[f64],
    out: &mut [f64],
) {
    homed_noise(sensor, rng, l0.len() / R + 1, |j, nj, n0| {
        let d = nj - n0;
        for c in 0..R {
            out[R * (j - 1) + c] = l0[R * (j - 1) + c] + d[c];
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{Quantity, ReadingFact, ARCSEC_PER_RAD};
    use crate::sensors::GradeReading;
    use nalgebra::Vector2;
    use rand::SeedableRng;

    /// A scale then an encoder (not the Tricept's layout). Noise-free, the
    /// homed readings' observation is (a_j − a_0) − (nominal_j − nominal_0);
    /// with noise the reference still reads its nominal value, each later
    /// reading's spread about the noise-free one is √2 σ of its own slot
    /// (n_j − n_0: 3 µm on the scale, 2″ on the encoder, 16 samples
    /// averaged), and two later poses' errors share the reference's noise
    /// (their covariance σ² on each slot).
    #[test]
    fn homed_readings_of_any_slot_layout() {
        static SLOTS: [ReadingFact; 2] = [
            ReadingFact::named("a scale", Quantity::Length),
            ReadingFact::named("an encoder", Quantity::Angle),
        ];
        let nominal = [
            Vector2::new(600.0, 0.1),
            Vector2::new(650.0, -0.2),
            Vector2::new(700.0, 0.3),
        ];
        let actual = [
            Vector2::new(600.01, 0.1001),
            Vector2::new(650.03, -0.1997),
            Vector2::new(699.98, 0.3002),
        ];
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(1);
        let exact = homed_readings(nominal[0], &actual, None, &mut rng);
        let l = observation_vector(&nominal, &exact);
        for j in 1..3 {
            let want = (actual[j] - actual[0]) - (nominal[j] - nominal[0]);
            for k in 0..2 {
                assert!((l[2 * (j - 1) + k] - want[k]).abs() < 1e-12);
            }
        }
        let sensors = SensorModel {
            slots: &SLOTS,
            encoder_arcsec: 8.0,
            scale_um: 12.0,
            samples: 16,
            reading: GradeReading::Sigma,
            structured: None,
        };
        let trials = 20_000;
        let (mut sq, mut cross) = ([0.0; 2], [0.0; 2]);
        for _ in 0..trials {
            let read = homed_readings(nominal[0], &actual, Some(&sensors), &mut rng);
            assert_eq!(read[0], nominal[0]);
            let (d1, d2) = (read[1] - exact[1], read[2] - exact[2]);
            for k in 0..2 {
                sq[k] += d2[k] * d2[k];
                cross[k] += d1[k] * d2[k];
            }
        }
        let sigma = [3e-3, 2.0 / ARCSEC_PER_RAD];
        for k in 0..2 {
            let ratio = (sq[k] / trials as f64).sqrt() / (2f64.sqrt() * sigma[k]);
            // 20,000 draws: the ratio's sampling error is 0.5 %, the
            // shared part's (σ² of 2σ⁴/n spread) 1 %.
            assert!((ratio - 1.0).abs() < 0.025, "slot {k}: {ratio}");
            let shared = cross[k] / trials as f64 / (sigma[k] * sigma[k]);
            assert!((shared - 1.0).abs() < 0.05, "slot {k}: shared {shared}");
        }
    }

    /// From one stream, the homed readings are the stream's draws in the
    /// order homing takes them: the reference's noise n_0 first, then each
    /// later pose's, reading_j = nominal_0 + (a_j + n_j) − (a_0 + n_0);
    /// datasheet sensors read nominal_0 + (raw_j − raw_0), raw_j their
    /// reference reading of the true joints after the machine's draws.
    #[test]
    fn homed_readings_take_the_streams_draws_in_order() {
        use crate::sensors::structured::fixtures::{encoder, scale};
        use crate::sensors::Structured;
        static SLOTS: [ReadingFact; 2] = [
            ReadingFact::named("a scale", Quantity::Length),
            ReadingFact::named("an encoder", Quantity::Angle),
        ];
        let actual = [
            Vector2::new(600.01, 0.1001),
            Vector2::new(650.03, -0.1997),
            Vector2::new(699.98, 0.3002),
        ];
        let nominal_0 = Vector2::new(600.0, 0.1);
        let white = SensorModel {
            slots: &SLOTS,
            encoder_arcsec: 8.0,
            scale_um: 12.0,
            samples: 4,
            reading: GradeReading::Sigma,
            structured: None,
        };
        let sheet = SensorModel {
            structured: Some(Structured {
                axes: [
                    scale(3.0, &[0.8], 400.0, 0.05),
                    encoder(5.0, &[0.7, 0.3], 0.1),
                ],
                from_section: [true; 2],
            }),
            ..white
        };
        for seed in 0..5 {
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
            let got = homed_readings(nominal_0, &actual, Some(&white), &mut rng);
            let mut same = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
            let n0 = white.draw(&mut same);
            for j in 1..3 {
                let nj = white.draw(&mut same);
                assert_eq!(got[j], nominal_0 + (actual[j] + nj) - (actual[0] + n0));
            }
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
            let got = homed_readings(nominal_0, &actual, Some(&sheet), &mut rng);
            let st = sheet.structured.unwrap();
            let mut same = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
            let (ph, jitter) = st.machine(&mut same, 4, 3);
            let raw: Vec<_> = (0..3)
                .map(|j| st.reading(&ph, &actual[j], 4, &jitter, j))
                .collect();
            assert_eq!(got[0], nominal_0);
            for j in 1..3 {
                assert_eq!(got[j], nominal_0 + (raw[j] - raw[0]));
                assert!(
                    got[j] != nominal_0 + (actual[j] - actual[0]),
                    "the sensors read"
                );
            }
        }
    }
}
