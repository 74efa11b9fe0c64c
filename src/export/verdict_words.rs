//! The verdict's sentences that every mechanism's study says alike, in
//! one place: what its machines cannot decide (the undecided lead), the
//! fragile passes it passed over, and a number in its words. The Tricept's
//! verdict (`verdict.rs`) and any other mechanism's (`study_verdict.rs`)
//! name their combinations and judged quantities in their own nouns and
//! hand them here; the sentences around them are these.

/// How many items a sentence lists before "and K more".
pub const LISTED: usize = 3;

/// A number in the verdict's words: `digits` decimals, "?" where it is
/// missing or not finite.
pub fn number(x: Option<f64>, digits: usize) -> String {
    x.filter(|v| v.is_finite())
        .map_or("?".to_string(), |v| format!("{v:.digits$}"))
}

/// One judged quantity between its confidence limits: "position p95
/// 0.0123 mm (95 % limits 0.0118 and 0.0131 mm)". The confidences: each
/// limit's one-sided confidence, lower and upper (0.95, or 0.975 for an
/// end of a two-sided 95 % interval), each named where they differ.
pub fn between(
    what: &str,
    (value, lower, upper): (Option<f64>, Option<f64>, Option<f64>),
    (unit, digits): (&str, usize),
    (lower_confidence, confidence): (f64, f64),
) -> String {
    let finite = |x: Option<f64>| x.filter(|v| v.is_finite());
    let (cl, c) = (percent(lower_confidence), percent(confidence));
    let limits = match (finite(lower), finite(upper)) {
        (Some(_), Some(_)) if cl == c => format!(
            "{c} % limits {} and {}{unit}",
            number(lower, digits),
            number(upper, digits)
        ),
        (Some(_), Some(_)) => format!(
            "lower {cl} % limit {}{unit}, upper {c} % limit {}{unit}",
            number(lower, digits),
            number(upper, digits)
        ),
        // Too few machines for an upper limit (a 95th percentile's needs
        // 59): said, not shown as a question mark.
        (Some(_), None) => format!(
            "lower {cl} % limit {}{unit}; no upper limit at these machines",
            number(lower, digits)
        ),
        (None, Some(_)) => format!(
            "upper {c} % limit {}{unit}; no lower limit at these machines",
            number(upper, digits)
        ),
        (None, None) => "no confidence limits at these machines".to_string(),
    };
    format!("{what} {}{unit} ({limits})", number(value, digits))
}

/// A confidence as a percentage: "95", "97.5".
fn percent(confidence: f64) -> String {
    let p = 100.0 * confidence;
    match (p - p.round()).abs() < 1e-9 {
        true => format!("{p:.0}"),
        false => format!("{p:.1}"),
    }
}

/// A combination the study's machines cannot decide on, in the verdict's
/// words: its name ("2 × A + B with 51 poses (wls)"), its judged
/// quantities between their limits ([`between`], joined), and about how
/// many machines would settle it (None: it sits on the target).
#[derive(Debug, Clone, PartialEq)]
pub struct Open {
    pub named: String,
    pub judged: String,
    pub machines: Option<u64>,
}

/// Whether a combination was chosen, and whether the undecided ones
/// include it (a choice made on the estimate can itself be undecided).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Chosen {
    None,
    Before,
    Among,
}

/// What the undecided lead says of the study: its machines, its limits'
/// one-sided confidence, whether a combination was chosen (the undecided
/// ones would be bought before it), the most machines one study runs, and
/// how to run more ("--trials, or sweep.until_decided = true").
#[derive(Debug, Clone, Copy)]
pub struct Lead<'a> {
    pub trials: u64,
    /// The limits' one-sided confidence where both share one (None: each
    /// item names its own).
    pub confidence: Option<f64>,
    pub chosen: Chosen,
    pub most: u64,
    pub how: &'a str,
}

/// The verdict's lead when the study has not decided: which combinations
/// (the first [`LISTED`] of `open`, and how many more verdict.json lists
/// of `total`) and how many machines would settle them. None when `open`
/// is empty.
pub fn undecided_lead(lead: Lead, open: &[Open], total: usize) -> Option<String> {
    if open.is_empty() {
        return None;
    }
    let machines = |n: u64| match n > lead.most {
        true => format!("more than the {} machines one study runs", lead.most),
        false => format!("about {n} machines"),
    };
    let listed = &open[..open.len().min(LISTED)];
    let list: Vec<String> = listed
        .iter()
        .map(|o| {
            format!(
                "{}: {}; {}",
                o.named,
                o.judged,
                match o.machines {
                    Some(n) => format!("{} would decide", machines(n)),
                    None => "it sits on the target".into(),
                }
            )
        })
        .collect();
    let largest = listed.iter().filter_map(|o| o.machines).max();
    Some(format!(
        "Undecided at {} machine{}: between their lower and upper {}confidence limits these combinations{} may or may not meet the target, so another seed could give another answer: {}{}. Run {} ({}) before buying.",
        lead.trials,
        if lead.trials == 1 { "" } else { "s" },
        lead.confidence.map_or(String::new(), |c| format!("{} % ", percent(c))),
        match lead.chosen {
            Chosen::None => "",
            Chosen::Before => ", bought before the choice,",
            Chosen::Among => ", the choice or bought before it,",
        },
        list.join("; "),
        more(listed.len(), total),
        largest.map_or("more machines".into(), machines),
        lead.how
    ))
}

