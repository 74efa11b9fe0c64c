//! The estimators (SPEC §6): OLS as the paper (eq. 12), WLS with rows
//! weighted by 1/σ of their sensor, and the options of an identification.

use crate::sensors::SensorModel;
use nalgebra::DVector;
use serde::{Deserialize, Serialize};

/// The estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Ordinary least squares on rows that mix rad and mm (the paper).
    Ols,
    /// Each row weighted by 1/σ of its sensor.
    Wls,
}

impl Method {
    /// Every estimator, in the order studies list them.
    pub const ALL: [Method; 2] = [Method::Ols, Method::Wls];

    /// The estimator of a config name ("ols", "wls").
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Heading of the estimator in figures.
    pub fn title(&self) -> &'static str {
        match self {
            Method::Ols => "OLS (the paper's estimator)",
            Method::Wls => "WLS (rows weighted by 1/σ)",
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            Method::Ols => "ols",
            Method::Wls => "wls",
        }
    }

    /// Row weights for 3·n rows (ψ4, θ4, q4 per pose).
    pub fn row_weights(&self, rows: usize, sensors: &SensorModel) -> DVector<f64> {
        match self {
            Method::Ols => DVector::from_element(rows, 1.0),
            Method::Wls => {
                let s = sensors.reading_sigma();
                DVector::from_fn(rows, |r, _| 1.0 / s[r % 3])
            }
        }
    }
}

/// How to identify.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyOptions {
    pub method: Method,
    /// 1 = one linearisation at the nominal poses (the paper); more =
    /// Gauss–Newton re-linearised at the current estimate.
    pub iterations: usize,
    /// Gauss–Newton stops when the largest step component is below this, mm.
    pub tolerance_mm: f64,
    /// Relative singular-value tolerance for rank decisions.
    pub rank_tolerance: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            method: Method::Ols,
            iterations: 1,
            tolerance_mm: 1e-9,
            rank_tolerance: 1e-9,
        }
    }
}
