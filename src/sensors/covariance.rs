//! The covariance of a homed observation's reading errors (docs/method.md §13): what
//! the sensors' datasheets say about how the errors at two poses go
//! together. A repeatable curve of random phase is one unknown shape across
//! the poses, not independent noise; GLS whitens the observation with it.
//!
//! For one sensor at joint values v_i, v_j (the poses' nominal values, the
//! reference included):
//!
//!   C_ij = Σk (a·hk)²/2 · cos(k·2π·(v_i − v_j)/T) + δ_ij · white,
//!
//! white = i²/2 + (noise² + r²/12)/samples for a datasheet axis (the paper's
//! reading: σ²/samples), raised to (10⁻³·a)²/samples when below it. The
//! observation holds homed differences d_j = e_j − e_0, so per sensor
//! Σ_ij = C_ij − C_i0 − C_0j + C_00; the three sensors are independent and Σ
//! is block-diagonal by sensor in the observation's row order (row 3(j−1)+k
//! is sensor k at pose j).

use super::noise::SensorModel;
use super::structured::Axis;
use crate::model::{Joints, N_READINGS};
use nalgebra::DMatrix;

/// The most envelope harmonics of an assumed coherence (ℓ down to about
/// 1/40 of the readings' span).
pub const MAX_ENVELOPE_TERMS: usize = 256;

/// Terms a covariance holds: every harmonic, and in a stated covariance the
/// interpolation kernel and its two side terms per harmonic.
const TERMS: usize = 3 * super::structured::MAX_HARMONICS + 1;

/// One sensor's error covariance as a function of two joint values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorCovariance {
    /// (variance (a·hk)²/2, angular rate k·2π/T) of each harmonic; in a
    /// stated covariance ([`SensorCovariance::stated_of_axis`]) the
    /// interpolation error's kernel after them.
    curve: [(f64, f64); TERMS],
    harmonics: usize,
    /// Variance of the part independent from pose to pose.
    pub white: f64,
    /// The interpolation error weighted by the coherence family
    /// (i²/2)·exp(−Δ²/(2ℓ²))·cos(ω·Δ): (i²/2, ω, ℓ); its low-rank factor
    /// is built at the poses ([`super::ObservationCovariance`]).
    pub envelope: Option<(f64, f64, f64)>,
}

impl SensorCovariance {
    /// A datasheet axis read as the mean of `samples` samples.
    pub fn of_axis(axis: &Axis, samples: u32) -> Self {
        let n = samples.max(1) as f64;
        let mut curve = [(0.0, 0.0); TERMS];
        let (terms, count) = axis.curve_terms();
        for (c, t) in curve.iter_mut().zip(&terms[..count]) {
            *c = (t.variance, t.rate);
        }
        let vi = axis.interpolation_variance();
        // With an assumed coherence the interpolation error is weighted by
        // its kernel, not as white noise (docs/method.md §18).
        let envelope = (vi > 0.0 && axis.weight_coherence > 0.0).then(|| {
            (
                vi,
                std::f64::consts::TAU / axis.signal_period,
                axis.weight_coherence,
            )
        });
        let white = if envelope.is_some() { 0.0 } else { vi }
            + (axis.noise * axis.noise + axis.resolution * axis.resolution / 12.0) / n;
        let floor = (1e-3 * axis.accuracy).powi(2) / n;
        SensorCovariance {
            curve,
            harmonics: count,
            white: white.max(floor),
            envelope,
        }
    }