/// The verdict's words on the fragile combinations the choice passed over
/// (`listed`: the first [`LISTED`], each named with its numbers; `total`:
/// how many there are). None when there are none.
pub fn passed_over(listed: &[String], total: usize) -> Option<String> {
    if listed.is_empty() {
        return None;
    }
    let listed = &listed[..listed.len().min(LISTED)];
    Some(format!(
        "Passed over as fragile (they meet the target with these poses but, beyond doubt, miss it with more of them, so the pass rests on which poses were picked): {}{}.",
        listed.join("; "),
        more(listed.len(), total)
    ))
}

/// The choice's sensors with the study's other pose counts: "The same
/// sensors with other pose counts: 20 poses 0.0110, 30 poses 0.0100
/// (misses the target)." (`items`: each pose count with its numbers, in
/// the mechanism's words). None when there are none.
pub fn other_pose_counts(sensors: &str, items: &[String]) -> Option<String> {
    (!items.is_empty()).then(|| {
        format!(
            "The same {sensors} with other pose counts: {}.",
            items.join(", ")
        )
    })
}

/// What the choice reaches when its sensors read otherwise than their
/// datasheets say: "If the true sensors are not as the datasheets say, the
/// same sensors, poses and estimator (gls) reach: …." (`cases`: each
/// what-if with its numbers, in the mechanism's words). None when the
/// study has none.
pub fn what_ifs(sensors: &str, estimator: &str, cases: &[String]) -> Option<String> {
    (!cases.is_empty()).then(|| {
        format!(
            "If the true {sensors} are not as the datasheets say, the same {sensors}, poses and estimator ({estimator}) reach: {}.",
            cases.join("; ")
        )
    })
}

/// The combinations not feasible whatever the target because their
/// calibration leaves the typical machine worse than not calibrating
/// (`criterion`: how the study judges that). None when there are none.
pub fn harmful(count: usize, criterion: &str) -> Option<String> {
    (count > 0).then(|| {
        format!(
            "Not feasible whatever the threshold: {count} combination(s) whose calibration leaves the typical machine worse than not calibrating ({criterion})."
        )
    })
}

