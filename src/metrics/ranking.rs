//! The buyer's rule over every combination of a study (`decision.csv`):
//! those that meet the target first, in the buyer's order of any mechanism
//! ([`super::buyer`]); then the others by how close they come; fragile and
//! what-if marks. The paragraph that answers "what to buy" is
//! [`super::verdict`].

use super::buyer::Offer;
use super::decision::{Confidence, Decision, DecisionMetric};
use super::summary::GradeSummary;
use crate::identify::Method;
use serde::Serialize;

/// One combination of `decision.csv`: its identity, price, the metric with
/// its upper confidence limit, and whether it meets the target.
#[derive(Debug, Clone, Serialize)]
pub struct RankedRow {
    /// 1 for the choice; feasible combinations first.
    pub rank: usize,
    /// Index of the combination's summary (and budget) row.
    #[serde(skip)]
    pub row: usize,
    pub chosen: bool,
    /// Meets the target and is not fragile.
    pub feasible: bool,
    /// Meets the target at this pose count but the same sensors and
    /// estimator miss it at a larger one: the pass rests on which poses were
    /// picked, so the rule does not choose it.
    pub fragile: bool,
    /// The calibration leaves the typical machine worse than not
    /// calibrating ([`GradeSummary::harms`]): never feasible.
    pub harms: bool,
    /// What the uncalibrated machines reach on the deciding metric's scale
    /// ([`DecisionMetric::uncalibrated`]).
    #[serde(skip)]
    pub uncalibrated: Option<f64>,
    /// Meets the target, and under every what-if row of the study too
    /// (empty without what-if rows; see [`mark_what_ifs`]).
    pub meets_every_what_if: Option<bool>,
    pub encoder: String,
    pub scale: String,
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub pose_count: usize,
    pub method: Method,
    pub price: Option<f64>,
    pub metric: DecisionMetric,
    pub value: Option<f64>,
    /// The metric's upper confidence limit (empty where it does not exist
    /// at this many machines, or the metric has none) and its one-sided
    /// confidence: 0.95, or 0.975 for the top of a two-sided 95 % interval.
    pub upper_limit: Option<f64>,
    pub upper_limit_confidence: Option<f64>,
    /// The lower confidence limit of the estimate (empty where the study has
    /// none; see [`DecisionMetric::lower_value`]).
    pub lower_limit: Option<f64>,
    /// The estimate's confidence interval holds the threshold: this many
    /// machines cannot tell whether the combination meets the target.
    pub undecided: bool,
    pub confidence: Confidence,
    pub threshold: f64,
}

/// Every combination (summary row) ranked by the buyer's rule: those that
/// meet the target first, in the buyer's order ([`Offer::buyer_cmp`]:
/// total price, pose count, the coarser grades, the more accurate); then
/// the others by how close they come.
/// The first row is the choice when it is feasible.
pub fn rank_combinations(decision: &Decision, summary: &[GradeSummary]) -> Vec<RankedRow> {
    let deciding = |r: &GradeSummary| decision.metric.value(r).unwrap_or(f64::NAN);
    // The same sensors and estimator: products and grades, and method. A
    // miss beyond doubt: no value, harm, or the lower limit beyond the
    // threshold (the rows `undecided` leaves out).
    let fragile = super::buyer::fragile(
        &summary
            .iter()
            .map(|r| {
                let sensors = (&r.encoder, &r.scale, r.encoder_arcsec, r.scale_um, r.method);
                let clear_miss = !r.meets_target
                    && (decision.estimate.value(r).is_none()
                        || r.harms()
                        || decision
                            .estimate
                            .lower_value(r)
                            .is_some_and(|l| l > decision.threshold));
                (sensors, r.pose_count, r.meets_target, clear_miss)
            })
            .collect::<Vec<_>>(),
    );
    let feasible: Vec<bool> = (0..summary.len())
        .map(|k| summary[k].meets_target && !fragile[k])
        .collect();
    let offers: Vec<Offer> = summary
        .iter()
        .map(|r| offer(r, decision.estimate.upper_limit().and_then(|m| m.value(r))))
        .collect();
    let mut order: Vec<usize> = (0..summary.len()).collect();
    order.sort_by(|&a, &b| {
        (!feasible[a])
            .cmp(&!feasible[b])
            .then_with(|| {
                if feasible[a] {
                    offers[a].buyer_cmp(&offers[b])
                } else {
                    let v = |r: &GradeSummary| {
                        let x = deciding(r);
                        if x.is_nan() {
                            f64::INFINITY
                        } else {
                            x
                        }
                    };
                    v(&summary[a]).total_cmp(&v(&summary[b]))
                }
            })
            .then(a.cmp(&b))
    });
    order
        .into_iter()
        .enumerate()
        .map(|(i, k)| {
            let r = &summary[k];
            let value = decision.estimate.value(r);
            let upper = decision.estimate.upper_limit().and_then(|m| m.value(r));
            let lower = decision.estimate.lower_value(r);
            let t = decision.threshold;
            // A metric with no confidence limits (a median, a mean ratio)
            // is decided on its estimate: no number of machines would
            // settle it otherwise.
            let undecided = value.is_some()
                && decision.estimate.upper_limit().is_some()
                && !r.harms()
                && lower.is_none_or(|l| l <= t)
                && upper.is_none_or(|u| u > t);
            RankedRow {
                rank: i + 1,
                row: k,
                chosen: i == 0 && feasible[k],
                feasible: feasible[k],
                fragile: fragile[k],
                harms: r.harms(),
                uncalibrated: decision.metric.uncalibrated(r),
                meets_every_what_if: None,
                encoder: r.encoder.clone(),
                scale: r.scale.clone(),
                encoder_arcsec: r.encoder_arcsec,
                scale_um: r.scale_um,
                pose_count: r.pose_count,
                method: r.method,
                price: r.price,
                metric: decision.estimate,
                value,
                upper_limit: upper,
                lower_limit: lower,
                undecided,
                upper_limit_confidence: decision
                    .estimate
                    .upper_limit()
                    .and_then(|m| m.limit_confidence())
                    .map(|c| c.0),
                confidence: decision.confidence,
                threshold: decision.threshold,
            }
        })
        .collect()
}

