//! Everything the tool keeps on disk, in one place: the files it reads and
//! writes and their formats.
//!
//! - [`inputs`]: the CSV inputs (readings, identified parameters, targets).
//!
//! Below [`crate::cli`]; above the layers whose results it stores.

pub mod inputs;
