//! Σ of the homed observation in factored form, and GLS's whitening from
//! it, in O(n·r²) time and O(n·r) memory for n poses (docs/method.md §13).
//!
//! Sensor k's curve is Σh A_h·cos(ω_h v) + B_h·sin(ω_h v) with A_h, B_h
//! independent of variance var_h, the same at every pose; its white part is
//! independent from pose to pose (variance w_k) and the homed reading
//! d_j = e_j − e_0 shares e_0. So, over sensor k's rows (row 3(j−1)+k),
//!
//!   Σ_k = w_k·I + U_k·U_kᵀ,   U_k row j = [√var_h·(cos ω_h v_j − cos ω_h v_0),
//!                                          √var_h·(sin ω_h v_j − sin ω_h v_0), …, √w_k]
//!
//! (the last column is the shared reference reading's white part): r_k =
//! 2·harmonics + 1 columns, and the sensors are independent. With Ũ = U/√w
//! = Q·R (thin QR, Q orthonormal) and S = I + R·Rᵀ = V·Λ·Vᵀ,
//!
//!   Σ_k^(−1/2) = w^(−1/2)·(I + Q·(S^(−1/2) − I)·Qᵀ),
//!
//! a symmetric whitening W with WᵀW = Σ⁻¹ applied to a vector in O(n·r).
//! GLS's estimate does not depend on which W is used (any two differ by an
//! orthogonal factor), so this one gives the dense Cholesky route's numbers
//! to rounding (tested), and Σ itself is never formed.

use super::covariance::SensorCovariance;
use crate::model::{Joints, N_READINGS};
use nalgebra::{DMatrix, DVector};

/// Σ of the homed observation at some poses, per sensor w·I + U·Uᵀ.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservationCovariance {
    /// Poses after the reference (rows = 3·n).
    n: usize,
    white: [f64; N_READINGS],
    /// Sensor k's U (n × r_k), its rows in pose order.
    u: [DMatrix<f64>; N_READINGS],
}

/// Columns of one sensor's factor: two per harmonic and the reference's,
/// and with an assumed coherence at most two per envelope term (an upper
/// bound: the count depends on the readings' span).
pub fn factor_columns(cov: &SensorCovariance) -> usize {
    let envelope = if cov.envelope.is_some() {
        2 * (2 * super::covariance::MAX_ENVELOPE_TERMS + 1)
    } else {
        0
    };
    2 * cov.terms().len() + 1 + envelope
}