    /// What a datasheet axis's reading errors do across poses, for every
    /// number the tool states (docs/method.md §18): as
    /// [`SensorCovariance::of_axis`], but the interpolation error as its
    /// kernel (i²/2)·cos(ω·(v_i − v_j)), ω = 2π/P (i²/4 with two heads),
    /// instead of white — readings within a signal period of each other
    /// share it, and the rest keep a correlation that sums over many poses.
    ///
    /// Evaluated at the measured readings: each is off its true value by
    /// the curve's error c (a phase error ω·c of the carrier), so the exact
    /// kernel between measured readings is
    /// (i²/2)·cos(ω·Δ)·exp(−ω²·(σ_c² − C_c(i, j))), C_c the curve's
    /// covariance and σ_c² its variance. To second order in ω·σ_c that is
    /// ρ·(i²/2)·cos(ω·Δ) (ρ = exp(−ω²σ_c²)) plus, for each curve term k of
    /// variance c_k and rate r_k, ρ·(i²/2)·ω²·c_k/2 at the rates ω + r_k and
    /// ω − r_k: every term rank 2, so the O(n) factored form holds. What
    /// the expansion leaves out is white, so each reading's variance stays
    /// i²/2.
    pub fn stated_of_axis(axis: &Axis, samples: u32) -> Self {
        let white_weighted = Axis {
            weight_coherence: 0.0,
            ..*axis
        };
        let mut c = Self::of_axis(&white_weighted, samples);
        let vi = axis.interpolation_variance();
        if vi > 0.0 {
            let curve: Vec<(f64, f64)> = c.terms().to_vec();
            let curve_var: f64 = curve.iter().map(|t| t.0).sum();
            let rate = std::f64::consts::TAU / axis.signal_period;
            let x = rate * rate * curve_var;
            let rho = (-x).exp();
            let mut push = |var: f64, r: f64| {
                c.curve[c.harmonics] = (var, r);
                c.harmonics += 1;
            };
            push(rho * vi, rate);
            for &(var, r) in &curve {
                let side = rho * vi * rate * rate * var / 2.0;
                push(side, rate + r);
                push(side, (rate - r).abs());
            }
            let n = samples.max(1) as f64;
            let random = (axis.noise * axis.noise + axis.resolution * axis.resolution / 12.0) / n;
            let floor = (1e-3 * axis.accuracy).powi(2) / n;
            if axis.coherence > 0.0 {
                // An interpolation error of finite coherence ℓ: the carrier
                // under its envelope exp(−Δ²/(2ℓ²)), attenuated as above.
                // The side terms stay as they are, without the envelope:
                // small (ρ·x of i²/2), and what they carry is between
                // nearby readings, which two poses at one joint value share
                // whole (left white, they made the statement 2.6× large).
                c.curve[curve.len()].0 = 0.0;
                c.envelope = Some((rho * vi, rate, axis.coherence));
            }
            // What the expansion leaves out, vi·(1 − ρ·(1 + x)) = vi·ρ·(eˣ −
            // 1 − x), written so that it never overflows (ρ → 0 for a curve
            // many signal periods wide: the kernel is then white).
            let rest = if x < 1e-4 {
                rho * x * x / 2.0
            } else {
                (1.0 - rho * (1.0 + x)).max(0.0)
            };
            c.white = (vi * rest + random).max(floor);
        }
        c
    }

    /// The interpolation error alone as it is between true readings (no
    /// attenuation): its stationary carrier (i²/2)·cos(ω·Δ), or under its
    /// envelope when its coherence is finite. None without one.
    pub fn interpolation_at_truth(axis: &Axis) -> Option<Self> {
        let vi = axis.interpolation_variance();
        if vi <= 0.0 || axis.signal_period <= 0.0 {
            return None;
        }
        let rate = std::f64::consts::TAU / axis.signal_period;
        let mut c = Self::white(0.0);
        if axis.coherence > 0.0 {
            c.envelope = Some((vi, rate, axis.coherence));
        } else {
            c.curve[0] = (vi, rate);
            c.harmonics = 1;
        }
        Some(c)
    }

    /// A white-noise sensor (the paper's reading) of reading σ `sigma`.
    pub fn white(sigma: f64) -> Self {
        SensorCovariance {
            curve: [(0.0, 0.0); TERMS],
            harmonics: 0,
            white: sigma * sigma,
            envelope: None,
        }
    }

    /// The curve's part of C between joint values `u` and `v`.
    pub fn curve(&self, u: f64, v: f64) -> f64 {
        self.curve[..self.harmonics]
            .iter()
            .map(|&(var, rate)| var * (rate * (u - v)).cos())
            .sum()
    }

    /// Covariance of the homed errors d_i = e_i − e_0 and d_j = e_j − e_0 at
    /// joint values `vi`, `vj` (reference `v0`); `same` when i = j.
    pub fn homed(&self, v0: f64, vi: f64, vj: f64, same: bool) -> f64 {
        let c = self.curve(vi, vj) - self.curve(vi, v0) - self.curve(v0, vj) + self.curve(v0, v0);
        // White: δ_ij·w − 0 − 0 + w.
        c + if same { 2.0 * self.white } else { self.white }
    }

