//! Least-squares solvers: OLS (the paper's eq. 12), WLS (rows scaled by
//! 1/σ of their sensor) and iterated Gauss–Newton identification.

use super::analysis::{analyse, svd_sorted, Identifiability};
use crate::error::KinematicsError;
use crate::model::jacobian::error_jacobian;
use crate::model::{ErrorVector, Geometry, Machine, N_PARAMS};
use crate::sensors::{NominalPoses, SensorModel};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::{Deserialize, Serialize};

/// The estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Ordinary least squares on rows that mix rad and mm (the paper).
    Ols,
    /// Each row weighted by 1/σ of its sensor.
    Wls,
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Ols => "ols",
            Method::Wls => "wls",
        }
    }

    /// Row weights for 3·n rows (ψ4, θ4, q4 per pose).
    pub fn row_weights(&self, rows: usize, sensors: &SensorModel) -> DVector<f64> {
        match self {
            Method::Ols => DVector::from_element(rows, 1.0),
            Method::Wls => {
                let s = sensors.reading_sigma();
                DVector::from_fn(rows, |r, _| 1.0 / s[r % 3])
            }
        }
    }
}

/// How to identify.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyOptions {
    pub method: Method,
    /// 1 = one linearisation at the nominal poses (the paper); more =
    /// Gauss–Newton re-linearised at the current estimate.
    pub iterations: usize,
    /// Gauss–Newton stops when the largest step component is below this, mm.
    pub tolerance_mm: f64,
    /// Relative singular-value tolerance for rank decisions.
    pub rank_tolerance: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Ols,
            iterations: 1,
            tolerance_mm: 1e-9,
            rank_tolerance: 1e-9,
        }
    }
}

/// An identification result.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// Estimates, mm (0 for unidentifiable parameters).
    pub values: ErrorVector,
    /// Standard uncertainties from the residual variance, mm (0 when unidentifiable).
    pub std_mm: ErrorVector,
    pub identifiable: [bool; N_PARAMS],
    /// RMS of the weighted residual.
    pub residual_rms: f64,
    /// Degrees of freedom m − p.
    pub dof: usize,
    /// Linearisations used.
    pub iterations: usize,
    /// False when Gauss–Newton stopped at the iteration limit.
    pub converged: bool,
}

/// A least-squares operator for a fixed design matrix: built once, applied
/// to many observation vectors without allocation (the sweep's hot path).
#[derive(Debug, Clone)]
pub struct LinearSolver {
    pub analysis: Identifiability,
    active: Vec<usize>,
    rows: usize,
    /// Row-major p × m operator mapping raw l to the active parameters.
    op: Vec<f64>,
    /// (HwᵀHw)⁻¹ restricted to the active parameters.
    cov: DMatrix<f64>,
    h: DMatrix<f64>,
    weights: DVector<f64>,
}

impl LinearSolver {
    pub fn new(h: &DMatrix<f64>, weights: &DVector<f64>, rank_tolerance: f64) -> Self {
        let hw = DMatrix::from_fn(h.nrows(), h.ncols(), |r, c| h[(r, c)] * weights[r]);
        let analysis = analyse(&hw, rank_tolerance);
        Self::with_analysis(h, weights, analysis)
    }

