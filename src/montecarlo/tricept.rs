//! The Tricept's study: its calibration poses with their first-order
//! start for forward kinematics, a trial's machine with its second-class
//! errors, Gauss–Newton at its pose subsets and the exact judgement of its
//! workspace ([`TriceptStudy`], the kernel's [`Studied`]), and the study
//! built from its config ([`TriceptContext::new`]). The kernel itself
//! (`context.rs`, `trial.rs`, `workspace.rs`, …) is written for any
//! mechanism.

use super::context::{GradeAxes, GradeTable, MapGrid, Parts, PoseSubset, SweepContext};
use super::streams::stream;
use super::studied::{Judging, Studied};
use crate::compensate::volumetric_error;
use crate::config::{Config, ConfigStudy, ErrorDraw, SweepConfig};
use crate::error::{Error, PoseError, Result};
use crate::identify::tricept::{angle_design, identify};
use crate::identify::tricept::{design_matrix, LinearSolver};
use crate::identify::IdentifyOptions;
use crate::mechanism::tricept::geometry::SecondClass;
use crate::mechanism::tricept::jacobian::position_sensitivity;
use crate::mechanism::tricept::poses::FirstOrder;
use crate::mechanism::tricept::second_class::{with_angles, Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{
    ErrorVector, Geometry, Joints, Machine, NominalPoses, Tricept, N_LEGS, N_PARAMS, N_READINGS,
    PARAM_NAMES,
};
use crate::mechanism::workspace::{iso9283_positions, workspace_grid};
use crate::sensors::SensorModel;
use nalgebra::{DVector, Vector3};

/// The Tricept's study context.
pub type TriceptContext = SweepContext<TriceptStudy, N_PARAMS, N_READINGS, N_ANGLES>;

/// The Tricept as the study kernel sees it.
pub struct TriceptStudy {
    pub(super) geometry: Geometry,
    pub(super) poses: NominalPoses,
    /// Each pose's nominal joints as the readings' vector.
    pub(super) nominal: Vec<Vector3<f64>>,
    /// Each pose subset's nominal poses (what Gauss–Newton re-linearises at).
    pub(super) subset_poses: Vec<NominalPoses>,
    /// Forward kinematics of a trial's machine starts from the first-order
    /// prediction nominal + J·ε at each calibration pose.
    pub(super) first_order: FirstOrder,
    /// Second-class errors every simulated machine carries.
    pub(super) second_class: Option<SecondClass>,
    /// Or: each machine draws its four second-class angles uniformly within
    /// ± this, degrees (stream 2; a tolerance what-if study).
    pub(super) second_class_draw_deg: Option<f64>,
    pub(super) seed: u64,
    /// The judging grids' nominal solutions: the workspace grid's and the
    /// ISO 9283 positions'.
    pub(super) grid: ExactGrid,
    pub(super) iso: ExactGrid,
}

/// A judging grid's points with the nominal machine's joints and commands
/// there.
#[derive(Debug, Clone, Default)]
pub(super) struct ExactGrid {
    pub(super) points: Vec<Vector3<f64>>,
    pub(super) nominal: Vec<Joints>,
    pub(super) commands: Vec<[f64; N_LEGS]>,
}

/// A worker's buffers: the first-order prediction of the joints (3 per
/// pose).
pub struct Buffers {
    guess: Vec<f64>,
}

impl Studied<N_PARAMS, N_READINGS, N_ANGLES> for TriceptStudy {
    type Machine = Machine;
    type Buffers = Buffers;

    fn names(&self) -> &[&str] {
        &PARAM_NAMES
    }

    fn unknown_names(&self) -> &'static [&'static str] {
        &ANGLE_NAMES
    }

    fn nominal(&self) -> &[Vector3<f64>] {
        &self.nominal
    }

    fn buffers(&self) -> Buffers {
        Buffers {
            guess: vec![0.0; 3 * self.poses.len()],
        }
    }

    /// The machine of errors `e` with the study's second-class errors, or
    /// trial k's draw of them.
    fn machine(&self, e: &ErrorVector, k: u64) -> Machine {
        Machine {
            second: match self.second_class_draw_deg {
                Some(t) => Some(second_class_draw(self.seed, k, t)),
                None => self.second_class,
            },
            ..Machine::with_errors(&self.geometry, e)
        }
    }

    fn actual(
        &self,
        machine: &Machine,
        e: &ErrorVector,
        buf: &mut Buffers,
        out: &mut [Vector3<f64>],
    ) -> std::result::Result<(), PoseError> {
        self.first_order.predict(e, &mut buf.guess);
        self.poses.actual_joints_near(machine, &buf.guess, out)
    }

    fn iterate(
        &self,
        subset: usize,
        solver: &LinearSolver,
        l: &DVector<f64>,
        options: &IdentifyOptions<N_PARAMS>,
    ) -> Option<(ErrorVector, bool)> {
        identify(
            &self.geometry,
            &self.subset_poses[subset],
            solver,
            l,
            options,
        )
        .ok()
        .map(|(e, _)| (e.values, e.termination.converged()))
    }

    fn identified(&self, est: &ErrorVector, angles: &Angles) -> Machine {
        with_angles(&Machine::with_errors(&self.geometry, est), angles)
    }

    fn exact_dv(
        &self,
        truth: &Machine,
        by: Option<&Machine>,
        at: Judging,
        i: usize,
    ) -> Option<f64> {
        let g = match at {
            Judging::Grid => &self.grid,
            Judging::Iso => &self.iso,
        };
        let (r, j) = (&g.points[i], &g.nominal[i]);
        let q = match by {
            None => g.commands[i],
            Some(m) => m.commands(r).ok()?,
        };
        volumetric_error::<Tricept, N_PARAMS, N_READINGS>(truth, &q, r, &j.as_vector()).ok()
    }

    /// The errors each machine draws, the Hooke axes when identified, and
    /// the UP limb's second-class errors.
    fn assumptions(&self, study: &ConfigStudy) -> Vec<String> {
        let mut out = Vec::new();
        let sw = &study.sweep;
        match sw.errors {
            crate::config::ErrorDraw::Random => out.push(format!(
                "each of the 15 geometric errors is within ±{} mm.",
                sw.error_bound_mm
            )),
            crate::config::ErrorDraw::Fixed => {
                out.push("the machine's geometric errors are the config's [errors].".into())
            }
        }
        if study.identification.second_class {
            out.push("the first Hooke axis's yaw and pitch and the axes' skew are identified from the readings with the 15 errors ([identification] second_class = true); the guide's twist, which no reading tells from the 15 errors, is not.".into());
        }
        out.push(match (self.second_class, sw.second_class_tolerance_deg.is_empty()) {
            (Some(_), _) => "the UP limb's second-class errors are the config's [second_class] values.".into(),
            (None, false) => "the UP limb's Hooke-joint axes and guide are within the second-class tolerance the verdict names (the choice itself is judged without second-class errors, then again with them drawn within each tolerance studied).".into(),
            (None, true) => "the UP limb's Hooke-joint axes and guide are exact: no second-class error was simulated (sweep.second_class_tolerance_deg shows what a tolerance costs).".into(),
        });
        out
    }
}

