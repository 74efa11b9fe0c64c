//! Everything the tool keeps on disk, in one place: the files it reads and
//! writes and their formats.
//!
//! - [`inputs`]: the CSV inputs (readings, identified parameters, targets);
//! - [`trials`]: the rows of trials.csv (header, rows, CSV or gzip);
//! - [`trials_file`]: the trials file of a run, the runner's
//!   [`crate::montecarlo::TrialSink`];
//! - [`partial`]: the codec of `partial.bin` and of block records;
//! - [`checkpoint`]: the block log of a resumable sweep and its checks;
//! - [`shards`]: a shard's files as `merge` reads and joins them;
//! - [`state`]: `state.json`, resuming, a shard's `partial.json`;
//! - [`names`]: every output file name and each command's list of them;
//! - [`nominal`]: the nominal machine a fit was identified on, and the
//!   check before applying it;
//! - [`outputs`]: the outputs of a study or a shard, written as one set.
//!
//! Below `cli`; above the layers whose results it stores (the
//! runner sees only the [`crate::montecarlo::TrialSink`] it implements).

pub mod checkpoint;
pub mod inputs;
pub mod names;
pub mod nominal;
pub mod outputs;
pub mod partial;
pub mod shards;
pub mod state;
pub mod trials;
pub mod trials_file;

pub use state::{RunMode, ShardInfo};
pub use trials::{TrialsFormat, WriterSink, TRIALS_HEADER};
pub use trials_file::TrialsFile;
