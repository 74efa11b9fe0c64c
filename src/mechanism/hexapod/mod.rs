//! The 6-UPS Gough–Stewart platform (hexapod) with rotary encoders on its
//! legs' base U-joints (docs/method.md §20).
//!
//! Base frame {O}, platform frame {P}. Leg i: U-joint centre b_i in {O},
//! spherical-joint centre p_i in {P}; pose X = (t, a, b, c), position t (mm)
//! and R = Rz(c)·Ry(b)·Rx(a) (degrees, LinuxCNC genhexkins' A, B, C). Leg
//! vector L_i = t + R·p_i − b_i, length |L_i| = ℓ0_i + q_i with q_i the
//! actuator's command and ℓ0_i its length at the home pose, so every
//! actuator reads 0 there.
//!
//! This folder is the machine: geometry and errors, exact kinematics and
//! readings, the design matrix, the convention and the LinuxCNC export.
//! Its identification (`identify::general`), study (`montecarlo::general`)
//! and config (`config::hexapod`) are in the layers they belong to.

pub mod convention;
pub mod design;
pub mod export;
pub mod kinematics;

use crate::mechanism::{Quantity, ReadingFact};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Legs.
pub const LEGS: usize = 6;
/// Errors per leg: the U-joint centre (3), the spherical joint's (3), the
/// leg's offset, the two encoders' zeros.
pub const PER_LEG: usize = 9;
/// Errors of the machine with both encoders on every joint.
pub const N_ERRORS: usize = LEGS * PER_LEG;

/// Which U-joint axes carry an encoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoders {
    /// φ and ψ on every joint: 12 readings a pose.
    Both,
    /// φ only (the first axis): 6 readings.
    First,
    /// ψ only (the second axis): 6 readings.
    Second,
}

impl Encoders {
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "both" => Some(Encoders::Both),
            "first" => Some(Encoders::First),
            "second" => Some(Encoders::Second),
            _ => None,
        }
    }

    /// The config's word for it.
    pub fn name(self) -> &'static str {
        match self {
            Encoders::Both => "both",
            Encoders::First => "first",
            Encoders::Second => "second",
        }
    }

    /// Readings each pose gives.
    pub fn per_pose(self) -> usize {
        match self {
            Encoders::Both => 2 * LEGS,
            _ => LEGS,
        }
    }

    /// Whether axis `k` (0 = φ, 1 = ψ) of every joint is read.
    pub fn reads(self, k: usize) -> bool {
        match self {
            Encoders::Both => true,
            Encoders::First => k == 0,
            Encoders::Second => k == 1,
        }
    }
}

/// How far (degrees) a reading may lie from the nominal machine's at its
/// target: a calibration's errors move a U-joint angle by well under this,
/// so a reading further off is a slip of the log (a column, a sign, a unit).
pub const PLAUSIBLE_DEG: f64 = 10.0;

/// How closely (degrees) a slip of the log (two columns swapped, a sign
/// flipped, radians) must explain a row's readings to be named: the size a
/// typical machine's errors move a reading by, well under
/// [`PLAUSIBLE_DEG`], which is what a machine with the largest errors a
/// config may give can reach.
pub const SLIP_DEG: f64 = 2.0;

macro_rules! reading {
    ($sym:literal, $ascii:literal, $leg:literal) => {
        ReadingFact {
            symbol: concat!($sym, $leg),
            ascii: concat!($ascii, $leg),
            column: concat!($ascii, $leg, "_deg"),
            quantity: Quantity::Angle,
            sensor: concat!($sym, $leg, " encoder"),
            sensor_ascii: concat!($ascii, $leg, " encoder"),
            sensor_key: concat!($ascii, $leg, "_encoder"),
            plausible: PLAUSIBLE_DEG,
        }
    };
}

