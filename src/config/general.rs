//! What a study of any mechanism is, as a config states it: the sensors
//! it compares ([`Sensor`], with the what-ifs of how they may read
//! otherwise, [`WhatIf`]), the estimators ([`Estimator`]) and the rest of
//! the study ([`Spec`]). A mechanism's config section checks its keys into
//! them (`config::hexapod`), and what the commands of any mechanism read
//! of a checked config ([`MechanismConfig`]).

use crate::identify::general::Holds;
use crate::mechanism::Mechanism;
use crate::sensors::Axis;
use nalgebra::Vector3;

/// How a trial's machine is identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    /// Least squares once, at the nominal machine (the study's operator).
    Linear,
    /// Least squares once at the nominal machine, each encoder's readings
    /// weighted by its datasheet covariance (its curve across the angles
    /// it stands at, its interpolation error, jitter and quantisation): the
    /// Tricept's GLS, one operator per encoder, pose count and per-joint
    /// variant.
    Gls,
    /// Gauss–Newton at the estimate's exact kinematics, as `identify`.
    GaussNewton,
}

impl Estimator {
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Linear => "linear",
            Estimator::Gls => "gls",
            Estimator::GaussNewton => "gauss-newton",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "linear" => Some(Estimator::Linear),
            "gls" => Some(Estimator::Gls),
            "gauss-newton" => Some(Estimator::GaussNewton),
            _ => None,
        }
    }
}

/// A study as the config states it, of a mechanism with targets `T`
/// instrumented as each of `V` (the hexapod: poses, one or two encoders
/// a joint).
#[derive(Debug, Clone)]
pub struct Spec<T, V> {
    pub sensors: Vec<Sensor>,
    /// The instrumentations compared (`sweep.per_joint` for the hexapod).
    pub variants: Vec<V>,
    pub pose_counts: Vec<usize>,
    pub estimators: Vec<Estimator>,
    pub trials: u64,
    pub seed: u64,
    /// Each length error of a trial's machine is uniform in ±this, mm.
    pub length_bound_mm: f64,
    /// Each angle error (a reading's zero) in ±this, degrees.
    pub zero_bound_deg: f64,
    /// Readings averaged per pose (the jitter's σ falls by √samples).
    pub samples: u32,
    /// Targets the accuracy is judged at.
    pub workspace: Vec<T>,
    /// The tool point in the platform's frame, mm (where targets are
    /// poses).
    pub tool_mm: Vector3<f64>,
    /// Gauss–Newton's iterations.
    pub iterations: usize,
    /// Errors held at known values (`identification.fix`): every simulated
    /// machine has them, and every estimator holds them.
    pub fixed: Vec<(usize, f64)>,
    /// A Gaussian prior's σ on every free length error (mm) and encoder
    /// zero (degrees) (`identification.prior_std_mm`, `prior_std_deg`):
    /// every estimator holds it, as identify does.
    pub prior_std_mm: Option<f64>,
    pub prior_std_deg: Option<f64>,
}

/// The most machines a study of any mechanism simulates (`sweep.trials`,
/// `--trials`).
pub const MAX_STUDY_TRIALS: u64 = 10_000_000;

/// One encoder a study compares: a catalogue product (with its price) or a
/// bare grade.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    pub name: String,
    /// Price of one encoder; None for a grade.
    pub price: Option<f64>,
    /// Its datasheet model, radians (period one turn): what the
    /// estimators weight by.
    pub axis: Axis,
    /// How it reads when not as its datasheet says (a what-if); None: as
    /// the datasheet says.
    pub truth: Option<Axis>,
}

/// Encoders that read otherwise than their datasheets say, the estimators
/// still weighting them by the datasheets: the study's what-ifs, run on
/// the chosen combination with the same machines and draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WhatIf {
    /// Interpolation error and jitter this many times the datasheet's.
    White(f64),
    /// Installed rings (a datasheet eccentricity and a ring diameter)
    /// mounted with up to this many µm of eccentricity.
    EccentricityUm(f64),
}

impl WhatIf {
    /// The encoder `axis` as it reads under this what-if (the sensors'
    /// own what-ifs, as the Tricept's study reads them); None where it does
    /// not apply (an encoder with integral bearing has no mounting
    /// eccentricity of its own).
    pub fn truth(&self, axis: &Axis) -> Option<Axis> {
        match *self {
            WhatIf::White(f) => Some(axis.with_white_scaled(f)),
            WhatIf::EccentricityUm(um) => axis.with_eccentricity_um(um),
        }
    }

    /// What it supposes, in words.
    pub fn words(&self) -> String {
        match *self {
            WhatIf::White(f) => format!("interpolation error and jitter {f}× the datasheet's"),
            WhatIf::EccentricityUm(um) => {
                format!(
                    "rings mounted to {um} µm of eccentricity instead of their stated tolerance"
                )
            }
        }
    }
}

/// The most poses a config, a readings file or a targets file may hold:
/// identification stacks a dense design of a pose's readings × the errors
/// (the hexapod's 12 × 54: 52 MB at 10,000 poses, a few copies in the fit).
pub const MAX_POSES: usize = 10_000;

/// The most trials × combinations a study may hold: each machine's four
/// numbers per combination (32 bytes) and, while its instrumentation's
/// study runs, the runner's record of it (65 bytes): 0.8 GiB at this many,
/// under 1 GiB with the runner's buffers
/// (`montecarlo::general::result_bytes`).
pub const MAX_RESULTS: u128 = 1 << 23;

