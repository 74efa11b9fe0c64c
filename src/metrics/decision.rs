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
    MuP95CiHigh,
    RatioP95CiHigh,
    DvAfterMaxP95,
    DvAfterMaxMedian,
    DvAfterMeanMean,
    DvAfterMaxP95CiHigh,
    DvAfterP95P95,
    DvAfterP95P95CiHigh,
    ApAfterMaxP95,
    ApAfterMaxP95CiHigh,
}

impl DecisionMetric {
    /// Every metric, in the order docs/config.md lists them.
    pub const ALL: [DecisionMetric; 17] = [
        DecisionMetric::MuMean,
        DecisionMetric::MuMedian,
        DecisionMetric::MuP95,
        DecisionMetric::RatioMean,
        DecisionMetric::RatioMedian,
        DecisionMetric::RatioP95,
        DecisionMetric::MuMeanCiHigh,
        DecisionMetric::MuP95CiHigh,
        DecisionMetric::RatioP95CiHigh,
        DecisionMetric::DvAfterMaxP95,
        DecisionMetric::DvAfterMaxMedian,
        DecisionMetric::DvAfterMeanMean,
        DecisionMetric::DvAfterMaxP95CiHigh,
        DecisionMetric::DvAfterP95P95,
        DecisionMetric::DvAfterP95P95CiHigh,
        DecisionMetric::ApAfterMaxP95,
        DecisionMetric::ApAfterMaxP95CiHigh,
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
            DecisionMetric::MuP95CiHigh => "mu_p95_ci_high",
            DecisionMetric::RatioP95CiHigh => "ratio_p95_ci_high",
            DecisionMetric::DvAfterMaxP95 => "dv_after_max_p95",
            DecisionMetric::DvAfterMaxMedian => "dv_after_max_median",
            DecisionMetric::DvAfterMeanMean => "dv_after_mean_mean",
            DecisionMetric::DvAfterMaxP95CiHigh => "dv_after_max_p95_ci_high",
            DecisionMetric::DvAfterP95P95 => "dv_after_p95_p95",
            DecisionMetric::DvAfterP95P95CiHigh => "dv_after_p95_p95_ci_high",
            DecisionMetric::ApAfterMaxP95 => "ap_after_max_p95",
            DecisionMetric::ApAfterMaxP95CiHigh => "ap_after_max_p95_ci_high",
        }
    }

    /// The metric in words (colour bars, legends).
    pub fn describe(&self) -> &'static str {
        match self {
            DecisionMetric::MuMean => "mean μ across machines (mm)",
            DecisionMetric::MuMedian => "median μ across machines (mm)",
            DecisionMetric::MuP95 => "μ reached by 95 % of machines (mm)",
            DecisionMetric::RatioMean => "mean μ/μ0 across machines",
            DecisionMetric::RatioMedian => "median μ/μ0 across machines",
            DecisionMetric::RatioP95 => "μ/μ0 reached by 95 % of machines",
            DecisionMetric::MuMeanCiHigh => "mean μ, upper 97.5 % confidence limit (mm)",
            DecisionMetric::MuP95CiHigh => {
                "μ of 95 % of machines, upper 95 % confidence limit (mm)"
            }
            DecisionMetric::RatioP95CiHigh => {
                "μ/μ0 of 95 % of machines, upper 97.5 % confidence limit"
            }
            DecisionMetric::DvAfterMaxP95 => "max dV over the workspace, 95 % of machines (mm)",
            DecisionMetric::DvAfterMaxMedian => "max dV over the workspace, median machine (mm)",
            DecisionMetric::DvAfterMeanMean => "mean dV over the workspace, mean of machines (mm)",
            DecisionMetric::DvAfterMaxP95CiHigh => {
                "max dV, 95 % of machines, upper 95 % confidence limit (mm)"
            }
            DecisionMetric::DvAfterP95P95 => "dV p95 over the workspace, 95 % of machines (mm)",
            DecisionMetric::DvAfterP95P95CiHigh => {
                "dV p95, 95 % of machines, upper 95 % confidence limit (mm)"
            }
            DecisionMetric::ApAfterMaxP95 => "worst ISO 9283 AP, 95 % of machines (mm)",
            DecisionMetric::ApAfterMaxP95CiHigh => {
                "worst AP, 95 % of machines, upper 95 % confidence limit (mm)"
            }
        }
    }

    /// The metric of a column name.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The metric's value in a summary row (None: not computed in this
    /// study, or not defined: a confidence limit that does not exist at
    /// this many machines, a statistic of none).
    pub fn value(&self, r: &GradeSummary) -> Option<f64> {
        self.raw_value(r).filter(|v| v.is_finite())
    }

    fn raw_value(&self, r: &GradeSummary) -> Option<f64> {
        Some(match self {
            DecisionMetric::MuMean => r.mu_mean,
            DecisionMetric::MuMedian => r.mu_median,
            DecisionMetric::MuP95 => r.mu_p95,
            DecisionMetric::RatioMean => r.ratio_mean,
            DecisionMetric::RatioMedian => r.ratio_median,
            DecisionMetric::RatioP95 => r.ratio_p95,
            DecisionMetric::MuMeanCiHigh => r.mu_mean_ci_high,
            DecisionMetric::MuP95CiHigh => r.mu_p95_ci_high,
            DecisionMetric::RatioP95CiHigh => r.ratio_p95_ci_high,
            DecisionMetric::DvAfterMaxP95 => r.dv.dv_after_max_p95?,
            DecisionMetric::DvAfterMaxMedian => r.dv.dv_after_max_median?,
            DecisionMetric::DvAfterMeanMean => r.dv.dv_after_mean_mean?,
            DecisionMetric::DvAfterMaxP95CiHigh => r.dv.dv_after_max_p95_ci_high?,
            DecisionMetric::DvAfterP95P95 => r.dv.dv_after_p95_p95?,
            DecisionMetric::DvAfterP95P95CiHigh => r.dv.dv_after_p95_p95_ci_high?,
            DecisionMetric::ApAfterMaxP95 => r.dv.ap_after_max_p95?,
            DecisionMetric::ApAfterMaxP95CiHigh => r.dv.ap_after_max_p95_ci_high?,
        })
    }

    /// The lower confidence limit of the metric's estimate in row `r` (of
    /// the estimate for a limit), where the study has one: mean μ's and
    /// μ/μ0 p95's two-sided interval bottoms, the other 95th percentiles'
    /// lower limits.
    pub fn lower_value(&self, r: &GradeSummary) -> Option<f64> {
        use DecisionMetric as M;
        match self {
            M::MuMean | M::MuMeanCiHigh => Some(r.mu_mean_ci_low),
            M::RatioP95 | M::RatioP95CiHigh => Some(r.ratio_p95_ci_low),
            M::MuP95 | M::MuP95CiHigh => r.lower.mu_p95,
            M::DvAfterMaxP95 | M::DvAfterMaxP95CiHigh => r.lower.dv_after_max_p95,
            M::DvAfterP95P95 | M::DvAfterP95P95CiHigh => r.lower.dv_after_p95_p95,
            M::ApAfterMaxP95 | M::ApAfterMaxP95CiHigh => r.lower.ap_after_max_p95,
            _ => None,
        }
        .filter(|v| v.is_finite())
    }

    /// The metric's upper 95 % confidence limit (itself for a limit; None
    /// when the summary has no confidence limit of it).
    pub fn upper_limit(&self) -> Option<Self> {
        use DecisionMetric as M;
        Some(match self {
            M::MuMean | M::MuMeanCiHigh => M::MuMeanCiHigh,
            M::MuP95 | M::MuP95CiHigh => M::MuP95CiHigh,
            M::RatioP95 | M::RatioP95CiHigh => M::RatioP95CiHigh,
            M::DvAfterMaxP95 | M::DvAfterMaxP95CiHigh => M::DvAfterMaxP95CiHigh,
            M::DvAfterP95P95 | M::DvAfterP95P95CiHigh => M::DvAfterP95P95CiHigh,
            M::ApAfterMaxP95 | M::ApAfterMaxP95CiHigh => M::ApAfterMaxP95CiHigh,
            _ => return None,
        })
    }

    /// For a confidence limit: its one-sided confidence (0.95 for the
    /// limits of a 95th percentile; 0.975 for the top of a two-sided 95 %
    /// interval: mean μ's and μ/μ0 p95's) and, for a quantile's, the
    /// quantile. None for an estimate.
    pub fn limit_confidence(&self) -> Option<(f64, Option<f64>)> {
        use DecisionMetric as M;
        Some(match self {
            M::MuMeanCiHigh => (0.975, None),
            M::RatioP95CiHigh => (0.975, Some(0.95)),
            M::MuP95CiHigh
            | M::DvAfterMaxP95CiHigh
            | M::DvAfterP95P95CiHigh
            | M::ApAfterMaxP95CiHigh => (0.95, Some(0.95)),
            _ => return None,
        })
    }

    /// The one-sided confidence of the metric's lower limit (the bottom
    /// of a two-sided 95 % interval: 0.975, for mean μ, μ p95 and μ/μ0
    /// p95; 0.95, the order statistic below a workspace percentile). None
    /// where it has none.
    pub fn lower_confidence(&self) -> Option<f64> {
        use DecisionMetric as M;
        match self {
            M::MuMean
            | M::MuMeanCiHigh
            | M::RatioP95
            | M::RatioP95CiHigh
            | M::MuP95
            | M::MuP95CiHigh => Some(0.975),
            M::DvAfterMaxP95
            | M::DvAfterMaxP95CiHigh
            | M::DvAfterP95P95
            | M::DvAfterP95P95CiHigh
            | M::ApAfterMaxP95
            | M::ApAfterMaxP95CiHigh => Some(0.95),
            _ => None,
        }
    }

    /// The fewest machines for which the metric exists: a quantile's upper
    /// limit needs the largest of n values to be one (59 for the one-sided
    /// 95 % limit of a p95, 72 for 97.5 %), a mean's t interval 2.
    pub fn machines_needed(&self) -> usize {
        match self.limit_confidence() {
            Some((conf, Some(p))) => super::stats::values_for_upper_limit(p, conf),
            Some((_, None)) => 2,
            None => 1,
        }
    }

    /// The limit in words, with its one-sided confidence.
    pub fn limit_words(&self) -> &'static str {
        match self.limit_confidence() {
            // The top of a two-sided 95 % interval (docs/method.md §15).
            Some((c, _)) if c > 0.95 => "upper 97.5 % confidence limit",
            _ => "upper 95 % confidence limit",
        }
    }

    /// Needs the per-calibration volumetric map (`sweep.volumetric = true`).
    pub fn needs_volumetric(&self) -> bool {
        self.volumetric_series().is_some()
    }

    /// For a workspace metric: which per-calibration series it summarises
    /// (index into the volumetric record: 0 dV max, 1 dV mean, 3 dV p95,
    /// 4 worst AP) and the statistic across machines (Some(p): the
    /// p-quantile; None: the mean) — what adaptive stopping must pin down.
    pub fn volumetric_series(&self) -> Option<(usize, Option<f64>)> {
        Some(match self {
            DecisionMetric::DvAfterMaxP95 | DecisionMetric::DvAfterMaxP95CiHigh => (0, Some(0.95)),
            DecisionMetric::DvAfterMaxMedian => (0, Some(0.5)),
            DecisionMetric::DvAfterMeanMean => (1, None),
            DecisionMetric::DvAfterP95P95 | DecisionMetric::DvAfterP95P95CiHigh => (3, Some(0.95)),
            DecisionMetric::ApAfterMaxP95 | DecisionMetric::ApAfterMaxP95CiHigh => (4, Some(0.95)),
            _ => return None,
        })
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

/// Which value of the metric must meet the threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Confidence {
    /// The estimate (the paper's rule).
    Estimate,
    /// Its upper 95 % confidence limit: the target is met with 95 %
    /// confidence despite the Monte-Carlo's finite sample.
    Upper95,
}

