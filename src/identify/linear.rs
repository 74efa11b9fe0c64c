//! The linear least-squares operator of eq. 12: Δε̂ = (HwᵀHw)⁺·Hwᵀ·W·l with
//! Hw = W·H and W the estimator's [`Weighting`] (a diagonal, or GLS's L⁻¹),
//! built once per design from an SVD of the column-equilibrated, weighted
//! H (never by inverting HᵀH), then applied to many observations without
//! allocation; and the one routine for a-posteriori uncertainties.
//!
//! Written for any topology of P errors and R readings a pose
//! ([`Solver`]): up to 16 errors one row updates every estimate in 16
//! vector lanes (the Tricept's 15: its sizes are [`super::tricept`]'s);
//! beyond, each estimate is its operator row's sum over the readings, in
//! row order as the lanes sum it.

use super::analysis::{analyse_named, Identifiability};
pub use super::constraints::Constraints;
use super::estimate::{EstimateOf, Split, Termination};
use super::weighting::Weighting;
use crate::sensors::ObservationCovariance;
use nalgebra::{DMatrix, DVector, SVector};

/// A least-squares operator for a fixed design matrix of a topology with P
/// errors and R readings a pose (rows r·j … r·j + R − 1 are pose j + 1's):
/// built once, applied to many observation vectors without allocation (the
/// sweep's hot path).
#[derive(Debug, Clone)]
pub struct Solver<const P: usize, const R: usize> {
    pub analysis: Identifiability,
    active: Vec<usize>,
    rows: usize,
    /// Row-major p × m operator mapping raw l to the active parameters.
    op: Vec<f64>,
    /// The same operator by observation row: column r of op scattered to the
    /// parameter indices (zero for unidentifiable ones), padded to 16 lanes
    /// so that one row updates all P (≤ 16) estimates in vector registers;
    /// empty for more errors (see [`Solver::wide`]).
    cols: Vec<[f64; 16]>,
    /// (HwᵀHw)⁻¹ restricted to the active parameters.
    cov: DMatrix<f64>,
    h: DMatrix<f64>,
    weighting: Weighting,
    /// The a-posteriori uncertainty is √diag(cov) itself (GLS: the weighting
    /// is the sensors' covariance), not rescaled by the residual variance.
    known_covariance: bool,
    constraints: Constraints<P>,
    /// Added to op·l: the fixed errors' values, less what their part of l
    /// would otherwise be read as (v_F − op·H_F·v_F).
    offset: SVector<f64, P>,
    /// With a prior: op's columns of the prior rows (p × p, row-major), for
    /// Gauss–Newton steps, whose prior rows read −ε/σp.
    op_prior: Vec<f64>,
}

impl<const P: usize, const R: usize> Solver<P, R> {
    /// The operator of design `h` under `weighting`, its active set from the
    /// weighted H, for a topology whose errors are `names` (its
    /// [`crate::mechanism::Topology::ERROR_NAMES`], P of them).
    pub fn named(
        h: &DMatrix<f64>,
        weighting: &Weighting,
        rank_tolerance: f64,
        names: &[&str],
    ) -> Self {
        assert_eq!(names.len(), P, "one name per error");
        let hw = weighting.apply(h);
        let analysis = analyse_named(&hw, rank_tolerance, names);
        Self::build(h, hw, weighting, analysis, &Constraints::default())
    }

    /// [`Solver::named`] holding `constraints` (fixed errors, a prior).
    pub fn constrained_named(
        h: &DMatrix<f64>,
        weighting: &Weighting,
        rank_tolerance: f64,
        (constraints, names): (&Constraints<P>, &[&str]),
    ) -> Self {
        assert_eq!(names.len(), P, "one name per error");
        let hw = weighting.apply(h);
        let analysis = analyse_named(&hw, rank_tolerance, names);
        Self::build(h, hw, weighting, analysis, constraints)
    }

    /// OLS (every row of weight 1) of a topology whose errors are `names`.
    pub fn ols_named(h: &DMatrix<f64>, rank_tolerance: f64, names: &[&str]) -> Self {
        let ones = Weighting::Rows(DVector::from_element(h.nrows(), 1.0));
        Self::named(h, &ones, rank_tolerance, names)
    }

