//! Datasheet sensors for the tests of the modules above `sensors` that must not read a config (`identify`): axes in internal units (rad, mm).

use super::{Axis, Structured, MAX_HARMONICS};
use crate::mechanism::tricept::{N_READINGS, SLOTS};
use crate::sensors::{GradeReading, SensorModel, ARCSEC_PER_RAD};

/// The q4 span of the paper's workspace (the scale's default measuring
/// length, mm): from the top face's centre to the far bottom edge.
pub fn paper_span_mm() -> f64 {
    (850.0f64.powi(2) + 400.0f64.powi(2)).sqrt() - 650.0
}

/// An encoder axis of grade ±`arcsec` with these harmonic fractions and
/// jitter σ `noise_arcsec`.
pub fn encoder(arcsec: f64, harmonics: &[f64], noise_arcsec: f64) -> Axis {
    axis(
        arcsec / ARCSEC_PER_RAD,
        harmonics,
        std::f64::consts::TAU,
        noise_arcsec / ARCSEC_PER_RAD,
    )
}

/// A scale axis of grade ±`um` over `length_mm`, jitter σ `noise_um`.
pub fn scale(um: f64, harmonics: &[f64], length_mm: f64, noise_um: f64) -> Axis {
    axis(um * 1e-3, harmonics, length_mm, noise_um * 1e-3)
}

fn axis(accuracy: f64, harmonics: &[f64], period: f64, noise: f64) -> Axis {
    let mut h = [0.0; MAX_HARMONICS];
    h[..harmonics.len()].copy_from_slice(harmonics);
    Axis {
        accuracy,
        harmonics: h,
        n_harmonics: harmonics.len(),
        period,
        interpolation: 0.0,
        signal_period: 0.0,
        noise,
        resolution: 0.0,
        readheads: 1,
        ..Axis::default()
    }
}

/// The three sensors (`from_section`: which are datasheet axes) read
/// as the mean of `samples` samples.
pub fn sensors(
    axes: [Axis; N_READINGS],
    from_section: [bool; N_READINGS],
    samples: u32,
) -> SensorModel<N_READINGS> {
    SensorModel {
        slots: SLOTS,
        encoder_arcsec: axes[0].accuracy * ARCSEC_PER_RAD,
        scale_um: axes[2].accuracy * 1e3,
        samples,
        reading: GradeReading::Sigma,
        structured: Some(Structured { axes, from_section }),
    }
}