/// "; and K more combinations (verdict.json lists them)" where a sentence lists fewer
/// than there are.
fn more(listed: usize, total: usize) -> String {
    match total > listed {
        true => format!(
            "; and {} more combination{} (verdict.json lists them)",
            total - listed,
            if total - listed == 1 { "" } else { "s" }
        ),
        false => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(name: &str, machines: Option<u64>) -> Open {
        Open {
            named: name.into(),
            judged: between(
                "position p95",
                (Some(0.0201), Some(0.019), None),
                (" mm", 4),
                (0.95, 0.95),
            ),
            machines,
        }
    }

    #[test]
    fn a_number_is_its_digits_or_a_question_mark() {
        assert_eq!(number(Some(0.012345), 4), "0.0123");
        assert_eq!(number(Some(1.5), 0), "2");
        assert_eq!(number(None, 4), "?");
        assert_eq!(number(Some(f64::NAN), 4), "?");
        assert_eq!(number(Some(f64::INFINITY), 2), "?");
    }

    #[test]
    fn a_quantity_between_its_limits_names_their_confidence() {
        let s = between(
            "ratio_p95",
            (Some(0.5), Some(0.49), Some(0.51)),
            ("", 4),
            (0.975, 0.975),
        );
        assert_eq!(s, "ratio_p95 0.5000 (97.5 % limits 0.4900 and 0.5100)");
        // μ p95: the bottom of a two-sided interval, the top one-sided.
        let s = between(
            "mu_p95",
            (Some(0.12), Some(0.1145), Some(0.13)),
            (" mm", 4),
            (0.975, 0.95),
        );
        assert_eq!(
            s,
            "mu_p95 0.1200 mm (lower 97.5 % limit 0.1145 mm, upper 95 % limit 0.1300 mm)"
        );
        let s = between(
            "position p95",
            (Some(0.02), None, Some(0.021)),
            (" mm", 3),
            (0.95, 0.95),
        );
        assert_eq!(
            s,
            "position p95 0.020 mm (upper 95 % limit 0.021 mm; no lower limit at these machines)"
        );
        let s = between(
            "position p95",
            (Some(0.02), Some(0.019), Some(f64::NAN)),
            (" mm", 3),
            (0.95, 0.95),
        );
        assert_eq!(
            s,
            "position p95 0.020 mm (lower 95 % limit 0.019 mm; no upper limit at these machines)"
        );
        let s = between("p95", (None, None, None), ("″", 2), (0.95, 0.95));
        assert_eq!(s, "p95 ?″ (no confidence limits at these machines)");
    }

    #[test]
    fn the_lead_lists_three_and_counts_the_rest() {
        let lead = Lead {
            trials: 400,
            confidence: Some(0.95),
            chosen: Chosen::Before,
            most: 10_000,
            how: "--trials",
        };
        assert_eq!(undecided_lead(lead, &[], 0), None);
        let four = [
            open("a", Some(900)),
            open("b", None),
            open("c", Some(2500)),
            open("d", Some(99_000)),
        ];
        let s = undecided_lead(lead, &four, 4).unwrap();
        assert_eq!(
            s,
            "Undecided at 400 machines: between their lower and upper 95 % confidence limits these combinations, bought before the choice, may or may not meet the target, so another seed could give another answer: a: position p95 0.0201 mm (lower 95 % limit 0.0190 mm; no upper limit at these machines); about 900 machines would decide; b: position p95 0.0201 mm (lower 95 % limit 0.0190 mm; no upper limit at these machines); it sits on the target; c: position p95 0.0201 mm (lower 95 % limit 0.0190 mm; no upper limit at these machines); about 2500 machines would decide; and 1 more combination (verdict.json lists them). Run about 2500 machines (--trials) before buying."
        );
        // The fourth's 99,000 is not among the listed, so not the advice;
        // a listed one beyond one study's reach is said so.
        let s = undecided_lead(
            Lead {
                chosen: Chosen::None,
                confidence: Some(0.975),
                ..lead
            },
            &four[3..],
            1,
        )
        .unwrap();
        assert!(
            s.contains("upper 97.5 % confidence limits these combinations may"),
            "{s}"
        );
        assert!(s.contains("d: "), "{s}");
        assert!(
            s.ends_with(
                "Run more than the 10000 machines one study runs (--trials) before buying."
            ),
            "{s}"
        );
        assert!(!s.contains("more (verdict.json"), "{s}");
        // Limits of two confidences: none named in the lead; the choice
        // itself among them.
        let mixed = Lead {
            confidence: None,
            chosen: Chosen::Among,
            ..lead
        };
        let s = undecided_lead(mixed, &four[..1], 1).unwrap();
        assert!(
            s.contains("between their lower and upper confidence limits these combinations, the choice or bought before it, may"),
            "{s}"
        );
        let one = Lead { trials: 1, ..lead };
        assert!(undecided_lead(one, &four[..1], 1)
            .unwrap()
            .starts_with("Undecided at 1 machine: "));
        // None with a machine count: more machines, without a number.
        let s = undecided_lead(lead, &four[1..2], 1).unwrap();
        assert!(
            s.ends_with("Run more machines (--trials) before buying."),
            "{s}"
        );
    }

    #[test]
    fn pose_counts_and_what_ifs_are_one_sentence_each() {
        assert_eq!(other_pose_counts("sensors", &[]), None);
        assert_eq!(
            other_pose_counts("sensors", &["17 poses 0.4468 (misses the target)".into(), "9 poses 1.7771".into()]).unwrap(),
            "The same sensors with other pose counts: 17 poses 0.4468 (misses the target), 9 poses 1.7771."
        );
        assert_eq!(what_ifs("U-joint encoders", "gls", &[]), None);
        assert_eq!(
            what_ifs("U-joint encoders", "gls", &["a: 1".into(), "b: 2".into()]).unwrap(),
            "If the true U-joint encoders are not as the datasheets say, the same U-joint encoders, poses and estimator (gls) reach: a: 1; b: 2."
        );
    }

    #[test]
    fn harm_is_one_sentence() {
        assert_eq!(harmful(0, "x"), None);
        assert_eq!(
            harmful(2, "median after ≥ before").unwrap(),
            "Not feasible whatever the threshold: 2 combination(s) whose calibration leaves the typical machine worse than not calibrating (median after ≥ before)."
        );
    }

    #[test]
    fn passed_over_lists_three_and_counts_the_rest() {
        assert_eq!(passed_over(&[], 0), None);
        let items: Vec<String> = ["w", "x", "y", "z"].iter().map(|s| s.to_string()).collect();
        let s = passed_over(&items, 4).unwrap();
        assert!(s.starts_with("Passed over as fragile (they meet the target with these poses but, beyond doubt, miss it with more of them"), "{s}");
        assert!(
            s.ends_with(": w; x; y; and 1 more combination (verdict.json lists them)."),
            "{s}"
        );
        assert!(passed_over(&items[..2], 2).unwrap().ends_with(": w; x."));
        let two_more = passed_over(&items, 5).unwrap();
        assert!(
            two_more.ends_with("; and 2 more combinations (verdict.json lists them)."),
            "{two_more}"
        );
    }
}
