//! The Tricept's facts ([`Topology`], `src/mechanism/facts.rs`): its 15
//! errors and their names, its three passive-joint readings with their
//! symbols, units and file columns, its three legs, the rules its nominal
//! layout must satisfy, where a pose is usable (reach, tilt, singularity),
//! and the travel its linear scale must cover.
//!
//! The rest of the Tricept's pipeline reads the facts of [`Mechanism`]
//! through the constants and functions below instead of copies of its
//! own. What still assumes the
//! Tricept's shape (the fast kernel's, datasheet sensors' and workspace
//! maps' fixed-size arrays of 15 errors and 3 readings) is listed in
//! ARCHITECTURE.md.

use super::geometry::{Geometry, Machine};
use super::jacobian::passive_matrix;
use super::kinematics::{normalized_det, Joints};
use super::params::{N_PARAMS, PARAM_NAMES};
use super::poses::Workspace;
use crate::error::KinematicsError;
use crate::mechanism::{GeometryRule, Quantity, ReadingFact, Topology};
use nalgebra::Vector3;

/// The Tricept's 3-DOF parallel module (Hong 2009): three active legs, a
/// passive central limb with a Hooke joint (ψ4, θ4) and a prismatic joint
/// (q4), 15 independent errors under the frame gauge of docs/method.md §3.
#[derive(Debug, Clone, Copy)]
pub struct Tricept;

impl Topology for Tricept {
    const NAME: &'static str = "tricept";
    const CONVENTION: &'static str = "B4 (the passive limb's base joint) is the origin; dzB1 = dzB2 = 0 and dxB2 = dxB1 (the base frame); dz'A1 = dz'A2 = dz'A3 = 0 (the platform frame); every error is relative to the reference pose the sensors are homed at";
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
    type Workspace = Workspace;

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

    /// Each limb's base and platform joints, nominal and identified, and
    /// its length offset (`limbs`).
    fn joints_json(
        nominal: &Machine,
        identified: &Machine,
    ) -> serde_json::Map<String, serde_json::Value> {
        // −0 printed as 0.
        let clean = |x: f64| x + 0.0;
        let v3 = |v: &Vector3<f64>| serde_json::json!([clean(v.x), clean(v.y), clean(v.z)]);
        let limbs: Vec<serde_json::Value> = (0..3)
            .map(|i| {
                serde_json::json!({
                    "limb": i + 1,
                    "base_nominal_mm": v3(&nominal.b[i]),
                    "base_identified_mm": v3(&identified.b[i]),
                    "platform_nominal_mm": v3(&nominal.a[i]),
                    "platform_identified_mm": v3(&identified.a[i]),
                    "length_offset_mm": clean(identified.dq[i]),
                })
            })
            .collect();
        [("limbs".to_string(), limbs.into())].into_iter().collect()
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

/// The Tricept's joints are its pose's readings, in [`READINGS`]' order.
impl crate::mechanism::PoseReadings<N_READINGS> for Joints {
    /// ψ4 (rad), θ4 (rad), q4 (mm): the order of [`Joints::as_vector`].
    #[inline]
    fn reading(&self, k: usize) -> f64 {
        [self.psi_rad, self.theta_rad, self.q4_mm][k]
    }
}

/// The readings as a mechanism's reading slots, one sensor each (ψ4
/// encoder, θ4 encoder, q4 scale): what a sensor set is laid out by.
pub const SLOTS: &[ReadingFact; N_READINGS] = match READINGS.first_chunk() {
    Some(slots) if READINGS.len() == N_READINGS => slots,
    _ => panic!("the Tricept's readings are N_READINGS"),
};

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

/// A Tricept log's row is any point mechanism's: its target, then ψ4, θ4
/// and q4.
impl crate::mechanism::LogRow<N_READINGS> for super::kinematics::Reading {
    const FACTS: &'static [ReadingFact; N_READINGS] = SLOTS;
    fn target(&self) -> Vector3<f64> {
        self.target
    }
    fn readings(&self) -> Vector3<f64> {
        self.joints.as_vector()
    }
    fn new(target: Vector3<f64>, x: &Vector3<f64>) -> Self {
        super::kinematics::Reading {
            target,
            joints: Joints::from_vector(x),
        }
    }
}

#[cfg(test)]
#[path = "topology_tests.rs"]
mod tests;
