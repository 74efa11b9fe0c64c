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
//!
//! Any number of readings a pose: one [`SensorCovariance`] per reading, in
//! the mechanism's reading order (the observation's row R(j−1)+k is
//! reading k at pose j).

use super::covariance::SensorCovariance;
use crate::mechanism::PoseReadings;
use nalgebra::{DMatrix, DVector};

/// Sensor row i's columns of an assumed coherence's kernel from column
/// `col` on, in [`SensorCovariance::envelope_terms`]'s order (ω; then ω + mν
/// and |ω − mν| for each m; a rate below zero flips its sine's column, which
/// Σ = U·Uᵀ does not see), each pair (cos, sin) at v less at v0: the rates
/// stepped by complex rotation (e^{i(ω±mν)v} = e^{iωv}·e^{±imνv}), two
/// sines and cosines per reading instead of two per term.
fn envelope_row(
    e: &super::covariance::EnvelopeSeries,
    v: f64,
    v0: f64,
    u: &mut DMatrix<f64>,
    i: usize,
    col: usize,
) {
    let unit = |x: f64| (x.cos(), x.sin());
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let (c_v, c_0) = (unit(e.omega * v), unit(e.omega * v0));
    let (s_v, s_0) = (unit(e.nu * v), unit(e.nu * v0));
    let (mut up_v, mut up_0) = ((1.0, 0.0), (1.0, 0.0));
    let mut c = col;
    for (m, &var) in e.variances.iter().enumerate() {
        let s = var.max(0.0).sqrt();
        if m == 0 {
            u[(i, c)] = s * (c_v.0 - c_0.0);
            u[(i, c + 1)] = s * (c_v.1 - c_0.1);
            c += 2;
            continue;
        }
        up_v = mul(up_v, s_v);
        up_0 = mul(up_0, s_0);
        let (p_v, p_0) = (mul(c_v, up_v), mul(c_0, up_0));
        let conj = |z: (f64, f64)| (z.0, -z.1);
        let (q_v, q_0) = (mul(c_v, conj(up_v)), mul(c_0, conj(up_0)));
        u[(i, c)] = s * (p_v.0 - p_0.0);
        u[(i, c + 1)] = s * (p_v.1 - p_0.1);
        u[(i, c + 2)] = s * (q_v.0 - q_0.0);
        u[(i, c + 3)] = s * (q_v.1 - q_0.1);
        c += 4;
    }
}