    /// The assumed-coherence kernel's rank-2 terms for readings that span
    /// `span` (their largest difference): (i²/2)·exp(−Δ²/(2ℓ²))·cos(ωΔ)
    /// with the envelope written as the Fourier series of its periodic
    /// extension of period P_e = span + 6ℓ (its nearest alias is then 6ℓ
    /// away, e^−18), each coefficient positive, so every product with the
    /// carrier is a pair of cosines at ω ± 2πm/P_e — positive semidefinite
    /// and O(n) in poses. Appends (variance, rate) to `out`; returns the
    /// variance the truncation leaves (white).
    pub fn envelope_terms(&self, span: f64, out: &mut Vec<(f64, f64)>) -> f64 {
        let Some((vi, omega, ell)) = self.envelope else {
            return 0.0;
        };
        let pe = span.max(0.0) + 6.0 * ell;
        let base = ell * std::f64::consts::TAU.sqrt() / pe;
        let mut sum = 0.0;
        // a_m ∝ exp(−(2πmℓ/P_e)²/2): past 2πmℓ/P_e = 5.7 below 10⁻⁷ of a_0.
        let last = (5.7 * pe / (std::f64::consts::TAU * ell)).ceil() as usize;
        for m in 0..=last.min(MAX_ENVELOPE_TERMS) {
            let x = std::f64::consts::TAU * m as f64 * ell / pe;
            let a = base * (-0.5 * x * x).exp() * if m == 0 { 1.0 } else { 2.0 };
            sum += a;
            if m == 0 {
                out.push((vi * a, omega));
            } else {
                let nu = std::f64::consts::TAU * m as f64 / pe;
                out.push((vi * a / 2.0, omega + nu));
                out.push((vi * a / 2.0, (omega - nu).abs()));
            }
        }
        // The periodised envelope is 1 at Δ = 0 to e^−18; what the sum
        // misses of it stays each reading's own.
        vi * (1.0 - sum).max(0.0)
    }

    /// (variance, angular rate) of each harmonic of the curve.
    pub fn terms(&self) -> &[(f64, f64)] {
        &self.curve[..self.harmonics]
    }

    /// Is there any error at all (so the covariance is positive definite)?
    pub fn is_positive(&self) -> bool {
        self.white > 0.0
    }
}

