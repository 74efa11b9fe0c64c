//! From per-calibration records to the study's results: per grade the
//! distribution of μ and μ/μ0 across machines (`summary.csv`), per grade and
//! error the Monte-Carlo spread against the linear prediction
//! (`parameters.csv`), and the decision. Partials of consecutive block
//! ranges give exactly the bytes of one run: sums run in the same order.

use super::assumptions::assumptions;
use super::outcome::Failure;
use super::partial::{Partial, BUDGET_TERMS, DV_PER_CALIBRATION};
use super::trial::{Grade, Studied, SweepContext};
use crate::config::Study;
use crate::identify::Solver;
use crate::metrics::{
    decide, rank_combinations, stats, BudgetRow, DvSummary, GradeSummary, ParameterRow,
};
use crate::sensors::{ObservationCovariance, SensorModel};
use nalgebra::SVector;
use rayon::prelude::*;

/// What a sweep returns.
#[derive(Debug, Clone)]
pub struct SweepResult {
    /// One row per combination with the datasheet's sensors.
    pub summary: Vec<GradeSummary>,
    /// The same combinations read by sensors whose curves are
    /// `[sweep] truth_amplitude` × the datasheet's (others than 1), or
    /// carry `truth_extra_harmonic`.
    pub truth: Vec<GradeSummary>,
    pub parameters: Vec<ParameterRow>,
    pub decisions: Vec<crate::metrics::DecisionRow>,
    /// Every combination ranked by the buyer's rule (`decision.csv`).
    pub ranking: Vec<crate::metrics::RankedRow>,
    /// Per grade: where the remaining error comes from (`budget.csv`).
    pub budget: Vec<BudgetRow>,
    /// The first-ranked combinations' budget in the deciding metric
    /// (`decision_budget.csv`, see [`super::budget`]); rank order.
    pub decision_budget: Vec<BudgetRow>,
    pub calibrations: u64,
    /// Calibrations computed by this process (not restored from a block
    /// log or merged from shards): what the throughput counts.
    pub computed: u64,
    pub trials: u64,
    pub wall_seconds: f64,
    /// Of the wall time: computing the trials (the parallel part), and
    /// summarising them (quantiles, decision; parallel over combinations).
    pub trials_seconds: f64,
    pub summary_seconds: f64,
    pub threads: usize,
    /// What the verdict rests on, one sentence each.
    pub assumptions: Vec<String>,
    /// Each second-class tolerance studied and the cheapest combination
    /// that meets the target there (see [`super::tolerance`]).
    pub tolerances: Vec<crate::metrics::Tolerance>,
    /// The choice with the Hooke axes identified and exact axes (see
    /// [`super::tolerance`]).
    pub identified_exact_axes: Option<crate::metrics::IdentifiedAxes>,
}

impl SweepResult {
    /// Calibrations computed by this process per second of its wall time.
    pub fn calibrations_per_second(&self) -> f64 {
        self.computed as f64 / self.wall_seconds.max(1e-9)
    }
}

/// One grade's records gathered from every partial, in trial order.
struct Samples<const P: usize> {
    mu: Vec<f64>,
    ratio: Vec<f64>,
    mu0_sum: f64,
    failed: u64,
    not_converged: u64,
    dv_max: Vec<f64>,
    dv_mean: Vec<f64>,
    dv_before: Vec<f64>,
    dv_p95: Vec<f64>,
    ap_max: Vec<f64>,
    err_sum: SVector<f64, P>,
    err_sq: SVector<f64, P>,
    budget: [f64; BUDGET_TERMS],
    budget_n: u64,
    /// Σ, Σ² and count of the trials' linearisation errors (a grade
    /// weighted per machine).
    lin_sum: SVector<f64, P>,
    lin_sq: SVector<f64, P>,
    lin_n: u64,
    rank: u8,
}

// By hand: a derived Default would ask [f64; P] for one.
impl<const P: usize> Default for Samples<P> {
    fn default() -> Self {
        Samples {
            mu: Vec::new(),
            ratio: Vec::new(),
            mu0_sum: 0.0,
            failed: 0,
            not_converged: 0,
            dv_max: Vec::new(),
            dv_mean: Vec::new(),
            dv_before: Vec::new(),
            dv_p95: Vec::new(),
            ap_max: Vec::new(),
            err_sum: SVector::zeros(),
            err_sq: SVector::zeros(),
            budget: [0.0; BUDGET_TERMS],
            budget_n: 0,
            lin_sum: SVector::zeros(),
            lin_sq: SVector::zeros(),
            lin_n: 0,
            rank: 0,
        }
    }
}