/// Trial k's second-class errors in a tolerance study: the four angles
/// (Hooke axis 1 yaw and pitch, the axes' skew, the guide's twist) each
/// uniform in ±`tol_deg`, from the trial's stream 2.
pub fn second_class_draw(seed: u64, k: u64, tol_deg: f64) -> SecondClass {
    use rand::RngExt;
    let mut rng = stream(seed, k, 2);
    let mut a = [0.0; 4];
    for x in a.iter_mut() {
        *x = rng.random_range(-tol_deg..=tol_deg);
    }
    SecondClass::from_angles_deg(a[0], a[1], a[2], a[3])
}

impl TriceptContext {
    /// The study of `cfg`'s machine: the poses, the sensor sets, the grade
    /// table, the judging grids, each built by a function of its own
    /// below, and the kernel's tables ([`SweepContext::assemble`]).
    pub fn new(cfg: &Config, study: &ConfigStudy) -> Result<Self> {
        let fail = |why: String| Error::config(&cfg.source, why);
        let nominal = cfg.nominal();
        let poses =
            NominalPoses::new(&nominal, &study.poses).map_err(|e| fail(format!("poses: {e}")))?;
        let h = design_matrix(&nominal, &poses).map_err(|e| fail(format!("poses: {e}")))?;
        let sw = &study.sweep;
        if sw.gls_per_machine == Some(true)
            && (study.identification.second_class || study.identification.iterations > 1)
        {
            return Err(fail("sweep.gls_per_machine does not combine with [identification] second_class = true or iterations > 1 yet: the operator per machine is one linearisation of the 15 errors; remove one of the two".into()));
        }
        let (assumed, sensors) = reading_sets(cfg, study);
        let subsets: Vec<PoseSubset> = sw
            .pose_counts
            .iter()
            .map(|&n| PoseSubset::new(poses.len(), n, N_READINGS))
            .collect();
        let nominal_readings: Vec<Vector3<f64>> =
            poses.joints.iter().map(|j| j.as_vector()).collect();
        let table = GradeTable::new(
            &GradeAxes {
                methods: &sw.methods,
                truths: &sw.truth,
                assumed: &assumed,
                h: &h,
                nominal: &nominal_readings,
                subsets: &subsets,
                options: &study.identification,
                names: &PARAM_NAMES,
            },
            |si| sensor_set_name(sw, si),
        )
        .map_err(fail)?;
        check_fixed_machine(cfg, study, &poses)?;
        let (grid, iso) = judging_grids(cfg, study)?;
        let first_order =
            FirstOrder::new(&nominal, &poses).map_err(|e| fail(format!("poses: {e}")))?;
        let h_second = match study.identification.second_class {
            true => Some(
                angle_design(&nominal, &Angles::zeros(), &poses.joints)
                    .map_err(|e| fail(format!("identification.second_class: poses: {e}")))?,
            ),
            false => None,
        };
        let mech = TriceptStudy {
            geometry: cfg.geometry,
            nominal: nominal_readings,
            subset_poses: subsets.iter().map(|s| poses.pick(&s.poses)).collect(),
            poses,
            first_order,
            second_class: cfg.second_class,
            second_class_draw_deg: sw.second_class_draw_deg,
            seed: sw.seed,
            grid: grid.1,
            iso: iso.1,
        };
        SweepContext::assemble(Parts {
            mech,
            h,
            h_second,
            subsets,
            table,
            assumed,
            sensors,
            products: sw.products.clone(),
            options: study.identification,
            gls_per_machine: sw.gls_per_machine,
            draw: sw.errors,
            fixed_errors: cfg.errors,
            bound_mm: sw.error_bound_mm,
            seed: sw.seed,
            perfect: sw.perfect_sensors,
            grids: (grid.0, iso.0),
            orientation: MapGrid::default(),
            exact: sw.volumetric_exact,
        })
        .map_err(fail)
    }
}

