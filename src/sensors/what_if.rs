//! The same datasheet sensors read otherwise than their datasheets say —
//! the study's what-ifs (curves scaled, a harmonic added or moved outside
//! the model's orders, white terms scaled, rings mounted off centre) — and
//! at other grades (the sweep's axis).

use super::structured::{Axis, Shape, Structured, ECCENTRICITY_ARCSEC_PER_UM_MM, MAX_HARMONICS};

impl Axis {
    /// The same axis with its white terms (interpolation error and jitter)
    /// `factor` times the datasheet's.
    pub fn with_white_scaled(&self, factor: f64) -> Axis {
        Axis {
            interpolation: self.interpolation * factor,
            noise: self.noise * factor,
            ..*self
        }
    }

    /// The same installed ring (one whose datasheet states a mounting
    /// eccentricity and a graduation diameter D) mounted with up to `um` µm
    /// of eccentricity instead (412·e/D arc-seconds); None for an encoder
    /// with integral bearing, which has none of its own.
    pub fn with_eccentricity_um(&self, um: f64) -> Option<Axis> {
        (self.eccentricity > 0.0 && self.ring_diameter > 0.0).then(|| Axis {
            eccentricity: ECCENTRICITY_ARCSEC_PER_UM_MM * um
                / self.ring_diameter
                / super::ARCSEC_PER_RAD,
            ..*self
        })
    }
}

/// One term of a datasheet sensor's reading error, as the error budget
/// splits it: the ring's or scale's curve (its harmonics), an installed
/// ring's mounting eccentricity, the interpolation error within a signal
/// period, and the jitter with the quantisation of each sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorTerm {
    Curve,
    Eccentricity,
    Interpolation,
    Jitter,
}

impl ErrorTerm {
    /// Every term, in the budget's column order.
    pub const ALL: [ErrorTerm; 4] = [
        ErrorTerm::Curve,
        ErrorTerm::Eccentricity,
        ErrorTerm::Interpolation,
        ErrorTerm::Jitter,
    ];

    /// The term in words.
    pub fn name(self) -> &'static str {
        match self {
            ErrorTerm::Curve => "curve",
            ErrorTerm::Eccentricity => "eccentricity",
            ErrorTerm::Interpolation => "interpolation error",
            ErrorTerm::Jitter => "jitter and quantisation",
        }
    }
}

