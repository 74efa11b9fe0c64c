//! Which encoder to buy for a parallel machine of any kind, how it is
//! fitted and how many poses: a Monte-Carlo study of random machines of a
//! [`Mechanism`](crate::mechanism::Mechanism), each self-calibrated from
//! its encoders' readings and judged over a workspace (docs/method.md
//! §20), run through the one study kernel ([`kernel`]): its rows
//! ([`Combination`]) and each machine's judgement ([`Judged`]). The dense
//! route the hexapod's study was before (readings absolute, every zero
//! estimated, one dense gain per combination) is built only with the
//! tests, as the reference the kernel is tested against
//! (`dense_fixtures.rs`, with its gains and readings).

#[cfg(test)]
#[path = "dense_fixtures.rs"]
pub(crate) mod dense;
pub mod kernel;

use crate::config::general::Estimator;
use crate::montecarlo::partial::{DV_PER_CALIBRATION, ORIENTATION_PER_CALIBRATION};

/// One row of the study: which sensor, instrumentation, poses, estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Combination<V> {
    pub sensor: usize,
    pub variant: V,
    pub poses: usize,
    pub estimator: Estimator,
}

/// One machine of one combination: the largest error over the workspace
/// before and after compensation (tool-point position mm, orientation ″;
/// 0 where the mechanism's accuracy is judged by position alone).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Judged {
    pub position_before: f64,
    pub position_after: f64,
    pub orientation_before: f64,
    pub orientation_after: f64,
}

/// Bytes a study holds at most, for the caller to count before work:
/// each machine's judgement of each combination (four numbers, 32 bytes),
/// and while an instrumentation's study runs, the runner's record of each
/// of its calibrations ([`RECORD_BYTES`], counted as though every
/// combination were in that study) and its block buffers
/// ([`kernel::RUNNER_BYTES`]).
pub fn result_bytes(combinations: usize, trials: u64) -> u128 {
    let each = std::mem::size_of::<Judged>() + RECORD_BYTES;
    combinations as u128 * trials as u128 * each as u128 + kernel::RUNNER_BYTES as u128
}

/// Bytes of the runner's record of one calibration: μ, its failure code,
/// its workspace numbers and its orientation errors.
pub const RECORD_BYTES: usize = 8 + 1 + 8 * (DV_PER_CALIBRATION + ORIENTATION_PER_CALIBRATION);