/// Every reading a pose can give, leg by leg: φi (the U-joint's first
/// axis) then ψi (its second), as readings files name them.
pub const READINGS: [ReadingFact; 2 * LEGS] = [
    reading!("φ", "phi", "1"),
    reading!("ψ", "psi", "1"),
    reading!("φ", "phi", "2"),
    reading!("ψ", "psi", "2"),
    reading!("φ", "phi", "3"),
    reading!("ψ", "psi", "3"),
    reading!("φ", "phi", "4"),
    reading!("ψ", "psi", "4"),
    reading!("φ", "phi", "5"),
    reading!("ψ", "psi", "5"),
    reading!("φ", "phi", "6"),
    reading!("ψ", "psi", "6"),
];

/// The readings of one encoder a joint, leg by leg: φi alone
/// ([`Encoders::First`]) or ψi alone ([`Encoders::Second`]).
pub const PHI_READINGS: [ReadingFact; LEGS] = [
    READINGS[0],
    READINGS[2],
    READINGS[4],
    READINGS[6],
    READINGS[8],
    READINGS[10],
];
pub const PSI_READINGS: [ReadingFact; LEGS] = [
    READINGS[1],
    READINGS[3],
    READINGS[5],
    READINGS[7],
    READINGS[9],
    READINGS[11],
];

/// Error `e` of leg `leg` (0-based), in the order of [`error_names`]:
/// dbx, dby, dbz, dpx, dpy, dpz, dl, dphi, dpsi.
pub fn error_index(leg: usize, e: usize) -> usize {
    leg * PER_LEG + e
}

/// The 54 errors' names, leg by leg (legs numbered from 1): lengths in mm,
/// the encoders' zeros in degrees.
pub fn error_names() -> Vec<String> {
    const E: [&str; PER_LEG] = [
        "dbx", "dby", "dbz", "dpx", "dpy", "dpz", "dl", "dphi", "dpsi",
    ];
    (0..LEGS)
        .flat_map(|i| E.iter().map(move |e| format!("{e}{}", i + 1)))
        .collect()
}

/// Whether error `index` is an angle (an encoder's zero, degrees).
pub fn is_angle(index: usize) -> bool {
    index % PER_LEG >= 7
}

/// A pose: position (mm) and orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub t: Vector3<f64>,
    pub r: Matrix3<f64>,
}

impl Pose {
    /// From [x, y, z, a, b, c] (mm, degrees), R = Rz(c)·Ry(b)·Rx(a).
    pub fn from_xyzabc(x: &[f64; 6]) -> Self {
        // nalgebra's roll, pitch, yaw is Rz(yaw)·Ry(pitch)·Rx(roll).
        let r =
            Rotation3::from_euler_angles(x[3].to_radians(), x[4].to_radians(), x[5].to_radians());
        Pose {
            t: Vector3::new(x[0], x[1], x[2]),
            r: r.into_inner(),
        }
    }

    /// [x, y, z, a, b, c] of this pose (b in [−90°, 90°]).
    pub fn to_xyzabc(&self) -> [f64; 6] {
        let (a, b, c) = Rotation3::from_matrix_unchecked(self.r).euler_angles();
        [
            self.t.x,
            self.t.y,
            self.t.z,
            a.to_degrees(),
            b.to_degrees(),
            c.to_degrees(),
        ]
    }
}

/// The machine's nominal geometry and how it is instrumented.
#[derive(Debug, Clone, PartialEq)]
pub struct Hexapod {
    /// U-joint centres in {O}, mm.
    pub base: [Vector3<f64>; LEGS],
    /// Spherical-joint centres in {P}, mm.
    pub platform: [Vector3<f64>; LEGS],
    /// The pose where every actuator reads 0.
    pub home: Pose,
    pub encoders: Encoders,
}

/// A machine's errors (the 54 of [`error_names`]; mm and degrees).
pub type Errors = [f64; N_ERRORS];

