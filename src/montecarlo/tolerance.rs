//! Second-class tolerances (`[sweep] second_class_tolerance_deg`): for each
//! tolerance a what-if study on the same machines, sensors and draws whose
//! machines also carry the four second-class errors of the UP limb (Hooke
//! axis 1 yaw and pitch, the axes' skew, the guide's twist), each drawn
//! uniformly within ± the tolerance from the trial's own stream 2. The
//! identification model assumes them zero: the rows say what an assembly
//! tolerance costs, and the verdict names the largest tolerance its choice
//! survives and the cheapest combination that meets the target at each.

use super::runner::run_in_memory;
use super::summary::SweepResult;
use crate::config::{Config, Study, Truth};
use crate::error::Result;
use crate::metrics::Tolerance;

/// The label of a tolerance's rows in summary.csv's `truth` column.
pub fn tolerance_label(deg: f64) -> String {
    format!("second-class errors within ±{deg}°")
}

/// Run the tolerance studies of `study` (as many machines as `result`
/// has) and add their rows to `result.truth` and their outcome to
/// `result.tolerances`. Nothing without tolerances.
pub fn add_second_class_tolerances(
    cfg: &Config,
    study: &Study,
    result: &mut SweepResult,
    threads: usize,
) -> Result<()> {
    for &deg in &study.sweep.second_class_tolerance_deg {
        let mut sub = study.clone();
        sub.sweep.truth = vec![Truth::DATASHEET];
        sub.sweep.second_class_tolerance_deg = Vec::new();
        sub.sweep.second_class_draw_deg = Some(deg);
        sub.sweep.trials = result.trials;
        let r = run_in_memory(cfg, &sub, threads)?;
        let cheapest = r.ranking.first().filter(|x| x.chosen).cloned();
        for mut row in r.summary {
            row.truth = tolerance_label(deg);
            row.second_class_deg = Some(deg);
            result.truth.push(row);
        }
        result.calibrations += r.calibrations;
        result.computed += r.computed;
        result.tolerances.push(Tolerance { deg, cheapest });
    }
    Ok(())
}