/// The sensor sets of a study: the datasheet's, which the estimators
/// assume, and the ones that read — each datasheet set with its curves as
/// each truth of `[sweep]` has them (the first is the datasheet itself).
fn reading_sets(
    cfg: &Config,
    study: &ConfigStudy,
) -> (Vec<SensorModel<N_READINGS>>, Vec<SensorModel<N_READINGS>>) {
    let assumed = study.sensor_sets(&cfg.sensors);
    let sensors: Vec<SensorModel<N_READINGS>> = study
        .sweep
        .truth
        .iter()
        .flat_map(|t| {
            assumed
                .iter()
                .map(move |s| match (t.is_datasheet(), &s.structured) {
                    (false, Some(st)) => SensorModel {
                        structured: Some(t.apply(st)),
                        ..*s
                    },
                    _ => *s,
                })
        })
        .collect();
    (assumed, sensors)
}

/// A study of the config's fixed machine: it must reach every calibration
/// pose.
fn check_fixed_machine(cfg: &Config, study: &ConfigStudy, poses: &NominalPoses) -> Result<()> {
    if study.sweep.errors != ErrorDraw::Fixed {
        return Ok(());
    }
    let mut x = vec![Vector3::zeros(); poses.len()];
    let truth = cfg.truth("sweep.errors = \"fixed\"")?;
    poses.actual_joints_into(&truth, &mut x).map_err(|e| {
        Error::config(
            &cfg.source,
            format!(
                "errors: the machine with these [errors] cannot reach calibration pose {}: {}",
                e.index, e.source
            ),
        )
    })
}

