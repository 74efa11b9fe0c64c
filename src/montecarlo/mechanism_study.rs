//! Any [`Commanded`] mechanism as the study kernel sees it
//! ([`MechanismStudy`]): the mechanism of any size (`mechanism::Mechanism`,
//! the hexapod's kind) put in the kernel's fixed sizes. Its P errors are
//! the coordinates of its geometry along the convention's free directions
//! (what no internal sensor sees is no part of the machine the kernel
//! draws, identifies or judges); its R readings a pose are homed at the
//! first calibration pose, as the kernel reads every mechanism, so its
//! readings' zeros cancel and are not among the P. Homing at the reference
//! loses nothing: least squares with the zeros unknown beside the geometry
//! is GLS on the homed rows under the homed covariance σ²(I + 11ᵀ), the
//! same estimate of the geometry (`mechanism_study_tests.rs` holds the two
//! routes to 1e-9 of each other).
//!
//! A machine is drawn with every error uniform in its bound (stream
//! (seed, k, 0), error by error), then put in the convention's frames by
//! [`convention_frames`], its readings come from
//! exact forward kinematics of that machine at the nominal commands,
//! Gauss–Newton re-linearises the mechanism's own design, and the
//! workspace is judged by the tool point's position: first order through
//! the mechanism's sensitivities, or exact (the identified machine's
//! commands, the true machine's forward kinematics).

use super::context::{MapGrid, PoseSubset};
use super::streams::stream;
use super::studied::{Judging, Studied};
use crate::config::Study;
use crate::error::{KinematicsError, PoseError};
use crate::identify::{gauss_newton, IdentifyOptions, Linearisation, Solver};
use crate::mechanism::general::error_of;
use crate::mechanism::{homed_rows, Commanded, Mechanism, Quantity, ORIENTATION, POSITION};
use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector3};
use rand::RngExt;

/// The convention's free directions of `m` (errors × f, its
/// [`Mechanism::free_directions`]) and the map of a machine's errors to
/// its coordinates along them (f × errors): the part no reading sees at
/// `targets` (the design's null space over the errors the machine has)
/// removed, to first order. Err: a sentence.
pub fn convention_frames<M: Mechanism>(
    m: &M,
    targets: &[M::Target],
) -> Result<(DMatrix<f64>, DMatrix<f64>), String> {
    let errors = m.error_names().len();
    let zero = vec![0.0; errors];
    let free = m.free_directions();
    let present = m.present();
    // The errors no reading sees at any of the targets: the design's
    // null space over the errors this machine has.
    let h = m.design(&zero, targets)?.select_columns(&present);
    let svd = h.clone().svd(false, true);
    let v_t = svd.v_t.as_ref().ok_or("the SVD gave no V")?;
    let f = free.ncols();
    let p = present.len();
    let hidden = p
        .checked_sub(f)
        .ok_or("the convention admits more directions than the machine has errors")?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
    let mut basis = DMatrix::zeros(p, p);
    for (r, &j) in present.iter().enumerate() {
        for c in 0..f {
            basis[(r, c)] = free[(j, c)];
        }
    }
    for (c, &k) in order.iter().take(hidden).enumerate() {
        for r in 0..p {
            basis[(r, f + c)] = v_t[(k, r)];
        }
    }
    let inv = basis
        .try_inverse()
        .ok_or("the convention does not complement what the readings cannot see")?;
    let coords = inv.rows(0, f).into_owned();
    let mut to_convention = DMatrix::zeros(errors, errors);
    let image = &free * coords;
    for (c, &j) in present.iter().enumerate() {
        to_convention.set_column(j, &image.column(c));
    }
    let to_free = free.transpose() * &to_convention;
    Ok((free, to_free))
}

/// Trial k's errors of `m` before the convention, from stream (seed, k,
/// 0): each length uniform in ±`length_mm`, each angle (a reading's zero)
/// in ±`angle_deg`, every error drawn whatever is fitted; then each of
/// `fixed` (error, value) set to its value (drawn all the same, so the
/// others are the draws they would be without it). The study's own draw
/// (`MechanismStudy::draw`) is this one without fixed errors; the dense
/// reference (`general/dense_fixtures.rs`, built with the tests) calls it.
#[cfg(test)]
pub(crate) fn drawn_errors<M: Mechanism>(
    m: &M,
    bounds: (f64, f64),
    fixed: &[(usize, f64)],
    seeds: (u64, u64),
) -> Vec<f64> {
    drawn(&angles(m), bounds, fixed, seeds)
}

/// Which of `m`'s errors are angles, in order.
fn angles<M: Mechanism>(m: &M) -> Vec<bool> {
    (0..m.error_names().len()).map(|j| m.is_angle(j)).collect()
}

