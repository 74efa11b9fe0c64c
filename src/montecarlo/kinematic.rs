//! Any `Kinematic` topology of P errors and R readings a pose as the
//! study kernel sees it ([`KinematicStudy`]): its calibration poses, a
//! trial's machine from its errors alone (no second-class unknowns),
//! forward kinematics from the nominal readings, Gauss–Newton over its
//! pose set, and the workspace judged by exact kinematics at the points
//! it is given, their first-order sensitivities by central differences.
//! A new mechanism of fixed sizes needs no `Studied` of its own: its
//! folder under `src/mechanism/` and the parts of its study (its design,
//! sensor sets, pose subsets, `context::Parts`) run it through the kernel;
//! the Tricept's own `Studied` (`tricept.rs`) adds its second-class errors
//! and a faster forward kinematics, and agrees with this one.

use super::context::{MapGrid, PoseSubset};
use super::studied::{Judging, Studied};
use crate::compensate::volumetric_error;
use crate::config::{ErrorDraw, Study};
use crate::error::PoseError;
use crate::identify::{identify_poses, IdentifyOptions, Solver};
use crate::mechanism::{Homed, Kinematic, Mechanism as _, PoseSet};
use nalgebra::{DVector, SMatrix, SVector, Vector3};

/// The workspace grid and the ISO 9283 positions with their first-order
/// sensitivities, as the kernel judges them.
pub type Grids<const P: usize> = (MapGrid<P>, MapGrid<P>);

/// A `Kinematic` topology's study: its layout, its calibration poses and
/// each pose subset's (in `[sweep] pose_counts` order), and the judging
/// points with the nominal machine's commands and readings there.
pub struct KinematicStudy<'a, T: Kinematic<P, R>, const P: usize, const R: usize> {
    layout: &'a T::Layout,
    poses: PoseSet<T, P, R>,
    subset_poses: Vec<PoseSet<T, P, R>>,
    grid: PoseSet<T, P, R>,
    iso: PoseSet<T, P, R>,
}

impl<'a, T: Kinematic<P, R>, const P: usize, const R: usize> KinematicStudy<'a, T, P, R> {
    /// The study of `layout` at calibration `targets` (the reference
    /// first), of the pose subsets `subsets` (the study's own, which
    /// Gauss–Newton iterates over), judged at `grid` and `iso` (empty: not
    /// judged); with the judging grids' first-order sensitivities. Err:
    /// the first target the nominal machine cannot reach, and where.
    pub fn new(
        layout: &'a T::Layout,
        targets: &[Vector3<f64>],
        subsets: &[PoseSubset],
        (grid, iso): (&[Vector3<f64>], &[Vector3<f64>]),
    ) -> Result<(Self, Grids<P>), (&'static str, String)>
    where
        T::Layout: Sync,
        T::Machine: Sync,
    {
        let nominal = T::machine(layout, &SVector::zeros());
        let at = |what: &'static str, points: &[Vector3<f64>]| {
            PoseSet::<T, P, R>::new(&nominal, points).map_err(|e| (what, e.to_string()))
        };
        let poses = at("poses", targets)?;
        let subset_poses = subsets
            .iter()
            .map(|s| {
                let picked: Vec<Vector3<f64>> = s.poses.iter().map(|&p| targets[p]).collect();
                at("poses", &picked)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let study = KinematicStudy {
            layout,
            poses,
            subset_poses,
            grid: at("workspace grid", grid)?,
            iso: at("ISO 9283 positions", iso)?,
        };
        let maps = (
            study
                .map_grid(&study.grid)
                .map_err(|e| ("workspace grid", e))?,
            study
                .map_grid(&study.iso)
                .map_err(|e| ("ISO 9283 positions", e))?,
        );
        Ok((study, maps))
    }

    /// The first-order position sensitivity ∂r/∂ε at each point of `set`,
    /// the machine commanded nominally: `Homed`'s, central differences of
    /// exact forward kinematics (its first P columns: a reading's zero
    /// moves no tool point).
    fn map_grid(&self, set: &PoseSet<T, P, R>) -> Result<MapGrid<P>, String>
    where
        T::Layout: Sync,
        T::Machine: Sync,
    {
        let homed = Homed::<T, P, R>::new(self.layout);
        let sensitivity = (set.targets.iter().enumerate())
            .map(|(k, r)| {
                let s = homed
                    .sensitivity(r, &Vector3::zeros())
                    .map_err(|e| format!("pose {}: {e}", k + 1))?;
                Ok(SMatrix::from_fn(|a, c| s[(a, c)]))
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(MapGrid::new(set.targets.clone(), sensitivity))
    }
}

impl<T, const P: usize, const R: usize> Studied<P, R, 0> for KinematicStudy<'_, T, P, R>
where
    T: Kinematic<P, R>,
    T::Layout: Sync,
    T::Machine: Sync,
{
    type Machine = T::Machine;
    type Buffers = ();

    fn names(&self) -> &[&str] {
        T::ERROR_NAMES
    }

    fn unknown_names(&self) -> &'static [&'static str] {
        &[]
    }

    fn nominal(&self) -> &[SVector<f64, R>] {
        &self.poses.nominal
    }

    fn buffers(&self) {}

    fn machine(&self, e: &SVector<f64, P>, _k: u64) -> T::Machine {
        T::machine(self.layout, e)
    }

    fn actual(
        &self,
        machine: &T::Machine,
        _e: &SVector<f64, P>,
        _buf: &mut (),
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError> {
        self.poses.actual_into(machine, out)
    }

    fn iterate(
        &self,
        subset: usize,
        solver: &Solver<P, R>,
        l: &DVector<f64>,
        options: &IdentifyOptions<P>,
    ) -> Option<(SVector<f64, P>, bool)> {
        identify_poses(self.layout, &self.subset_poses[subset], solver, l, options)
            .ok()
            .map(|(e, _)| (e.values, e.termination.converged()))
    }

    fn identified(&self, est: &SVector<f64, P>, _: &SVector<f64, 0>) -> T::Machine {
        T::machine(self.layout, est)
    }

    fn exact_dv(
        &self,
        truth: &T::Machine,
        by: Option<&T::Machine>,
        at: Judging,
        i: usize,
    ) -> Option<f64> {
        let set = match at {
            Judging::Grid => &self.grid,
            Judging::Iso => &self.iso,
        };
        let r = &set.targets[i];
        let q = match by {
            None => set.commands[i].clone(),
            Some(m) => T::command(m, r).ok()?.0,
        };
        volumetric_error::<T, P, R>(truth, &q, r, &set.nominal[i]).ok()
    }

    /// The errors each machine draws; it carries nothing else.
    fn assumptions(&self, study: &Study<P, R>) -> Vec<String> {
        let sw = &study.sweep;
        vec![match sw.errors {
            ErrorDraw::Random => format!(
                "each of the {P} geometric errors is within ±{} mm.",
                sw.error_bound_mm
            ),
            ErrorDraw::Fixed => "the machine's geometric errors are the config's [errors].".into(),
        }]
    }
}

#[cfg(test)]
#[path = "kinematic_tests.rs"]
mod tests;