/// Mark each combination that has what-if rows (`truth`: the same sensors,
/// pose count and estimator read by other sensors than the datasheets
/// describe) with whether it meets the target under every one of them.
pub fn mark_what_ifs(ranking: &mut [RankedRow], truth: &[GradeSummary]) {
    for r in ranking.iter_mut() {
        let mut rows = truth
            .iter()
            .filter(|t| {
                t.encoder == r.encoder
                    && t.scale == r.scale
                    && t.encoder_arcsec == r.encoder_arcsec
                    && t.scale_um == r.scale_um
                    && t.pose_count == r.pose_count
                    && t.method == r.method
            })
            .peekable();
        r.meets_every_what_if = match rows.peek() {
            None => None,
            Some(_) => Some(r.feasible && rows.all(|t| t.meets_target)),
        };
    }
}

/// What the buyer's order compares of a summary row whose deciding
/// statistic's upper limit is `upper`.
fn offer(r: &GradeSummary, upper: Option<f64>) -> Offer {
    Offer {
        upper,
        ..offer_parts(
            r.price,
            r.pose_count,
            [r.encoder_arcsec, r.scale_um],
            r.method,
        )
    }
}

/// Every row fits the same sensors (two encoders and a scale) and is
/// calibrated in one step.
fn offer_parts(price: Option<f64>, poses: usize, grades: [f64; 2], method: Method) -> Offer {
    Offer {
        price,
        fitted: 3,
        poses,
        grades,
        iterated: false,
        upper: None,
        estimator: Method::ALL.iter().position(|m| *m == method).unwrap_or(0) as u8,
    }
}

/// The combinations these machines cannot decide on: those whose interval
/// holds the threshold and that would be bought before the choice (any,
/// when nothing is chosen), cheapest first. Empty: the study has decided.
pub fn undecided(ranking: &[RankedRow]) -> Vec<&RankedRow> {
    let chosen = ranking.first().filter(|r| r.chosen);
    let mut out: Vec<&RankedRow> = ranking
        .iter()
        .filter(|r| r.undecided && chosen.is_none_or(|c| r.row == c.row || r.cheaper_than(c)))
        .collect();
    out.sort_by(|a, b| {
        if a.cheaper_than(b) {
            std::cmp::Ordering::Less
        } else if b.cheaper_than(a) {
            std::cmp::Ordering::Greater
        } else {
            std::cmp::Ordering::Equal
        }
    });
    out
}

impl RankedRow {
    /// Is this combination bought before `other` by the buyer's order
    /// ([`Offer::buyer_cmp`])?
    pub fn cheaper_than(&self, other: &RankedRow) -> bool {
        self.offer().buyer_cmp(&other.offer()).is_lt()
    }

    /// What the buyer's order compares of this row.
    pub fn offer(&self) -> Offer {
        Offer {
            upper: self.upper_limit,
            ..offer_parts(
                self.price,
                self.pose_count,
                [self.encoder_arcsec, self.scale_um],
                self.method,
            )
        }
    }

    /// Machines that would settle whether this combination meets the
    /// target: the interval's half-width on the threshold's side shrinks as
    /// 1/√n until it no longer holds the threshold; without an upper limit
    /// yet, the machines that give one (None when the estimate sits on the
    /// threshold or the metric has no limits).
    pub fn machines_to_decide(&self, trials: u64) -> Option<u64> {
        // No upper limit yet (too few machines for one): at least the
        // machines that give one, as the hexapod's verdict says.
        if let (None, Some(limit)) = (self.upper_limit, self.metric.upper_limit()) {
            return Some((limit.machines_needed() as u64).max(trials + 1));
        }
        super::buyer::machines_to_decide(
            trials,
            self.value?,
            self.threshold,
            (self.lower_limit, self.upper_limit),
        )
    }

    /// The sensor pair in short: products, or grades.
    pub fn sensors(&self) -> String {
        if self.encoder.is_empty() {
            format!("{}″ + {} µm", self.encoder_arcsec, self.scale_um)
        } else {
            format!("{} + {}", self.encoder, self.scale)
        }
    }
}