impl<const P: usize> Samples<P> {
    /// The spread over the study's machines of one linearisation's error
    /// (variance, mm²), where the trials recorded it.
    fn linearisation_variance(&self) -> Option<SVector<f64, P>> {
        (self.lin_n > 1).then(|| {
            let n = self.lin_n as f64;
            let mean = self.lin_sum / n;
            (self.lin_sq - mean.component_mul(&mean) * n).map(|x| x.max(0.0) / (n - 1.0))
        })
    }
}

fn gather<const P: usize>(
    parts: &[&Partial],
    g: usize,
    gi: usize,
    rank: u8,
    volumetric: bool,
) -> Samples<P> {
    let trials: u64 = parts.iter().map(|p| p.trials).sum();
    let mut s = Samples {
        mu: Vec::with_capacity(trials as usize),
        ratio: Vec::with_capacity(trials as usize),
        rank,
        ..Samples::default()
    };
    for p in parts {
        s.rank = p.rank.get(gi).copied().unwrap_or(s.rank);
        for t in 0..p.trials as usize {
            let k = t * g + gi;
            match p.failure_at(k) {
                Failure::ForwardKinematics => {
                    s.failed += 1;
                    continue;
                }
                Failure::NotConverged => s.not_converged += 1,
                Failure::None => {}
            }
            s.mu.push(p.mu[k]);
            s.ratio.push(p.mu[k] / p.mu0[t]);
            s.mu0_sum += p.mu0[t];
            if volumetric {
                let d = &p.dv[DV_PER_CALIBRATION * k..DV_PER_CALIBRATION * (k + 1)];
                s.dv_max.push(d[0]);
                s.dv_mean.push(d[1]);
                s.dv_before.push(d[2]);
                s.dv_p95.push(d[3]);
                s.ap_max.push(d[4]);
            }
        }
        // Block b's grade gi: the study's P errors at its cell.
        assert_eq!(p.errors, P, "a partial of this study");
        let at = |v: &[f64], c: usize| SVector::<f64, P>::from_column_slice(&v[c * P..][..P]);
        for b in 0..p.blocks() {
            let c = b * g + gi;
            s.err_sum += at(&p.block_err_sum, c);
            s.err_sq += at(&p.block_err_sq, c);
            for (acc, v) in s.budget.iter_mut().zip(p.block_budget[b * g + gi]) {
                *acc += v;
            }
            s.budget_n += p.block_budget_n[b * g + gi];
            s.lin_sum += at(&p.block_lin_sum, c);
            s.lin_sq += at(&p.block_lin_sq, c);
            s.lin_n += p.block_lin_n[b * g + gi];
        }
    }
    s
}

/// The summary row of one grade (reorders the samples).
fn grade_summary<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    grade: &Grade,
    s: &mut Samples<P>,
) -> GradeSummary {
    let volumetric = ctx.volumetric();
    let n = s.mu.len();
    let (mu_mean, mu_half) = stats::mean_ci95(&s.mu);
    let (ratio_mean, _) = stats::mean_ci95(&s.ratio);
    // Percentiles and their limits by one selection per series: the values
    // a sort would give, in O(n).
    let r = stats::Percentiles::of(&mut s.ratio);
    let (r95, (r95_lo, r95_hi), r50, r05) = (r.p95, r.p95_ci, r.p50, r.p05);
    let m = stats::Percentiles::of(&mut s.mu);
    let (mu_p95, mu_p95_ci_high, mu_median, mu_p05) = (m.p95, m.p95_upper, m.p50, m.p05);
    let (encoder, scale, price) = product_names(ctx, grade);
    let (dv, lower) = if volumetric {
        workspace(s)
    } else {
        (DvSummary::default(), Default::default())
    };
    GradeSummary {
        truth_amplitude: grade.truth.amplitude,
        truth_extra_harmonic: grade.truth.extra_harmonic,
        truth: grade.truth.label(),
        lower: crate::metrics::summary::LowerLimits {
            mu_p95: m.p95_ci.0,
            ..lower
        },
        second_class_deg: None,
        encoder_arcsec: grade.encoder_arcsec,
        scale_um: grade.scale_um,
        method: grade.method,
        pose_count: grade.pose_count,
        encoder,
        scale,
        price,
        trials: n as u64,
        failed: s.failed,
        not_converged: s.not_converged,
        mu_mean,
        mu_mean_ci_low: mu_mean - mu_half,
        mu_mean_ci_high: mu_mean + mu_half,
        mu_median,
        mu_p05,
        mu_p95,
        mu_p95_ci_high: mu_p95_ci_high.unwrap_or(f64::NAN),
        mu0_mean: s.mu0_sum / n.max(1) as f64,
        ratio_mean,
        ratio_median: r50,
        ratio_p05: r05,
        ratio_p95: r95,
        ratio_p95_ci_low: r95_lo.unwrap_or(f64::NAN),
        ratio_p95_ci_high: r95_hi.unwrap_or(f64::NAN),
        mu_mean_ci_rel: mu_half / mu_mean,
        ratio_p95_ci_rel: match (r95_lo, r95_hi) {
            (Some(lo), Some(hi)) => (hi - lo) / 2.0 / r95,
            _ => f64::NAN,
        },
        rank: s.rank,
        dv,
        meets_target: false,
    }
}