impl ObservationCovariance {
    /// Σ at the poses of `joints` (nominal joint values, reference first).
    pub fn new(cov: &[SensorCovariance; N_READINGS], joints: &[Joints]) -> Self {
        let n = joints.len().saturating_sub(1);
        let v0 = joints.first().map(|j| j.as_vector());
        let mut white = [0.0; N_READINGS];
        let u = std::array::from_fn(|k| {
            let c = &cov[k];
            let mut terms = c.terms().to_vec();
            // An assumed coherence's kernel: its terms over the readings' span.
            let (lo, hi) = joints
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), j| {
                    let v = j.as_vector()[k];
                    (a.min(v), b.max(v))
                });
            let span = if hi >= lo { hi - lo } else { 0.0 };
            white[k] = c.white + c.envelope_terms(span, &mut terms);
            let mut u = DMatrix::zeros(n, 2 * terms.len() + 1);
            if let Some(v0) = v0 {
                for i in 0..n {
                    let v = joints[i + 1].as_vector()[k];
                    for (h, &(var, rate)) in terms.iter().enumerate() {
                        let s = var.max(0.0).sqrt();
                        u[(i, 2 * h)] = s * ((rate * v).cos() - (rate * v0[k]).cos());
                        u[(i, 2 * h + 1)] = s * ((rate * v).sin() - (rate * v0[k]).sin());
                    }
                    u[(i, 2 * terms.len())] = white[k].max(0.0).sqrt();
                }
            }
            u
        });
        ObservationCovariance { n, white, u }
    }

    /// Rows of the observation (3 per pose after the reference).
    pub fn rows(&self) -> usize {
        N_READINGS * self.n
    }

    /// Sensor k's rows of the m × c matrix `x`, as an n × c matrix.
    fn gather(&self, x: &DMatrix<f64>, k: usize) -> DMatrix<f64> {
        DMatrix::from_fn(self.n, x.ncols(), |i, c| x[(N_READINGS * i + k, c)])
    }

    fn scatter(&self, y: &DMatrix<f64>, k: usize, out: &mut DMatrix<f64>) {
        for c in 0..y.ncols() {
            for i in 0..self.n {
                out[(N_READINGS * i + k, c)] = y[(i, c)];
            }
        }
    }

    /// Σ·X for an m × c matrix X, in O(m·r·c).
    pub fn mul(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(x.nrows(), self.rows(), "one row of X per observation row");
        let mut out = DMatrix::zeros(x.nrows(), x.ncols());
        for k in 0..N_READINGS {
            let xk = self.gather(x, k);
            let y = &xk * self.white[k] + &self.u[k] * (self.u[k].transpose() * &xk);
            self.scatter(&y, k, &mut out);
        }
        out
    }

    /// A·Σ·Aᵀ for a c × m matrix A (an operator's covariance), in O(m·r·c).
    pub fn sandwich(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        let s = a * self.mul(&a.transpose());
        (&s + s.transpose()) * 0.5
    }

    /// Σ's diagonal: each reading's variance.
    pub fn diagonal(&self) -> DVector<f64> {
        DVector::from_fn(self.rows(), |r, _| {
            let (i, k) = (r / N_READINGS, r % N_READINGS);
            self.white[k] + self.u[k].row(i).norm_squared()
        })
    }

    /// Σ as a dense matrix: O(rows²) memory, for tests and small checks.
    pub fn dense(&self) -> DMatrix<f64> {
        let m = self.rows();
        let mut s = DMatrix::zeros(m, m);
        for k in 0..N_READINGS {
            let uk = &self.u[k];
            let b = uk * uk.transpose();
            for i in 0..self.n {
                for j in 0..self.n {
                    s[(N_READINGS * i + k, N_READINGS * j + k)] =
                        b[(i, j)] + if i == j { self.white[k] } else { 0.0 };
                }
            }
        }
        s
    }

    /// The symmetric whitening W = Σ^(−1/2); Err when some sensor has no
    /// error independent from pose to pose (Σ would not be positive
    /// definite).
    pub fn whitening(&self) -> Result<Whitening, String> {
        if self.n > 0 && self.white.iter().any(|&w| !(w > 0.0 && w.is_finite())) {
            return Err(
                "the sensors' error covariance is not positive definite (is some sensor error-free?)"
                    .to_string(),
            );
        }
        let mut q = std::array::from_fn(|_| DMatrix::zeros(0, 0));
        let mut m = std::array::from_fn(|_| DMatrix::zeros(0, 0));
        for k in 0..N_READINGS {
            if self.n == 0 {
                continue;
            }
            let ut = &self.u[k] / self.white[k].sqrt();
            let qr = ut.qr();
            let (qk, rk) = (qr.q(), qr.r());
            let s = DMatrix::identity(rk.nrows(), rk.nrows()) + &rk * rk.transpose();
            let eig = s.symmetric_eigen();
            let d = eig.eigenvalues.map(|l| 1.0 / l.max(1.0).sqrt() - 1.0);
            let v = &eig.eigenvectors;
            m[k] = v * DMatrix::from_diagonal(&d) * v.transpose();
            q[k] = qk;
        }
        Ok(Whitening {
            n: self.n,
            inv_sqrt_white: std::array::from_fn(|k| 1.0 / self.white[k].sqrt()),
            q,
            m,
        })
    }

    /// Bytes the factor holds for `poses` poses with these sensors, and
    /// the whitening built from it as much again: what a caller counts
    /// before work.
    pub fn bytes_for(cov: &[SensorCovariance; N_READINGS], poses: usize) -> u64 {
        let cols: usize = cov.iter().map(factor_columns).sum();
        3 * (poses as u64) * cols as u64 * 8
    }
}

/// GLS's whitening W = Σ^(−1/2) in factored form (see the module's note).
#[derive(Debug, Clone, PartialEq)]
pub struct Whitening {
    n: usize,
    inv_sqrt_white: [f64; N_READINGS],
    /// Per sensor: Q (n × r) and S^(−1/2) − I (r × r).
    q: [DMatrix<f64>; N_READINGS],
    m: [DMatrix<f64>; N_READINGS],
}

impl Whitening {
    /// Rows it applies to.
    pub fn rows(&self) -> usize {
        N_READINGS * self.n
    }

