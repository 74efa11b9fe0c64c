//! `verify`: an identified model against a fresh log, position by the
//! passive limb against where the model puts the tool.

use super::check_targets;
use crate::config::Config;
use crate::error::{Error, Result};
use crate::io::data_line;
use crate::model::{Joints, Machine};
use crate::sensors::Reading;
use nalgebra::Vector3;

/// One row of a verification: where the log's passive limb says the tool
/// was, against where the identified model says it should be.
#[derive(Debug, Clone, serde::Serialize)]
pub struct VerifyRow {
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    /// Expected position: the target (compensated commands), or the
    /// identified machine at the nominal commands.
    pub expected_x_mm: f64,
    pub expected_y_mm: f64,
    pub expected_z_mm: f64,
    /// Position measured by the passive limb's readings.
    pub measured_x_mm: f64,
    pub measured_y_mm: f64,
    pub measured_z_mm: f64,
    pub error_mm: f64,
}

/// Check an identified model against a fresh log of the machine. With
/// `nominal_commands` false the log was taken with the commands `compensate`
/// wrote for its targets, so the tool should be at each target; with it
/// true the log was taken with the nominal commands (as a calibration log
/// is), and the identified machine at those commands says where the tool
/// should be. Either way the passive limb's readings say where it was —
/// relative to the reference pose (the first row), where the sensors were
/// homed: the log's readings are taken back to absolute joints by the
/// offset at which the identified model puts the reference, so a constant
/// offset no reading can see (an unidentifiable error) is not measured.
pub fn verify(
    cfg: &Config,
    identified: &Machine,
    readings: &[Reading],
    nominal_commands: bool,
    file: &str,
) -> Result<Vec<VerifyRow>> {
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    let nominal = cfg.nominal();
    let expected_joints = |k: usize, r: &Reading| -> Result<Joints> {
        if !nominal_commands {
            // The identified machine's limb at the target (with identified
            // Hooke axes, their rotations; else the ideal limb's).
            return identified
                .inverse(&r.target)
                .map(|p| p.joints)
                .map_err(|e| Error::csv(file, format!("line {}: {e}", data_line(k))));
        }
        let bad = |e: crate::error::KinematicsError| {
            Error::csv(file, format!("line {}: {e}", data_line(k)))
        };
        let pose = nominal.inverse(&r.target).map_err(bad)?;
        let q = nominal.commands(&r.target).map_err(bad)?;
        identified.forward(&q, &pose.joints).map_err(|e| {
            Error::csv(
                file,
                format!(
                    "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                    data_line(k)
                ),
            )
        })
    };
    let Some(first) = readings.first() else {
        return Ok(Vec::new());
    };
    let offset = expected_joints(0, first)?.as_vector() - first.joints.as_vector();
    readings
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let expected = if nominal_commands {
                let bad = |e: crate::error::KinematicsError| {
                    Error::csv(file, format!("line {}: {e}", data_line(k)))
                };
                let pose = nominal.inverse(&r.target).map_err(bad)?;
                let q = nominal.commands(&r.target).map_err(bad)?;
                let j = identified.forward(&q, &pose.joints).map_err(|e| {
                    Error::csv(
                        file,
                        format!(
                            "line {}: the identified machine cannot reach this target with the nominal commands: {e}",
                            data_line(k)
                        ),
                    )
                })?;
                identified.position(&j)
            } else {
                r.target
            };
            // The passive limb's readings through the identified machine's
            // own axes (the ideal limb's when none were identified).
            let measured = identified.position(&Joints::from_vector(&(r.joints.as_vector() + offset)));
            Ok(VerifyRow {
                x_mm: r.target.x,
                y_mm: r.target.y,
                z_mm: r.target.z,
                expected_x_mm: expected.x,
                expected_y_mm: expected.y,
                expected_z_mm: expected.z,
                measured_x_mm: measured.x,
                measured_y_mm: measured.y,
                measured_z_mm: measured.z,
                error_mm: (measured - expected).norm(),
            })
        })
        .collect()
}
