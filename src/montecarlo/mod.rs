//! The Monte-Carlo study (docs/method.md §10 `sweep`): thousands of random machines ×
//! sensor-noise draws × grades, each a complete self-calibration with exact
//! kinematics.
//!
//! - [`streams`]: the random stream of (seed, trial, stream);
//! - [`context`]: what a study's trials share, built once, for any
//!   mechanism the kernel sees through [`studied`] (the Tricept's:
//!   [`tricept`]; any `Kinematic` topology's: [`kinematic`]);
//! - [`general`]: the study of any mechanism (the hexapod's; any
//!   `Kinematic` topology's through `Homed`);
//! - [`plan`]: the kernel's path and its tables of sharing;
//! - [`trial`]: the pure trial kernel ([`per_machine`]: GLS weighted at
//!   each machine's own readings);
//! - [`workspace`]: a calibration judged over the workspace grid;
//! - [`runner`]: blocks of trials on a rayon pool, rows and block records
//!   to a [`sink`] (whose files are `store`'s);
//! - [`adaptive`]: blocks until the estimates are precise enough;
//! - [`partial`]: per-calibration records of a range of blocks;
//! - [`summary`]: records → summary, parameter spreads, decision;
//! - [`tolerance`] and [`budget`]: the follow-up studies of a finished
//!   sweep (second-class tolerances, the deciding metric's error budget),
//!   run by [`follow_ups`].
//!
//! Results are gathered in trial order, so the thread count cannot change a
//! byte.

pub mod adaptive;
mod assumptions;
pub mod budget;
pub mod context;
pub mod follow_ups;
pub mod general;
pub mod kinematic;
pub mod mechanism_study;
pub mod memory;
pub mod outcome;
pub mod partial;
pub mod per_machine;
pub mod plan;
pub mod runner;
pub mod sink;
pub mod statement;
pub mod streams;
pub mod studied;
pub mod subsets;
mod summary;
pub mod tolerance;
pub mod trial;
pub mod tricept;
pub mod workspace;

pub use adaptive::{run_adaptive, run_until_decided};
pub use follow_ups::{add_follow_ups, run_in_memory};
pub use partial::Partial;
pub use plan::{KernelPath, TrialPlan};
pub use runner::{run, run_alone, BlockRunner, Progress, RunOptions, Silent, BLOCK_TRIALS};
pub use sink::{NoRows, RowEncoder, TrialSink, ROWS_PER_RUN};
pub use streams::{simulate_stream, stream, trial_errors};
pub use studied::Studied;
pub use summary::{finalize, SweepResult};
pub use trial::{run_trial, Failure, Grade, Outcome, Scratch, SweepContext};