    /// Build with a given active set (e.g. kept from the nominal analysis
    /// during Gauss–Newton).
    pub fn with_analysis(
        h: &DMatrix<f64>,
        weights: &DVector<f64>,
        analysis: Identifiability,
    ) -> Self {
        let active: Vec<usize> = (0..N_PARAMS)
            .filter(|&c| analysis.identifiable[c])
            .collect();
        let m = h.nrows();
        let p = active.len();
        let mut hs = DMatrix::zeros(m, p);
        let mut scale = vec![0.0; p];
        for (k, &c) in active.iter().enumerate() {
            let col = DVector::from_fn(m, |r, _| h[(r, c)] * weights[r]);
            scale[k] = col.norm();
            hs.set_column(k, &(col / scale[k]));
        }
        let mut op = vec![0.0; p * m];
        let mut cov = DMatrix::zeros(p, p);
        if p > 0 && m > 0 {
            let svd = hs.svd(true, true);
            let u = svd.u.as_ref().expect("u requested");
            let v_t = svd.v_t.as_ref().expect("v_t requested");
            let sv = &svd.singular_values;
            // op = C⁻¹·V·Σ⁻¹·Uᵀ·W ; cov = C⁻¹·V·Σ⁻²·Vᵀ·C⁻¹
            for a in 0..p {
                for r in 0..m {
                    let mut acc = 0.0;
                    for s in 0..sv.len() {
                        acc += v_t[(s, a)] * u[(r, s)] / sv[s];
                    }
                    op[a * m + r] = acc * weights[r] / scale[a];
                }
                for b in 0..p {
                    let mut acc = 0.0;
                    for s in 0..sv.len() {
                        acc += v_t[(s, a)] * v_t[(s, b)] / (sv[s] * sv[s]);
                    }
                    cov[(a, b)] = acc / (scale[a] * scale[b]);
                }
            }
        }
        LinearSolver {
            analysis,
            active,
            rows: m,
            op,
            cov,
            h: h.clone(),
            weights: weights.clone(),
        }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn identifiable(&self) -> [bool; N_PARAMS] {
        let mut out = [false; N_PARAMS];
        for &c in &self.active {
            out[c] = true;
        }
        out
    }

    /// Δε̂ = op·l, zero for unidentifiable parameters. No allocation.
    #[inline]
    pub fn apply(&self, l: &[f64], out: &mut ErrorVector) {
        debug_assert_eq!(l.len(), self.rows);
        out.fill(0.0);
        for (a, &c) in self.active.iter().enumerate() {
            let row = &self.op[a * self.rows..(a + 1) * self.rows];
            out[c] = row.iter().zip(l).map(|(x, y)| x * y).sum();
        }
    }

    /// Standard deviation of each estimate predicted by the linear model for
    /// the given per-row noise σ (rows of l), mm: sqrt(diag(op·Σ_l·opᵀ)) with
    /// Σ_l the covariance of l_j = n_j − n_0 (the reference noise is shared).
    pub fn predicted_std(&self, reading_sigma: &Vector3<f64>) -> ErrorVector {
        let mut out = ErrorVector::zeros();
        let m = self.rows;
        for (a, &c) in self.active.iter().enumerate() {
            let row = &self.op[a * m..(a + 1) * m];
            let mut var = 0.0;
            for k in 0..3 {
                let s2 = reading_sigma[k] * reading_sigma[k];
                let mut sum_k = 0.0;
                let mut sq_k = 0.0;
                for j in (k..m).step_by(3) {
                    sum_k += row[j];
                    sq_k += row[j] * row[j];
                }
                // Var(Σ o_j (n_j − n_0)) = σ²(Σ o_j² + (Σ o_j)²)
                var += s2 * (sq_k + sum_k * sum_k);
            }
            out[c] = var.sqrt();
        }
        out
    }

    /// Estimate with standard uncertainties from the residual variance.
    pub fn estimate(&self, l: &DVector<f64>) -> Estimate {
        let mut values = ErrorVector::zeros();
        self.apply(l.as_slice(), &mut values);
        let resid = l - &self.h * values;
        let rss: f64 = resid
            .iter()
            .zip(self.weights.iter())
            .map(|(r, w)| (r * w) * (r * w))
            .sum();
        let dof = self.rows.saturating_sub(self.active.len());
        let s2 = if dof > 0 { rss / dof as f64 } else { 0.0 };
        let mut std_mm = ErrorVector::zeros();
        for (a, &c) in self.active.iter().enumerate() {
            std_mm[c] = (s2 * self.cov[(a, a)]).sqrt();
        }
        Estimate {
            values,
            std_mm,
            identifiable: self.identifiable(),
            residual_rms: if self.rows > 0 {
                (rss / self.rows as f64).sqrt()
            } else {
                0.0
            },
            dof,
            iterations: 1,
            converged: true,
        }
    }
}

/// Full identification from an observation vector: one linearisation at the
/// nominal poses, then (if `iterations > 1`) Gauss–Newton steps re-linearised
/// at the machine of the current estimate, with the active set of the
/// nominal analysis. FK failures of an intermediate estimate are returned.
pub fn identify(
    geometry: &Geometry,
    poses: &NominalPoses,
    h_nominal: &DMatrix<f64>,
    weights: &DVector<f64>,
    l: &DVector<f64>,
    options: &IdentifyOptions,
) -> Result<(Estimate, LinearSolver), (usize, KinematicsError)> {
    let solver = LinearSolver::new(h_nominal, weights, options.rank_tolerance);
    let mut est = solver.estimate(l);
    if options.iterations <= 1 {
        return Ok((est, solver));
    }
    let n = poses.len();
    let mut values = est.values;
    let mut converged = false;
    let mut used = 1;
    let mut previous_step = f64::INFINITY;
    let mut last = solver.clone();
    let mut jac = Vec::with_capacity(n);
    let mut x = vec![Vector3::zeros(); n];
    while used < options.iterations {
        let machine = Machine::with_errors(geometry, &values);
        poses.actual_joints_into(&machine, &mut x)?;
        jac.clear();
        for (k, xk) in x.iter().enumerate() {
            let j = crate::model::Joints::from_vector(xk);
            jac.push(error_jacobian(&machine, &j).map_err(|e| (k, e))?);
        }
        let h = super::stack_differences(&jac);
        let mut r = l.clone();
        for j in 1..n {
            let g = (x[j] - x[0]) - (poses.joints[j].as_vector() - poses.joints[0].as_vector());
            for k in 0..3 {
                r[3 * (j - 1) + k] -= g[k];
            }
        }
        let step_solver = LinearSolver::with_analysis(&h, weights, solver.analysis.clone());
        let mut step = ErrorVector::zeros();
        step_solver.apply(r.as_slice(), &mut step);
        values += step;
        used += 1;
        last = step_solver;
        let size = step.amax();
        // Converged when the step is below the tolerance, or when it has
        // stopped shrinking at round-off level (forward kinematics is exact to
        // ~1e-11 mm, so steps cannot fall below a floor of ~1e-10 mm): a step
        // no smaller than the previous one and within 100 × tolerance.
        if size < options.tolerance_mm
            || (size >= previous_step && size < 100.0 * options.tolerance_mm)
        {
            converged = true;
            break;
        }
        previous_step = size;
    }
    // Uncertainty from the last linearisation and the final residual.
    let machine = Machine::with_errors(geometry, &values);
    poses.actual_joints_into(&machine, &mut x)?;
    let mut r = l.clone();
    for j in 1..n {
        let g = (x[j] - x[0]) - (poses.joints[j].as_vector() - poses.joints[0].as_vector());
        for k in 0..3 {
            r[3 * (j - 1) + k] -= g[k];
        }
    }
    let rss: f64 = r
        .iter()
        .zip(weights.iter())
        .map(|(a, w)| (a * w) * (a * w))
        .sum();
    let s2 = if est.dof > 0 {
        rss / est.dof as f64
    } else {
        0.0
    };
    let mut std_mm = ErrorVector::zeros();
    for (a, &c) in last.active.iter().enumerate() {
        std_mm[c] = (s2 * last.cov[(a, a)]).sqrt();
    }
    est.values = values;
    est.std_mm = std_mm;
    est.residual_rms = if r.is_empty() {
        0.0
    } else {
        (rss / r.len() as f64).sqrt()
    };
    est.iterations = used;
    est.converged = converged;
    Ok((est, last))
}

/// Singular values of a matrix, descending (re-exported helper for reports).
pub fn singular_values(a: &DMatrix<f64>) -> Vec<f64> {
    svd_sorted(a).0
}
