//! The same datasheet sensors read otherwise than their datasheets say —
//! the study's what-ifs (curves scaled, a harmonic added or moved outside
//! the model's orders, white terms scaled, rings mounted off centre) — and
//! at other grades (the sweep's axis).

use super::structured::{Shape, Structured, ECCENTRICITY_ARCSEC_PER_UM_MM, MAX_HARMONICS};

impl Structured {
    /// The same sensors with every systematic curve (harmonics and
    /// interpolation) `factor` times the datasheet's; jitter and
    /// quantisation as they are.
    pub fn with_curves_scaled(&self, factor: f64) -> Self {
        let mut s = *self;
        for a in s.axes.iter_mut() {
            a.accuracy *= factor;
            a.interpolation *= factor;
            a.eccentricity *= factor;
        }
        s
    }

    /// The same sensors with one more harmonic (one order above the last)
    /// of `fraction` × the accuracy on each datasheet axis that has room.
    pub fn with_extra_harmonic(&self, fraction: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if from && a.n_harmonics < MAX_HARMONICS {
                a.harmonics[a.n_harmonics] = fraction;
                a.n_harmonics += 1;
            }
        }
        s
    }

    /// The same sensors with their white terms (interpolation error and
    /// jitter) `factor` times the datasheet's.
    pub fn with_white_scaled(&self, factor: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if from {
                a.interpolation *= factor;
                a.noise *= factor;
            }
        }
        s
    }

    /// The same sensors with each datasheet curve whole at the grade's
    /// bound in one harmonic just outside the orders its model holds: order
    /// K + 1 (K + 2 when two heads would cancel an odd K + 1), phase drawn
    /// per machine as ever; eccentricity as it was.
    pub fn with_curve_outside_order(&self) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if !from {
                continue;
            }
            let mut order = a.n_harmonics + 1;
            if a.readheads == 2 && order % 2 == 1 {
                order += 1;
            }
            let order = order.min(MAX_HARMONICS);
            a.shape = Shape::Listed;
            a.harmonics = [0.0; MAX_HARMONICS];
            a.harmonics[order - 1] = 1.0;
            a.n_harmonics = order;
        }
        s
    }

    /// The same sensors with each installed encoder ring (one whose
    /// datasheet states a mounting eccentricity) mounted with up to `um` µm
    /// of eccentricity instead (412·e/D arc-seconds on its diameter D);
    /// encoders with integral bearing are left as they are.
    pub fn with_eccentricity_um(&self, um: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section).take(2) {
            if from && a.eccentricity > 0.0 && a.ring_diameter > 0.0 {
                a.eccentricity =
                    ECCENTRICITY_ARCSEC_PER_UM_MM * um / a.ring_diameter / super::ARCSEC_PER_RAD;
            }
        }
        s
    }

    /// The same sensors at other grades (the sweep's axis): the encoders'
    /// accuracy set to `encoder_rad`, the scale's to `scale_mm`.
    pub fn at_grades(&self, encoder_rad: f64, scale_mm: f64) -> Self {
        let mut s = *self;
        for (k, grade) in [encoder_rad, encoder_rad, scale_mm].into_iter().enumerate() {
            if s.from_section[k] {
                s.axes[k].accuracy = grade;
            } else {
                s.axes[k].noise = grade;
            }
        }
        s
    }
}