impl Hexapod {
    /// The example machine: base radius 325 mm, platform radius 125 mm,
    /// base joints in pairs ±15° about 0°, 120° and 240°, each leg's
    /// platform joint 30° towards the next pair (pairs about 60°, 180°,
    /// 300°), home 500 mm above the base.
    pub fn example() -> Self {
        let at = |r: f64, deg: f64| {
            let a = deg.to_radians();
            Vector3::new(r * a.cos(), r * a.sin(), 0.0)
        };
        let base_deg =
            |i: usize| 120.0 * (i / 2) as f64 + if i.is_multiple_of(2) { -15.0 } else { 15.0 };
        let platform_deg = |i: usize| base_deg(i) + if i.is_multiple_of(2) { -30.0 } else { 30.0 };
        Hexapod {
            base: std::array::from_fn(|i| at(325.0, base_deg(i))),
            platform: std::array::from_fn(|i| at(125.0, platform_deg(i))),
            home: Pose::from_xyzabc(&[0.0, 0.0, 500.0, 0.0, 0.0, 0.0]),
            encoders: Encoders::Both,
        }
    }

    /// Readings a pose gives.
    pub fn readings_per_pose(&self) -> usize {
        self.encoders.per_pose()
    }

    /// The readings a pose of this machine gives, in the order of its
    /// readings files' columns and of [`Hexapod::readings`].
    pub fn reading_facts(&self) -> Vec<ReadingFact> {
        READINGS
            .iter()
            .enumerate()
            .filter(|(k, _)| self.encoders.reads(k % 2))
            .map(|(_, f)| *f)
            .collect()
    }

    /// The errors this machine can have: all 54 with both encoders, else
    /// the 48 without the unread axis's zeros (their indices).
    pub fn error_indices(&self) -> Vec<usize> {
        (0..N_ERRORS)
            .filter(|&j| match j % PER_LEG {
                7 => self.encoders.reads(0),
                8 => self.encoders.reads(1),
                _ => true,
            })
            .collect()
    }
}

impl crate::mechanism::Mechanism for Hexapod {
    type Target = Pose;
    type Variant = Encoders;

    fn with_variant(&self, encoders: Encoders) -> Self {
        Hexapod {
            encoders,
            ..self.clone()
        }
    }

    fn tool_point(&self, target: &Pose, tool: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
        target.t + target.r * tool
    }

