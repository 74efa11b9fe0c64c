//! A study with its follow-up studies: the second-class tolerances
//! ([`super::tolerance`]) and the deciding metric's budget
//! ([`super::budget`]), each a restricted study run again on the same
//! machines ([`super::runner::run_alone`]).

use super::runner::run_alone;
use super::summary::SweepResult;
use crate::config::{Config, ConfigStudy};
use crate::error::Result;

/// Every follow-up study of a finished sweep: the second-class tolerances
/// ([`super::tolerance`]) and the deciding metric's budget.
pub fn add_follow_ups(
    cfg: &Config,
    study: &ConfigStudy,
    result: &mut SweepResult,
    threads: usize,
) -> Result<()> {
    if study.sweep.follow_up {
        return Ok(());
    }
    super::tolerance::add_second_class_tolerances(cfg, study, result, threads)?;
    super::budget::add_decision_budget(cfg, study, result, threads)
}

/// A study run in memory with its follow-ups: no trials.csv, no progress
/// bar, no block log (reports, pose design).
pub fn run_in_memory(cfg: &Config, study: &ConfigStudy, threads: usize) -> Result<SweepResult> {
    let mut result = run_alone(cfg, study, threads)?;
    add_follow_ups(cfg, study, &mut result, threads)?;
    Ok(result)
}
