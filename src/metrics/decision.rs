//! The decision rule of a study: a grade passes when its [`DecisionMetric`]
//! is at most the threshold, and [`decide`] picks, for every estimator and
//! scale grade, the coarsest encoder grade that passes (the cheapest sensor
//! that is good enough). A new metric is one arm here.

use super::summary::GradeSummary;
use crate::identify::Method;
use serde::{Serialize, Serializer};

/// A column of `summary.csv` a decision may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecisionMetric {
    MuMean,
    MuMedian,
    MuP95,
    RatioMean,
    RatioMedian,
    RatioP95,
    MuMeanCiHigh,
    RatioP95CiHigh,
    DvAfterMaxP95,
    DvAfterMaxMedian,
    DvAfterMeanMean,
}

impl DecisionMetric {
    /// Every metric, in the order the README lists them.
    pub const ALL: [DecisionMetric; 11] = [
        DecisionMetric::MuMean,
        DecisionMetric::MuMedian,
        DecisionMetric::MuP95,
        DecisionMetric::RatioMean,
        DecisionMetric::RatioMedian,
        DecisionMetric::RatioP95,
        DecisionMetric::MuMeanCiHigh,
        DecisionMetric::RatioP95CiHigh,
        DecisionMetric::DvAfterMaxP95,
        DecisionMetric::DvAfterMaxMedian,
        DecisionMetric::DvAfterMeanMean,
    ];

    /// The summary column's name.
    pub fn name(&self) -> &'static str {
        match self {
            DecisionMetric::MuMean => "mu_mean",
            DecisionMetric::MuMedian => "mu_median",
            DecisionMetric::MuP95 => "mu_p95",
            DecisionMetric::RatioMean => "ratio_mean",
            DecisionMetric::RatioMedian => "ratio_median",
            DecisionMetric::RatioP95 => "ratio_p95",
            DecisionMetric::MuMeanCiHigh => "mu_mean_ci_high",
            DecisionMetric::RatioP95CiHigh => "ratio_p95_ci_high",
            DecisionMetric::DvAfterMaxP95 => "dv_after_max_p95",
            DecisionMetric::DvAfterMaxMedian => "dv_after_max_median",
            DecisionMetric::DvAfterMeanMean => "dv_after_mean_mean",
        }
    }

    /// The metric of a column name.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The metric's value in a summary row (None: not computed in this study).
    pub fn value(&self, r: &GradeSummary) -> Option<f64> {
        Some(match self {
            DecisionMetric::MuMean => r.mu_mean,
            DecisionMetric::MuMedian => r.mu_median,
            DecisionMetric::MuP95 => r.mu_p95,
            DecisionMetric::RatioMean => r.ratio_mean,
            DecisionMetric::RatioMedian => r.ratio_median,
            DecisionMetric::RatioP95 => r.ratio_p95,
            DecisionMetric::MuMeanCiHigh => r.mu_mean_ci_high,
            DecisionMetric::RatioP95CiHigh => r.ratio_p95_ci_high,
            DecisionMetric::DvAfterMaxP95 => r.dv_after_max_p95?,
            DecisionMetric::DvAfterMaxMedian => r.dv_after_max_median?,
            DecisionMetric::DvAfterMeanMean => r.dv_after_mean_mean?,
        })
    }

    /// Needs the per-calibration volumetric map (`sweep.volumetric = true`).
    pub fn needs_volumetric(&self) -> bool {
        matches!(
            self,
            DecisionMetric::DvAfterMaxP95
                | DecisionMetric::DvAfterMaxMedian
                | DecisionMetric::DvAfterMeanMean
        )
    }

    /// A ratio μ/μ0 (drawn against the μ/μ0 axis of the sweep's figure).
    pub fn is_ratio(&self) -> bool {
        matches!(
            self,
            DecisionMetric::RatioMean
                | DecisionMetric::RatioMedian
                | DecisionMetric::RatioP95
                | DecisionMetric::RatioP95CiHigh
        )
    }

    /// Built on the 95th percentile of μ/μ0 (adaptive stopping then also
    /// checks that percentile's confidence interval).
    pub fn uses_ratio_p95(&self) -> bool {
        matches!(
            self,
            DecisionMetric::RatioP95 | DecisionMetric::RatioP95CiHigh
        )
    }
}

impl std::fmt::Display for DecisionMetric {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for DecisionMetric {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// The coarsest encoder grade meeting the target, per (method, scale).
#[derive(Debug, Clone, Serialize)]
pub struct DecisionRow {
    pub method: Method,
    pub scale_um: f64,
    pub metric: DecisionMetric,
    pub threshold: f64,
    /// Empty when no grade meets the target.
    pub chosen_encoder_arcsec: Option<f64>,
    pub value_at_choice: Option<f64>,
    pub verdict: String,
}

/// A study's target: `metric ≤ threshold`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    pub metric: DecisionMetric,
    pub threshold: f64,
}

impl Decision {
    /// Does the grade of this summary row meet the target?
    pub fn meets(&self, r: &GradeSummary) -> bool {
        self.metric.value(r).is_some_and(|v| v <= self.threshold)
    }
}

/// For each (estimator, scale grade), in the study's order: the coarsest
/// encoder grade whose row meets the target (rows' `meets_target`).
pub fn decide(
    decision: &Decision,
    methods: &[Method],
    scales_um: &[f64],
    summary: &[GradeSummary],
) -> Vec<DecisionRow> {
    let metric = decision.metric;
    let threshold = decision.threshold;
    let mut out = Vec::new();
    for &method in methods {
        for &scale in scales_um {
            let chosen = summary
                .iter()
                .filter(|r| r.method == method && r.scale_um == scale && r.meets_target)
                .max_by(|a, b| a.encoder_arcsec.total_cmp(&b.encoder_arcsec));
            let m = method.name();
            let verdict = match chosen {
                Some(r) => format!(
                    "{m} with a {scale} um scale: the coarsest encoder meeting {metric} <= {threshold} is {} arcsec ({metric} = {:.4})",
                    r.encoder_arcsec,
                    metric.value(r).unwrap_or(f64::NAN),
                ),
                None => format!(
                    "{m} with a {scale} um scale: no encoder grade studied meets {metric} <= {threshold}"
                ),
            };
            out.push(DecisionRow {
                method,
                scale_um: scale,
                metric,
                threshold,
                chosen_encoder_arcsec: chosen.map(|r| r.encoder_arcsec),
                value_at_choice: chosen.and_then(|r| metric.value(r)),
                verdict,
            });
        }
    }
    out
}