/// The workspace statistics of one grade (sorts its series) and the lower
/// limits of their 95th percentiles.
fn workspace<const P: usize>(
    s: &mut Samples<P>,
) -> (DvSummary, crate::metrics::summary::LowerLimits) {
    let computed = s.dv_max.iter().filter(|x| x.is_finite()).count();
    let dv_failed = Some((s.dv_max.len() - computed) as u64);
    let finite = failures_as_worst;
    finite(&mut s.dv_max);
    finite(&mut s.dv_before);
    finite(&mut s.dv_p95);
    finite(&mut s.ap_max);
    s.dv_mean.retain(|x| x.is_finite());
    let q = |v: &[f64], p: f64| Some(stats::quantile_sorted(v, p));
    let ci_high = |v: &[f64]| stats::quantile_upper95(v, 0.95);
    let ci_low = |v: &[f64]| stats::quantile_lower95(v, 0.95).filter(|x| x.is_finite());
    let lower = crate::metrics::summary::LowerLimits {
        mu_p95: None,
        dv_after_max_p95: ci_low(&s.dv_max),
        dv_after_p95_p95: ci_low(&s.dv_p95),
        ap_after_max_p95: ci_low(&s.ap_max),
    };
    let dv = DvSummary {
        dv_after_max_median: q(&s.dv_max, 0.5),
        dv_after_max_p95: q(&s.dv_max, 0.95),
        dv_after_mean_mean: Some(stats::mean_ci95(&s.dv_mean).0),
        dv_before_max_median: q(&s.dv_before, 0.5),
        dv_after_max_p95_ci_high: ci_high(&s.dv_max),
        dv_after_p95_median: q(&s.dv_p95, 0.5),
        dv_after_p95_p95: q(&s.dv_p95, 0.95),
        dv_after_p95_p95_ci_high: ci_high(&s.dv_p95),
        ap_after_max_median: q(&s.ap_max, 0.5),
        ap_after_max_p95: q(&s.ap_max, 0.95),
        ap_after_max_p95_ci_high: ci_high(&s.ap_max),
        dv_failed,
    };
    (dv, lower)
}

/// Sort one workspace series for its percentiles. A machine whose map
/// failed (NaN) is not "within X": it counts as +∞, so a p95 with more than
/// 5 % of maps failed, or a limit the failures reach, is empty and never
/// meets a target; only the mean is taken over the machines judged.
fn failures_as_worst(v: &mut [f64]) {
    for x in v.iter_mut().filter(|x| x.is_nan()) {
        *x = f64::INFINITY;
    }
    v.sort_unstable_by(f64::total_cmp);
}

/// The catalogue products of a grade and their total price (two encoders
/// and a scale); empty in a grade study.
pub fn product_names<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    grade: &Grade,
) -> (String, String, Option<f64>) {
    match &ctx.products {
        Some(p) => {
            let (e, s) = p.pair(grade.product);
            (e.name.clone(), s.name.clone(), Some(p.price(grade.product)))
        }
        None => (String::new(), String::new(), None),
    }
}