    /// W·A for an m × c matrix A, in O(m·r·c).
    pub fn apply(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(a.nrows(), self.rows(), "one row of A per observation row");
        let mut out = DMatrix::zeros(a.nrows(), a.ncols());
        if self.n == 0 {
            return out;
        }
        for k in 0..N_READINGS {
            let ak = DMatrix::from_fn(self.n, a.ncols(), |i, c| a[(N_READINGS * i + k, c)]);
            let t = &self.m[k] * (self.q[k].transpose() * &ak);
            let y = (ak + &self.q[k] * t) * self.inv_sqrt_white[k];
            for c in 0..y.ncols() {
                for i in 0..self.n {
                    out[(N_READINGS * i + k, c)] = y[(i, c)];
                }
            }
        }
        out
    }

    /// W·v.
    pub fn apply_vector(&self, v: &DVector<f64>) -> DVector<f64> {
        let a = DMatrix::from_column_slice(v.len(), 1, v.as_slice());
        DVector::from_column_slice(self.apply(&a).as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensors::covariance::observation_covariance;
    use crate::sensors::structured::{Axis, Shape, MAX_HARMONICS};

    fn joints(n: usize) -> Vec<Joints> {
        (0..n)
            .map(|k| Joints {
                psi_rad: 0.3 * (k as f64 * 0.77).sin(),
                theta_rad: -0.25 * (k as f64 * 1.31).cos(),
                q4_mm: 700.0 + 40.0 * (k as f64 * 0.53).sin(),
            })
            .collect()
    }

    fn covs() -> Vec<[SensorCovariance; 3]> {
        let mut listed = [0.0; MAX_HARMONICS];
        listed[0] = 0.7;
        listed[1] = 0.3;
        let enc = Axis {
            accuracy: 1e-5,
            harmonics: listed,
            n_harmonics: 2,
            period: std::f64::consts::TAU,
            interpolation: 2e-7,
            signal_period: 1e-3,
            noise: 1e-7,
            readheads: 1,
            ..Axis::default()
        };
        let unknown = Axis {
            shape: Shape::Unknown,
            n_harmonics: 6,
            eccentricity: 3e-6,
            ..enc
        };
        let scale = Axis {
            accuracy: 3e-3,
            harmonics: listed,
            n_harmonics: 2,
            period: 400.0,
            interpolation: 1e-4,
            signal_period: 0.02,
            noise: 1e-5,
            readheads: 1,
            ..Axis::default()
        };
        vec![
            [
                SensorCovariance::white(1e-5),
                SensorCovariance::white(2e-5),
                SensorCovariance::white(1e-3),
            ],
            [
                SensorCovariance::of_axis(&enc, 3),
                SensorCovariance::of_axis(&unknown, 1),
                SensorCovariance::of_axis(&scale, 2),
            ],
        ]
    }

    /// The factored Σ is the dense one built entry by entry from the
    /// covariance function (an independent route), and Σ·X, A·Σ·Aᵀ and the
    /// diagonal agree with it; WᵀW·Σ = I.
    #[test]
    fn the_factored_covariance_and_its_whitening_match_the_dense_route() {
        for cov in covs() {
            for n in [1, 2, 5, 40] {
                let j = joints(n);
                let f = ObservationCovariance::new(&cov, &j);
                let dense = observation_covariance(&cov, &j);
                let scale = dense.amax().max(1e-300);
                assert!((f.dense() - &dense).amax() <= 1e-12 * scale, "n={n}");
                let m = f.rows();
                let x = DMatrix::from_fn(m, 4, |r, c| ((r * 7 + c * 3) as f64 * 0.37).sin());
                let err = (f.mul(&x) - &dense * &x).amax();
                assert!(err <= 1e-12 * scale * m as f64, "n={n} {err} {scale}");
                let a = x.transpose();
                assert!(
                    (f.sandwich(&a) - &a * &dense * a.transpose()).amax()
                        <= 1e-12 * scale * (m * m) as f64
                );
                assert!((f.diagonal() - dense.diagonal()).amax() <= 1e-12 * scale);
                if m == 0 {
                    continue;
                }
                let w = f.whitening().unwrap();
                let wd = w.apply(&DMatrix::identity(m, m));
                let should_be_i = wd.transpose() * &wd * &dense;
                assert!(
                    (should_be_i - DMatrix::identity(m, m)).amax() < 1e-7,
                    "n={n}"
                );
                // Symmetric: W = Wᵀ.
                assert!((&wd - wd.transpose()).amax() < 1e-9 * wd.amax());
            }
        }
    }

    /// A sensor without white error has no whitening.
    #[test]
    fn an_error_free_sensor_is_refused() {
        let cov = [
            SensorCovariance::white(1.0),
            SensorCovariance::white(0.0),
            SensorCovariance::white(1.0),
        ];
        let f = ObservationCovariance::new(&cov, &joints(4));
        assert!(f.whitening().is_err());
    }
}
