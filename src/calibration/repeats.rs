//! A log's rows that repeat a pose, as identify counts them ([`Repeats`]:
//! fresh readings stay rows, copies are one reading at the pose's mean),
//! for any mechanism whose log rows are [`LogRow`]s.

use crate::error::{Error, Result};
use crate::identify::repeats::{Counted, Repeats, Unit};
use crate::mechanism::LogRow;
use crate::sensors::SensorModel;
use nalgebra::SVector;

/// A log's rows as identify counts them ([`Repeats`]): each row's
/// distinct pose (`groups`, for the held-out folds; empty when every pose
/// is once), each kept reading's row in the file (`rows`), and the note
/// identify prints when rows repeat.
pub struct ByPose<L> {
    pub readings: Vec<L>,
    pub groups: Vec<usize>,
    pub rows: Vec<usize>,
    /// The loggings each kept reading averages (a steady offset between
    /// them, [`Counted::Means`]): their fresh noise averages as `samples`
    /// times this many samples would ([`ByPose::averaged`]); 1 otherwise.
    pub loggings: u32,
    pub note: Option<String>,
}

impl<L> ByPose<L> {
    /// The sensors the kept readings are fitted under: None where they
    /// are `sensors` themselves; where each averages `loggings` > 1,
    /// `sensors` with their `samples` that many times over (the fresh
    /// noise, jitter and quantisation, of a mean of means; a curve does
    /// not average).
    pub fn averaged<const R: usize>(&self, sensors: &SensorModel<R>) -> Option<SensorModel<R>> {
        (self.loggings > 1).then(|| SensorModel {
            samples: sensors.samples.saturating_mul(self.loggings),
            ..*sensors
        })
    }
}

