//! One estimate under another weighting of the same design: what a study
//! that weights each simulated machine at its own readings needs
//! (`[sweep] gls_per_machine`). The operator of [`Solver::build`] would
//! be formed and applied once, so instead the whitened least squares is
//! solved directly, by a QR of the column-scaled W·H (one 3n × p
//! factorisation, no SVD), on the solver's own active set and constraints:
//! the numbers [`Solver::build`] with that weighting would give, to
//! rounding, wherever its active set stands (tested).

use super::Solver;
use crate::identify::Weighting;
use nalgebra::{DMatrix, DVector, SVector};

impl<const P: usize, const R: usize> Solver<P, R> {
    /// The estimate from observation `l` had this solver been built with
    /// `weighting` instead of its own (same design, active errors, fixed
    /// values and prior). None when the weighted design is rank-deficient
    /// on the active errors (then build the solver itself).
    pub fn estimate_reweighted(&self, weighting: &Weighting, l: &[f64]) -> Option<SVector<f64, P>> {
        self.estimates_reweighted(weighting, [l]).map(|[e]| e)
    }

    /// [`Solver::estimate_reweighted`] of several observations under the
    /// same weighting: one factorisation, one triangular solve each (a
    /// study's noisy readings and the noise-free ones beside them).
    pub fn estimates_reweighted<const K: usize>(
        &self,
        weighting: &Weighting,
        ls: [&[f64]; K],
    ) -> Option<[SVector<f64, P>; K]> {
        let m = self.rows;
        for l in ls {
            assert_eq!(l.len(), m, "one reading per observation row");
        }
        let fixed = &self.constraints.fixed;
        // The fixed errors' part of l, removed before the fit.
        let fixed_part = fixed.iter().any(Option::is_some).then(|| {
            let v = DVector::from_fn(P, |c, _| fixed[c].unwrap_or(0.0));
            &self.h * v
        });
        let p = self.active.len();
        let mut out = [SVector::<f64, P>::from_fn(|c, _| fixed[c].unwrap_or(0.0)); K];
        if p == 0 || m == 0 {
            return Some(out);
        }
        let hw = weighting.apply(&self.h.select_columns(&self.active));
        let prior = self.constraints.prior_std_mm;
        let mp = m + if prior.is_some() { p } else { 0 };
        let mut a = DMatrix::zeros(mp, p);
        let mut scale = vec![0.0; p];
        let prior_row = prior.map_or(0.0, |sp| 1.0 / sp);
        for k in 0..p {
            let col = hw.column(k);
            scale[k] = (col.norm_squared() + prior_row * prior_row).sqrt();
            if scale[k].is_nan() || scale[k] <= 0.0 {
                return None;
            }
            a.view_mut((0, k), (m, 1)).copy_from(&(col / scale[k]));
            if prior.is_some() {
                a[(m + k, k)] = prior_row / scale[k];
            }
        }
        let qr = a.qr();
        let r = qr.r();
        // A pivot this small against the largest is the rank deficiency
        // the solver's own analysis would have left out.
        let largest = r.diagonal().amax();
        if r.diagonal().iter().any(|d| d.abs() <= 1e-12 * largest) {
            return None;
        }
        for (l, out) in ls.into_iter().zip(out.iter_mut()) {
            let mut rhs = DVector::from_column_slice(l);
            if let Some(f) = &fixed_part {
                rhs -= f;
            }
            let lw = weighting.apply_vector(&rhs);
            let mut b = DVector::zeros(mp);
            b.rows_mut(0, m).copy_from(&lw);
            qr.q_tr_mul(&mut b);
            let y = r.solve_upper_triangular(&b.rows(0, p).into_owned())?;
            for (k, &c) in self.active.iter().enumerate() {
                out[c] = y[k] / scale[k];
            }
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use crate::identify::tricept::design_matrix;
    use crate::identify::tricept::LinearSolver;
    use crate::identify::Constraints;
    use crate::identify::Method;
    use crate::mechanism::tricept::{Geometry, Machine, NominalPoses, N_PARAMS};
    use crate::sensors::structured::fixtures::{encoder, paper_span_mm, scale, sensors};
    use crate::sensors::structured::Axis;
    use nalgebra::DVector;

    /// Datasheet sensors whose interpolation error GLS weights by its
    /// kernel (so each sensor's whitening is the dense block's at these
    /// pose counts).
    fn kernel_weighted() -> crate::sensors::SensorModel<3> {
        let with = |a: Axis, i: f64, p: f64, ell: f64| Axis {
            interpolation: i,
            signal_period: p,
            weight_coherence: ell,
            ..a
        };
        let e = encoder(5.0, &[0.8, 0.2], 0.1);
        let e = with(e, 7e-6, 7e-4, 0.05);
        let s = with(
            scale(2.0, &[0.6, 0.3], paper_span_mm(), 0.05),
            2e-4,
            0.02,
            10.0,
        );
        sensors([e, e, s], [true; 3], 3)
    }

    /// The estimate under another weighting is the one the solver built
    /// with that weighting gives: free, with errors fixed, with a prior,
    /// on a full-rank and a rank-deficient layout; at the nominal joints
    /// and at joints moved by a machine's reading errors.
    #[test]
    fn a_reweighted_estimate_is_the_rebuilt_solvers() {
        let full = Geometry::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-30.0, 90.0, 210.0]);
        let sensors = kernel_weighted();
        for g in [full, Geometry::paper()] {
            let nominal = Machine::nominal(&g);
            let poses =
                NominalPoses::new(&nominal, &crate::mechanism::tricept::poses::paper_targets())
                    .unwrap();
            let h = design_matrix(&nominal, &poses).unwrap();
            let l: Vec<f64> = (0..h.nrows())
                .map(|r| 1e-3 * ((r as f64) * 0.71).sin())
                .collect();
            let moved: Vec<_> = poses
                .joints
                .iter()
                .enumerate()
                .map(|(j, n)| {
                    let mut m = *n;
                    m.psi_rad += 3e-5 * (j as f64).sin();
                    m.q4_mm += 2e-3 * (j as f64 * 1.7).cos();
                    m
                })
                .collect();
            let mut fixed = Constraints::default();
            fixed.fixed[3] = Some(0.02);
            fixed.fixed[13] = Some(-0.01);
            let prior = Constraints {
                prior_std_mm: Some(0.1),
                ..Constraints::default()
            };
            for c in [Constraints::default(), fixed, prior] {
                let nominal_w = Method::Gls.weighting(&sensors, &poses.joints).unwrap();
                let study = LinearSolver::constrained(&h, &nominal_w, 1e-9, &c);
                for joints in [&poses.joints, &moved] {
                    let w = Method::Gls.weighting(&sensors, joints).unwrap();
                    if let crate::identify::Weighting::Whiten(x) = &w {
                        assert!(x.is_dense(0), "the study's pose counts whiten densely");
                    }
                    let want = LinearSolver::constrained(&h, &w, 1e-9, &c)
                        .estimate(&DVector::from_column_slice(&l))
                        .values;
                    let got = study.estimate_reweighted(&w, &l).expect("full rank");
                    for k in 0..N_PARAMS {
                        assert!(
                            (got[k] - want[k]).abs() <= 1e-9 * want.amax().max(1e-6),
                            "error {k}: {} vs {}",
                            got[k],
                            want[k]
                        );
                    }
                }
                // Another weighting changes the estimate (the test can fail).
                let w = Method::Gls.weighting(&sensors, &moved).unwrap();
                let own = study.estimate_reweighted(&w, &l).unwrap();
                let mut at_nominal = Default::default();
                study.apply(&l, &mut at_nominal);
                assert!((own - at_nominal).amax() > 1e-9);
            }
        }
    }
}
