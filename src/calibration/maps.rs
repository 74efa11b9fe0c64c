//! What compensation does over a workspace, for any mechanism of fixed
//! sizes read through its `Kinematic` traits: the position error of a
//! machine commanded by the nominal and by an identified model at each
//! point ([`map_of`]), the error the identified model predicts for the
//! nominal commands ([`correction_vectors`]), and the compensated commands
//! for a file's targets ([`commands`]). Exact kinematics throughout.

use super::verify::check_targets;
use crate::compensate::{position_error, volumetric_map, VolumetricMap};
use crate::error::{Error, Result};
use crate::io::Source;
use crate::mechanism::{Homed, Kinematic, Reach};
use nalgebra::Vector3;

/// dV at every point of `grid` of `truth` commanded by `homed`'s nominal
/// machine and by the `identified` model; a point that fails is named in
/// an error on `config`.
pub fn map_of<T, const P: usize, const R: usize>(
    homed: &Homed<T, P, R>,
    (identified, truth): (&T::Machine, &T::Machine),
    grid: &[Vector3<f64>],
    config: &str,
) -> Result<VolumetricMap>
where
    T: Kinematic<P, R>,
    T::Machine: Sync,
{
    volumetric_map::<T, P, R>(homed.nominal(), identified, truth, grid).map_err(|e| {
        let p = grid[e.index];
        Error::config(
            config,
            format!(
                "compensation: map point ({:.1}, {:.1}, {:.1}) mm fails: {}",
                p.x, p.y, p.z, e.source
            ),
        )
    })
}

/// For a real machine: at each point of `map`, the position error
/// (attained − target, mm) the `identified` model predicts for the nominal
/// commands — the vector whose length is the correction map's `before_mm`.
pub fn correction_vectors<T: Kinematic<P, R>, const P: usize, const R: usize>(
    homed: &Homed<T, P, R>,
    identified: &T::Machine,
    map: &VolumetricMap,
    config: &str,
) -> Result<Vec<Vector3<f64>>> {
    map.points
        .iter()
        .map(|r| {
            let (q, guess) = T::command(homed.nominal(), r).ok()?;
            position_error::<T, P, R>(identified, &q, r, &guess).ok()
        })
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            Error::config(
                config,
                "compensation: a map point the correction map reached fails again",
            )
        })
}

/// The commands (the Tricept's q1, q2, q3 in mm) that put the `identified`
/// machine's tool point on each target, every target first checked against
/// `reach`; errors name the line of `file`.
pub fn commands<T: Kinematic<P, R>, const P: usize, const R: usize>(
    reach: &Reach<T, P, R>,
    identified: &T::Machine,
    targets: &[Vector3<f64>],
    file: Source,
) -> Result<Vec<T::Command>> {
    check_targets(reach, targets, file)?;
    targets
        .iter()
        .enumerate()
        .map(|(k, r)| {
            T::command(identified, r)
                .map(|(q, _)| q)
                .map_err(|e| Error::csv(file.name, format!("line {}: {e}", file.line(k))))
        })
        .collect()
}
