//! The rows of a study's results: one [`GradeSummary`] per grade
//! (`summary.csv`) and one [`ParameterRow`] per grade and error
//! (`parameters.csv`). CSV columns are the field names, those of a
//! [`DvSummary`] in its place.

use crate::identify::Method;
use serde::Serialize;

/// Summary of one grade (one row of summary.csv).
#[derive(Debug, Clone, Serialize)]
pub struct GradeSummary {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    /// Calibration poses used (the reference included).
    pub pose_count: usize,
    /// Catalogue products (empty in a grade study).
    pub encoder: String,
    pub scale: String,
    /// Two encoders and a scale (empty in a grade study).
    pub price: Option<f64>,
    pub trials: u64,
    pub failed: u64,
    pub not_converged: u64,
    pub mu_mean: f64,
    pub mu_mean_ci_low: f64,
    pub mu_mean_ci_high: f64,
    pub mu_median: f64,
    pub mu_p05: f64,
    pub mu_p95: f64,
    pub mu_p95_ci_high: f64,
    pub mu0_mean: f64,
    pub ratio_mean: f64,
    pub ratio_median: f64,
    pub ratio_p05: f64,
    pub ratio_p95: f64,
    pub ratio_p95_ci_low: f64,
    pub ratio_p95_ci_high: f64,
    /// Achieved 95 % CI half-widths relative to the value (adaptive stopping).
    pub mu_mean_ci_rel: f64,
    pub ratio_p95_ci_rel: f64,
    pub rank: u8,
    /// Volumetric accuracy after compensation (empty unless
    /// sweep.volumetric): columns of the row in place.
    pub dv: DvSummary,
    pub meets_target: bool,
    /// The true sensors' curves as a multiple of the datasheet's (docs/method.md §11
    /// amplitudes) that the estimator assumes: 1 is the datasheet's claim,
    /// the rows the verdict is made on; others show what rests on it.
    pub truth_amplitude: f64,
    /// A harmonic the datasheet omits that the true sensors carry, as a
    /// fraction of the accuracy (0: none).
    pub truth_extra_harmonic: f64,
    /// The what-if in words ("the datasheet" for the rows the verdict is
    /// made on; see `Truth::label`).
    pub truth: String,
    /// Lower confidence limits of the 95th percentiles, for telling a
    /// combination that clearly misses the target from one this many
    /// machines cannot decide (not written to summary.csv).
    #[serde(skip)]
    pub lower: LowerLimits,
    /// The second-class tolerance of a tolerance what-if row, degrees.
    #[serde(skip)]
    pub second_class_deg: Option<f64>,
}

/// The lower confidence limits of a grade's 95th percentiles: μ's (the
/// bottom of its two-sided 95 % interval) and the workspace series'
/// (one-sided 95 %).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LowerLimits {
    pub mu_p95: Option<f64>,
    pub dv_after_max_p95: Option<f64>,
    pub dv_after_p95_p95: Option<f64>,
    pub ap_after_max_p95: Option<f64>,
}

/// One grade's volumetric accuracy after compensation: its columns of
/// summary.csv, all empty (the default) unless sweep.volumetric.
#[derive(Debug, Clone, Default, Serialize)]
pub struct DvSummary {
    /// Per machine the largest and the mean dV over the workspace grid
    /// after compensation, and the largest before.
    pub dv_after_max_median: Option<f64>,
    pub dv_after_max_p95: Option<f64>,
    pub dv_after_mean_mean: Option<f64>,
    pub dv_before_max_median: Option<f64>,
    pub dv_after_max_p95_ci_high: Option<f64>,
    /// Per machine the 95th percentile of dV over the workspace grid; its
    /// median and 95th percentile across machines.
    pub dv_after_p95_median: Option<f64>,
    pub dv_after_p95_p95: Option<f64>,
    pub dv_after_p95_p95_ci_high: Option<f64>,
    /// Per machine the worst ISO 9283 AP at P1–P5 after compensation.
    pub ap_after_max_median: Option<f64>,
    pub ap_after_max_p95: Option<f64>,
    pub ap_after_max_p95_ci_high: Option<f64>,
    /// Calibrations whose map could not be computed (some point unreachable
    /// by the true machine); left out of the dV statistics.
    pub dv_failed: Option<u64>,
}

