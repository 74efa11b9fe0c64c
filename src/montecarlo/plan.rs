//! The trial kernel's plan (docs/method.md §10 `sweep`): which path a study's trials
//! take and which tables of sharing that path reads, decided once per
//! study from its grades, sensor sets and iterations.
//!
//! | path | when | tables |
//! |---|---|---|
//! | [`KernelPath::WhiteNoise`] | white-noise sensors, one linearisation | `split_of`, noise groups |
//! | [`KernelPath::DatasheetParts`] | unquantised datasheet sensors that draw alike, one linearisation | `split_of` |
//! | [`KernelPath::PerSensor`] | any other sensors, one linearisation | `split_of`, [`AxisSharing`], `sensor_split_of` |
//! | [`KernelPath::GaussNewton`] | more than one linearisation, or the Hooke axes identified too | [`AxisSharing`] |
//!
//! Every table maps an index to the first earlier one whose work gives the
//! same values: the later one copies instead of computing again. The plan
//! changes what is computed, never a value: each path is tested against
//! the general one.

use crate::sensors::{draws_alike, SensorModel};
use nalgebra::SVector;

/// How a study's trials compute their grades' estimates.
#[derive(Debug, Clone, PartialEq)]
pub enum KernelPath<const R: usize> {
    /// Every grade's estimate is linear in one shared unit noise: each
    /// operator is applied once to the exact observation and once to each
    /// sensor's noise, a grade's estimate is their combination with its own
    /// σ, and the workspace propagates each group's directions once.
    WhiteNoise { groups: Vec<NoiseGroup<R>> },
    /// Every grade's estimate is linear in the parts of one machine's
    /// datasheet-sensor errors: each operator is applied once per part
    /// ([`crate::sensors::MachineDraws::linear_parts`]), a grade's estimate
    /// is their combination with its own amplitudes.
    DatasheetParts,
    /// Each sensor set's errors are formed; op·l0 once per operator and
    /// op·e per sensor, shared where the rows are alike.
    PerSensor {
        axes: AxisSharing<R>,
        /// For each grade and sensor, the first grade of the same operator
        /// whose sensor set has the same rows of that sensor (by
        /// [`AxisSharing::axis_of`]): op·e of that sensor is computed there
        /// and shared.
        sensor_split_of: Vec<[usize; R]>,
    },
    /// Each grade's observation is formed and identified in full
    /// (Gauss–Newton, or second-class unknowns beside the errors: the
    /// Tricept's Hooke axes' three angles).
    GaussNewton { axes: AxisSharing<R> },
}

/// How sensor sets share a trial's draws and rows (the paths that form each
/// set's errors).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSharing<const R: usize> {
    /// For each sensor set and slot (the Tricept's ψ4, θ4, q4), the first set whose rows
    /// of that axis are the same in every trial: datasheet sensors that
    /// draw alike with that axis equal (the scale of an encoder grade
    /// sweep). The set itself otherwise.
    pub axis_of: Vec<[usize; R]>,
    /// For each sensor set, the first set that takes the same draws of a
    /// machine (datasheet sensors of the same samples that draw alike, see
    /// [`draws_alike`]): the draws are kept from one to the next.
    pub draw_class: Vec<usize>,
    /// For each sensor set and axis, is a shared axis copied into the set's
    /// own rows (some estimate reads them)? Every axis under Gauss–Newton.
    pub rows_read: Vec<[bool; R]>,
}

/// The plan of a study: its path and the grades that share an operator.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialPlan<const R: usize> {
    pub path: KernelPath<R>,
    /// For each grade, the first grade with the same operator (OLS grades
    /// share one; the other truth amplitudes share the datasheet's): the
    /// operator's work of a trial is done once, at that grade.
    pub split_of: Vec<usize>,
}

impl<const R: usize> TrialPlan<R> {
    /// The plan of grades read by `sensors` (grade g by set `sensor_of[g]`),
    /// with `split_of` the grades' shared operators; `in_full` when each
    /// grade's observation must be formed and identified in full
    /// (Gauss–Newton, or second-class unknowns identified beside the
    /// errors).
    pub fn new(
        sensor_of: &[usize],
        sensors: &[SensorModel<R>],
        split_of: Vec<usize>,
        in_full: bool,
    ) -> TrialPlan<R> {
        let one = !in_full;
        let white = sensors.iter().all(|s| s.structured.is_none());
        let path = if one && white {
            KernelPath::WhiteNoise {
                groups: NoiseGroup::of(&split_of, |g| sensors[sensor_of[g]].unit_scale()),
            }
        } else if one && parts_alike(sensors) {
            KernelPath::DatasheetParts
        } else {
            let axis_of = same_axes(sensors);
            let draw_class = draw_classes(sensors);
            if one {
                let sensor_split_of = sensor_splits(sensor_of, &split_of, &axis_of);
                let mut rows_read = vec![[false; R]; sensors.len()];
                for (gi, split) in sensor_split_of.iter().enumerate() {
                    for k in (0..R).filter(|&k| split[k] == gi) {
                        rows_read[sensor_of[gi]][k] = true;
                    }
                }
                KernelPath::PerSensor {
                    axes: AxisSharing {
                        axis_of,
                        draw_class,
                        rows_read,
                    },
                    sensor_split_of,
                }
            } else {
                KernelPath::GaussNewton {
                    axes: AxisSharing {
                        axis_of,
                        draw_class,
                        rows_read: vec![[true; R]; sensors.len()],
                    },
                }
            }
        };
        TrialPlan { path, split_of }
    }

    /// The noise groups of the white-noise path (none on the others).
    pub fn noise_groups(&self) -> &[NoiseGroup<R>] {
        match &self.path {
            KernelPath::WhiteNoise { groups } => groups,
            _ => &[],
        }
    }

