//! Two parts of the verdict's prose kept apart from its paragraph: the
//! sentence on what identifying the Hooke axes buys, and where the
//! paragraph turns to a new subject (report.html sets each part apart).

use crate::metrics::verdict::SecondClass;
use crate::metrics::{IdentifiedAxes, RankedRow};

/// Where the verdict's paragraph turns to a new subject: what limits the
/// choice, the what-ifs, the assembly, identifying the axes, the
/// assumptions (report.html sets each part as a paragraph of its own).
const TURNS: [&str; 7] = [
    " Of its remaining error",
    " If the true sensors",
    " It holds if the UP limb",
    " It needs the UP limb",
    " Identifying the first Hooke axis",
    " The cheapest combination that meets the target with the second-class",
    " It assumes that",
];

/// The verdict's paragraph in its parts, split before each of [`TURNS`]
/// (the parts joined by one space are the paragraph).
pub fn paragraphs(text: &str) -> Vec<&str> {
    let mut cuts: Vec<usize> = TURNS.iter().filter_map(|t| text.find(t)).collect();
    cuts.sort_unstable();
    let mut out = Vec::with_capacity(cuts.len() + 1);
    let mut start = 0;
    for c in cuts {
        if c > start {
            out.push(text[start..c].trim());
        }
        start = c;
    }
    out.push(text[start..].trim());
    out.retain(|p| !p.is_empty());
    out
}

/// " (misses…)" after an identified value that misses the target, with the
/// limit it was judged on when that is not the value itself.
fn misses(i: &IdentifiedAxes) -> String {
    match (i.meets_target, i.upper_limit) {
        (true, _) => String::new(),
        (false, Some(u)) => format!(" (upper limit {u:.4}: misses)"),
        (false, None) => " (misses)".into(),
    }
}

/// What identifying the Hooke axes buys the choice `c`, in one sentence.
pub(super) fn identified_sentence(
    c: &RankedRow,
    tolerances: &[SecondClass],
    exact_axes: Option<IdentifiedAxes>,
    holds_to: Option<f64>,
) -> String {
    let v = |x: Option<f64>| x.map_or("n/a".into(), |v| format!("{v:.4}"));
    let each: Vec<String> = tolerances
        .iter()
        .map(|s| {
            let i = s.identified.expect("checked by the caller");
            format!(
                "{} mm{} within ±{}° ({} without{})",
                v(Some(i.value)),
                misses(&i),
                s.tolerance_deg,
                v(s.value),
                if s.meets_target { "" } else { ", which misses" }
            )
        })
        .collect();
    let holds = match holds_to {
        Some(d) => format!("it holds to ±{d}°{}", per_100_mm(d)),
        None => format!("it still misses at ±{}°", tolerances[0].tolerance_deg),
    };
    let exact = match exact_axes {
        Some(e) => format!(
            "; with exact axes it gives {} mm{} against {} without them",
            v(Some(e.value)),
            misses(&e),
            v(c.value)
        ),
        None => String::new(),
    };
    format!(
        " Identifying the first Hooke axis's yaw and pitch and the axes' skew from the same readings ([identification] second_class = true) gives {}: {holds}{exact}. The guide's twist cannot be identified and stays in the error either way.",
        each.join(", ")
    )
}

/// An angular tolerance as a machine builder measures it: " (3.49 µm per
/// 100 mm)" for ±0.002° (tan of the angle × 100 mm).
pub fn per_100_mm(deg: f64) -> String {
    format!(
        " ({:.2} µm per 100 mm)",
        deg.to_radians().tan() * 100.0 * 1000.0
    )
}
