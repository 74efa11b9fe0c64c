//! A Tricept log's rows that repeat a pose, as identify counts them
//! ([`Repeats`]: fresh readings stay rows, copies are one reading at the
//! pose's mean).

use super::{check_readings, check_targets};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::identify::repeats::{Counted, Repeats, Unit};
use crate::mechanism::tricept::{Joints, Reading, N_READINGS, READINGS};
use crate::sensors::SensorModel;
use nalgebra::Vector3;

/// A log's rows as identify counts them ([`Repeats`]): each row's
/// distinct pose (`groups`, for the held-out folds; empty when every pose
/// is once), each kept reading's row in the file (`rows`), and the note
/// identify prints when rows repeat.
pub struct ByPose {
    pub readings: Vec<Reading>,
    pub groups: Vec<usize>,
    pub rows: Vec<usize>,
    /// The loggings each kept reading averages (a steady offset between
    /// them, [`Counted::Means`]): their fresh noise averages as `samples`
    /// times this many samples would ([`ByPose::config`]); 1 otherwise.
    pub loggings: u32,
    pub note: Option<String>,
}

impl ByPose {
    /// The config the kept readings are fitted under: `cfg` itself, or,
    /// where each averages `loggings` > 1, its sensors' `samples` that
    /// many times over (the fresh noise, jitter and quantisation, of a
    /// mean of means; a curve does not average).
    pub fn config(&self, cfg: &Config) -> Option<Config> {
        (self.loggings > 1).then(|| {
            let mut c = cfg.clone();
            c.sensors.samples = c.sensors.samples.saturating_mul(self.loggings);
            c
        })
    }
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
            loggings: 1,
            note: None,
        });
    }
    let values: Vec<f64> = readings
        .iter()
        .flat_map(|r| r.joints.as_vector().iter().copied().collect::<Vec<_>>())
        .collect();
    let white = cfg.sensors.fresh_sigma();
    let units: Vec<Unit> = READINGS
        .iter()
        .map(|r| Unit {
            name: r.symbol,
            scale: r.quantity.sensor_per_model(),
            symbol: r.quantity.sensor_symbol(),
        })
        .collect();
    let what = fresh_in_words(&cfg.sensors);
    let judged = repeats.judged((&values, N_READINGS), white.as_slice(), &what, &units);
    let targets: Vec<Vector3<f64>> = readings.iter().map(|r| r.target).collect();
    let (counted, note) = match judged {
        Ok(j) => j,
        Err(why) => {
            // A row's own slip is named before the log's offset.
            check_targets(cfg, &targets, file)?;
            check_readings(cfg, &readings, file)?;
            return Err(Error::csv(file, why));
        }
    };
    if counted == Counted::Rows {
        let rows = (0..readings.len()).collect();
        return Ok(ByPose {
            readings,
            groups: repeats.of_row,
            rows,
            loggings: 1,
            note,
        });
    }
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
        loggings: match counted {
            Counted::Means(n) => u32::try_from(n).unwrap_or(u32::MAX),
            Counted::Rows | Counted::Once => 1,
        },
        note,
    })
}

/// What states the σ that repeats of a pose scatter by
/// ([`SensorModel::fresh_sigma`]), in words: the datasheet's jitter and
/// quantisation, or the grades, each of a reading averaged over
/// `samples`.
fn fresh_in_words<const R: usize>(s: &SensorModel<R>) -> String {
    let of = match s.structured {
        Some(_) => "the [sensors] section's jitter and quantisation",
        None => "the [sensors] grades",
    };
    match s.samples {
        0 | 1 => format!("{of}, one sample a reading"),
        n => format!("{of}, for a reading averaged over {n} samples"),
    }
}