/// Per parameter and grade: Monte-Carlo spread of the estimate against the
/// standard deviation the linear covariance predicts (parameters.csv).
#[derive(Debug, Clone, Serialize)]
pub struct ParameterRow {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    /// Calibration poses used (the reference included).
    pub pose_count: usize,
    /// Catalogue products (empty in a grade study).
    pub encoder: String,
    pub scale: String,
    pub parameter: String,
    pub identifiable: bool,
    pub bias_mm: f64,
    pub mc_std_mm: f64,
    pub predicted_std_mm: f64,
    pub ratio_mc_to_predicted: f64,
}

impl GradeSummary {
    /// Machines were calibrated but the workspace map failed for every one
    /// of them: the workspace statistics do not exist, and no verdict may
    /// be made on them.
    pub fn workspace_unjudged(&self) -> bool {
        self.trials > 0 && self.dv.dv_failed == Some(self.trials)
    }
}

/// Where one grade's remaining error comes from, in one measure (`measure`):
/// mean μ of every combination (`budget.csv`), or the deciding metric of the
/// first-ranked ones (`decision_budget.csv`). The floor is the measure of
/// the same calibrations with every sensor perfect (what no sensor can fix:
/// linearisation and unidentifiable errors); the savings what making each
/// sensor alone perfect would save. The shares split the sensors' part
/// (total − floor) in proportion to those savings, so that floor + shares =
/// total (the savings themselves need not add up).
#[derive(Debug, Clone, Serialize)]
pub struct BudgetRow {
    /// The measure: `mu_mean`, or the deciding metric's summary column.
    pub measure: &'static str,
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub method: Method,
    pub pose_count: usize,
    pub encoder: String,
    pub scale: String,
    /// Calibrations in the budget (Gauss–Newton ones are left out).
    pub calibrations: u64,
    /// The measure with the sensors as their datasheets say, mm.
    pub total_mm: f64,
    pub floor_mm: f64,
    pub psi_encoder_mm: f64,
    pub theta_encoder_mm: f64,
    pub scale_mm: f64,
    pub saving_psi_encoder_mm: f64,
    pub saving_theta_encoder_mm: f64,
    pub saving_scale_mm: f64,
    /// The sensor whose perfection would save most ("none" when no sensor
    /// would save 1 % of μ, or nothing is left above the floor).
    pub limiting: &'static str,
    /// The same split by error term (decision budget of datasheet sensors
    /// only): written as decision_budget.csv's further columns and
    /// verdict.json's `budget_terms`, not budget.csv's.
    #[serde(skip)]
    pub terms: Option<TermSplit>,
}

/// The sensors' part of a budget split by error term instead of by sensor:
/// the measure with that term read exactly in every sensor (the estimator
/// still weighting them by their datasheets), what that saves, and shares
/// of total − floor in proportion to the savings. A term no sensor has
/// saves nothing and was not rerun.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TermSplit {
    pub curve_mm: f64,
    pub eccentricity_mm: f64,
    pub interpolation_mm: f64,
    pub jitter_mm: f64,
    pub saving_curve_mm: f64,
    pub saving_eccentricity_mm: f64,
    pub saving_interpolation_mm: f64,
    pub saving_jitter_mm: f64,
    /// The term whose exact reading would save most ("none" below 1 % of
    /// the measure or with nothing above the floor).
    pub limiting_term: &'static str,
    /// Which terms the combination's sensors have (in [`BUDGET_TERMS`]
    /// order): an absent one was not rerun, and its columns are written
    /// empty (a present one can save 0: its exact reading did not lower
    /// the measure on these machines).
    pub present: [bool; 4],
}

