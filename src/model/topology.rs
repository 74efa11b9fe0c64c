//! The facts of the mechanism that the rest of the tool reads (issue 21):
//! how many geometric errors and their names, which passive-joint readings
//! with their symbols, units and file columns, how many legs, the rules a
//! nominal layout must satisfy, where a pose is usable (reach, tilt,
//! singularity), and the travel the linear scale must cover.
//!
//! A second topology implements [`Topology`] beside [`Tricept`] (and
//! [`super::Kinematic`] for identification and the generic sweep); the rest
//! of the tool reads the facts of [`Mechanism`] through the constants and
//! functions below instead of copies of its own. What still assumes the
//! Tricept's shape (the fast kernel's, datasheet sensors' and workspace
//! maps' fixed-size arrays of 15 errors and 3 readings) is listed in
//! ARCHITECTURE.md.

use super::geometry::{Geometry, Machine};
use super::jacobian::passive_matrix;
use super::kinematics::{normalized_det, Joints};
use super::params::{N_PARAMS, PARAM_NAMES};
use super::poses::Workspace;
use crate::error::KinematicsError;
use nalgebra::Vector3;

/// Arcseconds per radian.
pub const ARCSEC_PER_RAD: f64 = 206_264.806_247_096_36;

/// What a reading measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// An angle: radians inside, degrees in files, arcseconds for sensors.
    Angle,
    /// A length: mm inside and in files, µm for sensors.
    Length,
}

impl Quantity {
    /// The unit of the reading's file column.
    pub fn file_unit(self) -> &'static str {
        match self {
            Quantity::Angle => "deg",
            Quantity::Length => "mm",
        }
    }

    /// The ASCII name of the unit a sensor's accuracy is given in (CSV
    /// cells): arcsec, um.
    pub fn sensor_unit_ascii(self) -> &'static str {
        match self {
            Quantity::Angle => "arcsec",
            Quantity::Length => "um",
        }
    }

    /// Sensor units per model unit: arcseconds per radian, µm per mm.
    pub fn sensor_per_model(self) -> f64 {
        match self {
            Quantity::Angle => ARCSEC_PER_RAD,
            Quantity::Length => 1e3,
        }
    }

    /// A sensor's value (″, µm) in the model's unit (rad, mm).
    pub fn from_sensor(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v / ARCSEC_PER_RAD,
            Quantity::Length => v * 1e-3,
        }
    }

    /// A value in the model's unit (rad, mm) in the file's (deg, mm).
    pub fn to_file(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v.to_degrees(),
            Quantity::Length => v,
        }
    }

    /// A value in the file's unit (deg, mm) in the model's (rad, mm).
    pub fn from_file(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v.to_radians(),
            Quantity::Length => v,
        }
    }
}

/// One passive-joint reading of every pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingFact {
    /// As the paper writes it ("ψ4").
    pub symbol: &'static str,
    /// In ASCII ("psi4").
    pub ascii: &'static str,
    /// Its column in readings files ("psi4_deg"), in [`Quantity::file_unit`].
    pub column: &'static str,
    pub quantity: Quantity,
    /// The sensor that reads it, as a person names it ("ψ4 encoder").
    pub sensor: &'static str,
    /// The same in ASCII ("psi4 encoder").
    pub sensor_ascii: &'static str,
    /// The sensor as a CSV cell names it ("psi4_encoder").
    pub sensor_key: &'static str,
    /// The largest difference (file unit) between a reading and the nominal
    /// joint value at its target that geometric errors of a few mm can
    /// make: more says units, column order or signs are wrong.
    pub plausible: f64,
}

/// A layout that breaks one of the topology's rules: which joints (base or
/// platform) and why.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryRule {
    /// `true` when the rule is about the base joints, else the platform's.
    pub base: bool,
    pub why: String,
}

