//! The verdict's content as data: what to buy, the combinations this many
//! machines cannot decide on, the what-ifs, the second-class tolerances and
//! the budget. The paragraph a buyer reads is written from it by the text
//! layer (`export/verdict.rs`).

use super::ranking::RankedRow;
use super::summary::BudgetRow;
use crate::identify::Method;
use serde::Serialize;

/// The verdict for scripts (`verdict.json`, `sweep --json`): the same
/// content as the paragraph.
#[derive(Debug, Clone, Serialize)]
pub struct Verdict {
    /// "buy": a combination meets the target and nothing cheaper might;
    /// "undecided": a combination's interval holds the threshold where it
    /// would change the answer, so this many machines cannot decide;
    /// "none_meets": every combination clearly misses;
    /// "none_meets_at_tolerances": one meets the target with exact axes but
    /// misses at every second-class tolerance studied (`holds_to_deg` is the
    /// tolerance a "buy" needs).
    pub status: &'static str,
    /// The combination recommended (status "buy" only).
    pub choice: Option<Choice>,
    /// When undecided: the cheapest combination that meets the target at
    /// this many machines, which a longer run may yet displace.
    pub meets_so_far: Option<Choice>,
    /// The combinations this many machines cannot decide on, cheapest
    /// first, with the machines that would.
    pub undecided: Vec<Undecided>,
    pub machines: u64,
    pub metric: String,
    pub threshold: f64,
    /// What the answer rests on, one sentence each.
    pub assumptions: Vec<String>,
    /// The choice under each what-if, with the estimator it was made with.
    pub what_ifs: Vec<WhatIf>,
    /// The same what-ifs with the second-class errors drawn within the
    /// largest tolerance the choice holds to (empty without tolerances,
    /// what-ifs or one it holds to); each `truth` names the tolerance.
    pub what_ifs_at_tolerance: Vec<WhatIf>,
    /// The second-class tolerances studied, and the largest at which the
    /// choice still meets the target (every smaller one too).
    pub second_class: Vec<SecondClass>,
    pub holds_to_deg: Option<f64>,
    /// What identifying the Hooke axes (`second_class = true`) gives the
    /// choice with exact axes, and the largest tolerance it holds to then.
    pub identified_exact_axes: Option<IdentifiedAxes>,
    pub identified_holds_to_deg: Option<f64>,
    /// Where the first-ranked combination's remaining error comes from, in
    /// the deciding metric where the study budgeted it (else mean μ).
    pub budget: Option<BudgetRow>,
    /// The same budget split by error term (curve, eccentricity,
    /// interpolation error, jitter and quantisation), where the study
    /// split it: datasheet sensors, the deciding metric.
    pub budget_terms: Option<super::TermSplit>,
    /// The paragraph.
    pub text: String,
}

/// A second-class tolerance studied and the cheapest combination that
/// meets the target at it (None: none does).
#[derive(Debug, Clone)]
pub struct Tolerance {
    pub deg: f64,
    pub cheapest: Option<RankedRow>,
    /// The choice there with the Hooke axes identified (`second_class =
    /// true`; None when the study identifies them itself or chose nothing).
    pub identified: Option<IdentifiedAxes>,
    /// The study (and so these rows) identifies the Hooke axes itself.
    pub identified_in_study: bool,
}

/// The choice's metric with the Hooke axes' yaw, pitch and skew identified.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct IdentifiedAxes {
    pub value: f64,
    /// The metric's confidence limit the target is judged on (None for a
    /// point-estimate decision).
    pub upper_limit: Option<f64>,
    pub meets_target: bool,
}

/// The verdict's word on one tolerance.
#[derive(Debug, Clone, Serialize)]
pub struct SecondClass {
    pub tolerance_deg: f64,
    /// The choice's metric with second-class errors within ± the tolerance.
    pub value: Option<f64>,
    pub meets_target: bool,
    /// The cheapest combination that meets the target there.
    pub cheapest: Option<Choice>,
    /// The choice there with the Hooke axes identified.
    pub identified: Option<IdentifiedAxes>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Choice {
    pub encoder: String,
    pub scale: String,
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub price: Option<f64>,
    pub poses: usize,
    pub method: Method,
    pub value: Option<f64>,
    pub upper_limit: Option<f64>,
    /// The metric in words with its numbers.
    pub statement: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct Undecided {
    pub sensors: String,
    pub price: Option<f64>,
    pub poses: usize,
    pub method: Method,
    pub value: Option<f64>,
    pub lower_limit: Option<f64>,
    pub upper_limit: Option<f64>,
    pub machines_to_decide: Option<u64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct WhatIf {
    pub truth: String,
    pub value: Option<f64>,
    pub meets_target: bool,
}