/// The error budget of one grade from its summed terms.
fn budget_row<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    grade: &Grade,
    s: &Samples<P>,
) -> BudgetRow {
    let n = s.budget_n.max(1) as f64;
    let m = s
        .budget
        .map(|v| if s.budget_n > 0 { v / n } else { f64::NAN });
    let (encoder, scale, _) = product_names(ctx, grade);
    BudgetRow {
        encoder_arcsec: grade.encoder_arcsec,
        scale_um: grade.scale_um,
        method: grade.method,
        pose_count: grade.pose_count,
        encoder,
        scale,
        calibrations: s.budget_n,
        ..BudgetRow::from_means(m[0], m[1], [m[2], m[3], m[4]])
    }
}

/// Per error: bias and Monte-Carlo spread of the estimates against the
/// spread the linear model predicts for the grade's sensors: √diag(op·Σ·opᵀ)
/// for every estimator (docs/method.md §18), Σ the sensors' model at the
/// grade's poses (white noise: σ²(I + 11ᵀ) by sensor) plus `kernel`, the
/// interpolation error's share averaged over the study's machines at their
/// true readings ([`super::statement`]). With second-class unknowns
/// identified (the Tricept's Hooke axes), the P errors' share of the
/// (P + A)-unknown operator.
fn parameter_rows<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    gi: usize,
    solver: &Solver<P, R>,
    sensor: &SensorModel<R>,
    joints: &[SVector<f64, R>],
    s: &Samples<P>,
    kernel: Option<&SVector<f64, P>>,
) -> Vec<ParameterRow> {
    let grade = &ctx.grades[gi];
    let n = s.mu.len();
    // The part of Σ every machine shares: without the interpolation error
    // when its kernel is added per machine.
    let fixed = match kernel {
        Some(_) => super::statement::without_interpolation(sensor),
        None => *sensor,
    };
    let base = if solver.constraints().prior_std_mm.is_some() {
        // A prior's MAP error: the posterior (HwᵀHw + I/σp²)⁻¹, which
        // counts what the readings leave at the prior.
        solver.covariance_std()
    } else if let Some(ext) = ctx.second_class_solvers.get(gi) {
        let sd = ext.predicted_std(
            solver,
            &ObservationCovariance::new(&fixed.covariances(), joints),
        );
        SVector::<f64, P>::from_iterator(sd.into_iter().take(P))
    } else if fixed.structured.is_some() {
        solver.predicted_std_under(&ObservationCovariance::new(&fixed.covariances(), joints))
    } else {
        solver.predicted_std(&fixed.reading_sigma())
    };
    let predicted = match kernel {
        // Weighted per machine: the machines' own operators' statement
        // ([`super::statement`]) and what one linearisation leaves, whose
        // spread over the study's machines every trial recorded (heavy
        // tailed: over 128 machines dxA2's share came out 0.76 of its
        // spread over 15,000).
        Some(k) if ctx.per_machine[gi] => match s.linearisation_variance() {
            Some(lin) => (k + lin).map(f64::sqrt),
            None => k.map(f64::sqrt),
        },
        Some(k) => base.zip_map(k, |b, v| (b * b + v).sqrt()),
        None => base,
    };
    let ident = solver.identifiable();
    let (encoder, scale, _) = product_names(ctx, grade);
    let names = ctx.mech.names();
    (0..P)
        .map(|p| {
            let nf = n.max(1) as f64;
            let mean = s.err_sum[p] / nf;
            let var = if n > 1 {
                (s.err_sq[p] - nf * mean * mean).max(0.0) / (nf - 1.0)
            } else {
                0.0
            };
            let sd = var.sqrt();
            ParameterRow {
                encoder_arcsec: grade.encoder_arcsec,
                scale_um: grade.scale_um,
                method: grade.method,
                pose_count: grade.pose_count,
                encoder: encoder.clone(),
                scale: scale.clone(),
                parameter: names[p].to_string(),
                identifiable: ident[p],
                bias_mm: mean,
                mc_std_mm: sd,
                // An error the poses cannot identify has no predicted
                // spread (its estimate is held at 0): an empty cell.
                predicted_std_mm: if ident[p] { predicted[p] } else { f64::NAN },
                ratio_mc_to_predicted: if ident[p] && predicted[p] > 0.0 {
                    sd / predicted[p]
                } else {
                    f64::NAN
                },
            }
        })
        .collect()
}