/// The facts of one parallel-module topology. Everything outside `model/`
/// reads them (through [`Mechanism`]); kinematics, the error Jacobian and
/// the error vector are the topology's own types beside them.
pub trait Topology {
    /// The independent geometric errors, in canonical order.
    const ERROR_NAMES: &'static [&'static str];
    /// Raw errors the frame gauge fixes (not estimated, named when a config
    /// gives one).
    const GAUGE_FIXED: &'static [&'static str];
    /// The passive-joint readings of a pose, in order.
    const READINGS: &'static [ReadingFact];
    /// Active legs (commands per pose).
    const LEGS: usize;
    /// Its nominal layout.
    type Layout;
    /// Its machine (layout + errors), which solves the kinematics.
    type Machine;

    /// Does the nominal layout obey the topology's rules (the frame gauge
    /// the errors are defined in, distinct joints)?
    fn check_layout(layout: &Self::Layout) -> Result<(), GeometryRule>;

    /// Is the tool-centre position `r` usable with the nominal machine: it
    /// reaches it, within `max_tilt_deg`, away from a singularity?
    fn check_pose(
        nominal: &Self::Machine,
        r: &Vector3<f64>,
        max_tilt_deg: f64,
    ) -> Result<(), String>;

    /// The travel of the length reading over the workspace (mm): what a
    /// linear scale must cover.
    fn length_travel(ws: &Workspace) -> f64;
}

/// The Tricept's 3-DOF parallel module (Hong 2009): three active legs, a
/// passive central limb with a Hooke joint (ψ4, θ4) and a prismatic joint
/// (q4), 15 independent errors under the frame gauge of docs/method.md §3.
#[derive(Debug, Clone, Copy)]
pub struct Tricept;