/// The error terms of a [`TermSplit`], in its column order.
pub const BUDGET_TERMS: [&str; 4] = [
    "curve",
    "eccentricity",
    "interpolation error",
    "jitter and quantisation",
];

impl TermSplit {
    /// From the measure, its floor and its value with each term read
    /// exactly (in [`BUDGET_TERMS`] order).
    pub fn from_means(total: f64, floor: f64, without: [f64; 4], present: [bool; 4]) -> TermSplit {
        let (share, saving, limiting) = split(total, floor, without);
        TermSplit {
            curve_mm: share[0],
            eccentricity_mm: share[1],
            interpolation_mm: share[2],
            jitter_mm: share[3],
            saving_curve_mm: saving[0],
            saving_eccentricity_mm: saving[1],
            saving_interpolation_mm: saving[2],
            saving_jitter_mm: saving[3],
            limiting_term: limiting.map_or("none", |k| BUDGET_TERMS[k]),
            present,
        }
    }

    /// The shares, in [`BUDGET_TERMS`] order.
    pub fn shares(&self) -> [f64; 4] {
        [
            self.curve_mm,
            self.eccentricity_mm,
            self.interpolation_mm,
            self.jitter_mm,
        ]
    }

    /// What reading the limiting term exactly would save, mm.
    pub fn limiting_saving(&self) -> f64 {
        [
            self.saving_curve_mm,
            self.saving_eccentricity_mm,
            self.saving_interpolation_mm,
            self.saving_jitter_mm,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// A measure `mu` split above its floor in proportion to what each part,
/// made exact, saves (`without`: the measure then): the shares (summing to
/// mu − floor), the savings, and the part that limits (saves most, and at
/// least 1 % of mu, with something above the floor).
fn split<const N: usize>(
    mu: f64,
    floor: f64,
    without: [f64; N],
) -> ([f64; N], [f64; N], Option<usize>) {
    // Exact parts can leave a measure above this one (the sensors' errors
    // and the linearisation's partly cancel): what no sensor can fix is
    // then all of it, never more.
    let floor = floor.min(mu);
    let saving = without.map(|w| (mu - w).max(0.0));
    let total: f64 = saving.iter().sum();
    let part = (mu - floor).max(0.0);
    let share = saving.map(|s| if total > 0.0 { part * s / total } else { 0.0 });
    let (k, best) =
        saving.iter().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |a, (i, &v)| if v > a.1 { (i, v) } else { a },
        );
    // A part limits only when making it exact saves a visible part of the
    // measure (1 %), not micrometres of sampling noise.
    let limiting = (best > 0.01 * mu && mu > floor).then_some(k);
    (share, saving, limiting)
}

impl BudgetRow {
    /// What making the limiting sensor perfect would save, mm.
    pub fn limiting_saving(&self) -> f64 {
        [
            self.saving_psi_encoder_mm,
            self.saving_theta_encoder_mm,
            self.saving_scale_mm,
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// The sensors of a budget, in its column order.
pub const BUDGET_SENSORS: [&str; 3] = ["ψ4 encoder", "θ4 encoder", "scale"];

impl BudgetRow {
    /// From the measure (mean μ, or a deciding metric), its floor and its
    /// value with each sensor alone perfect; identity columns are left for
    /// the caller.
    pub fn from_means(mu: f64, floor: f64, without: [f64; 3]) -> BudgetRow {
        let (share, saving, limiting) = split(mu, floor, without);
        BudgetRow {
            measure: "mu_mean",
            encoder_arcsec: f64::NAN,
            scale_um: f64::NAN,
            method: Method::Ols,
            pose_count: 0,
            encoder: String::new(),
            scale: String::new(),
            calibrations: 0,
            total_mm: mu,
            floor_mm: floor.min(mu),
            psi_encoder_mm: share[0],
            theta_encoder_mm: share[1],
            scale_mm: share[2],
            saving_psi_encoder_mm: saving[0],
            saving_theta_encoder_mm: saving[1],
            saving_scale_mm: saving[2],
            limiting: limiting.map_or("none", |k| BUDGET_SENSORS[k]),
            terms: None,
        }
    }
}

impl GradeSummary {
    /// Does the calibration leave the typical machine worse than not
    /// calibrating: median μ/μ0 ≥ 1, or, with the workspace judged, the
    /// median of the largest dV after compensation at or above its median
    /// before? (Not a number counts as harm: nothing can be claimed.)
    pub fn harms(&self) -> bool {
        let worse = |after: f64, before: f64| after.is_nan() || before.is_nan() || after >= before;
        worse(self.ratio_median, 1.0)
            || matches!(
                (self.dv.dv_after_max_median, self.dv.dv_before_max_median),
                (Some(a), Some(b)) if worse(a, b)
            )
    }
}

/// A summary row for tests: grade (method, scale, encoder) with μ/μ0 p95
/// `ratio_p95`, the rest plausible constants.
#[cfg(test)]
pub(crate) fn sample_row(method: Method, scale: f64, enc: f64, ratio_p95: f64) -> GradeSummary {
    GradeSummary {
        encoder_arcsec: enc,
        scale_um: scale,
        method,
        pose_count: 51,
        encoder: String::new(),
        scale: String::new(),
        price: None,
        mu_p95_ci_high: 0.1,
        trials: 100,
        failed: 0,
        not_converged: 0,
        mu_mean: 0.05,
        mu_mean_ci_low: 0.04,
        mu_mean_ci_high: 0.06,
        mu_median: 0.05,
        mu_p05: 0.01,
        mu_p95: 0.09,
        mu0_mean: 0.25,
        ratio_mean: 0.2,
        ratio_median: 0.2,
        ratio_p05: 0.05,
        ratio_p95,
        ratio_p95_ci_low: ratio_p95 * 0.9,
        ratio_p95_ci_high: ratio_p95 * 1.1,
        mu_mean_ci_rel: 0.1,
        ratio_p95_ci_rel: 0.1,
        rank: 14,
        dv: DvSummary::default(),
        meets_target: false,
        truth_amplitude: 1.0,
        truth_extra_harmonic: 0.0,
        truth: "the datasheet".into(),
        lower: LowerLimits::default(),
        second_class_deg: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_workspace_failed_for_every_machine_is_unjudged() {
        let mut r = sample_row(Method::Gls, 1.0, 1.0, 0.2);
        assert!(!r.workspace_unjudged(), "no workspace study");
        r.dv.dv_failed = Some(99);
        assert!(!r.workspace_unjudged(), "one machine judged");
        r.dv.dv_failed = Some(100);
        assert!(r.workspace_unjudged());
        r.trials = 0;
        assert!(
            !r.workspace_unjudged(),
            "no machine at all is another refusal"
        );
    }

    /// summary.csv: the workspace columns between `rank` and
    /// `meets_target`, empty without a workspace study; no NaN anywhere.
    #[test]
    fn the_workspace_columns_sit_in_place_in_summary_csv() {
        let mut r = sample_row(Method::Gls, 1.0, 1.0, 0.2);
        r.mu_p95_ci_high = f64::NAN;
        let mut w = r.clone();
        w.dv = DvSummary {
            dv_after_max_median: Some(0.5),
            dv_after_max_p95_ci_high: Some(f64::INFINITY),
            dv_failed: Some(2),
            ..DvSummary::default()
        };
        // Written as export's CSV writer writes a row (through Cells).
        let mut out = csv::Writer::from_writer(Vec::new());
        for row in [&r, &w] {
            out.serialize(crate::metrics::finite::Cells(row)).unwrap();
        }
        let text = String::from_utf8(out.into_inner().unwrap()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "encoder_arcsec,scale_um,method,pose_count,encoder,scale,price,trials,failed,not_converged,mu_mean,mu_mean_ci_low,mu_mean_ci_high,mu_median,mu_p05,mu_p95,mu_p95_ci_high,mu0_mean,ratio_mean,ratio_median,ratio_p05,ratio_p95,ratio_p95_ci_low,ratio_p95_ci_high,mu_mean_ci_rel,ratio_p95_ci_rel,rank,dv_after_max_median,dv_after_max_p95,dv_after_mean_mean,dv_before_max_median,dv_after_max_p95_ci_high,dv_after_p95_median,dv_after_p95_p95,dv_after_p95_p95_ci_high,ap_after_max_median,ap_after_max_p95,ap_after_max_p95_ci_high,dv_failed,meets_target,truth_amplitude,truth_extra_harmonic,truth"
        );
        let tail = |l: &str| l.split(",14,").nth(1).unwrap().to_string();
        assert_eq!(tail(lines[1]), ",,,,,,,,,,,,false,1.0,0.0,the datasheet");
        assert_eq!(
            tail(lines[2]),
            "0.5,,,,,,,,,,,2,false,1.0,0.0,the datasheet"
        );
        assert!(lines[1].contains(",0.09,,0.25,"), "{}", lines[1]);
        assert_eq!(r.dv.dv_failed, None);
        assert_eq!(
            w.dv.dv_failed,
            Some(2),
            "the row reads its workspace fields"
        );
    }

    #[test]
    fn the_budget_splits_the_sensors_part_in_proportion_to_the_savings() {
        let b = BudgetRow::from_means(0.1, 0.02, [0.09, 0.1, 0.05]);
        // Savings 0.01, 0, 0.05 of a sensor part 0.08.
        assert!((b.saving_psi_encoder_mm - 0.01).abs() < 1e-15);
        assert_eq!(b.saving_theta_encoder_mm, 0.0);
        assert!((b.saving_scale_mm - 0.05).abs() < 1e-15);
        assert!((b.psi_encoder_mm - 0.08 * 0.01 / 0.06).abs() < 1e-15);
        assert_eq!(b.theta_encoder_mm, 0.0);
        assert!((b.scale_mm - 0.08 * 0.05 / 0.06).abs() < 1e-15);
        let sum = b.floor_mm + b.psi_encoder_mm + b.theta_encoder_mm + b.scale_mm;
        assert!((sum - 0.1).abs() < 1e-15);
        assert_eq!(b.limiting, "scale");
        assert!((b.limiting_saving() - 0.05).abs() < 1e-15);
        // A perfect sensor that would not help saves 0, not a negative amount.
        let b = BudgetRow::from_means(0.1, 0.02, [0.11, 0.07, 0.1]);
        assert_eq!(b.saving_psi_encoder_mm, 0.0);
        assert_eq!(b.limiting, "θ4 encoder");
        // Nothing to save: no shares, nothing limiting.
        let b = BudgetRow::from_means(0.1, 0.1, [0.1, 0.1, 0.1]);
        assert_eq!(
            (b.psi_encoder_mm, b.theta_encoder_mm, b.scale_mm),
            (0.0, 0.0, 0.0)
        );
        assert_eq!(b.limiting, "none");
        assert_eq!(
            BudgetRow::from_means(0.1, 0.02, [0.05, 0.1, 0.1]).limiting,
            "ψ4 encoder"
        );
        // Perfect sensors doing worse than these (floor 0.12 > μ 0.1): the
        // floor is all of μ, never above it, and nothing limits, even where
        // one sensor's perfection would save a micrometre.
        let b = BudgetRow::from_means(0.1, 0.12, [0.099, 0.1, 0.1]);
        assert_eq!(b.floor_mm, 0.1);
        assert_eq!(b.limiting, "none");
        // A saving under 1 % of μ limits nothing; at 1 % and over it does.
        assert_eq!(
            BudgetRow::from_means(0.1, 0.02, [0.0995, 0.1, 0.1]).limiting,
            "none"
        );
        assert_eq!(
            BudgetRow::from_means(0.1, 0.02, [0.0985, 0.1, 0.1]).limiting,
            "ψ4 encoder"
        );
    }
}
