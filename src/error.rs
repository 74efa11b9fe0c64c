//! Library error type.
//!
//! Every failure the library can report is one variant of [`Error`]. The
//! binary maps [`Error::is_input`] to exit status 2 (bad config, readings,
//! arguments) and everything else to exit status 1.

use std::path::PathBuf;

/// Failures of the kinematic model (never a NaN in an output: these instead).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    #[error("target ({x:.3}, {y:.3}, {z:.3}) mm is not reachable: {reason}")]
    Unreachable {
        x: f64,
        y: f64,
        z: f64,
        reason: String,
    },
    #[error("the configuration near psi4={psi_deg:.4} deg, theta4={theta_deg:.4} deg, q4={q4_mm:.3} mm is singular (condition number {condition:.3e})")]
    Singular {
        psi_deg: f64,
        theta_deg: f64,
        q4_mm: f64,
        condition: f64,
    },
    #[error("forward kinematics did not converge after {iterations} Newton iterations (residual {residual_mm:.3e} mm)")]
    NotConverged { iterations: usize, residual_mm: f64 },
    /// A mechanism's own account of why (one that states its failures as
    /// sentences, through `mechanism::Mechanism`).
    #[error("{0}")]
    Stated(String),
}

/// A kinematic failure at one pose of a list (calibration poses, readings
/// rows, map points): the index says which.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("pose {index}: {source}")]
pub struct PoseError {
    /// Position in the list, 0 = the reference pose.
    pub index: usize,
    pub source: KinematicsError,
}

impl PoseError {
    pub fn new(index: usize, source: KinematicsError) -> Self {
        PoseError { index, source }
    }
}

/// The library's error.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A configuration value is missing, malformed or out of range.
    #[error("{file}: {message}")]
    Config { file: String, message: String },
    /// A CSV input (readings, identified parameters, targets) is malformed.
    #[error("{file}: {message}")]
    Csv { file: String, message: String },
    /// A command-line argument is out of range.
    #[error("{0}")]
    Argument(String),
    /// Reading or writing a file failed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        action: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A numerical failure that is not the user's input (e.g. a plot backend).
    #[error("{0}")]
    Internal(String),
    /// `--require-target`: the study ran and no combination meets its target.
    #[error("{0}")]
    TargetNotMet(String),
}

impl Error {
    /// True when the failure is caused by the user's input (exit status 2).
    pub fn is_input(&self) -> bool {
        matches!(
            self,
            Error::Config { .. } | Error::Csv { .. } | Error::Argument(_)
        )
    }

    /// The process exit status: 2 bad input, 3 target not met
    /// (`--require-target`), 1 anything else.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::TargetNotMet(_) => 3,
            e if e.is_input() => 2,
            _ => 1,
        }
    }

    pub fn config(file: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Config {
            file: file.into(),
            message: message.into(),
        }
    }

    pub fn csv(file: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Csv {
            file: file.into(),
            message: message.into(),
        }
    }

    pub fn io(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            action,
            path: path.into(),
            source,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