/// A study's target: `metric ≤ threshold`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decision {
    /// The deciding column: `estimate`, or its upper confidence limit.
    pub metric: DecisionMetric,
    /// The metric as the config states it.
    pub estimate: DecisionMetric,
    pub confidence: Confidence,
    pub threshold: f64,
}

impl DecisionMetric {
    /// What the uncalibrated machines of a row reach on this metric's
    /// scale, to warn of a target they already meet: 1 for μ/μ0, mean μ0
    /// for μ, the median of max dV before compensation for dV and AP.
    pub fn uncalibrated(&self, r: &GradeSummary) -> Option<f64> {
        let name = self.name();
        if name.starts_with("ratio") {
            Some(1.0)
        } else if name.starts_with("mu") {
            Some(r.mu0_mean)
        } else {
            r.dv.dv_before_max_median
        }
        .filter(|v| v.is_finite())
    }
}

impl Decision {
    /// Does the grade of this summary row meet the target? Never when its
    /// calibration harms the machine ([`GradeSummary::harms`]), whatever
    /// the threshold.
    pub fn meets(&self, r: &GradeSummary) -> bool {
        !r.harms() && self.metric.value(r).is_some_and(|v| v <= self.threshold)
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
                    "{m} with a {scale} µm scale: the coarsest encoder meeting {metric} ≤ {threshold} is {}″ ({metric} = {:.4})",
                    r.encoder_arcsec,
                    metric.value(r).unwrap_or(f64::NAN),
                ),
                None => format!(
                    "{m} with a {scale} µm scale: no encoder grade studied meets {metric} ≤ {threshold}"
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::summary::sample_row as row;

    #[test]
    fn decide_picks_the_coarsest_grade_that_meets_the_target() {
        let d = Decision {
            metric: DecisionMetric::RatioP95,
            estimate: DecisionMetric::RatioP95,
            confidence: Confidence::Estimate,
            threshold: 0.5,
        };
        // Ratio grows with the encoder grade; 1″, 2″ and 4″ pass, 8″ fails.
        let mut rows: Vec<GradeSummary> = [(1.0, 0.2), (8.0, 0.7), (2.0, 0.3), (4.0, 0.5)]
            .iter()
            .map(|&(e, r)| row(Method::Ols, 0.5, e, r))
            .chain([row(Method::Ols, 2.0, 1.0, 0.9)])
            .collect();
        for r in rows.iter_mut() {
            r.meets_target = d.meets(r);
        }
        assert_eq!(
            rows.iter().map(|r| r.meets_target).collect::<Vec<_>>(),
            [true, false, true, true, false]
        );
        let out = decide(&d, &[Method::Ols], &[0.5, 2.0], &rows);
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].chosen_encoder_arcsec, Some(4.0));
        assert_eq!(out[0].value_at_choice, Some(0.5));
        assert!(out[0].verdict.contains("is 4″"), "{}", out[0].verdict);
        assert!(
            out[0].verdict.contains("meeting ratio_p95 ≤ 0.5"),
            "{}",
            out[0].verdict
        );
        assert_eq!(format!("{}", DecisionMetric::MuP95), "mu_p95");
        assert_eq!(out[1].chosen_encoder_arcsec, None);
        assert!(out[1].verdict.contains("no encoder grade"));
    }

    #[test]
    fn metric_names_round_trip_and_classify() {
        for m in DecisionMetric::ALL {
            assert_eq!(DecisionMetric::parse(m.name()), Some(m));
            assert_eq!(
                m.needs_volumetric(),
                m.name().starts_with("dv_") || m.name().starts_with("ap_")
            );
            assert_eq!(m.is_ratio(), m.name().starts_with("ratio"));
            assert_eq!(m.uses_ratio_p95(), m.name().starts_with("ratio_p95"));
        }
        let r = row(Method::Wls, 0.5, 1.0, 0.4);
        assert_eq!(DecisionMetric::RatioP95CiHigh.value(&r), Some(0.4 * 1.1));
        assert_eq!(DecisionMetric::MuMeanCiHigh.value(&r), Some(0.06));
        assert_eq!(DecisionMetric::DvAfterMaxP95.value(&r), None);
        assert_eq!(DecisionMetric::parse("ratio_p99"), None);
        // Every metric has its own words, naming its unit where it has one.
        let words: Vec<&str> = DecisionMetric::ALL.iter().map(|m| m.describe()).collect();
        for (m, w) in DecisionMetric::ALL.iter().zip(&words) {
            assert!(w.len() > 10, "{m}: {w}");
            assert_eq!(
                w.contains("(mm)"),
                !m.name().starts_with("ratio"),
                "{m}: {w}"
            );
        }
    }

    #[test]
    fn each_metric_with_a_confidence_limit_maps_to_it() {
        use DecisionMetric as M;
        let pairs = [
            (M::MuMean, M::MuMeanCiHigh),
            (M::MuP95, M::MuP95CiHigh),
            (M::RatioP95, M::RatioP95CiHigh),
            (M::DvAfterMaxP95, M::DvAfterMaxP95CiHigh),
            (M::DvAfterP95P95, M::DvAfterP95P95CiHigh),
            (M::ApAfterMaxP95, M::ApAfterMaxP95CiHigh),
        ];
        for (m, hi) in pairs {
            assert_eq!(m.upper_limit(), Some(hi), "{m}");
            assert_eq!(hi.upper_limit(), Some(hi), "{hi}");
        }
        for m in [
            M::MuMedian,
            M::RatioMean,
            M::RatioMedian,
            M::DvAfterMaxMedian,
            M::DvAfterMeanMean,
        ] {
            assert_eq!(m.upper_limit(), None, "{m}");
        }
    }
}