/// Where calibrations are judged: the workspace grid and the ISO 9283
/// positions (empty without `volumetric`).
fn judging_grids(cfg: &Config, study: &ConfigStudy) -> Result<(Grids, Grids)> {
    Ok(match study.sweep.volumetric_step_mm {
        Some(step) => {
            let ws = &cfg.workspace;
            let points = workspace_grid(ws, step, cfg.layers);
            let iso = iso9283_positions(ws).to_vec();
            (
                map_grid(cfg, points, "workspace (its volumetric grid)")?,
                map_grid(cfg, iso, "workspace (ISO 9283 positions)")?,
            )
        }
        None => Default::default(),
    })
}

/// The sensor set `i` as a config names it: its catalogue pair, or its grades.
fn sensor_set_name(sw: &SweepConfig<N_READINGS>, i: usize) -> String {
    match &sw.products {
        Some(p) => {
            let (e, s) = p.pair(i);
            format!("encoder \"{}\" with scale \"{}\"", e.name, s.name)
        }
        None => {
            let (ne, _) = (sw.encoder_arcsec.len(), sw.scale_um.len());
            format!(
                "encoder grade {} arcsec with scale grade {} µm",
                sw.encoder_arcsec[i % ne],
                sw.scale_um[i / ne]
            )
        }
    }
}

/// A judging grid: its sensitivities (the kernel's) and its nominal
/// solutions (the exact judgement's).
type Grids = (MapGrid<N_PARAMS>, ExactGrid);

/// Nominal solutions and sensitivities at `points`; errors name `key`.
fn map_grid(cfg: &Config, points: Vec<Vector3<f64>>, key: &str) -> Result<Grids> {
    let nominal = cfg.nominal();
    let mut grid = ExactGrid {
        points,
        ..ExactGrid::default()
    };
    let mut sensitivity = Vec::with_capacity(grid.points.len());
    for r in &grid.points {
        let fail = |e: crate::error::KinematicsError| {
            Error::config(&cfg.source, format!("{key}: map point {r:?}: {e}"))
        };
        // The first-order path would give a number where exact kinematics
        // cannot: every point is checked as the calibration poses are.
        crate::mechanism::tricept::check_pose(&nominal, r, cfg.max_tilt_deg).map_err(|why| {
            Error::config(
                &cfg.source,
                format!(
                    "{key}: the point ({:.1}, {:.1}, {:.1}) mm is not reachable by the nominal machine: {why}; shrink [workspace] (radius, height, top) or relax geometry.max_tilt_deg",
                    r.x, r.y, r.z
                ),
            )
        })?;
        let pose = nominal.inverse(r).map_err(fail)?;
        sensitivity.push(position_sensitivity(&pose).map_err(fail)?);
        grid.nominal.push(pose.joints);
        grid.commands.push(pose.legs_mm);
    }
    Ok((MapGrid::new(grid.points.clone(), sensitivity), grid))
}