/// [`drawn_errors`] of a mechanism whose errors are angles where `angles`
/// says (the study's draw, which names no error).
fn drawn(
    angles: &[bool],
    (length_mm, angle_deg): (f64, f64),
    fixed: &[(usize, f64)],
    (seed, k): (u64, u64),
) -> Vec<f64> {
    let mut rng = stream(seed, k, 0);
    let mut e: Vec<f64> = (angles.iter())
        .map(|&angle| {
            let b = if angle { angle_deg } else { length_mm };
            if b > 0.0 {
                rng.random_range(-b..=b)
            } else {
                0.0
            }
        })
        .collect();
    for &(j, v) in fixed {
        e[j] = v;
    }
    e
}

/// How a [`MechanismStudy`] draws its machines: every error uniform in
/// its bound (mm, degrees), put in the convention's frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub length_mm: f64,
    pub angle_deg: f64,
}

/// What a [`MechanismStudy`] is built on: the mechanism (its
/// instrumentation chosen) and its error names (every error, in order),
/// the calibration targets (the reference first) and each pose subset's
/// (the study's own, which Gauss–Newton iterates over), the workspace
/// targets, the tool point (in the moving frame), whether the workspace is judged by exact kinematics
/// and how machines are drawn (None: the kernel's own draw).
pub struct Setup<'a, 'b, M: Mechanism> {
    pub m: &'a M,
    pub names: &'a [&'a str],
    pub targets: &'b [M::Target],
    pub subsets: &'b [PoseSubset],
    pub workspace: &'b [M::Target],
    pub tool: Vector3<f64>,
    pub exact: bool,
    pub bounds: Option<Bounds>,
}

/// Where a [`MechanismStudy`] judges its workspace, to first order: the
/// tool point's position and the moving frame's orientation.
pub struct Grids<const P: usize> {
    pub position: MapGrid<P>,
    pub orientation: MapGrid<P>,
}

/// A [`Commanded`] mechanism of R readings a pose, in the kernel's fixed
/// sizes: P coordinates along the convention's free directions that move
/// no reading's zero.
pub struct MechanismStudy<'a, M: Commanded, const P: usize, const R: usize> {
    m: &'a M,
    /// The P coordinates' names: the first error each moves.
    names: Vec<&'a str>,
    /// errors × P: a machine's errors from its coordinates.
    basis: DMatrix<f64>,
    /// P × errors: a drawn machine's coordinates (to first order).
    to_coords: DMatrix<f64>,
    targets: Vec<M::Target>,
    subsets: Vec<Vec<M::Target>>,
    workspace: Vec<M::Target>,
    /// Each slot's file unit per model unit (degrees per radian, 1).
    per_model: [f64; R],
    nominal: Vec<SVector<f64, R>>,
    /// Which judged quantity is the tool point's position.
    position: usize,
    bounds: Option<Bounds>,
    /// Which of the mechanism's errors are angles (how they are drawn).
    angles: Vec<bool>,
}