    /// Build with a given active set (e.g. kept from the nominal analysis
    /// during Gauss–Newton) and the constraints of `like` (its fixed errors
    /// stay out of the step; no offset: a step moves from the estimate).
    pub fn with_analysis(
        h: &DMatrix<f64>,
        weighting: &Weighting,
        analysis: Identifiability,
        like: &Constraints<P>,
    ) -> Self {
        let step = Constraints {
            fixed: like.fixed.map(|f| f.map(|_| 0.0)),
            ..*like
        };
        Self::build(h, weighting.apply(h), weighting, analysis, &step)
    }

    pub(super) fn build(
        h: &DMatrix<f64>,
        hw: DMatrix<f64>,
        weighting: &Weighting,
        analysis: Identifiability,
        constraints: &Constraints<P>,
    ) -> Self {
        assert_eq!(h.ncols(), P, "one column of H per error");
        // A fixed error is not estimated; with a prior every free error is
        // (the prior determines what the readings leave).
        let prior = constraints.prior_std_mm;
        let active: Vec<usize> = (0..P)
            .filter(|&c| {
                constraints.fixed[c].is_none() && (prior.is_some() || analysis.identifiable[c])
            })
            .collect();
        let m = h.nrows();
        let p = active.len();
        let mp = m + if prior.is_some() { p } else { 0 };
        let mut hs = DMatrix::zeros(mp, p);
        let mut scale = vec![0.0; p];
        for (k, &c) in active.iter().enumerate() {
            // Columns scaled to unit norm, the prior's row included (a
            // column the readings hardly see is then the prior's).
            let col = hw.column(c).into_owned();
            let prior_row = prior.map_or(0.0, |sp| 1.0 / sp);
            scale[k] = (col.norm_squared() + prior_row * prior_row).sqrt();
            hs.view_mut((0, k), (m, 1)).copy_from(&(col / scale[k]));
            if prior.is_some() {
                hs[(m + k, k)] = prior_row / scale[k];
            }
        }
        let mut op = vec![0.0; p * m];
        let mut op_prior = vec![0.0; if prior.is_some() { p * p } else { 0 }];
        let mut cov = DMatrix::zeros(p, p);
        if p > 0 && m > 0 {
            let svd = hs.svd(true, true);
            let u = svd.u.as_ref().expect("u requested");
            let v_t = svd.v_t.as_ref().expect("v_t requested");
            let sv = &svd.singular_values;
            // op = C⁻¹·V·Σ⁻¹·Uᵀ·W ; cov = C⁻¹·V·Σ⁻²·Vᵀ·C⁻¹
            for a in 0..p {
                if prior.is_some() {
                    for b in 0..p {
                        let mut acc = 0.0;
                        for s in 0..sv.len() {
                            acc += v_t[(s, a)] * u[(m + b, s)] / sv[s];
                        }
                        op_prior[a * p + b] = acc / scale[a];
                    }
                }
                for r in 0..m {
                    let mut acc = 0.0;
                    for s in 0..sv.len() {
                        acc += v_t[(s, a)] * u[(r, s)] / sv[s];
                    }
                    op[a * m + r] = match weighting {
                        Weighting::Rows(w) => acc * w[r] / scale[a],
                        Weighting::Whiten(_) => acc / scale[a],
                    };
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
        if let Weighting::Whiten(w) = weighting {
            // The operator on whitened rows, then read through W:
            // P·W = (Wᵀ·Pᵀ)ᵀ.
            let on_white = DMatrix::from_fn(m, p, |r, a| op[a * m + r]);
            let raw = w.apply_transpose(&on_white);
            for a in 0..p {
                for r in 0..m {
                    op[a * m + r] = raw[(r, a)];
                }
            }
        }
        let mut cols = Vec::new();
        if Self::LANES {
            cols = vec![[0.0; 16]; m];
            for (a, &c) in active.iter().enumerate() {
                for (r, col) in cols.iter_mut().enumerate() {
                    col[c] = op[a * m + r];
                }
            }
        }
        // The fixed errors' part of l, read out of every estimate.
        let mut offset = SVector::<f64, P>::zeros();
        if constraints.fixed.iter().any(Option::is_some) {
            let v = DVector::from_fn(P, |c, _| constraints.fixed[c].unwrap_or(0.0));
            let part = h * &v;
            for (a, &c) in active.iter().enumerate() {
                offset[c] = -(0..m).map(|r| op[a * m + r] * part[r]).sum::<f64>();
            }
            for c in 0..P {
                if let Some(x) = constraints.fixed[c] {
                    offset[c] = x;
                }
            }
        }
        Solver {
            analysis,
            active,
            rows: m,
            op,
            cols,
            cov,
            h: h.clone(),
            weighting: weighting.clone(),
            // With a prior the readings' weights and the prior share one
            // scale (GLS, see Method::check_prior): no residual rescaling.
            known_covariance: matches!(weighting, Weighting::Whiten(_)) || prior.is_some(),
            constraints: *constraints,
            offset,
            op_prior,
        }
    }

    /// [`EstimateOf::source`] of each error given its standard uncertainty.
    pub fn sources(&self, std_mm: &SVector<f64, P>) -> [&'static str; P] {
        let ident = self.identifiable();
        std::array::from_fn(|c| {
            if self.constraints.fixed[c].is_some() {
                "fixed"
            } else if !ident[c] {
                "unidentifiable"
            } else if self
                .constraints
                .prior_std_mm
                .is_some_and(|sp| std_mm[c].is_nan() || std_mm[c] > sp / std::f64::consts::SQRT_2)
            {
                "prior"
            } else {
                "readings"
            }
        })
    }

    /// The constraints this operator holds.
    pub fn constraints(&self) -> &Constraints<P> {
        &self.constraints
    }

    /// A Gauss–Newton step from the estimate `values` for the residual
    /// `r`: op·r, and with a prior its rows reading −ε/σp.
    pub fn step(&self, r: &[f64], values: &SVector<f64, P>, out: &mut SVector<f64, P>) {
        let mut s = SVector::zeros();
        self.apply_raw(r, &mut s);
        if let Some(sp) = self.constraints.prior_std_mm {
            let p = self.active.len();
            for (a, &c) in self.active.iter().enumerate() {
                s[c] -= (0..p)
                    .map(|b| self.op_prior[a * p + b] * values[self.active[b]] / sp)
                    .sum::<f64>();
            }
        }
        *out = s;
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Known after this identification: identified from the readings (or
    /// held by the prior), or fixed.
    pub fn identifiable(&self) -> [bool; P] {
        let mut out = std::array::from_fn(|c| self.constraints.fixed[c].is_some());
        for &c in &self.active {
            out[c] = true;
        }
        out
    }

    /// Δε̂ = op·l, zero for unidentifiable parameters. No allocation. Each
    /// estimate is summed over the rows in row order (with AVX2 four lanes
    /// at a time: the same operations, the same bits).
    #[inline]
    pub fn apply(&self, l: &[f64], out: &mut SVector<f64, P>) {
        self.apply_raw(l, out);
        if self.has_offset() {
            *out += self.offset;
        }
    }

    /// Are errors fixed (so every estimate carries [`Solver::offset`])?
    #[inline]
    fn has_offset(&self) -> bool {
        self.constraints.fixed.iter().any(Option::is_some)
    }

    /// Does one row update every estimate in 16 lanes (P ≤ 16)?
    const LANES: bool = P <= 16;

    /// op·l, the slots' sums added in slot order; and, with `by_slot`
    /// (`need`, `out`), op applied to each reading slot's rows of `l`
    /// (rows r with r mod R = k) for the slots k with `need[k]`, into
    /// `out[k]` (the others left as they are). Each active estimate is its
    /// operator row's sums over the rows, a slot's in row order: the form
    /// of more than 16 errors, one pass over each operator row with the R
    /// slots side by side.
    fn wide(
        &self,
        l: &[f64],
        mut by_slot: Option<([bool; R], &mut [SVector<f64, P>; R])>,
    ) -> SVector<f64, P> {
        let m = self.rows;
        let mut total = SVector::zeros();
        if let Some((need, out)) = by_slot.as_mut() {
            for k in (0..R).filter(|&k| need[k]) {
                out[k].fill(0.0);
            }
        }
        crate::cpu::wide(
            #[inline(always)]
            || {
                for (a, &c) in self.active.iter().enumerate() {
                    let row = &self.op[a * m..(a + 1) * m];
                    let mut acc = [0.0; R];
                    for (o, x) in row.chunks_exact(R).zip(l.chunks_exact(R)) {
                        for k in 0..R {
                            acc[k] += o[k] * x[k];
                        }
                    }
                    if let Some((need, out)) = by_slot.as_mut() {
                        for k in (0..R).filter(|&k| need[k]) {
                            out[k][c] = acc[k];
                        }
                    }
                    total[c] = acc.iter().sum();
                }
            },
        );
        total
    }

    /// op·l alone (no fixed errors' offset): a step, or a noise part.
    #[inline]
    fn apply_raw(&self, l: &[f64], out: &mut SVector<f64, P>) {
        debug_assert_eq!(l.len(), self.rows);
        if !Self::LANES {
            *out = self.wide(l, None);
            return;
        }
        let [acc] = crate::cpu::wide(
            #[inline(always)]
            || {
                let mut acc = [0.0; 16];
                for (col, &x) in self.cols.iter().zip(l) {
                    add_scaled(&mut acc, col, x);
                }
                [acc]
            },
        );
        out.copy_from_slice(&acc[..P]);
    }

    /// The estimate of every observation `l0 + s ⊙ dz` at once, by the
    /// linearity of the operator in l: op·l0 and, for each reading's sensor
    /// (the mechanism's ψ4, θ4, q4), op applied to that sensor's rows of dz
    /// (row r belongs to sensor r mod R). With dz the homed unit noise of a
    /// trial and s a grade's noise scale, [`Split::estimate`] gives that
    /// grade's estimate in P·R multiply-adds (the mechanism's 45).
    /// With AVX2 four lanes at a time: the same sums in row order, the same
    /// bits (a white-noise trial: 74.6k -> 67.6k instructions).
    #[inline]
    pub fn apply_split(&self, l0: &[f64], dz: &[f64]) -> Split<P, R> {
        debug_assert_eq!(l0.len(), self.rows);
        debug_assert_eq!(dz.len(), self.rows);
        if !Self::LANES {
            let mut exact = SVector::zeros();
            self.apply_raw(l0, &mut exact);
            if self.has_offset() {
                exact += self.offset;
            }
            let mut noise = [SVector::zeros(); R];
            self.wide(dz, Some(([true; R], &mut noise)));
            return Split { exact, noise };
        }
        let (exact, noise) = crate::cpu::wide(
            #[inline(always)]
            || {
                let mut exact = [0.0; 16];
                let mut noise = [[0.0; 16]; R];
                let rows = self.cols.chunks_exact(R).zip(l0.chunks_exact(R));
                for ((cols, l), d) in rows.zip(dz.chunks_exact(R)) {
                    // Both sums lane by lane (two calls of `add_scaled`
                    // here compile to 1.9 % more instructions a trial).
                    for k in 0..R {
                        for c in 0..16 {
                            exact[c] += cols[k][c] * l[k];
                            noise[k][c] += cols[k][c] * d[k];
                        }
                    }
                }
                (exact, noise)
            },
        );
        let v = |a: &[f64; 16]| SVector::<f64, P>::from_column_slice(&a[..P]);
        let mut exact = v(&exact);
        if self.has_offset() {
            exact += self.offset;
        }
        Split {
            exact,
            noise: std::array::from_fn(|k| v(&noise[k])),
        }
    }

    /// The operator applied to each sensor's rows of `e` alone (row r belongs
    /// to sensor r mod R): [`Split::noise`] of [`Solver::apply_split`]
    /// without its exact part, for observations l0 + e whose op·l0 is shared.
    #[inline]
    pub fn apply_by_sensor(&self, e: &[f64]) -> [SVector<f64, P>; R] {
        let mut out = [SVector::zeros(); R];
        self.apply_sensors(e, [true; R], &mut out);
        out
    }

    /// [`Solver::apply_by_sensor`] for the sensors k with `need[k]`,
    /// written to `out[k]` (the others are left as they are). Each sum runs in row order, so every way below
    /// gives the same bits. With AVX2 the sensors share one pass over the
    /// rows: each has four 4-wide accumulators, and the adds of two or three
    /// sensors overlap instead of each waiting on its own last add. Without
    /// it one sensor at a time: its 16 accumulators fit the 16 SSE2 registers
    /// (two sensors' would spill).
    #[inline]
    pub fn apply_sensors(&self, e: &[f64], need: [bool; R], out: &mut [SVector<f64, P>; R]) {
        debug_assert_eq!(e.len(), self.rows);
        if !Self::LANES {
            self.wide(e, Some((need, out)));
            return;
        }
        // All 16 lanes of each sum are kept to the end (the 16th is zero):
        // with only 15 wanted the compiler splits the rows into odd pieces.
        let mut acc = [[0.0; 16]; R];
        let shared = crate::cpu::has_avx2();
        crate::cpu::wide(
            #[inline(always)]
            || match need.as_slice() {
                [true, true, true] if shared => {
                    [acc[0], acc[1], acc[2]] = self.apply_columns(e, [0, 1, 2])
                }
                [true, true, false] if shared => [acc[0], acc[1]] = self.apply_columns(e, [0, 1]),
                [true, false, true] if shared => [acc[0], acc[2]] = self.apply_columns(e, [0, 2]),
                [false, true, true] if shared => [acc[1], acc[2]] = self.apply_columns(e, [1, 2]),
                _ => {
                    for k in (0..R).filter(|&k| need[k]) {
                        [acc[k]] = self.apply_columns(e, [k]);
                    }
                }
            },
        );
        for k in (0..R).filter(|&k| need[k]) {
            out[k].copy_from_slice(&acc[k][..P]);
        }
    }

    /// The operator applied to sensor k's rows of `e` alone (rows r with
    /// r mod R = k), for each k of `ks`, in one pass over the rows.
    #[inline(always)]
    fn apply_columns<const K: usize>(&self, e: &[f64], ks: [usize; K]) -> [[f64; 16]; K] {
        let mut acc = [[0.0; 16]; K];
        for (cols, d) in self.cols.chunks_exact(R).zip(e.chunks_exact(R)) {
            for (a, &k) in acc.iter_mut().zip(&ks) {
                add_scaled(a, &cols[k], d[k]);
            }
        }
        acc
    }

    /// Standard deviation of each estimate predicted by the linear model for
    /// the given per-row noise σ (rows of l), mm: sqrt(diag(op·Σ_l·opᵀ)) with
    /// Σ_l the covariance of l_j = n_j − n_0 (the reference noise is shared).
    pub fn predicted_std(&self, reading_sigma: &SVector<f64, R>) -> SVector<f64, P> {
        let mut out = SVector::zeros();
        let m = self.rows;
        for (a, &c) in self.active.iter().enumerate() {
            let row = &self.op[a * m..(a + 1) * m];
            let mut var = 0.0;
            for k in 0..R {
                let s2 = reading_sigma[k] * reading_sigma[k];
                let mut sum_k = 0.0;
                let mut sq_k = 0.0;
                for j in (k..m).step_by(R) {
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

    /// Standard deviation of each estimate for observation errors of
    /// covariance `sigma`, mm: sqrt(diag(op·Σ·opᵀ)), the sandwich that holds
    /// for any operator (for GLS with its own Σ it equals
    /// √diag((HwᵀHw)⁻¹), [`Solver::covariance_std`]). O(rows).
    pub fn predicted_std_under(&self, sigma: &ObservationCovariance) -> SVector<f64, P> {
        let mut out = SVector::zeros();
        let cov = sigma.sandwich(&self.operator());
        for &c in &self.active {
            out[c] = cov[(c, c)].max(0.0).sqrt();
        }
        out
    }

    /// (HwᵀHw)⁻¹ (with a prior, plus I/σp²) as a P × P matrix, zero for the
    /// errors not estimated: the estimate's covariance when the weighting
    /// whitens the readings (GLS).
    pub fn posterior_covariance(&self) -> DMatrix<f64> {
        let mut c = DMatrix::zeros(P, P);
        for (a, &i) in self.active.iter().enumerate() {
            for (b, &j) in self.active.iter().enumerate() {
                c[(i, j)] = self.cov[(a, b)];
            }
        }
        c
    }

    /// The operator as a P × rows matrix (zero rows for unidentifiable
    /// errors): the estimate is operator·l.
    pub fn operator(&self) -> DMatrix<f64> {
        let m = self.rows;
        let mut op = DMatrix::zeros(P, m);
        for (a, &c) in self.active.iter().enumerate() {
            for r in 0..m {
                op[(c, r)] = self.op[a * m + r];
            }
        }
        op
    }

    /// √diag((HwᵀHw)⁻¹), mm: the estimate's standard deviation when the
    /// weighting whitens the observation errors (GLS with its Σ; docs/method.md §13).
    pub fn covariance_std(&self) -> SVector<f64, P> {
        let mut out = SVector::zeros();
        for (a, &c) in self.active.iter().enumerate() {
            out[c] = self.cov[(a, a)].sqrt();
        }
        out
    }

    /// Degrees of freedom m − p of the fit.
    pub fn dof(&self) -> usize {
        self.rows.saturating_sub(self.active.len())
    }

    /// A-posteriori standard uncertainties and the RMS of the weighted
    /// residual `resid` (of the linear or the exact model). OLS and WLS:
    /// residual variance s² = Σ(W·r)²/(m − p) times diag((HwᵀHw)⁻¹), not
    /// estimable (NaN, an empty cell in the outputs) without degrees of
    /// freedom. GLS: the weighting is the sensors' covariance, so
    /// √diag((HwᵀHw)⁻¹) itself (docs/method.md §13), and the whitened RMS says how well
    /// the data fit it (about 1 when they do).
    pub fn posterior(&self, resid: &DVector<f64>) -> (SVector<f64, P>, f64) {
        let rss: f64 = if resid.is_empty() {
            0.0
        } else {
            match &self.weighting {
                Weighting::Rows(w) => resid
                    .iter()
                    .zip(w.iter())
                    .map(|(r, w)| (r * w) * (r * w))
                    .sum(),
                Weighting::Whiten(_) => self.weighting.apply_vector(resid).norm_squared(),
            }
        };
        let dof = self.dof();
        let s2 = if self.known_covariance {
            1.0
        } else if dof > 0 {
            rss / dof as f64
        } else {
            f64::NAN
        };
        let mut std_mm = SVector::zeros();
        for (a, &c) in self.active.iter().enumerate() {
            std_mm[c] = (s2 * self.cov[(a, a)]).sqrt();
        }
        // A fixed error's uncertainty is its measurement's, not stated here.
        for c in 0..P {
            if self.constraints.fixed[c].is_some() {
                std_mm[c] = f64::NAN;
            }
        }
        let rms = if resid.is_empty() {
            0.0
        } else {
            (rss / resid.len() as f64).sqrt()
        };
        (std_mm, rms)
    }

    /// The design matrix this operator inverts.
    pub fn design(&self) -> &DMatrix<f64> {
        &self.h
    }

    /// The weighting this operator uses.
    pub fn weighting(&self) -> &Weighting {
        &self.weighting
    }

    /// Estimate with standard uncertainties from the residual variance.
    pub fn estimate(&self, l: &DVector<f64>) -> EstimateOf<P> {
        let mut values = SVector::zeros();
        self.apply(l.as_slice(), &mut values);
        let resid = l - &self.h * values;
        let (std_mm, residual_rms) = self.posterior(&resid);
        EstimateOf {
            values,
            std_mm,
            identifiable: self.identifiable(),
            source: self.sources(&std_mm),
            residual_rms,
            dof: self.dof(),
            iterations: 1,
            termination: Termination::SingleLinearisation,
        }
    }
}

/// acc += col·x, lane by lane: one row's term of op·l (a multiply and an
/// add per lane, no FMA, so every copy rounds alike).
#[inline(always)]
fn add_scaled(acc: &mut [f64; 16], col: &[f64; 16], x: f64) {
    for c in 0..16 {
        acc[c] += col[c] * x;
    }
}

#[path = "reweighted.rs"]
mod reweighted;

#[cfg(test)]
#[path = "linear_tests.rs"]
mod tests;