/// The most bytes a study's results may hold.
pub const MAX_RESULT_BYTES: u128 = 1 << 30;

/// A study as a config asks it: the spec its kernel runs, the what-ifs
/// run on the chosen combination, and the targets the verdict asks
/// (`[decision]`: position; orientation where targets are poses).
#[derive(Debug, Clone)]
pub struct StudyConfig<T, V> {
    pub spec: Spec<T, V>,
    /// `sweep.until_decided`: the most machines the study may grow to
    /// while a combination bought before its choice is undecided (None:
    /// `spec.trials`, as asked).
    pub until_decided: Option<u64>,
    pub what_ifs: Vec<WhatIf>,
    pub position_mm: Option<f64>,
    pub orientation_arcsec: Option<f64>,
}

/// What a mechanism's checked config gives the commands that run any
/// mechanism (identifiability, simulate, identify): the machine, its
/// poses, what identification holds and states, and the workspace its
/// accuracy is judged over.
pub trait MechanismConfig {
    type M: Mechanism;
    /// The config file, for messages.
    fn source(&self) -> &str;
    fn machine(&self) -> &Self::M;
    /// The simulated machine's errors; None for a real machine.
    fn simulated(&self) -> Option<Vec<f64>>;
    /// The poses as written (each in `target_columns` order) and as
    /// targets.
    fn pose_rows(&self) -> Vec<Vec<f64>>;
    fn poses(&self) -> &[<Self::M as Mechanism>::Target];
    fn iterations(&self) -> usize;
    fn rank_tolerance(&self) -> f64;
    /// The readings' σ (file units): empty where not stated, one for every
    /// reading, or one per reading of a pose; and the key that states it.
    fn reading_sigma(&self) -> (Vec<f64>, &'static str);
    fn holds(&self) -> &Holds;
    /// Targets accuracy is judged at, and the tool point (mm, platform
    /// frame).
    fn workspace(&self) -> &[<Self::M as Mechanism>::Target];
    fn tool_mm(&self) -> Vector3<f64>;
    /// The target a file row names, checked against the machine's limits.
    fn target(&self, cells: &[f64]) -> Result<<Self::M as Mechanism>::Target, String>;
    /// The `[sweep]` study; None without one (`study_keys` says what
    /// states one).
    fn study(&self) -> Option<&Study<Self::M>>;
    fn study_keys(&self) -> &'static str;
    /// What the machine's limits keep the poses within, a sentence for a
    /// report's assumptions.
    fn limits_words(&self) -> String;
    /// Whether actuator commands `q` (mm, one an actuator) are within the
    /// machine's travel, or which one is not and the config key that says
    /// so. Without stated limits every command is.
    fn check_commands(&self, q: &[f64]) -> Result<(), String> {
        let _ = q;
        Ok(())
    }
}

/// The study of a mechanism's config.
pub type Study<M> = StudyConfig<<M as Mechanism>::Target, <M as Mechanism>::Variant>;

/// A `Kinematic` topology's config as the commands of any mechanism read
/// it (through [`crate::mechanism::Homed`]): its machine, poses, simulated
/// errors, readings' σ, holds and study, set by the caller (there is no
/// config file for one yet: `[mechanism] kind` knows the Tricept and the
/// hexapod). Targets are points; the workspace is the poses; no limits.
pub struct HomedConfig<M: Mechanism<Target = Vector3<f64>>> {
    pub source: String,
    pub machine: M,
    pub poses: Vec<Vector3<f64>>,
    /// The simulated machine's errors; None for a real machine.
    pub errors: Option<Vec<f64>>,
    /// The readings' σ (file units; empty: unstated) and its key.
    pub sigma: (Vec<f64>, &'static str),
    pub holds: Holds,
    pub study: Option<Study<M>>,
}

impl<M: Mechanism<Target = Vector3<f64>>> MechanismConfig for HomedConfig<M> {
    type M = M;
    fn source(&self) -> &str {
        &self.source
    }
    fn machine(&self) -> &M {
        &self.machine
    }
    fn simulated(&self) -> Option<Vec<f64>> {
        self.errors.clone()
    }
    fn pose_rows(&self) -> Vec<Vec<f64>> {
        self.poses.iter().map(|p| p.as_slice().to_vec()).collect()
    }
    fn poses(&self) -> &[Vector3<f64>] {
        &self.poses
    }
    fn iterations(&self) -> usize {
        30
    }
    fn rank_tolerance(&self) -> f64 {
        1e-9
    }
    fn reading_sigma(&self) -> (Vec<f64>, &'static str) {
        self.sigma.clone()
    }
    fn holds(&self) -> &Holds {
        &self.holds
    }
    fn workspace(&self) -> &[Vector3<f64>] {
        &self.poses
    }
    fn tool_mm(&self) -> Vector3<f64> {
        Vector3::zeros()
    }
    fn target(&self, cells: &[f64]) -> Result<Vector3<f64>, String> {
        self.machine.target_of(cells)
    }
    fn study(&self) -> Option<&Study<M>> {
        self.study.as_ref()
    }
    fn study_keys(&self) -> &'static str {
        "a Spec built by the caller"
    }
    fn limits_words(&self) -> String {
        "The targets are the poses given; no limits were stated.".into()
    }
}