impl SweepResult {
    /// The first-ranked combination's budget: in the deciding metric when
    /// the study made one ([`super::budget`]), else in mean μ.
    pub fn first_budget(&self) -> Option<&BudgetRow> {
        let first = self.ranking.first()?;
        let same = |b: &&BudgetRow| {
            b.encoder == first.encoder
                && b.scale == first.scale
                && b.encoder_arcsec.to_bits() == first.encoder_arcsec.to_bits()
                && b.scale_um.to_bits() == first.scale_um.to_bits()
                && b.pose_count == first.pose_count
                && b.method == first.method
        };
        self.decision_budget
            .iter()
            .find(same)
            .or_else(|| self.budget.get(first.row))
    }

    /// Every row of summary.csv: the datasheet's, then the what-if rows.
    pub fn summary_rows(&self) -> Vec<&GradeSummary> {
        self.summary.iter().chain(&self.truth).collect()
    }
}

/// Summaries from consecutive partials (a single run is one partial).
pub fn finalize<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
    parts: &[&Partial],
) -> SweepResult {
    let g = ctx.grades.len();
    let trials: u64 = parts.iter().map(|p| p.trials).sum();
    let volumetric = ctx.volumetric();
    // Grades are independent: summarised in parallel, gathered in order
    // (the same bytes for any thread count). Equal keys under total_cmp are
    // equal bits, so an unstable sort gives the stable sort's result.
    // The interpolation kernel's share of each grade's stated spread, per
    // machine (only for the rows parameters.csv lists).
    let wanted: Vec<bool> = ctx.grades.iter().map(|g| g.truth.is_datasheet()).collect();
    let kernel = super::statement::interpolation_variances(ctx, &wanted, trials);
    let rows: Vec<(GradeSummary, Vec<ParameterRow>, BudgetRow)> = ctx
        .grades
        .par_iter()
        .zip(&ctx.solvers)
        .enumerate()
        .map(|(gi, (grade, solver))| {
            let rank = solver.analysis.rank as u8;
            let mut samples = gather(parts, g, gi, rank, volumetric);
            let mut row = grade_summary(ctx, grade, &mut samples);
            row.meets_target = study.decision.meets(&row);
            let sensor = &ctx.sensors[grade.sensor_index];
            let joints = &ctx.subset_nominal[grade.subset];
            let params = parameter_rows(
                ctx,
                gi,
                solver,
                sensor,
                joints,
                &samples,
                kernel[gi].as_ref(),
            );
            (row, params, budget_row(ctx, grade, &samples))
        })
        .collect();
    let mut summary = Vec::with_capacity(g);
    let mut parameters = Vec::new();
    let mut budget = Vec::with_capacity(g);
    let mut truth = Vec::new();
    for ((row, params, b), grade) in rows.into_iter().zip(&ctx.grades) {
        // Rows of sensors whose curves differ from the datasheet's are
        // what-if rows: summary.csv lists them, the verdict reads them, and
        // nothing is chosen or drawn from them.
        if !grade.truth.is_datasheet() {
            // A what-if that leaves these sensors as their datasheets say
            // (rings mounted off centre, for encoders with their own
            // bearing) does not apply to them: no row is quoted for it.
            if ctx.sensors[grade.sensor_index] != ctx.assumed[grade.product] {
                truth.push(row);
            }
            continue;
        }
        summary.push(row);
        parameters.extend(params);
        budget.push(b);
    }
    let sw = &study.sweep;
    // The coarsest encoder grade per (estimator, scale grade): grade studies
    // with one pose count; catalogue and pose-count studies rank instead.
    let decisions = if sw.products.is_none() && sw.pose_counts.len() <= 1 {
        decide(&study.decision, &sw.methods, &sw.scale_um, &summary)
    } else {
        Vec::new()
    };
    let mut ranking = rank_combinations(&study.decision, &summary);
    crate::metrics::mark_what_ifs(&mut ranking, &truth);
    SweepResult {
        assumptions: assumptions(ctx, study),
        tolerances: Vec::new(),
        identified_exact_axes: None,
        ranking,
        summary,
        truth,
        parameters,
        decisions,
        budget,
        decision_budget: Vec::new(),
        calibrations: trials * g as u64,
        computed: trials * g as u64,
        trials,
        wall_seconds: 0.0,
        trials_seconds: 0.0,
        summary_seconds: 0.0,
        threads: 0,
    }
}

#[cfg(test)]
#[path = "summary_tests.rs"]
mod failure_tests;