/// Σ of the homed observation at some poses, per sensor w·I + U·Uᵀ.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservationCovariance {
    /// Poses after the reference (rows = readings·n).
    n: usize,
    /// Each reading's white variance.
    white: Vec<f64>,
    /// Sensor k's U (n × r_k), its rows in pose order.
    u: Vec<DMatrix<f64>>,
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
    /// Σ at the poses of `joints` (nominal joint values, reference first),
    /// one covariance in `cov` per reading.
    pub fn new<const R: usize, J: PoseReadings<R>>(
        cov: &[SensorCovariance; R],
        joints: &[J],
    ) -> Self {
        let n = joints.len().saturating_sub(1);
        let v0 = joints.first();
        let mut white = vec![0.0; cov.len()];
        let mut reading = |k: usize| {
            let c = &cov[k];
            let terms = c.terms();
            // An assumed coherence's kernel: its terms over the readings' span.
            let (lo, hi) = joints
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), j| {
                    let v = j.reading(k);
                    (a.min(v), b.max(v))
                });
            let span = if hi >= lo { hi - lo } else { 0.0 };
            let series = c.envelope_series(span);
            white[k] = c.white + series.as_ref().map_or(0.0, |e| e.rest);
            let env_cols = series.as_ref().map_or(0, |e| 2 * e.variances.len() - 1);
            let mut u = DMatrix::zeros(n, 2 * (terms.len() + env_cols) + 1);
            let last = u.ncols() - 1;
            if let Some(v0) = v0 {
                let v0 = v0.reading(k);
                for i in 0..n {
                    let v = joints[i + 1].reading(k);
                    for (h, &(var, rate)) in terms.iter().enumerate() {
                        let s = var.max(0.0).sqrt();
                        u[(i, 2 * h)] = s * ((rate * v).cos() - (rate * v0).cos());
                        u[(i, 2 * h + 1)] = s * ((rate * v).sin() - (rate * v0).sin());
                    }
                    if let Some(e) = &series {
                        envelope_row(e, v, v0, &mut u, i, 2 * terms.len());
                    }
                    u[(i, last)] = white[k].max(0.0).sqrt();
                }
            }
            u
        };
        let u = (0..cov.len()).map(&mut reading).collect();
        ObservationCovariance { n, white, u }
    }

    /// Readings a pose.
    pub fn readings(&self) -> usize {
        self.white.len()
    }

    /// Rows of the observation (one per reading of each pose after the
    /// reference).
    pub fn rows(&self) -> usize {
        self.readings() * self.n
    }

    /// Sensor k's rows of the m × c matrix `x`, as an n × c matrix.
    fn gather(&self, x: &DMatrix<f64>, k: usize) -> DMatrix<f64> {
        let r = self.readings();
        DMatrix::from_fn(self.n, x.ncols(), |i, c| x[(r * i + k, c)])
    }

    fn scatter(&self, y: &DMatrix<f64>, k: usize, out: &mut DMatrix<f64>) {
        let r = self.readings();
        for c in 0..y.ncols() {
            for i in 0..self.n {
                out[(r * i + k, c)] = y[(i, c)];
            }
        }
    }

    /// Σ·X for an m × c matrix X, in O(m·r·c).
    pub fn mul(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        assert_eq!(x.nrows(), self.rows(), "one row of X per observation row");
        let mut out = DMatrix::zeros(x.nrows(), x.ncols());
        for k in 0..self.readings() {
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
        let readings = self.readings();
        DVector::from_fn(self.rows(), |r, _| {
            let (i, k) = (r / readings, r % readings);
            self.white[k] + self.u[k].row(i).norm_squared()
        })
    }

    /// Σ as a dense matrix: O(rows²) memory, for tests and small checks.
    pub fn dense(&self) -> DMatrix<f64> {
        let m = self.rows();
        let mut s = DMatrix::zeros(m, m);
        let r = self.readings();
        for k in 0..r {
            let uk = &self.u[k];
            let b = uk * uk.transpose();
            for i in 0..self.n {
                for j in 0..self.n {
                    s[(r * i + k, r * j + k)] =
                        b[(i, j)] + if i == j { self.white[k] } else { 0.0 };
                }
            }
        }
        s
    }

    /// A whitening W with WᵀW = Σ⁻¹; Err when some sensor has no error
    /// independent from pose to pose (Σ would not be positive definite).
    /// Per sensor, whichever form costs less at these poses: the factored
    /// Σ^(−1/2) above (O(n·r²), what a long log needs), or, when the factor
    /// has about as many columns as there are poses (a study's pose counts
    /// with an assumed coherence), the dense block's Cholesky factor
    /// (W_k = L_k⁻¹, at most [`DENSE_MAX_POSES`] poses). GLS's estimate
    /// and its covariance do not depend on which.
    pub fn whitening(&self) -> Result<Whitening, String> {
        if self.n > 0 && self.white.iter().any(|&w| !(w > 0.0 && w.is_finite())) {
            return Err(
                "the sensors' error covariance is not positive definite (is some sensor error-free?)"
                    .to_string(),
            );
        }
        let mut blocks = Vec::with_capacity(self.readings());
        for k in 0..self.readings() {
            if self.n == 0 {
                blocks.push(Block::Dense(DMatrix::zeros(0, 0)));
                continue;
            }
            if dense_is_cheaper(self.n, self.u[k].ncols()) {
                let mut s = &self.u[k] * self.u[k].transpose();
                for i in 0..self.n {
                    s[(i, i)] += self.white[k];
                }
                // Not positive definite to rounding (not seen: the white
                // part is on the diagonal): the factored form below.
                if let Some(c) = s.cholesky() {
                    blocks.push(Block::Dense(c.unpack()));
                    continue;
                }
            }
            let ut = &self.u[k] / self.white[k].sqrt();
            let qr = ut.qr();
            let (qk, rk) = (qr.q(), qr.r());
            let s = DMatrix::identity(rk.nrows(), rk.nrows()) + &rk * rk.transpose();
            let eig = s.symmetric_eigen();
            let d = eig.eigenvalues.map(|l| 1.0 / l.max(1.0).sqrt() - 1.0);
            let v = &eig.eigenvectors;
            blocks.push(Block::Factored {
                inv_sqrt_white: 1.0 / self.white[k].sqrt(),
                q: qk,
                m: v * DMatrix::from_diagonal(&d) * v.transpose(),
            });
        }
        Ok(Whitening { n: self.n, blocks })
    }

    /// Bytes the factor holds for `poses` poses with these sensors, and
    /// the whitening built from it as much again (a dense block, at most
    /// [`DENSE_MAX_POSES`]², where it is cheaper): what a caller counts
    /// before work.
    pub fn bytes_for(cov: &[SensorCovariance], poses: usize) -> u64 {
        let cols: usize = cov.iter().map(factor_columns).sum();
        let dense = (poses.min(DENSE_MAX_POSES) as u64).pow(2) * cov.len() as u64 * 8;
        3 * (poses as u64) * cols as u64 * 8 + dense
    }
}

