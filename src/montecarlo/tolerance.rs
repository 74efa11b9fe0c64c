//! Second-class tolerances (`[sweep] second_class_tolerance_deg`): for each
//! tolerance a what-if study on the same machines, sensors and draws whose
//! machines also carry the four second-class errors of the UP limb (Hooke
//! axis 1 yaw and pitch, the axes' skew, the guide's twist), each drawn
//! uniformly within ± the tolerance from the trial's own stream 2. The
//! verdict names the largest tolerance its choice survives and the
//! cheapest combination that meets the target at each.
//!
//! Unless the study identifies the Hooke axes itself (`[identification]
//! second_class = true`), the chosen combination is then run again with
//! them identified, at each tolerance and with exact axes: what
//! `second_class = true` buys (and costs) in the deciding metric.

use super::budget::restricted;
use super::runner::run_alone;
use super::summary::SweepResult;
use crate::config::{Config, ConfigStudy, Truth};
use crate::error::Result;
use crate::identify::Method;
use crate::metrics::{IdentifiedAxes, RankedRow, Tolerance};

/// The label of a tolerance's rows in summary.csv's `truth` column.
pub fn tolerance_label(deg: f64) -> String {
    format!("second-class errors within ±{deg}°")
}

/// Run the tolerance studies of `study` (as many machines as `result`
/// has) and add their rows to `result.truth` and their outcome to
/// `result.tolerances`. Nothing without tolerances.
pub fn add_second_class_tolerances(
    cfg: &Config,
    study: &ConfigStudy,
    result: &mut SweepResult,
    threads: usize,
) -> Result<()> {
    if study.sweep.second_class_tolerance_deg.is_empty() {
        return Ok(());
    }
    // What identifying the axes buys, for the choice: not when the study
    // identifies them already (its own rows show it), nor with held errors
    // or Gauss–Newton, which second_class does not combine with yet.
    let id = &study.identification;
    let chosen = result
        .ranking
        .first()
        .filter(|r| {
            r.chosen
                && !id.second_class
                && id.constraints.none()
                && id.iterations <= 1
                // The axes' operator is built once per combination: with
                // GLS weighted per machine the rerun would compare another
                // weighting, not what identifying the axes buys.
                && !(study.sweep.gls_per_machine != Some(false) && r.method == Method::Gls)
        })
        .cloned();
    for &deg in &study.sweep.second_class_tolerance_deg {
        let mut sub = study.clone();
        sub.sweep.truth = vec![Truth::DATASHEET];
        sub.sweep.second_class_tolerance_deg = Vec::new();
        sub.sweep.second_class_draw_deg = Some(deg);
        sub.sweep.trials = result.trials;
        sub.sweep.follow_up = true;
        let r = run_alone(cfg, &sub, threads)?;
        let cheapest = r.ranking.first().filter(|x| x.chosen).cloned();
        for mut row in r.summary {
            row.truth = tolerance_label(deg);
            row.second_class_deg = Some(deg);
            result.truth.push(row);
        }
        result.calibrations += r.calibrations;
        result.computed += r.computed;
        let identified = match &chosen {
            Some(c) => with_axes_identified(cfg, study, c, Some(deg), result, threads)?,
            None => None,
        };
        result.tolerances.push(Tolerance {
            deg,
            cheapest,
            identified,
            identified_in_study: id.second_class,
        });
    }
    if let Some(c) = &chosen {
        result.identified_exact_axes = with_axes_identified(cfg, study, c, None, result, threads)?;
    }
    what_ifs_at_tolerance(cfg, study, result, threads)
}

/// The label of a what-if's rows run at a second-class tolerance.
pub fn what_if_at_tolerance_label(what_if: &str, deg: f64) -> String {
    format!("{what_if}, and {}", tolerance_label(deg))
}

/// The choice's what-ifs run again at the largest second-class tolerance
/// it holds to (the tolerance the verdict names), on the same machines:
/// the two are met together on a real machine. Rows added to
/// `result.truth` with that tolerance and a label naming both; nothing
/// without a choice, what-ifs, or a tolerance it holds to.
fn what_ifs_at_tolerance(
    cfg: &Config,
    study: &ConfigStudy,
    result: &mut SweepResult,
    threads: usize,
) -> Result<()> {
    let Some(c) = result.ranking.first().filter(|r| r.chosen).cloned() else {
        return Ok(());
    };
    let what_ifs: Vec<Truth> = study
        .sweep
        .truth
        .iter()
        .filter(|t| !t.is_datasheet())
        .copied()
        .collect();
    if what_ifs.is_empty() {
        return Ok(());
    }
    let same = |r: &crate::metrics::GradeSummary| {
        r.encoder == c.encoder
            && r.scale == c.scale
            && r.encoder_arcsec.to_bits() == c.encoder_arcsec.to_bits()
            && r.scale_um.to_bits() == c.scale_um.to_bits()
            && r.pose_count == c.pose_count
            && r.method == c.method
    };
    let holds = result
        .truth
        .iter()
        .filter(|r| same(r) && r.meets_target)
        .filter_map(|r| {
            r.second_class_deg
                .filter(|&d| r.truth == tolerance_label(d))
        })
        .fold(None, |a: Option<f64>, d| Some(a.map_or(d, |a| a.max(d))));
    let Some(deg) = holds else {
        return Ok(());
    };
    let Some(mut sub) = restricted(study, &c, result.trials, [false; 3], Truth::DATASHEET) else {
        return Ok(());
    };
    sub.sweep.truth = what_ifs;
    sub.sweep.second_class_draw_deg = Some(deg);
    let r = run_alone(cfg, &sub, threads)?;
    result.calibrations += r.calibrations;
    result.computed += r.computed;
    for mut row in r.truth {
        row.truth = what_if_at_tolerance_label(&row.truth, deg);
        row.second_class_deg = Some(deg);
        result.truth.push(row);
    }
    Ok(())
}

/// The choice `c` run again on the same machines with the Hooke axes
/// identified, its machines' second-class errors drawn within ±`deg` (None:
/// exact axes). None when the combination cannot be rerun.
fn with_axes_identified(
    cfg: &Config,
    study: &ConfigStudy,
    c: &RankedRow,
    deg: Option<f64>,
    result: &mut SweepResult,
    threads: usize,
) -> Result<Option<IdentifiedAxes>> {
    let Some(mut sub) = restricted(study, c, result.trials, [false; 3], Truth::DATASHEET) else {
        return Ok(None);
    };
    sub.identification.second_class = true;
    sub.sweep.second_class_draw_deg = deg;
    let r = run_alone(cfg, &sub, threads)?;
    result.calibrations += r.calibrations;
    result.computed += r.computed;
    Ok(r.summary.first().and_then(|row| {
        c.metric.value(row).map(|value| IdentifiedAxes {
            value,
            upper_limit: c.metric.upper_limit().and_then(|m| m.value(row)),
            meets_target: row.meets_target,
        })
    }))
}