impl<const R: usize> Structured<R> {
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
                *a = a.with_white_scaled(factor);
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
            if let Some(mounted) = a.with_eccentricity_um(um).filter(|_| from) {
                *a = mounted;
            }
        }
        s
    }

    /// The same sensors with one error term read exactly (the error
    /// budget's reruns). Each machine draws exactly as before (common
    /// random numbers): the phases of a term are drawn whatever its
    /// amplitude, so a curve or interpolation error is zeroed by its
    /// amplitude; an eccentricity, whose draws depend on its being there,
    /// is set to the smallest positive amplitude (1e-308 rad, nothing a
    /// reading can show); the jitter, drawn last, is zeroed with the
    /// quantisation. Every axis is read so, the paper's white reading's
    /// jitter included.
    pub fn with_term_exact(&self, term: ErrorTerm) -> Self {
        let mut s = *self;
        for a in s.axes.iter_mut() {
            match term {
                ErrorTerm::Curve => a.accuracy = 0.0,
                ErrorTerm::Eccentricity => {
                    if a.eccentricity > 0.0 {
                        a.eccentricity = f64::MIN_POSITIVE;
                    }
                }
                ErrorTerm::Interpolation => a.interpolation = 0.0,
                ErrorTerm::Jitter => {
                    a.noise = 0.0;
                    a.resolution = 0.0;
                }
            }
        }
        s
    }

    /// The same sensors with each datasheet interpolation error coherent
    /// over `fraction` × the length the estimator assumes for it (its
    /// `weight_coherence`; an axis weighted as white is left as it is).
    pub fn with_coherence_fraction(&self, fraction: f64) -> Self {
        let mut s = *self;
        for (a, &from) in s.axes.iter_mut().zip(&self.from_section) {
            if from && a.interpolation > 0.0 && a.weight_coherence > 0.0 {
                a.coherence = fraction * a.weight_coherence;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::structured::fixtures::{encoder, scale};
    use crate::sensors::structured::Axis;
    use rand::SeedableRng;

    fn sensors() -> Structured<3> {
        let mut e = encoder(4.0, &[0.7, 0.3], 0.2);
        e.eccentricity = 3.0 / crate::sensors::ARCSEC_PER_RAD;
        e.ring_diameter = 50.0;
        e.interpolation = 1.0 / crate::sensors::ARCSEC_PER_RAD;
        e.signal_period = 144.0 / crate::sensors::ARCSEC_PER_RAD;
        let mut s = scale(2.0, &[1.0], 800.0, 0.05);
        s.interpolation = 0.0002;
        s.signal_period = 0.02;
        Structured {
            axes: [e, e, s],
            from_section: [true; 3],
        }
    }

    /// Each term read exactly: the machine draws exactly the same phases
    /// (common random numbers), and each reading loses exactly that term,
    /// computed here from its own formula; the others stay.
    #[test]
    fn a_term_read_exactly_loses_that_term_and_keeps_the_draws() {
        let st = sensors();
        let v = [0.31, -0.12, 512.3];
        for term in ErrorTerm::ALL {
            let exact = st.with_term_exact(term);
            let mut r1 = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(7);
            let mut r2 = r1.clone();
            let (p1, p2) = (st.phases(&mut r1), exact.phases(&mut r2));
            assert_eq!(p1, p2, "{term:?}: the draws moved");
            for k in 0..3 {
                let (a, b): (&Axis, &Axis) = (&st.axes[k], &exact.axes[k]);
                let ph = &p1[k];
                let x = std::f64::consts::TAU * v[k] / a.period;
                let curve: f64 = (0..a.n_harmonics)
                    .map(|h| {
                        a.accuracy * a.harmonics[h] * ((h + 1) as f64 * x + ph.harmonic[h]).sin()
                    })
                    .sum();
                let ecc = a.eccentricity * ph.eccentric * (x + ph.eccentric_phase).sin();
                let interp = a.interpolation
                    * (std::f64::consts::TAU * v[k] / a.signal_period + ph.interpolation).sin();
                let z = |_: usize| 0.8;
                let lost = a.reading(ph, v[k], 3, z) - b.reading(ph, v[k], 3, z);
                let want = match term {
                    ErrorTerm::Curve => curve,
                    ErrorTerm::Eccentricity => ecc,
                    ErrorTerm::Interpolation => interp,
                    ErrorTerm::Jitter => a.mean_noise(3) * 0.8,
                };
                let want = if k == 2 && term == ErrorTerm::Eccentricity {
                    0.0
                } else {
                    want
                };
                assert!(
                    (lost - want).abs() <= 1e-12 * (1.0 + v[k].abs()),
                    "{term:?} axis {k}: lost {lost:e}, want {want:e}"
                );
            }
        }
    }
}

#[cfg(test)]
mod coherence_tests {
    use crate::sensors::structured::fixtures::encoder;
    use rand::SeedableRng;

    /// An interpolation error of finite coherence ℓ, drawn machine by
    /// machine as the study and simulate draw it, has the covariance of the
    /// family (i²/2)·exp(−Δ²/(2ℓ²))·cos(2πΔ/P) between any two readings
    /// (one head: i²/2; two heads: i²/4), to the sampling error of 40,000
    /// machines; a stationary one (ℓ left out) the bare carrier's.
    #[test]
    fn a_coherent_interpolation_error_has_the_family_s_covariance() {
        let p = 144.0 / crate::sensors::ARCSEC_PER_RAD;
        let ell = 3f64.to_radians();
        for (heads, coherence) in [(1u8, ell), (2, ell), (1, 0.0)] {
            let mut a = encoder(0.0, &[], 0.0);
            a.interpolation = 1.0;
            a.signal_period = p;
            a.readheads = heads;
            a.coherence = coherence;
            let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(3);
            let v0 = 0.3;
            let deltas = [
                0.0,
                0.3 * p,
                0.5 * ell,
                ell,
                1.7 * ell,
                3.0 * ell + 0.25 * p,
            ];
            let mut sum = [0.0; 6];
            let n = 40_000;
            for _ in 0..n {
                let ph = a.phases(&mut rng);
                let s0 = a.systematic(&ph, v0);
                for (k, d) in deltas.iter().enumerate() {
                    sum[k] += s0 * a.systematic(&ph, v0 + d);
                }
            }
            let var = if heads == 2 { 0.25 } else { 0.5 };
            for (k, d) in deltas.iter().enumerate() {
                let env = if coherence > 0.0 {
                    (-d * d / (2.0 * ell * ell)).exp()
                } else {
                    1.0
                };
                let want = var * env * (std::f64::consts::TAU * d / p).cos();
                let got = sum[k] / n as f64;
                assert!(
                    (got - want).abs() < 0.012,
                    "heads {heads}, ℓ {coherence}, Δ {d:e}: {got:.4} against {want:.4}"
                );
            }
        }
    }
}