impl SensorModel {
    /// Each sensor's covariance (ψ4, θ4, q4) under this set's model: the
    /// datasheet curves when it has them, else white noise of
    /// [`SensorModel::reading_sigma`].
    pub fn covariances(&self) -> [SensorCovariance; N_READINGS] {
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
    pub fn white_interpolation(&self) -> SensorModel {
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
    pub fn stated_covariances(&self) -> [SensorCovariance; N_READINGS] {
        match &self.structured {
            Some(st) => {
                std::array::from_fn(|k| SensorCovariance::stated_of_axis(&st.axes[k], self.samples))
            }
            None => self.covariances(),
        }
    }
}

/// Σ of the homed observation at the poses of `joints` (nominal joint
/// values, reference first) as a dense matrix, entry by entry from
/// [`SensorCovariance::homed`]: 3·(n − 1) rows, row 3(j−1)+k sensor k at
/// pose j (an assumed coherence's kernel is the factored form's alone).
/// O(rows²): the reference route the tests check the factored form
/// ([`super::ObservationCovariance`], what the estimators use) against.
pub fn observation_covariance(
    cov: &[SensorCovariance; N_READINGS],
    joints: &[Joints],
) -> DMatrix<f64> {
    let n = joints.len().saturating_sub(1);
    let mut sigma = DMatrix::zeros(3 * n, 3 * n);
    let Some(reference) = joints.first() else {
        return sigma;
    };
    let v0 = reference.as_vector();
    for i in 0..n {
        let vi = joints[i + 1].as_vector();
        for j in 0..=i {
            let vj = joints[j + 1].as_vector();
            for (k, c) in cov.iter().enumerate() {
                let x = c.homed(v0[k], vi[k], vj[k], i == j);
                sigma[(3 * i + k, 3 * j + k)] = x;
                sigma[(3 * j + k, 3 * i + k)] = x;
            }
        }
    }
    sigma
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::structured::{Phases, MAX_HARMONICS};
    use rand::{RngExt, SeedableRng};

    fn axis() -> Axis {
        let mut harmonics = [0.0; MAX_HARMONICS];
        harmonics[0] = 0.8;
        harmonics[1] = 0.2;
        Axis {
            accuracy: 2e-5,
            harmonics,
            n_harmonics: 2,
            period: std::f64::consts::TAU,
            interpolation: 3e-7,
            signal_period: 1e-3,
            noise: 1e-6,
            resolution: 2e-7,
            readheads: 1,
            ..Axis::default()
        }
    }

    /// The formula against the sample covariance of the model's own curves:
    /// many machines (random phases), the homed curve errors at three
    /// joint values, by a route that never writes the cosine sum.
    #[test]
    fn the_curve_covariance_is_the_curves_sample_covariance() {
        let mut a = axis();
        a.interpolation = 0.0;
        a.noise = 0.0;
        a.resolution = 0.0;
        let c = SensorCovariance::of_axis(&a, 3);
        let v = [0.1, -0.4, 0.45];
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let n = 200_000;
        let mut acc = [[0.0; 2]; 2];
        for _ in 0..n {
            let ph = Phases {
                harmonic: std::array::from_fn(|_| rng.random_range(0.0..std::f64::consts::TAU)),
                interpolation: 0.0,
                ..Phases::default()
            };
            let d = [
                a.systematic(&ph, v[1]) - a.systematic(&ph, v[0]),
                a.systematic(&ph, v[2]) - a.systematic(&ph, v[0]),
            ];
            for i in 0..2 {
                for j in 0..2 {
                    acc[i][j] += d[i] * d[j] / n as f64;
                }
            }
        }
        for i in 0..2 {
            for j in 0..2 {
                let want = c.homed(v[0], v[1 + i], v[1 + j], i == j)
                    - c.white * (1.0 + (i == j) as u8 as f64);
                // Sample covariance of 2·10⁵ draws: a few per mille.
                assert!(
                    (acc[i][j] - want).abs() < 0.02 * acc[0][0].abs().max(acc[1][1].abs()),
                    "({i},{j}): sample {} formula {want}",
                    acc[i][j]
                );
            }
        }
    }

    /// The white term: interpolation²/2 + (noise² + r²/12)/samples, floored
    /// at (10⁻³·a)²/samples; the paper's reading σ².
    #[test]
    fn the_white_term_and_its_floor() {
        let a = axis();
        let c = SensorCovariance::of_axis(&a, 4);
        let want = 3e-7f64.powi(2) / 2.0 + (1e-12 + 4e-14 / 12.0) / 4.0;
        assert!((c.white - want).abs() < 1e-12 * want, "{} {want}", c.white);
        let mut bare = a;
        bare.interpolation = 0.0;
        bare.noise = 0.0;
        bare.resolution = 0.0;
        let f = SensorCovariance::of_axis(&bare, 4);
        assert_eq!(f.white, (1e-3 * 2e-5f64).powi(2) / 4.0);
        assert!(f.is_positive());
        bare.accuracy = 0.0;
        assert!(!SensorCovariance::of_axis(&bare, 4).is_positive());
        assert_eq!(SensorCovariance::white(3.0).white, 9.0);
        // An interpolation amplitude without a signal period is no error
        // (the model reads none, Axis::shape_at).
        let mut no_period = a;
        no_period.signal_period = 0.0;
        let want = (1e-12 + 4e-14 / 12.0) / 4.0;
        let got = SensorCovariance::of_axis(&no_period, 4).white;
        assert!((got - want).abs() < 1e-12 * want, "{got} {want}");
    }

    /// The stated covariance keeps each reading's variance whatever the
    /// curve's width in signal periods (ω²σ_c² from 10⁻⁶ to 10⁴, where
    /// e^x overflows): the kernel's terms plus the white part sum to
    /// i²/2 + the jitter's; every number finite and the kernel's share ρ
    /// falling to nothing.
    #[test]
    fn the_stated_kernel_keeps_each_readings_variance() {
        for period in [1e-1, 1e-3, 1e-5, 1e-7] {
            let a = Axis {
                shape: crate::sensors::structured::Shape::Unknown,
                n_harmonics: 6,
                interpolation: 3e-7,
                signal_period: period,
                ..axis()
            };
            let plain = SensorCovariance::of_axis(&a, 4);
            let stated = SensorCovariance::stated_of_axis(&a, 4);
            let var = |c: &SensorCovariance| c.terms().iter().map(|t| t.0).sum::<f64>() + c.white;
            assert!(stated.white.is_finite() && stated.terms().iter().all(|t| t.0.is_finite()));
            assert!(
                (var(&stated) - var(&plain)).abs() < 1e-9 * var(&plain),
                "P = {period}: {} vs {}",
                var(&stated),
                var(&plain)
            );
            // 1 + 2·6 more terms than the curve's 6.
            assert_eq!(stated.terms().len(), plain.terms().len() + 13);
        }
        // A curve many periods wide: the kernel is white.
        let wide = Axis {
            interpolation: 3e-7,
            signal_period: 1e-9,
            ..axis()
        };
        let s = SensorCovariance::stated_of_axis(&wide, 4);
        assert!(s.terms()[2].0 < 1e-300, "{:?}", s.terms()[2]);
    }

    /// Σ of white-noise sensors is σ²·(I + 11ᵀ) within each sensor (the
    /// reference reading is shared), zero across sensors.
    #[test]
    fn white_noise_shares_the_reference_reading() {
        let cov = [
            SensorCovariance::white(1.0),
            SensorCovariance::white(2.0),
            SensorCovariance::white(3.0),
        ];
        let joints: Vec<Joints> = (0..4)
            .map(|k| Joints {
                psi_rad: 0.1 * k as f64,
                theta_rad: -0.05 * k as f64,
                q4_mm: 700.0 + k as f64,
            })
            .collect();
        let s = observation_covariance(&cov, &joints);
        assert_eq!(s.shape(), (9, 9));
        for r in 0..9 {
            for c in 0..9 {
                let want = if r % 3 != c % 3 {
                    0.0
                } else {
                    let v = ((r % 3) + 1) as f64;
                    v * v * if r == c { 2.0 } else { 1.0 }
                };
                assert_eq!(s[(r, c)], want, "({r},{c})");
            }
        }
    }
}

#[cfg(test)]
mod shape_unknown_tests {
    use super::*;
    use crate::sensors::structured::Shape;
    use rand::SeedableRng;

    /// An unknown shape of order K (Dirichlet fractions and phases drawn
    /// per machine by the model itself), with eccentricity or two heads:
    /// the sample covariance of its homed curve errors at three joint
    /// values is a²/(K(K+1))·Σ cos + E²/6·cos (odd orders and E gone for
    /// two heads), and its interpolation's variance i²/2 (i²/4 for two).
    #[test]
    fn the_unknown_shape_covariance_is_the_sample_covariance_of_its_draws() {
        for (k, ecc, heads) in [(6, 0.0, 1u8), (3, 0.8, 1), (5, 0.8, 2), (1, 0.0, 1)] {
            let a = Axis {
                accuracy: 2.0,
                shape: Shape::Unknown,
                n_harmonics: k,
                eccentricity: ecc,
                readheads: heads,
                period: std::f64::consts::TAU,
                interpolation: 0.3,
                signal_period: 0.01,
                ..Axis::default()
            };
            let c = SensorCovariance::of_axis(&a, 1);
            let v = [0.1, -0.4, 0.45];
            let mut rng = rand::rngs::StdRng::seed_from_u64(11);
            let n = 200_000;
            let mut acc = [[0.0; 2]; 2];
            let mut interp = 0.0;
            for _ in 0..n {
                let ph = a.phases(&mut rng);
                let curve = |x: f64| a.curve_scale() * a.shape_at(&ph, x).0;
                let d = [curve(v[1]) - curve(v[0]), curve(v[2]) - curve(v[0])];
                for i in 0..2 {
                    for j in 0..2 {
                        acc[i][j] += d[i] * d[j] / n as f64;
                    }
                }
                interp += (a.interpolation * a.shape_at(&ph, 0.123).1).powi(2) / n as f64;
            }
            // The formula written out independently of curve_terms.
            let kk = k as f64;
            let cf = |x: f64, y: f64| -> f64 {
                let mut s = 0.0;
                for o in 1..=k {
                    if heads == 2 && o % 2 == 1 {
                        continue;
                    }
                    s += 4.0 / (kk * (kk + 1.0)) * (o as f64 * (x - y)).cos();
                }
                if heads == 1 {
                    s += ecc * ecc / 6.0 * (x - y).cos();
                }
                s
            };
            for i in 0..2 {
                for j in 0..2 {
                    let (x, y) = (v[1 + i], v[1 + j]);
                    let want = cf(x, y) - cf(x, v[0]) - cf(v[0], y) + cf(v[0], v[0]);
                    let from_model =
                        c.homed(v[0], x, y, i == j) - c.white * (1.0 + (i == j) as u8 as f64);
                    assert!(
                        (from_model - want).abs() < 1e-12,
                        "K={k}: model {from_model} formula {want}"
                    );
                    let scale = acc[0][0].abs().max(acc[1][1].abs());
                    assert!(
                        (acc[i][j] - want).abs() < 0.02 * scale,
                        "K={k} e={ecc} heads={heads} ({i},{j}): sample {} formula {want}",
                        acc[i][j]
                    );
                }
            }
            let want_i = 0.09 / 2.0 / heads as f64;
            assert!((interp / want_i - 1.0).abs() < 0.02, "{interp} vs {want_i}");
            assert!((c.white - want_i.max(4e-6)).abs() < 1e-15);
            // The Dirichlet fractions sum to 1: the curve never exceeds ±a.
            let ph = a.phases(&mut rng);
            let sum: f64 = ph.fractions[..k].iter().sum();
            assert!((sum - 1.0).abs() < 1e-12);
        }
    }
}

#[cfg(test)]
mod envelope_tests {
    use super::*;
    use crate::sensors::factored::ObservationCovariance;
    use crate::sensors::structured::Shape;

    /// The assumed-coherence kernel built from its Fourier terms is
    /// (i²/2)·exp(−Δ²/(2ℓ²))·cos(ωΔ) between any two readings within the
    /// span (dense Σ of the factored form, entry by entry against the
    /// formula, homed differences included), for a coherence from a 40th
    /// of the span to more than the span.
    #[test]
    fn the_envelope_kernel_is_the_formula() {
        for (ell, period) in [(0.05, 7e-4), (0.01, 7e-4), (0.5, 1e-3), (2.0, 3e-3)] {
            let a = Axis {
                accuracy: 1e-9,
                shape: Shape::Unknown,
                n_harmonics: 1,
                period: std::f64::consts::TAU,
                interpolation: 7e-6,
                signal_period: period,
                noise: 1e-12,
                readheads: 1,
                weight_coherence: ell,
                ..Axis::default()
            };
            let c = SensorCovariance::of_axis(&a, 1);
            let (vi, omega, _) = c.envelope.unwrap();
            let vals: Vec<f64> = (0..40)
                .map(|k| -0.5 + 0.025 * k as f64 + 1e-4 * (k * k) as f64)
                .collect();
            let joints: Vec<Joints> = vals
                .iter()
                .map(|&v| Joints {
                    psi_rad: v,
                    theta_rad: 0.0,
                    q4_mm: 700.0,
                })
                .collect();
            let cov = [
                c,
                SensorCovariance::white(1.0),
                SensorCovariance::white(1.0),
            ];
            let dense = ObservationCovariance::new(&cov, &joints).dense();
            let k = |x: f64, y: f64| {
                let d = x - y;
                vi * (-d * d / (2.0 * ell * ell)).exp() * (omega * d).cos()
            };
            let v0 = vals[0];
            let mut worst = 0.0f64;
            for i in 1..vals.len() {
                for j in 1..vals.len() {
                    let want = k(vals[i], vals[j]) - k(vals[i], v0) - k(v0, vals[j]) + k(v0, v0)
                        // the white parts (jitter, and the shared reference's)
                        + cov[0].white * (1.0 + (i == j) as u8 as f64);
                    let got = dense[(3 * (i - 1), 3 * (j - 1))];
                    worst = worst.max((got - want).abs());
                }
            }
            assert!(worst < 1e-6 * vi, "ℓ = {ell}: {worst} of {vi}");
        }
    }
}
