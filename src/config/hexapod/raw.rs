//! A hexapod config's sections as the TOML states them (serde, with
//! their defaults); `mod.rs` checks them into a [`super::HexapodConfig`].

use crate::mechanism::hexapod::{Encoders, Pose};
use serde::Deserialize;
use std::collections::BTreeMap;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Raw {
    pub(super) mechanism: MechanismSection,
    pub(super) hexapod: HexapodSection,
    pub(super) errors: Option<BTreeMap<String, f64>>,
    pub(super) poses: PosesSection,
    #[serde(default)]
    pub(super) identification: IdentificationSection,
    #[serde(default)]
    pub(super) sensors: SensorsSection,
    pub(super) sweep: Option<SweepSection>,
    #[serde(default)]
    pub(super) workspace: WorkspaceSection,
    #[serde(default)]
    pub(super) decision: DecisionSection,
}

/// `[sweep]`: which encoders, how many per joint, poses, estimators.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SweepSection {
    pub(super) catalogue: Option<String>,
    pub(super) encoders: Option<Vec<String>>,
    pub(super) encoder_arcsec: Option<Vec<f64>>,
    #[serde(default = "per_joint")]
    pub(super) per_joint: Vec<String>,
    pub(super) pose_counts: Option<Vec<usize>>,
    #[serde(default = "estimators")]
    pub(super) estimators: Vec<String>,
    #[serde(default = "trials")]
    pub(super) trials: u64,
    #[serde(default = "one")]
    pub(super) seed: u64,
    #[serde(default = "length_bound")]
    pub(super) length_bound_mm: f64,
    #[serde(default = "zero_bound")]
    pub(super) zero_bound_deg: f64,
    #[serde(default = "one_sample")]
    pub(super) samples: u32,
    pub(super) truth_white: Option<f64>,
    pub(super) truth_eccentricity_um: Option<f64>,
    #[serde(default)]
    pub(super) until_decided: bool,
    pub(super) max_trials: Option<u64>,
}

pub(super) fn per_joint() -> Vec<String> {
    vec!["both".into(), "first".into()]
}
pub(super) fn estimators() -> Vec<String> {
    vec!["linear".into()]
}
pub(super) fn trials() -> u64 {
    2000
}
pub(super) fn one() -> u64 {
    1
}
pub(super) fn one_sample() -> u32 {
    1
}
pub(super) fn length_bound() -> f64 {
    0.1
}
pub(super) fn zero_bound() -> f64 {
    0.02
}

/// `[workspace]`: the poses accuracy is judged at, a grid of positions
/// about the home pose × orientations, and the tool point.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct WorkspaceSection {
    pub(super) half_extent_mm: [f64; 3],
    pub(super) grid: usize,
    pub(super) tilt_deg: f64,
    pub(super) tool_point_mm: [f64; 3],
}

impl Default for WorkspaceSection {
    fn default() -> Self {
        WorkspaceSection {
            half_extent_mm: [80.0, 80.0, 60.0],
            grid: 3,
            tilt_deg: 8.0,
            tool_point_mm: [0.0; 3],
        }
    }
}

/// `[decision]`: what the machine must reach (95 % of machines, at the
/// upper 95 % confidence limit, everywhere in the workspace).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub(super) struct DecisionSection {
    pub(super) position_mm: Option<f64>,
    pub(super) orientation_arcsec: Option<f64>,
}

pub use crate::config::general::MAX_RESULTS;

/// A hexapod study: the spec its kernel runs, and what the verdict asks.
pub type StudyConfig = crate::config::general::StudyConfig<Pose, Encoders>;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MechanismSection {
    pub(super) kind: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct HexapodSection {
    pub(super) base_joints_mm: Vec<[f64; 3]>,
    pub(super) platform_joints_mm: Vec<[f64; 3]>,
    pub(super) home_pose: [f64; 6],
    #[serde(default = "both")]
    pub(super) encoders: String,
    pub(super) stroke_mm: Option<[f64; 2]>,
    pub(super) joint_angle_deg: Option<f64>,
}

pub(super) fn both() -> String {
    "both".into()
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PosesSection {
    pub(super) list: Vec<[f64; 6]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(super) struct IdentificationSection {
    pub(super) iterations: usize,
    pub(super) rank_tolerance: f64,
    /// Errors measured elsewhere, held at these values (mm, degrees).
    pub(super) fix: Option<BTreeMap<String, f64>>,
    /// A Gaussian prior's σ on every free length error, mm.
    pub(super) prior_std_mm: Option<f64>,
    /// A Gaussian prior's σ on every free encoder zero, degrees.
    pub(super) prior_std_deg: Option<f64>,
}

impl Default for IdentificationSection {
    fn default() -> Self {
        IdentificationSection {
            iterations: 10,
            rank_tolerance: 1e-9,
            fix: None,
            prior_std_mm: None,
            prior_std_deg: None,
        }
    }
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub(super) struct SensorsSection {
    /// The encoders' reading σ, arc seconds (white, for `simulate`).
    pub(super) encoder_noise_arcsec: f64,
}