/// The most poses a sensor's whitening is formed densely for (n × n, 0.5 MB).
pub const DENSE_MAX_POSES: usize = 256;

/// Whether n poses with an r-column factor whiten faster densely: forming
/// and factoring the block (n²·r + n³/3) against the factored form's QR and
/// eigen-decomposition (2·n·r² + 10·r³).
fn dense_is_cheaper(n: usize, r: usize) -> bool {
    let (n, r) = (n as f64, r as f64);
    n <= DENSE_MAX_POSES as f64 && n * n * (r + n / 3.0) < 2.0 * n * r * r + 10.0 * r * r * r
}

/// One sensor's whitening.
#[derive(Debug, Clone, PartialEq)]
enum Block {
    /// w^(−1/2)·(I + Q·M·Qᵀ): Q (n × r) and M = S^(−1/2) − I (r × r); symmetric.
    Factored {
        inv_sqrt_white: f64,
        q: DMatrix<f64>,
        m: DMatrix<f64>,
    },
    /// The block's Cholesky factor L (lower, n × n); W_k = L⁻¹.
    Dense(DMatrix<f64>),
}

impl Block {
    /// W_k·A (or W_kᵀ·A) for an n × c matrix, in place.
    fn apply(&self, a: &mut DMatrix<f64>, transpose: bool) {
        match self {
            Block::Factored {
                inv_sqrt_white,
                q,
                m,
            } => {
                let t = m * (q.transpose() * &*a);
                *a += q * t;
                *a *= *inv_sqrt_white;
            }
            Block::Dense(l) if transpose => {
                l.tr_solve_lower_triangular_mut(a);
            }
            Block::Dense(l) => {
                l.solve_lower_triangular_mut(a);
            }
        }
    }
}

/// GLS's whitening, per sensor (see [`ObservationCovariance::whitening`]):
/// WᵀW = Σ⁻¹.
#[derive(Debug, Clone, PartialEq)]
pub struct Whitening {
    n: usize,
    /// One block per reading.
    blocks: Vec<Block>,
}

impl Whitening {
    /// Rows it applies to.
    pub fn rows(&self) -> usize {
        self.blocks.len() * self.n
    }

    /// W·A for an m × c matrix A, in O(m·r·c) (O(m·n·c) where dense).
    pub fn apply(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        self.apply_as(a, false)
    }

    /// Wᵀ·A (W itself where every block is factored, which is symmetric).
    pub fn apply_transpose(&self, a: &DMatrix<f64>) -> DMatrix<f64> {
        self.apply_as(a, true)
    }

