//! Compensation and volumetric accuracy (docs/method.md §7), for any
//! [`Kinematic`] topology.
//!
//! Compensated command: the identified machine's inverse kinematics at the
//! target (the nominal geometry plus the identified errors, its own leg
//! offsets taken off). Volumetric error at a target: dV = |r_actual − r|
//! with r_actual from exact forward kinematics of the true machine driven
//! with those commands.

use crate::error::{KinematicsError, PoseError};
use crate::mechanism::Kinematic;
use nalgebra::{SVector, Vector3};
use serde::Serialize;

/// dV of `truth` commanded with `q_cmd` for `target`, mm. `guess` (the
/// readings of a nearby configuration) seeds forward kinematics.
pub fn volumetric_error<T: Kinematic<P, R>, const P: usize, const R: usize>(
    truth: &T::Machine,
    q_cmd: &T::Command,
    target: &Vector3<f64>,
    guess: &SVector<f64, R>,
) -> Result<f64, KinematicsError> {
    Ok(position_error::<T, P, R>(truth, q_cmd, target, guess)?.norm())
}

/// Attained − target of `truth` commanded with `q_cmd`, mm (dV is its
/// length).
pub fn position_error<T: Kinematic<P, R>, const P: usize, const R: usize>(
    truth: &T::Machine,
    q_cmd: &T::Command,
    target: &Vector3<f64>,
    guess: &SVector<f64, R>,
) -> Result<Vector3<f64>, KinematicsError> {
    let x = T::readings(truth, q_cmd, guess)?;
    Ok(T::position(truth, &x) - target)
}

/// dV before (nominal IK) and after (identified IK) compensation.
#[derive(Debug, Clone)]
pub struct VolumetricMap {
    pub points: Vec<Vector3<f64>>,
    pub before_mm: Vec<f64>,
    pub after_mm: Vec<f64>,
}

/// Max, min and mean of a map.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Stats {
    pub max_mm: f64,
    pub min_mm: f64,
    pub mean_mm: f64,
}

impl Stats {
    pub fn of(v: &[f64]) -> Stats {
        let max_mm = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min_mm = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let mean_mm = v.iter().sum::<f64>() / v.len().max(1) as f64;
        Stats {
            max_mm,
            min_mm,
            mean_mm,
        }
    }
}

impl VolumetricMap {
    pub fn before(&self) -> Stats {
        Stats::of(&self.before_mm)
    }
    pub fn after(&self) -> Stats {
        Stats::of(&self.after_mm)
    }
}

/// The map over `points` for the true machine, commanded by the nominal and
/// by the identified model (each machine's own commands, [`Kinematic::command`]:
/// `nominal` is the machine without errors, whose commands are the
/// uncompensated ones). The error names the first failing point's
/// index. Points are computed in parallel on the current rayon pool; each
/// is independent of the others, so the map does not depend on the threads.
pub fn volumetric_map<T: Kinematic<P, R>, const P: usize, const R: usize>(
    nominal: &T::Machine,
    identified: &T::Machine,
    truth: &T::Machine,
    points: &[Vector3<f64>],
) -> Result<VolumetricMap, PoseError>
where
    T::Machine: Sync,
{
    use rayon::prelude::*;
    let point = |r: &Vector3<f64>| -> Result<(f64, f64), KinematicsError> {
        let (q_nom, guess) = T::command(nominal, r)?;
        let before = volumetric_error::<T, P, R>(truth, &q_nom, r, &guess)?;
        let (q_id, _) = T::command(identified, r)?;
        let after = volumetric_error::<T, P, R>(truth, &q_id, r, &guess)?;
        Ok((before, after))
    };
    let each: Vec<_> = points.par_iter().map(point).collect();
    let mut before_mm = Vec::with_capacity(points.len());
    let mut after_mm = Vec::with_capacity(points.len());
    for (k, r) in each.into_iter().enumerate() {
        let (b, a) = r.map_err(|e| PoseError::new(k, e))?;
        before_mm.push(b);
        after_mm.push(a);
    }
    Ok(VolumetricMap {
        points: points.to_vec(),
        before_mm,
        after_mm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::tricept::{
        ErrorVector, Geometry, Machine, Tricept, N_PARAMS, N_READINGS, PAPER_ERRORS_MM,
    };

    #[test]
    fn perfect_identification_compensates_exactly() {
        let g = Geometry::paper();
        let e = ErrorVector::from_row_slice(&PAPER_ERRORS_MM);
        let truth = Machine::with_errors(&g, &e);
        let pts = [
            Vector3::new(100.0, -50.0, 750.0),
            Vector3::new(-300.0, 200.0, 700.0),
        ];
        let map = volumetric_map::<Tricept, N_PARAMS, N_READINGS>(
            &Machine::nominal(&g),
            &truth,
            &truth,
            &pts,
        )
        .unwrap();
        assert!(map.after_mm.iter().all(|d| *d < 1e-9), "{:?}", map.after_mm);
        assert!(map.before_mm.iter().all(|d| *d > 0.1));
    }
}
