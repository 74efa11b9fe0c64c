//! What one calibration of a trial produced ([`Outcome`]) and why it may
//! have produced nothing or something doubtful ([`Failure`]): the record the
//! kernel ([`super::trial`]) and the workspace judgement
//! ([`super::workspace`]) fill, and everything downstream reads (partials,
//! trials.csv rows, the summary). It imports nothing of theirs, so neither
//! of them imports the other for it. It holds no number of errors: a
//! calibration's estimate − truth goes beside it (the trial's scratch, the
//! runner's block of error vectors), so the record is any mechanism's.

/// Why a calibration produced no estimate or a doubtful one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Failure {
    #[default]
    None,
    /// Forward kinematics of the true machine failed at some pose.
    ForwardKinematics,
    /// Gauss–Newton hit its iteration limit (estimate kept, counted).
    NotConverged,
}

impl Failure {
    /// The `failure` column of trials.csv.
    pub fn label(&self) -> &'static str {
        match self {
            Failure::None => "",
            Failure::ForwardKinematics => "fk_failed",
            Failure::NotConverged => "not_converged",
        }
    }

    /// The byte stored in a partial result.
    pub fn code(&self) -> u8 {
        match self {
            Failure::None => 0,
            Failure::ForwardKinematics => 1,
            Failure::NotConverged => 2,
        }
    }

    /// Inverse of [`Failure::code`] (None for a byte no failure has).
    pub fn from_code(code: u8) -> Option<Self> {
        [
            Failure::None,
            Failure::ForwardKinematics,
            Failure::NotConverged,
        ]
        .into_iter()
        .find(|f| f.code() == code)
    }
}

/// One calibration's outcome.
#[derive(Debug, Clone, Copy, Default)]
pub struct Outcome {
    pub mu: f64,
    pub mu0: f64,
    pub rank: u8,
    pub failure: Failure,
    /// Max, mean and 95th percentile of dV after compensation over the
    /// workspace grid, mm (NaN when off or when some point failed).
    pub dv_after_max: f64,
    pub dv_after_mean: f64,
    pub dv_after_p95: f64,
    /// Worst ISO 9283 pose accuracy AP at P1–P5 after compensation, mm.
    pub ap_after_max: f64,
    /// Max dV before compensation (nominal commands), mm (NaN when off).
    pub dv_before_max: f64,
    /// The largest orientation error over the workspace before and after
    /// compensation, rad, first order (NaN where orientation is not
    /// judged: a mechanism whose targets are points).
    pub orientation_before_max: f64,
    pub orientation_after_max: f64,
    /// The error budget: μ of the same calibration with every sensor
    /// perfect (what no sensor can fix), then with the ψ4 encoder, the θ4
    /// encoder or the scale alone perfect (common random numbers; NaN with
    /// Gauss–Newton, and for a mechanism of other than three readings a
    /// pose, whose sensors these columns do not name).
    pub budget: [f64; 4],
}

impl Outcome {
    /// A machine whose calibration poses forward kinematics could not solve:
    /// only μ0 (its true errors) is known; every other number is NaN (an
    /// empty cell), the rank 0.
    pub fn forward_kinematics_failed(mu0: f64) -> Outcome {
        Outcome {
            mu: f64::NAN,
            mu0,
            rank: 0,
            failure: Failure::ForwardKinematics,
            dv_after_max: f64::NAN,
            dv_after_mean: f64::NAN,
            dv_after_p95: f64::NAN,
            ap_after_max: f64::NAN,
            dv_before_max: f64::NAN,
            orientation_before_max: f64::NAN,
            orientation_after_max: f64::NAN,
            budget: [f64::NAN; 4],
        }
    }
}