    fn variant_name(&self, v: Encoders) -> &'static str {
        v.name()
    }

    fn variant_words(&self, v: Encoders) -> [&'static str; 2] {
        match v {
            Encoders::Both => ["a φ and a ψ encoder", "two a joint (φ and ψ)"],
            Encoders::First => ["one φ encoder", "one a joint (φ)"],
            Encoders::Second => ["one ψ encoder", "one a joint (ψ)"],
        }
    }

    fn words(&self) -> crate::mechanism::Words {
        crate::mechanism::Words {
            machine: "hexapod",
            sensor: "U-joint encoder",
            joint: "U-joint",
            length_errors: ["joint centre and leg offset", "joint centres and leg offsets"],
            angle_errors: ["encoder zero", "encoder zeros"],
            fitted: "6 or 12 U-joint encoders",
            sensors_heading: "U-joint encoders (6 fitted with one a joint, 12 with two)",
            more_sensors: "both encoders per joint",
            workspace: "poses about the home pose",
            reading: "the exact U-joint angle formula",
            frames: "Accuracy is judged in the convention's frames: the nine combinations no internal sensor sees (a translation of the machine, the choice of the platform frame) are fixed by the convention, and one external measurement of the platform ties them to the shop's frame.",
            moving: "platform",
            readers: "the encoders",
            cannot_see: "the nine combinations no internal sensor sees (a translation of the machine, the choice of the platform frame), which the convention fixes, and any error the encoders' readings share with the model; one external measurement of the platform tests those",
        }
    }

    fn slots(&self) -> usize {
        2 * LEGS
    }

    /// φi is slot 2(i − 1), ψi slot 2i − 1.
    fn slot(&self, k: usize) -> usize {
        match self.encoders {
            Encoders::Both => k,
            Encoders::First => 2 * k,
            Encoders::Second => 2 * k + 1,
        }
    }

    fn zero_of(&self, k: usize) -> Option<usize> {
        let s = self.slot(k);
        Some(error_index(s / 2, 7 + s % 2))
    }

    fn name(&self) -> &'static str {
        "hexapod"
    }

    fn target_columns(&self) -> &'static [&'static str] {
        &["x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg"]
    }

    /// Angles beyond ±90° refused.
    fn target_of(&self, x: &[f64]) -> Result<Pose, String> {
        let x: [f64; 6] = x
            .try_into()
            .map_err(|_| format!("a pose has 6 values, not {}", x.len()))?;
        if x[3..6].iter().any(|a| a.abs() > 90.0) {
            return Err("the pose's angles must be within ±90°".into());
        }
        Ok(Pose::from_xyzabc(&x))
    }

    fn convention(&self) -> &'static str {
        convention::CONVENTION
    }

    fn error_source(&self, j: usize) -> &'static str {
        convention::source(j)
    }

    fn nominal(&self) -> Vec<(String, Vec<f64>)> {
        let mut out = Vec::with_capacity(2 * LEGS + 1);
        for (key, at) in [
            ("base_joints_mm", &self.base),
            ("platform_joints_mm", &self.platform),
        ] {
            for (i, p) in at.iter().enumerate() {
                out.push((format!("hexapod.{key}[{i}]"), vec![p.x, p.y, p.z]));
            }
        }
        out.push(("hexapod.home_pose".into(), self.home.to_xyzabc().to_vec()));
        out
    }

    fn layout(&self, errors: &[f64]) -> Result<serde_json::Map<String, serde_json::Value>, String> {
        Ok(export::layout(self, &errors_of(errors)?))
    }

    fn slip_tolerance(&self, _k: usize) -> f64 {
        SLIP_DEG
    }

    fn error_names(&self) -> Vec<String> {
        error_names()
    }

    fn is_angle(&self, j: usize) -> bool {
        is_angle(j)
    }

    fn present(&self) -> Vec<usize> {
        self.error_indices()
    }

    /// A leg's offset or an encoder's zero.
    fn fixable(&self, j: usize) -> bool {
        j % PER_LEG >= 6
    }

    fn reading_facts(&self) -> Vec<ReadingFact> {
        Hexapod::reading_facts(self)
    }

    fn readings(&self, errors: &[f64], target: &Pose) -> Result<Vec<f64>, String> {
        Hexapod::readings(self, &errors_of(errors)?, target)
    }

    fn readings_into(
        &self,
        errors: &[f64],
        targets: &[Pose],
        out: &mut Vec<f64>,
    ) -> Result<(), String> {
        let m = self.actual(&errors_of(errors)?);
        let (frames, home) = (self.frames(), self.home_lengths());
        for (j, t) in targets.iter().enumerate() {
            let pose = Hexapod::forward(&m, &self.commands_from(t, &home), t)
                .map_err(|e| format!("pose {}: {e}", j + 1))?;
            self.read_into(&m, &pose, &frames, out);
        }
        Ok(())
    }

    fn design(&self, errors: &[f64], targets: &[Pose]) -> Result<nalgebra::DMatrix<f64>, String> {
        design::design(self, &errors_of(errors)?, targets)
    }

    fn free_directions(&self) -> nalgebra::DMatrix<f64> {
        convention::basis(self)
    }

    fn judged(&self) -> &'static [crate::mechanism::Judged] {
        &[crate::mechanism::POSITION, crate::mechanism::ORIENTATION]
    }

    fn sensitivity(
        &self,
        target: &Pose,
        tool: &Vector3<f64>,
    ) -> Result<nalgebra::DMatrix<f64>, String> {
        kinematics::tool_sensitivity(self, target, tool)
    }
}

/// The 54 errors of a slice, or why not.
pub fn errors_of(e: &[f64]) -> Result<Errors, String> {
    e.try_into()
        .map_err(|_| format!("{} errors given, the hexapod has {N_ERRORS}", e.len()))
}

#[cfg(test)]
#[path = "tests.rs"]
pub(crate) mod tests;