/// Repeats that scatter as fresh readings of `sensors`' noise (the part
/// of a reading drawn afresh, [`crate::sensors::SensorModel::fresh_sigma`])
/// stay rows: the covariance states each as a reading, its curve and
/// interpolation error shared with the pose's others. Otherwise (copies,
/// a value the controller logged again) each distinct pose once, at the
/// mean of its readings, as one reading; every row is checked first
/// (`check`: the mechanism's checks of a log's targets and readings, in
/// file `file`), so a refusal names its own line. Distinct poses keep
/// their first row's order.
pub fn by_pose<L: LogRow<R>, const R: usize>(
    sensors: &SensorModel<R>,
    readings: Vec<L>,
    file: &str,
    check: impl Fn(&[L]) -> Result<()>,
) -> Result<ByPose<L>> {
    let cells: Vec<f64> = readings
        .iter()
        .flat_map(|r| r.target().iter().copied().collect::<Vec<_>>())
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
        .flat_map(|r| r.readings().iter().copied().collect::<Vec<_>>())
        .collect();
    let white = sensors.fresh_sigma();
    let units: Vec<Unit> = L::FACTS
        .iter()
        .map(|r| Unit {
            name: r.symbol,
            scale: r.quantity.sensor_per_model(),
            symbol: r.quantity.sensor_symbol(),
        })
        .collect();
    let what = fresh_in_words(sensors);
    let judged = repeats.judged((&values, R), white.as_slice(), &what, &units);
    let (counted, note) = match judged {
        Ok(j) => j,
        Err(why) => {
            // A row's own slip is named before the log's offset.
            check(&readings)?;
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
    check(&readings)?;
    let means = repeats.means(&values, R);
    let distinct = repeats
        .first
        .iter()
        .zip(means.chunks_exact(R))
        .map(|(&i, m)| L::new(readings[i].target(), &SVector::from_column_slice(m)))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::{Quantity, ReadingFact};
    use crate::sensors::GradeReading;
    use nalgebra::Vector3;

    static SLOTS: [ReadingFact; 2] = [
        ReadingFact::named("an encoder", Quantity::Angle),
        ReadingFact::named("a scale", Quantity::Length),
    ];

    /// A row of a mechanism that is not the Tricept: an angle and a length.
    #[derive(Debug, Clone, PartialEq)]
    struct Row(Vector3<f64>, SVector<f64, 2>);

    impl LogRow<2> for Row {
        const FACTS: &'static [ReadingFact; 2] = &SLOTS;
        fn target(&self) -> Vector3<f64> {
            self.0
        }
        fn readings(&self) -> SVector<f64, 2> {
            self.1
        }
        fn new(target: Vector3<f64>, x: &SVector<f64, 2>) -> Self {
            Row(target, *x)
        }
    }

    /// Three poses logged twice. Copies count once each, in the first
    /// logging's order and rows; a second logging a steady offset away
    /// counts each pose once at its mean, its fresh noise that of twice
    /// the samples; a log where a repeat scatters far beyond the sensors'
    /// fresh noise is refused, after the mechanism's own check of its rows.
    #[test]
    fn a_logs_repeats_count_for_any_mechanism() {
        let sensors = SensorModel::<2> {
            slots: &SLOTS,
            encoder_arcsec: 1.0,
            scale_um: 1.0,
            samples: 4,
            reading: GradeReading::Sigma,
            structured: None,
        };
        let poses = [
            Vector3::new(0.0, 0.0, 700.0),
            Vector3::new(50.0, 0.0, 700.0),
            Vector3::new(0.0, 50.0, 650.0),
        ];
        let x = |k: usize| SVector::<f64, 2>::new(0.01 * k as f64, 600.0 + k as f64);
        let log = |offset: SVector<f64, 2>| -> Vec<Row> {
            (0..6)
                .map(|i| {
                    Row(
                        poses[i % 3],
                        x(i % 3) + if i >= 3 { offset } else { SVector::zeros() },
                    )
                })
                .collect()
        };
        let fine = |_: &[Row]| Ok(());
        let copies = by_pose(&sensors, log(SVector::zeros()), "log.csv", fine).unwrap();
        assert_eq!(copies.readings, log(SVector::zeros())[..3].to_vec());
        assert_eq!(copies.rows, vec![0, 1, 2]);
        assert!(copies.groups.is_empty());
        assert!(copies.averaged(&sensors).is_none());
        // 0.01 rad and 0.1 mm: far beyond a 1″, 1 µm sensor's fresh noise
        // (σ/√4 a reading), about which the second logging scatters as
        // fresh readings do.
        let step = SVector::<f64, 2>::new(0.01, 0.1);
        let fresh = sensors.fresh_sigma();
        let mut homed_again = log(step);
        for (i, w) in [1.3, -0.8, -0.5].iter().enumerate() {
            homed_again[3 + i].1 += fresh * *w;
        }
        let offset = by_pose(&sensors, homed_again.clone(), "log.csv", fine).unwrap();
        assert_eq!(offset.loggings, 2, "{:?}", offset.note);
        for (k, r) in offset.readings.iter().enumerate() {
            assert_eq!(r.0, poses[k]);
            let mean = (homed_again[k].1 + homed_again[3 + k].1) / 2.0;
            assert!((r.1 - mean).amax() < 1e-12, "{k}");
        }
        // Copies a steady offset apart average nothing: once each.
        let copied = by_pose(&sensors, log(step), "log.csv", fine).unwrap();
        assert_eq!(copied.loggings, 1);
        assert_eq!(copied.readings.len(), 3);
        assert_eq!(offset.averaged(&sensors).unwrap().samples, 8);
        // The note says what states the fresh σ the repeats were judged by.
        let note = offset.note.unwrap();
        assert!(note.contains("steady"), "{note}");
        assert_eq!(
            fresh_in_words(&sensors),
            "the [sensors] grades, for a reading averaged over 4 samples"
        );
        let one = SensorModel {
            samples: 1,
            ..sensors
        };
        assert_eq!(
            fresh_in_words(&one),
            "the [sensors] grades, one sample a reading"
        );
        // One pose logged three times, the others twice: no steady offset
        // explains it, and the rows' own check speaks first.
        let mut uneven = log(step);
        uneven.push(Row(poses[0], x(0) + step * 2.0));
        let refused = |_: &[Row]| Err(Error::csv("log.csv", "line 2: checked first"));
        let err = by_pose(&sensors, uneven.clone(), "log.csv", refused)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("checked first"), "{err}");
        let err = by_pose(&sensors, uneven, "log.csv", fine)
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("log.csv"), "{err}");
    }
}