    fn apply_as(&self, a: &DMatrix<f64>, transpose: bool) -> DMatrix<f64> {
        assert_eq!(a.nrows(), self.rows(), "one row of A per observation row");
        let mut out = DMatrix::zeros(a.nrows(), a.ncols());
        if self.n == 0 {
            return out;
        }
        let r = self.blocks.len();
        for (k, block) in self.blocks.iter().enumerate() {
            let mut y = DMatrix::from_fn(self.n, a.ncols(), |i, c| a[(r * i + k, c)]);
            block.apply(&mut y, transpose);
            for c in 0..y.ncols() {
                for i in 0..self.n {
                    out[(r * i + k, c)] = y[(i, c)];
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

    /// Whether sensor k's whitening is the dense block's (for tests).
    pub fn is_dense(&self, k: usize) -> bool {
        matches!(self.blocks[k], Block::Dense(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{Joints, N_READINGS};
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
                // Symmetric where factored (W = Wᵀ); Wᵀ applied alike.
                for k in 0..N_READINGS {
                    if !w.is_dense(k) {
                        assert!((&wd - wd.transpose()).amax() < 1e-9 * wd.amax());
                    }
                }
                let wt = w.apply_transpose(&DMatrix::identity(m, m));
                assert!((&wt - wd.transpose()).amax() <= 1e-12 * wd.amax());
            }
        }
    }

    /// An assumed coherence's kernel: the factor built by rotation equals
    /// the homed kernel summed term by term from
    /// [`SensorCovariance::envelope_terms`] with a sine and cosine each (an
    /// independent route), whichever side of the carrier a term's rate
    /// falls; at few poses the whitening is the dense block's, at many the
    /// factored form's, and both give WᵀW·Σ = I.
    #[test]
    fn the_kernel_built_by_rotation_is_the_terms_and_whitens_either_way() {
        for (ell, period) in [(0.05, 7e-4), (0.02, 0.2)] {
            let axis = Axis {
                accuracy: 1e-5,
                shape: Shape::Unknown,
                n_harmonics: 3,
                period: std::f64::consts::TAU,
                interpolation: 5e-6,
                signal_period: period,
                noise: 1e-7,
                readheads: 1,
                weight_coherence: ell,
                ..Axis::default()
            };
            let c = SensorCovariance::of_axis(&axis, 2);
            assert!(c.envelope.is_some());
            let cov = [c, c, SensorCovariance::white(1e-3)];
            for n in [12, 300] {
                let j = joints(n);
                let f = ObservationCovariance::new(&cov, &j);
                let span = {
                    let v: Vec<f64> = j.iter().map(|x| x.psi_rad).collect();
                    v.iter().cloned().fold(f64::MIN, f64::max)
                        - v.iter().cloned().fold(f64::MAX, f64::min)
                };
                let mut terms = c.terms().to_vec();
                let rest = c.envelope_terms(span, &mut terms);
                let kernel = |a: f64, b: f64| -> f64 {
                    terms
                        .iter()
                        .map(|&(var, r)| var * (r * (a - b)).cos())
                        .sum()
                };
                let v0 = j[0].psi_rad;
                let dense = f.dense();
                let w0 = c.white + rest;
                let mut worst: f64 = 0.0;
                for a in 0..(n - 1).min(40) {
                    for b in 0..(n - 1).min(40) {
                        let (va, vb) = (j[a + 1].psi_rad, j[b + 1].psi_rad);
                        let want = kernel(va, vb) - kernel(va, v0) - kernel(v0, vb)
                            + kernel(v0, v0)
                            + if a == b { 2.0 * w0 } else { w0 };
                        worst = worst.max((dense[(3 * a, 3 * b)] - want).abs());
                    }
                }
                assert!(worst <= 1e-9 * dense[(0, 0)], "ℓ={ell} n={n}: {worst}");
                let w = f.whitening().unwrap();
                assert_eq!(w.is_dense(0), n == 12, "ℓ={ell} n={n}");
                if n == 12 {
                    let m = f.rows();
                    let wd = w.apply(&DMatrix::identity(m, m));
                    let back = wd.transpose() * &wd * &dense;
                    assert!((back - DMatrix::identity(m, m)).amax() < 1e-7);
                }
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
