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
//! is block-diagonal by sensor in the observation's row order (row R(j−1)+k
//! is sensor k at pose j, R readings a pose: any mechanism's).

use super::structured::Axis;
use crate::mechanism::PoseReadings;
use nalgebra::DMatrix;

/// The most envelope harmonics of an assumed coherence (ℓ down to about
/// 1/40 of the readings' span).
pub const MAX_ENVELOPE_TERMS: usize = 256;

/// Terms a covariance holds: every harmonic, and in a stated covariance the
/// interpolation kernel and its two side terms per harmonic.
const TERMS: usize = 3 * super::structured::MAX_HARMONICS + 1;

/// An assumed coherence's kernel as a series of carrier-and-envelope rates
/// ([`SensorCovariance::envelope_series`]).
#[derive(Debug, Clone, PartialEq)]
pub struct EnvelopeSeries {
    pub omega: f64,
    pub nu: f64,
    pub variances: Vec<f64>,
    /// The variance the truncation leaves (white).
    pub rest: f64,
}

/// What the weighting by an assumed coherence's kernel keeps of the
/// interpolation variance as each reading's own (white): 10⁻⁴ of it. The
/// kernel is evaluated at the measured readings, which sit off the true
/// ones by the curve's and the interpolation's own errors, and the
/// readings hold what one linearisation leaves; without a floor a sensor
/// without jitter gets combinations of readings weighted as if nearly
/// exact, which they are not. Measured (docs/method.md §18, 76 poses, no
/// jitter, the scale's coherence 10 mm, 2,000 machines): at an assumed
/// coherence equal to the sensor's (3°) mean μ 0.0058 → 0.0045 mm, stationary 0.0054 → 0.0037, 18°
/// 0.0059 → 0.0044; at the 1° default it costs 7–14 % there, and gains
/// 23 % where the sensor's coherence is shorter still (0.3°). With jitter
/// (0.2″, the catalogue's order) the jitter exceeds it and nothing moves.
pub const KERNEL_FLOOR: f64 = 1e-4;

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
        let white = if envelope.is_some() {
            KERNEL_FLOOR * vi
        } else {
            vi
        } + (axis.noise * axis.noise + axis.resolution * axis.resolution / 12.0) / n;
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

    /// Covariance of the (unhomed) reading errors at joint values `u` and
    /// `v`, the whole kernel entry by entry (an assumed coherence's
    /// envelope exactly, not in its factored form); `same` when they are
    /// one reading. For a dense Σ over a few poses (the hexapod study).
    pub fn between(&self, u: f64, v: f64, same: bool) -> f64 {
        let mut c = self.curve(u, v) + if same { self.white } else { 0.0 };
        if let Some((var, rate, ell)) = self.envelope {
            let d = u - v;
            c += var * (-d * d / (2.0 * ell * ell)).exp() * (rate * d).cos();
        }
        c
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
        let Some(e) = self.envelope_series(span) else {
            return 0.0;
        };
        for (m, &var) in e.variances.iter().enumerate() {
            if m == 0 {
                out.push((var, e.omega));
            } else {
                let nu = e.nu * m as f64;
                out.push((var, e.omega + nu));
                out.push((var, (e.omega - nu).abs()));
            }
        }
        e.rest
    }

    /// [`SensorCovariance::envelope_terms`] as its series: the carrier ω,
    /// the envelope's fundamental ν = 2π/P_e and each order's variance (m = 0
    /// at ω; m ≥ 1 at ω + m·ν and |ω − m·ν| each), so a caller can step
    /// through the rates by rotation instead of a sine and cosine each.
    pub fn envelope_series(&self, span: f64) -> Option<EnvelopeSeries> {
        let (vi, omega, ell) = self.envelope?;
        let pe = span.max(0.0) + 6.0 * ell;
        let base = ell * std::f64::consts::TAU.sqrt() / pe;
        let mut sum = 0.0;
        // a_m ∝ exp(−(2πmℓ/P_e)²/2): past 2πmℓ/P_e = 5.7 below 10⁻⁷ of a_0.
        let last = (5.7 * pe / (std::f64::consts::TAU * ell)).ceil() as usize;
        let mut variances = Vec::with_capacity(last.min(MAX_ENVELOPE_TERMS) + 1);
        for m in 0..=last.min(MAX_ENVELOPE_TERMS) {
            let x = std::f64::consts::TAU * m as f64 * ell / pe;
            let a = base * (-0.5 * x * x).exp() * if m == 0 { 1.0 } else { 2.0 };
            sum += a;
            variances.push(if m == 0 { vi * a } else { vi * a / 2.0 });
        }
        // The periodised envelope is 1 at Δ = 0 to e^−18; what the sum
        // misses of it stays each reading's own.
        Some(EnvelopeSeries {
            omega,
            nu: std::f64::consts::TAU / pe,
            variances,
            rest: vi * (1.0 - sum).max(0.0),
        })
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

/// Σ of the homed observation at the poses of `joints` (nominal joint
/// values, reference first) as a dense matrix, entry by entry from
/// [`SensorCovariance::homed`]: R·(n − 1) rows for R readings a pose (one
/// covariance each in `cov`), row R(j−1)+k sensor k at pose j (an assumed
/// coherence's kernel is the factored form's alone).
/// O(rows²): the reference route the tests check the factored form
/// ([`super::ObservationCovariance`], what the estimators use) against.
pub fn observation_covariance<const R: usize, J: PoseReadings<R>>(
    cov: &[SensorCovariance; R],
    joints: &[J],
) -> DMatrix<f64> {
    let n = joints.len().saturating_sub(1);
    let r = cov.len();
    let mut sigma = DMatrix::zeros(r * n, r * n);
    let Some(v0) = joints.first() else {
        return sigma;
    };
    for i in 0..n {
        let vi = &joints[i + 1];
        for j in 0..=i {
            let vj = &joints[j + 1];
            for (k, c) in cov.iter().enumerate() {
                let x = c.homed(v0.reading(k), vi.reading(k), vj.reading(k), i == j);
                sigma[(r * i + k, r * j + k)] = x;
                sigma[(r * j + k, r * i + k)] = x;
            }
        }
    }
    sigma
}

#[cfg(test)]
#[path = "covariance_tests.rs"]
mod tests;