impl<'a, M: Commanded, const P: usize, const R: usize> MechanismStudy<'a, M, P, R> {
    /// The study of `s`, with its workspace's first-order sensitivities
    /// (the machine commanded nominally) of the tool point's position (∂
    /// position/∂ coordinates, mm) and of the moving frame's orientation
    /// (∂ rotation vector/∂ coordinates, rad; empty where the mechanism
    /// judges none). Err: a sentence naming what does not fit the
    /// kernel's sizes or which target the nominal machine cannot reach.
    pub fn new(s: Setup<'a, '_, M>) -> Result<(Self, Grids<P>), String> {
        let m = s.m;
        let facts = m.reading_facts();
        if facts.len() != R {
            return Err(format!(
                "the study is built for {R} readings a pose, the {} gives {}",
                m.name(),
                facts.len()
            ));
        }
        let errors = m.error_names().len();
        if s.names.len() != errors {
            return Err(format!(
                "{} error names for the {} errors of the {}",
                s.names.len(),
                errors,
                m.name()
            ));
        }
        if s.exact && s.tool != Vector3::zeros() {
            return Err("sweep: exact kinematics judges the moving frame's origin; judge a tool point away from it to first order".into());
        }
        let position =
            m.judged().iter().position(|q| *q == POSITION).ok_or(
                "the study judges the tool point's position, which this mechanism does not",
            )?;
        // Homed readings: a direction that moves only readings' zeros is
        // no part of the machine.
        let zeros: Vec<usize> = (0..R).filter_map(|k| m.zero_of(k)).collect();
        let (free, to_free) = convention_frames(m, s.targets)?;
        let kept: Vec<usize> = (0..free.ncols())
            .filter(|&c| zeros.iter().all(|&z| free[(z, c)] == 0.0))
            .collect();
        if kept.len() != P {
            return Err(format!(
                "the study is built for {P} coordinates, the {}'s convention leaves {} that move no reading's zero",
                m.name(),
                kept.len()
            ));
        }
        let basis = free.select_columns(&kept);
        let to_coords = to_free.select_rows(&kept);
        let names = kept.iter().map(|&c| s.names[error_of(&free, c)]).collect();
        let per_model = std::array::from_fn(|k| match facts[k].quantity {
            Quantity::Angle => 180.0 / std::f64::consts::PI,
            Quantity::Length => 1.0,
        });
        let study = MechanismStudy {
            m,
            names,
            basis,
            to_coords,
            targets: s.targets.to_vec(),
            subsets: s
                .subsets
                .iter()
                .map(|sub| sub.poses.iter().map(|&p| s.targets[p]).collect())
                .collect(),
            workspace: s.workspace.to_vec(),
            per_model,
            nominal: Vec::new(),
            position,
            bounds: s.bounds,
            angles: angles(m),
        };
        let mut nominal = vec![SVector::zeros(); s.targets.len()];
        let mut buf = Vec::new();
        study
            .read(&vec![0.0; errors], s.targets, &mut buf, &mut nominal)
            .map_err(|e| format!("poses: {e}"))?;
        let full = s
            .workspace
            .iter()
            .enumerate()
            .map(|(w, t)| {
                m.sensitivity(t, &s.tool)
                    .map_err(|e| format!("workspace pose {}: {e}", w + 1))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let grid_of = |q: usize| {
            let sensitivity = full
                .iter()
                .map(|f| {
                    let rows = f.rows(3 * q, 3) * &study.basis;
                    SMatrix::<f64, 3, P>::from_fn(|a, c| rows[(a, c)])
                })
                .collect();
            let points = s.workspace.iter().map(|t| m.tool_point(t, &s.tool));
            MapGrid::new(points.collect(), sensitivity)
        };
        let grids = Grids {
            position: grid_of(position),
            orientation: m
                .judged()
                .iter()
                .position(|q| *q == ORIENTATION)
                .map_or_else(MapGrid::default, grid_of),
        };
        Ok((MechanismStudy { nominal, ..study }, grids))
    }

    /// The homed design at every calibration pose (R rows a pose after
    /// the reference, model units per coordinate), the nominal machine's.
    pub fn design(&self) -> Result<DMatrix<f64>, String> {
        let mut at = Subset {
            study: self,
            targets: &self.targets,
            nominal: self.nominal.clone(),
            x: self.nominal.clone(),
            buf: Vec::new(),
        };
        at.design(&SVector::zeros()).map_err(|e| e.to_string())
    }

    /// The coordinate that moves error `j` (None: the convention holds
    /// it, or it is a reading's zero, which homing cancels).
    pub fn coordinate_of(&self, j: usize) -> Option<usize> {
        crate::mechanism::general::column_of(&self.basis, j)
    }

    /// The machine's errors from its coordinates `e`.
    pub fn errors(&self, e: &SVector<f64, P>) -> Vec<f64> {
        (&self.basis * e).as_slice().to_vec()
    }

    /// The readings (model units) the machine of `errors` gives at
    /// `targets`, into `out`; `buf` the file-unit readings.
    fn read(
        &self,
        errors: &[f64],
        targets: &[M::Target],
        buf: &mut Vec<f64>,
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError> {
        buf.clear();
        self.m
            .readings_into(errors, targets, buf)
            .map_err(|e| PoseError::new(0, KinematicsError::Stated(e)))?;
        for (x, row) in out.iter_mut().zip(buf.chunks_exact(R)) {
            *x = SVector::from_fn(|k, _| row[k] / self.per_model[k]);
        }
        Ok(())
    }
}

/// One pose subset of a [`MechanismStudy`] as Gauss–Newton re-linearises
/// it: homed rows of exact readings, the mechanism's own design.
struct Subset<'s, 'a, M: Commanded, const P: usize, const R: usize> {
    study: &'s MechanismStudy<'a, M, P, R>,
    targets: &'s [M::Target],
    nominal: Vec<SVector<f64, R>>,
    x: Vec<SVector<f64, R>>,
    buf: Vec<f64>,
}

impl<M: Commanded, const P: usize, const R: usize> Linearisation<P, R> for Subset<'_, '_, M, P, R> {
    fn observe(&mut self, values: &SVector<f64, P>, g: &mut [f64]) -> Result<(), PoseError> {
        let errors = self.study.errors(values);
        self.study
            .read(&errors, self.targets, &mut self.buf, &mut self.x)?;
        homed_rows(self.targets.len(), |j| self.nominal[j], &self.x, g);
        Ok(())
    }

    fn design(&mut self, values: &SVector<f64, P>) -> Result<DMatrix<f64>, PoseError> {
        let errors = self.study.errors(values);
        let h = self
            .study
            .m
            .design(&errors, self.targets)
            .map_err(|e| PoseError::new(0, KinematicsError::Stated(e)))?
            * &self.study.basis;
        let n = self.targets.len();
        let scale = |r: usize| 1.0 / self.study.per_model[r % R];
        Ok(DMatrix::from_fn(R * n.saturating_sub(1), P, |r, c| {
            let k = r % R;
            (h[(r + R, c)] - h[(k, c)]) * scale(k)
        }))
    }
}

impl<M: Commanded, const P: usize, const R: usize> Studied<P, R, 0>
    for MechanismStudy<'_, M, P, R>
{
    /// The machine's errors, every one of the mechanism's.
    type Machine = Vec<f64>;
    /// The file-unit readings of one machine.
    type Buffers = Vec<f64>;

    fn names(&self) -> &[&str] {
        &self.names
    }

    fn unknown_names(&self) -> &'static [&'static str] {
        &[]
    }

    fn nominal(&self) -> &[SVector<f64, R>] {
        &self.nominal
    }

    fn buffers(&self) -> Vec<f64> {
        Vec::with_capacity(R * self.targets.len())
    }

    fn draw(&self, seed: u64, k: u64) -> Option<SVector<f64, P>> {
        let b = self.bounds?;
        let d = drawn(&self.angles, (b.length_mm, b.angle_deg), &[], (seed, k));
        Some(SVector::from_fn(|c, _| {
            (self.to_coords.row(c).iter().zip(&d))
                .map(|(a, x)| a * x)
                .sum()
        }))
    }

    fn machine(&self, e: &SVector<f64, P>, _k: u64) -> Vec<f64> {
        self.errors(e)
    }

    fn actual(
        &self,
        machine: &Vec<f64>,
        _e: &SVector<f64, P>,
        buf: &mut Vec<f64>,
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError> {
        self.read(machine, &self.targets, buf, out)
    }

    fn iterate(
        &self,
        subset: usize,
        solver: &Solver<P, R>,
        l: &DVector<f64>,
        options: &IdentifyOptions<P>,
    ) -> Option<(SVector<f64, P>, bool)> {
        let targets = self.subsets.get(subset)?;
        let mut nominal = vec![SVector::zeros(); targets.len()];
        let mut buf = Vec::new();
        let zero = vec![0.0; self.basis.nrows()];
        self.read(&zero, targets, &mut buf, &mut nominal).ok()?;
        let mut model = Subset {
            study: self,
            targets,
            x: nominal.clone(),
            nominal,
            buf,
        };
        gauss_newton(&mut model, solver, l, options)
            .ok()
            .map(|(e, _)| (e.values, e.termination.converged()))
    }

    fn identified(&self, est: &SVector<f64, P>, _: &SVector<f64, 0>) -> Vec<f64> {
        self.errors(est)
    }

    /// The moving frame's position error: exact kinematics judges the
    /// pose the machine reaches, so a study judged exactly has its tool
    /// point at the moving frame's origin ([`MechanismStudy::new`] is
    /// given the workspace's positions, and the first-order judgement its
    /// tool point).
    fn exact_dv(
        &self,
        truth: &Vec<f64>,
        by: Option<&Vec<f64>>,
        at: Judging,
        i: usize,
    ) -> Option<f64> {
        let t = match at {
            Judging::Grid => self.workspace.get(i)?,
            Judging::Iso => return None,
        };
        let zero;
        let model = match by {
            Some(b) => b,
            None => {
                zero = vec![0.0; truth.len()];
                &zero
            }
        };
        let q = self.m.commands(model, t).ok()?;
        let reached = self.m.reach(truth, &q, t).ok()?;
        self.m.miss(t, &reached).get(self.position).copied()
    }

    fn assumptions(&self, _study: &Study<P, R>) -> Vec<String> {
        vec![match self.bounds {
            Some(b) => format!(
                "each of the {}'s length errors is within ±{} mm and each reading's zero within ±{}°, the machine put in the convention's frames ({P} coordinates).",
                self.m.name(),
                b.length_mm,
                b.angle_deg
            ),
            None => format!("each of the {P} coordinates of the {}'s geometry is drawn by the study.", self.m.name()),
        }]
    }
}

#[cfg(test)]
#[path = "mechanism_study_tests.rs"]
mod tests;
