//! A Tricept log's rows that repeat a pose, as identify counts them
//! ([`Repeats`]: fresh readings stay rows, copies are one reading at the
//! pose's mean).

use super::{check_readings, check_targets};
use crate::config::Config;
use crate::error::Result;
use crate::identify::repeats::Repeats;
use crate::mechanism::tricept::{Joints, N_READINGS, READINGS};
use crate::sensors::Reading;
use nalgebra::Vector3;

/// A log's rows as identify counts them ([`Repeats`]): each row's
/// distinct pose (`groups`, for the held-out folds; empty when every pose
/// is once), each kept reading's row in the file (`rows`), and the note
/// identify prints when rows repeat.
pub struct ByPose {
    pub readings: Vec<Reading>,
    pub groups: Vec<usize>,
    pub rows: Vec<usize>,
    pub note: Option<String>,
}

/// Repeats that scatter as fresh readings of the sensors' noise (the part
/// of a reading drawn afresh, [`crate::sensors::SensorModel::fresh_sigma`])
/// stay rows: the covariance states each as a reading, its curve and
/// interpolation error shared with the pose's others. Otherwise (copies,
/// a value the controller logged again) each distinct pose once, at the
/// mean of its readings, as one reading; every row is checked first, so a
/// refusal names its own line. Distinct poses keep their first row's order.
pub fn by_pose(cfg: &Config, readings: Vec<Reading>, file: &str) -> Result<ByPose> {
    let cells: Vec<f64> = readings
        .iter()
        .flat_map(|r| r.target.iter().copied())
        .collect();
    let repeats = Repeats::of(&cells, 3);
    if repeats.repeated() == 0 {
        let rows = (0..readings.len()).collect();
        return Ok(ByPose {
            readings,
            groups: Vec::new(),
            rows,
            note: None,
        });
    }
    let values: Vec<f64> = readings
        .iter()
        .flat_map(|r| r.joints.as_vector().iter().copied().collect::<Vec<_>>())
        .collect();
    let white = cfg.sensors.fresh_sigma();
    let units: Vec<(f64, &str)> = READINGS
        .iter()
        .map(|r| (r.quantity.sensor_per_model(), r.quantity.sensor_symbol()))
        .collect();
    let (fresh, note) = repeats.judged(
        (&values, N_READINGS),
        white.as_slice(),
        "the [sensors] section's jitter and quantisation",
        &units,
    );
    if fresh {
        let rows = (0..readings.len()).collect();
        return Ok(ByPose {
            readings,
            groups: repeats.of_row,
            rows,
            note,
        });
    }
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    check_targets(cfg, &targets, file)?;
    check_readings(cfg, &readings, file)?;
    let means = repeats.means(&values, N_READINGS);
    let distinct = repeats
        .first
        .iter()
        .zip(means.chunks_exact(N_READINGS))
        .map(|(&i, m)| Reading {
            target: readings[i].target,
            joints: Joints::from_vector(&Vector3::from_column_slice(m)),
        })
        .collect();
    Ok(ByPose {
        readings: distinct,
        groups: Vec::new(),
        rows: repeats.first,
        note,
    })
}
