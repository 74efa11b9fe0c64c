// Numerical code indexes parallel arrays (poses, rows, parameters) by one
// index; iterator chains would hide the equation being implemented.
#![allow(clippy::needless_range_loop)]

//! tricept-calib: self-calibration of a Tricept-type parallel module from
//! its passive-limb sensors (Hong Zhenyu, Acta Aeronautica et Astronautica
//! Sinica 30(4), 2009), with Monte-Carlo studies of the sensor grades.
//!
//! Data flows one way, and the folders are its layers (a module imports
//! only the ones listed after it; `tests/docs.rs` checks):
//!
//! - [`cli`]: arguments → validated config → one command each; console output;
//! - [`report`]: `reproduce` and `report.md`;
//! - [`export`]: CSV/JSON exporters, figures, views;
//! - [`calibration`]: one self-calibration end to end from a config;
//! - [`store`]: what is kept on disk: inputs, trial rows, partials, block
//!   logs, run state, each command's output files;
//! - [`design`]: pose-set design;
//! - [`montecarlo`]: streams, trial kernel, runner, partials, summary;
//! - [`config`]: raw TOML → one validated [`config::Config`] and studies;
//! - [`metrics`]: μ, statistics, summary rows, the decision rule;
//! - [`compensate`]: compensated commands and volumetric error;
//! - [`identify`]: design matrix, analysis, solvers, Gauss–Newton;
//! - [`sensors`]: noise and the observation vector;
//! - [`mechanism`]: each mechanism's geometry, errors, exact kinematics and
//!   facts, a folder each (`tricept/`, `hexapod/`), and the traits every
//!   mechanism implements;
//! - [`io`]: atomic writes and CSV tables; [`cpu`]: the vector width chosen
//!   at run time; [`digest`]: content digests; [`error`]: the error types.

pub mod calibration;
pub mod cli;
pub mod compensate;
pub mod config;
pub mod cpu;
pub mod design;
pub mod digest;
pub mod error;
pub mod export;
pub mod identify;
pub mod io;
pub mod mechanism;
pub mod metrics;

pub mod montecarlo;
pub mod report;
pub mod sensors;
pub mod store;

pub use error::{Error, KinematicsError, PoseError, Result};