impl Topology for Tricept {
    const ERROR_NAMES: &'static [&'static str] = &PARAM_NAMES;
    const GAUGE_FIXED: &'static [&'static str] = &["dzB1", "dzB2", "dxB2", "dzA1", "dzA2", "dzA3"];
    const READINGS: &'static [ReadingFact] = &[
        ReadingFact {
            symbol: "ψ4",
            ascii: "psi4",
            column: "psi4_deg",
            quantity: Quantity::Angle,
            sensor: "ψ4 encoder",
            sensor_ascii: "psi4 encoder",
            sensor_key: "psi4_encoder",
            plausible: 2.0,
        },
        ReadingFact {
            symbol: "θ4",
            ascii: "theta4",
            column: "theta4_deg",
            quantity: Quantity::Angle,
            sensor: "θ4 encoder",
            sensor_ascii: "theta4 encoder",
            sensor_key: "theta4_encoder",
            plausible: 2.0,
        },
        ReadingFact {
            symbol: "q4",
            ascii: "q4",
            column: "q4_mm",
            quantity: Quantity::Length,
            sensor: "scale",
            sensor_ascii: "scale",
            sensor_key: "scale",
            plausible: 20.0,
        },
    ];
    const LEGS: usize = 3;
    type Layout = Geometry;
    type Machine = Machine;

    /// B1B2 parallel to the y axis (the gauge ΔxB2 = ΔxB1 rests on it), B1,
    /// B2 and B4 spanning the base plane, no two joints at one point.
    /// The tolerances scale with the radii as the layout gives them back
    /// (|B1| = b and |A0,1| = a to the last bit or so).
    fn check_layout(g: &Geometry) -> Result<(), GeometryRule> {
        let size = g.b[0].norm().max(g.a[0].norm());
        let base = |why: String| Err(GeometryRule { base: true, why });
        if (g.b[0].x - g.b[1].x).abs() > 1e-9 * g.b[0].norm() {
            return base(format!(
                "puts B1 and B2 at x = {:.4} and {:.4} mm: B1B2 must be parallel to the y axis (use angles ±β)",
                g.b[0].x, g.b[1].x
            ));
        }
        let b = g.b[0].norm();
        if g.b[0].x.abs() < 1e-6 * b || (g.b[0] - g.b[1]).norm() < 1e-6 * b {
            return base("puts B1, B2 and B4 on one line: they must span the base plane".into());
        }
        for (p, on_base) in [(g.b, true), (g.a, false)] {
            for i in 0..3 {
                for j in i + 1..3 {
                    if (p[i] - p[j]).norm() < 1e-6 * size {
                        return Err(GeometryRule {
                            base: on_base,
                            why: format!("puts joints {} and {} at the same point", i + 1, j + 1),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Nominal IK exists, the UP limb's tilt is within `max_tilt_deg`, and
    /// the passive limb's matrix is not (nearly) singular.
    fn check_pose(nominal: &Machine, r: &Vector3<f64>, max_tilt_deg: f64) -> Result<(), String> {
        let pose = nominal.inverse(r).map_err(|e| match e {
            KinematicsError::Unreachable { reason, .. } => reason,
            other => other.to_string(),
        })?;
        let tilt = (r.z / r.norm()).clamp(-1.0, 1.0).acos().to_degrees();
        if tilt > max_tilt_deg {
            return Err(format!(
                "the UP limb would tilt {tilt:.1}° from the base normal, beyond geometry.max_tilt_deg = {max_tilt_deg}°"
            ));
        }
        let det = normalized_det(&passive_matrix(&pose));
        if det.abs() < 1e-6 {
            return Err(format!(
                "the configuration is (nearly) singular (normalised det {det:.2e})"
            ));
        }
        Ok(())
    }

    /// q4 from the workspace's top-face centre to its far bottom edge.
    fn length_travel(ws: &Workspace) -> f64 {
        ((ws.top_mm + ws.height_mm).powi(2) + ws.radius_mm.powi(2)).sqrt() - ws.top_mm
    }
}

/// The topology this build simulates and calibrates.
pub type Mechanism = Tricept;

/// The mechanism's readings (see [`Topology::READINGS`]).
pub const READINGS: &[ReadingFact] = <Mechanism as Topology>::READINGS;

/// Raw errors the mechanism's frame gauge fixes.
pub const GAUGE_FIXED: &[&str] = <Mechanism as Topology>::GAUGE_FIXED;

/// How many readings a pose gives.
pub const N_READINGS: usize = 3;

/// Active legs of the mechanism.
pub const N_LEGS: usize = <Mechanism as Topology>::LEGS;

const _: () = assert!(READINGS.len() == N_READINGS);
const _: () = assert!(<Mechanism as Topology>::ERROR_NAMES.len() == N_PARAMS);

/// [`Topology::check_layout`] of the mechanism.
pub fn check_layout(g: &Geometry) -> Result<(), GeometryRule> {
    Mechanism::check_layout(g)
}

/// [`Topology::check_pose`] of the mechanism.
pub fn check_pose(nominal: &Machine, r: &Vector3<f64>, max_tilt_deg: f64) -> Result<(), String> {
    Mechanism::check_pose(nominal, r, max_tilt_deg)
}

/// [`Topology::length_travel`] of the mechanism.
pub fn length_travel(ws: &Workspace) -> f64 {
    Mechanism::length_travel(ws)
}

/// The reading that is a length (the scale's), by index.
pub const LENGTH_READING: usize = 2;

const _: () = assert!(matches!(
    READINGS[LENGTH_READING].quantity,
    Quantity::Length
));

/// The readings of joints `j` in the files' units (deg, mm), in
/// [`READINGS`] order.
pub fn file_values(j: &Joints) -> [f64; N_READINGS] {
    let v = j.as_vector();
    std::array::from_fn(|k| READINGS[k].quantity.to_file(v[k]))
}

/// Joints from readings in the files' units (deg, mm), in [`READINGS`]
/// order.
pub fn from_file_values(v: [f64; N_READINGS]) -> Joints {
    Joints::from_vector(&Vector3::from_fn(|k, _| {
        READINGS[k].quantity.from_file(v[k])
    }))
}

#[cfg(test)]
#[path = "topology_tests.rs"]
mod tests;
