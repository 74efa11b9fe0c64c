//! The rows of a study's results: one [`GradeSummary`] per grade
//! (`summary.csv`) and one [`ParameterRow`] per grade and error
//! (`parameters.csv`). CSV columns are the field names.

use crate::identify::Method;
use serde::Serialize;

/// Summary of one grade (one row of summary.csv).
#[derive(Debug, Clone, Serialize)]
pub struct GradeSummary {
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub encoder_arcsec: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub scale_um: f64,
    pub method: Method,
    pub trials: u64,
    pub failed: u64,
    pub not_converged: u64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_mean: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_mean_ci_low: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_mean_ci_high: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_median: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_p05: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_p95: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu0_mean: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_mean: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_median: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_p05: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_p95: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_p95_ci_low: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_p95_ci_high: f64,
    /// Achieved 95 % CI half-widths relative to the value (adaptive stopping).
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mu_mean_ci_rel: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_p95_ci_rel: f64,
    pub rank: u8,
    /// Volumetric accuracy after compensation (empty unless sweep.volumetric).
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_max_median: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_max_p95: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_mean_mean: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_before_max_median: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_max_p95_ci_high: Option<f64>,
    /// Per machine the 95th percentile of dV over the workspace grid; its
    /// median and 95th percentile across machines.
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_p95_median: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_p95_p95: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub dv_after_p95_p95_ci_high: Option<f64>,
    /// Per machine the worst ISO 9283 AP at P1–P5 after compensation.
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub ap_after_max_median: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub ap_after_max_p95: Option<f64>,
    #[serde(serialize_with = "crate::metrics::finite::optional")]
    pub ap_after_max_p95_ci_high: Option<f64>,
    /// Calibrations whose map could not be computed (some point unreachable
    /// by the true machine); left out of the dV statistics.
    pub dv_failed: Option<u64>,
    pub meets_target: bool,
}

/// Per parameter and grade: Monte-Carlo spread of the estimate against the
/// standard deviation the linear covariance predicts (parameters.csv).
#[derive(Debug, Clone, Serialize)]
pub struct ParameterRow {
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub encoder_arcsec: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub scale_um: f64,
    pub method: Method,
    pub parameter: &'static str,
    pub identifiable: bool,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub bias_mm: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub mc_std_mm: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub predicted_std_mm: f64,
    #[serde(serialize_with = "crate::metrics::finite::number")]
    pub ratio_mc_to_predicted: f64,
}