    /// The path's name, as the tests say it.
    #[cfg(test)]
    pub fn name(&self) -> &'static str {
        match self.path {
            KernelPath::WhiteNoise { .. } => "white noise",
            KernelPath::DatasheetParts => "datasheet parts",
            KernelPath::PerSensor { .. } => "per sensor",
            KernelPath::GaussNewton { .. } => "Gauss–Newton",
        }
    }
}

/// Are these unquantised datasheet sensor sets of the same samples that
/// draw alike (one machine's draws, split in parts, serve them all)?
fn parts_alike<const R: usize>(sensors: &[SensorModel<R>]) -> bool {
    sensors.iter().all(|s| {
        s.samples == sensors[0].samples
            && match (&s.structured, &sensors[0].structured) {
                (Some(a), Some(b)) => {
                    a.axes.iter().all(|x| x.resolution <= 0.0) && draws_alike(a, b)
                }
                _ => false,
            }
    })
}

/// [`KernelPath::PerSensor`]'s `sensor_split_of`.
fn sensor_splits<const R: usize>(
    sensor_of: &[usize],
    split_of: &[usize],
    axis_of: &[[usize; R]],
) -> Vec<[usize; R]> {
    (0..sensor_of.len())
        .map(|gi| {
            let set = |g: usize| axis_of[sensor_of[g]];
            std::array::from_fn(|k| {
                (0..gi)
                    .find(|&gj| split_of[gj] == split_of[gi] && set(gj)[k] == set(gi)[k])
                    .unwrap_or(gi)
            })
        })
        .collect()
}

/// The grades that share one operator on the white-noise fast path. Grade
/// g's estimate is exact + Σk σ_gk·n_k (n_k: the operator applied to sensor
/// k's unit noise), so its residual differs from the first grade's by
/// −Σk (σ_gk − σ_0k)·n_k. Sensors whose σ differ alike across the group
/// (the two encoders of a grade axis) share one direction w = Σ n_k, and
/// sensors whose σ never differ need none: a grade axis has one direction,
/// a grid of encoder × scale grades two. The workspace then propagates the
/// first residual and each direction through S once per point, and every
/// other grade is a combination of those (see `first_order_after`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NoiseGroup<const R: usize> {
    /// The group's first grade (whose residual is the base).
    pub first: usize,
    /// Which sensors make up each direction (1.0 or 0.0 per sensor).
    pub directions: Vec<[f64; R]>,
    /// The other grades, each with its coefficient on each direction.
    pub members: Vec<(usize, Vec<f64>)>,
}

impl<const R: usize> NoiseGroup<R> {
    /// The groups of `grades` whose unit scales are `scale(g)`, grouped by
    /// `split_of`.
    pub fn of(split_of: &[usize], scale: impl Fn(usize) -> SVector<f64, R>) -> Vec<NoiseGroup<R>> {
        let mut groups = Vec::new();
        for (first, _) in split_of.iter().enumerate().filter(|&(g, &f)| g == f) {
            let others: Vec<usize> = (first + 1..split_of.len())
                .filter(|&g| split_of[g] == first)
                .collect();
            let base = scale(first);
            let delta: Vec<SVector<f64, R>> = others.iter().map(|&g| scale(g) - base).collect();
            let column = |k: usize| delta.iter().map(|d| d[k]).collect::<Vec<f64>>();
            // Sensor k's column of differences: none, like an earlier one, or new.
            let mut directions: Vec<[f64; R]> = Vec::new();
            let mut representative: Vec<usize> = Vec::new();
            for k in 0..R {
                let col = column(k);
                if col.iter().all(|&x| x == 0.0) {
                    continue;
                }
                match representative.iter().position(|&r| column(r) == col) {
                    Some(i) => directions[i][k] = 1.0,
                    None => {
                        let mut d = [0.0; R];
                        d[k] = 1.0;
                        directions.push(d);
                        representative.push(k);
                    }
                }
            }
            let members = others
                .iter()
                .zip(&delta)
                .map(|(&g, d)| (g, representative.iter().map(|&k| d[k]).collect()))
                .collect();
            groups.push(NoiseGroup {
                first,
                directions,
                members,
            });
        }
        groups
    }
}

/// [`AxisSharing::axis_of`] of these sensor sets: the rows of axis k of two
/// datasheet sets are the same in every trial when they take the same draws
/// (same samples, [`draws_alike`]) and that axis's model is equal.
pub(super) fn same_axes<const R: usize>(sensors: &[SensorModel<R>]) -> Vec<[usize; R]> {
    let same = |a: &SensorModel<R>, b: &SensorModel<R>, k: usize| {
        draw_alike(a, b) && a.structured.map(|x| x.axes[k]) == b.structured.map(|y| y.axes[k])
    };
    (0..sensors.len())
        .map(|i| {
            std::array::from_fn(|k| {
                (0..i)
                    .find(|&j| same(&sensors[j], &sensors[i], k))
                    .unwrap_or(i)
            })
        })
        .collect()
}

/// [`AxisSharing::draw_class`] of these sensor sets.
pub(super) fn draw_classes<const R: usize>(sensors: &[SensorModel<R>]) -> Vec<usize> {
    (0..sensors.len())
        .map(|i| {
            (0..i)
                .find(|&j| draw_alike(&sensors[j], &sensors[i]))
                .unwrap_or(i)
        })
        .collect()
}

/// Do two sensor sets take the same draws of a machine (datasheet sensors
/// of the same samples that [`draws_alike`])?
fn draw_alike<const R: usize>(a: &SensorModel<R>, b: &SensorModel<R>) -> bool {
    match (&a.structured, &b.structured) {
        (Some(x), Some(y)) => a.samples == b.samples && draws_alike(x, y),
        _ => false,
    }
}
