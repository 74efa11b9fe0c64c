//! What identification and a white-noise study ask of a mechanism's
//! kinematics, beside its facts ([`Topology`]): its machine with errors, the
//! nominal machine's commands at a target, the exact readings an erroneous
//! machine gives at those commands, and the error Jacobian of its readings.
//! P errors and R readings a pose are the trait's parameters (the
//! Tricept's: 15 and 3); the same Gauss–Newton (`identify::gauss_newton`)
//! and the same operator (`identify::Solver`) serve every mechanism that
//! implements it.

use super::facts::{Quantity, ReadingFact, Topology};
use super::general::{Commanded, Judged, Mechanism, Words, POSITION};
use crate::error::{KinematicsError, PoseError};
use nalgebra::{DMatrix, SMatrix, SVector, Vector3};

/// The kinematics of a topology with P errors and R readings a pose.
pub trait Kinematic<const P: usize, const R: usize>: Topology {
    /// What a pose commands the active legs: one value an actuator (mm), a
    /// fixed-size array (its default's length is the number of actuators).
    type Command: Clone + Send + Sync + Default + AsRef<[f64]> + for<'a> TryFrom<&'a [f64]>;

    /// The layout with errors `e` (mm, in [`Topology::ERROR_NAMES`] order).
    fn machine(layout: &Self::Layout, e: &SVector<f64, P>) -> Self::Machine;

    /// Inverse kinematics of `machine` at target `r` (the nominal machine's
    /// for a log's commands, an identified one's for compensated ones):
    /// the commands, its own leg offsets taken off, and the readings it
    /// gives there.
    fn command(
        machine: &Self::Machine,
        r: &Vector3<f64>,
    ) -> Result<(Self::Command, SVector<f64, R>), KinematicsError>;

    /// Exact forward kinematics: the readings `machine` gives at `command`,
    /// solved from `guess` (the nominal machine's readings there).
    fn readings(
        machine: &Self::Machine,
        command: &Self::Command,
        guess: &SVector<f64, R>,
    ) -> Result<SVector<f64, R>, KinematicsError>;

    /// ∂readings/∂errors of `machine` in the configuration whose readings
    /// are `x` (R × P; model units: rad and mm per mm).
    fn error_jacobian(
        machine: &Self::Machine,
        x: &SVector<f64, R>,
    ) -> Result<SMatrix<f64, R, P>, KinematicsError>;

    /// Where `machine`'s tool point stands in the configuration whose
    /// readings are `x` (mm).
    fn position(machine: &Self::Machine, x: &SVector<f64, R>) -> Vector3<f64>;

    /// ∂(tool position)/∂errors (mm per mm, 3 × P) of the layout's
    /// machine driven by its nominal commands at target `r`: where an
    /// error takes the tool. By default central differences of exact
    /// forward kinematics (a step of 1e-4 mm); a topology with a closed
    /// form gives it.
    fn position_sensitivity(
        layout: &Self::Layout,
        r: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 3, P>, KinematicsError> {
        let nominal = Self::machine(layout, &SVector::zeros());
        let (q, guess) = Self::command(&nominal, r)?;
        let mut s = SMatrix::<f64, 3, P>::zeros();
        let h = 1e-4;
        for c in 0..P {
            let mut col = Vector3::zeros();
            for sign in [1.0, -1.0] {
                let mut e = SVector::<f64, P>::zeros();
                e[c] = sign * h;
                let m = Self::machine(layout, &e);
                let x = Self::readings(&m, &q, &guess)?;
                col += Self::position(&m, &x) * (sign / (2.0 * h));
            }
            s.set_column(c, &col);
        }
        Ok(s)
    }
}

/// A topology's second-class unknowns: A angles (degrees) of its joints'
/// axes that its P errors leave out and identification may estimate
/// beside them (the Tricept's Hooke axes). A topology without any has
/// A = 0.
pub trait AxisAngles<const P: usize, const R: usize, const A: usize>: Kinematic<P, R> {
    /// `machine` with its axes turned by `angles` (deg).
    fn with_angles(machine: &Self::Machine, angles: &SVector<f64, A>) -> Self::Machine;

    /// ∂(tool position)/∂angles (mm per degree, 3 × A) of `nominal`
    /// (its axes at zero) driven by its commands at target `r`.
    fn position_angle_sensitivity(
        nominal: &Self::Machine,
        r: &Vector3<f64>,
    ) -> Result<SMatrix<f64, 3, A>, KinematicsError>;
}

/// Where a mechanism's config lets its tool go: its nominal machine (as
/// [`Homed`]) and the tilt beyond which a target is refused
/// ([`Topology::check_pose`]). What a log's checks read of a config.
pub struct Reach<'a, T: Kinematic<P, R>, const P: usize, const R: usize> {
    pub homed: Homed<'a, T, P, R>,
    pub max_tilt_deg: f64,
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> Reach<'_, T, P, R> {
    /// Is target `r` usable with the nominal machine? Why not, in words.
    pub fn check(&self, r: &Vector3<f64>) -> Result<(), String> {
        T::check_pose(self.homed.nominal(), r, self.max_tilt_deg)
    }
}

/// A [`Kinematic`] topology as a [`Mechanism`] of any size sees it: its P
/// errors (mm) and then each reading's zero (file units), P + R in all, so
/// that absolute readings identify what homing at a reference pose would.
/// Targets are tool-point positions; accuracy is judged by position. Its
/// frame gauge is its convention (its errors are the ones left free); an
/// error no reading sees in a particular layout stays free and leaves the
/// design rank-deficient, which identification refuses until it is held.
pub struct Homed<'a, T: Kinematic<P, R>, const P: usize, const R: usize> {
    layout: &'a T::Layout,
    nominal: T::Machine,
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> Clone for Homed<'_, T, P, R> {
    fn clone(&self) -> Self {
        Homed::new(self.layout)
    }
}

impl<'a, T: Kinematic<P, R>, const P: usize, const R: usize> Homed<'a, T, P, R> {
    pub fn new(layout: &'a T::Layout) -> Self {
        Homed {
            layout,
            nominal: T::machine(layout, &SVector::zeros()),
        }
    }

    /// Its nominal machine (no errors).
    pub fn nominal(&self) -> &T::Machine {
        &self.nominal
    }

    /// Its nominal layout.
    pub fn layout(&self) -> &'a T::Layout {
        self.layout
    }

    /// The machine of `errors`' first P and the readings' zeros.
    fn split(&self, errors: &[f64]) -> Result<(T::Machine, SVector<f64, R>), String> {
        if errors.len() != P + R {
            return Err(format!(
                "{} errors given, the mechanism has {}",
                errors.len(),
                P + R
            ));
        }
        let e = SVector::<f64, P>::from_column_slice(&errors[..P]);
        let z = SVector::<f64, R>::from_column_slice(&errors[P..]);
        Ok((T::machine(self.layout, &e), z))
    }

    /// The readings (model units) `machine` gives at `target`.
    fn solve(
        &self,
        machine: &T::Machine,
        target: &Vector3<f64>,
    ) -> Result<(T::Command, SVector<f64, R>), String> {
        let (q, guess) = T::command(&self.nominal, target).map_err(|e| e.to_string())?;
        let x = T::readings(machine, &q, &guess).map_err(|e| e.to_string())?;
        Ok((q, x))
    }
}

/// A [`Kinematic`] topology's actuators: one command an actuator (mm,
/// "q1_mm", …), its inverse and forward kinematics, and the tool point its
/// readings put it at (the readings less their zeros, in model units).
impl<T, const P: usize, const R: usize> Commanded for Homed<'_, T, P, R>
where
    T: Kinematic<P, R>,
    T::Layout: Sync,
    T::Machine: Sync,
{
    fn command_columns(&self) -> Vec<String> {
        (1..=T::Command::default().as_ref().len())
            .map(|i| format!("q{i}_mm"))
            .collect()
    }

    fn commands(&self, errors: &[f64], target: &Vector3<f64>) -> Result<Vec<f64>, String> {
        let (machine, _) = self.split(errors)?;
        let (q, _) = T::command(&machine, target).map_err(|e| e.to_string())?;
        Ok(q.as_ref().to_vec())
    }

    fn reach(
        &self,
        errors: &[f64],
        commands: &[f64],
        near: &Vector3<f64>,
    ) -> Result<Vector3<f64>, String> {
        let (machine, _) = self.split(errors)?;
        let q = T::Command::try_from(commands).map_err(|_| {
            format!(
                "{} commands given, the mechanism has {}",
                commands.len(),
                T::Command::default().as_ref().len()
            )
        })?;
        let (_, guess) = T::command(&self.nominal, near).map_err(|e| e.to_string())?;
        let x = T::readings(&machine, &q, &guess).map_err(|e| e.to_string())?;
        Ok(T::position(&machine, &x))
    }

    fn seen(
        &self,
        errors: &[f64],
        readings: &[f64],
        _near: &Vector3<f64>,
    ) -> Result<Vector3<f64>, String> {
        let (machine, zeros) = self.split(errors)?;
        if readings.len() != R {
            return Err(format!("{} readings given, a pose has {R}", readings.len()));
        }
        let x = SVector::<f64, R>::from_fn(|k, _| {
            T::READINGS[k].quantity.from_file(readings[k] - zeros[k])
        });
        Ok(T::position(&machine, &x))
    }

    fn miss(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> Vec<f64> {
        vec![(a - b).norm()]
    }
}

impl<T, const P: usize, const R: usize> Mechanism for Homed<'_, T, P, R>
where
    T: Kinematic<P, R>,
    T::Layout: Sync,
    T::Machine: Sync,
{
    type Target = Vector3<f64>;
    type Variant = ();

    fn with_variant(&self, _: ()) -> Self {
        self.clone()
    }

    fn variant_name(&self, _: ()) -> &'static str {
        "all"
    }

    fn variant_words(&self, _: ()) -> [&'static str; 2] {
        ["one", "one a reading"]
    }

    /// Its readings' sensors and errors in general words.
    fn words(&self) -> Words {
        Words {
            machine: T::NAME,
            sensor: "encoder",
            joint: "passive joint",
            length_errors: ["length error", "length errors"],
            angle_errors: ["reading zero", "reading zeros"],
            fitted: "the encoders",
            sensors_heading: "Encoders",
            more_sensors: "more sensors",
            workspace: "targets",
            reading: "its exact forward kinematics",
            frames: "Accuracy is judged in the frame the topology's gauge fixes.",
            moving: "tool point",
            readers: "its sensors",
            cannot_see: "the frame its gauge fixes, and any error its sensors' readings share with the model; one external measurement of the tool point tests those",
        }
    }

    fn slots(&self) -> usize {
        R
    }

    fn tool_point(&self, target: &Vector3<f64>, _tool: &Vector3<f64>) -> Vector3<f64> {
        *target
    }

    fn slot(&self, k: usize) -> usize {
        k
    }

    fn zero_of(&self, k: usize) -> Option<usize> {
        Some(P + k)
    }

    fn name(&self) -> &'static str {
        T::NAME
    }

    fn target_columns(&self) -> &'static [&'static str] {
        &["x_mm", "y_mm", "z_mm"]
    }

    fn target_of(&self, x: &[f64]) -> Result<Vector3<f64>, String> {
        match x {
            [x, y, z] => Ok(Vector3::new(*x, *y, *z)),
            _ => Err(format!("a target has 3 values, not {}", x.len())),
        }
    }

    /// Its gauge fixes the frame; an error no reading sees in a layout
    /// (the Tricept's dyA3 in the paper's) is left to the user to hold.
    fn convention(&self) -> &'static str {
        "the topology's frame gauge (an error no reading sees in this layout is not identified: hold it at a value)"
    }

    fn error_source(&self, _j: usize) -> &'static str {
        "identified"
    }

    /// A fifth of the reading's plausible distance.
    fn slip_tolerance(&self, k: usize) -> f64 {
        T::READINGS[k].plausible / 5.0
    }

    fn error_names(&self) -> Vec<String> {
        T::ERROR_NAMES
            .iter()
            .map(|n| n.to_string())
            .chain(T::READINGS.iter().map(|r| format!("zero_{}", r.ascii)))
            .collect()
    }

    fn is_angle(&self, j: usize) -> bool {
        j >= P && T::READINGS[j - P].quantity == Quantity::Angle
    }

    /// The readings' zeros: the topology's own errors are in the frame
    /// its gauge picks, which a measurement elsewhere does not share.
    fn fixable(&self, j: usize) -> bool {
        j >= P
    }

    fn reading_facts(&self) -> Vec<ReadingFact> {
        T::READINGS.to_vec()
    }

    fn readings(&self, errors: &[f64], target: &Vector3<f64>) -> Result<Vec<f64>, String> {
        let (machine, zeros) = self.split(errors)?;
        let (_, x) = self.solve(&machine, target)?;
        Ok((0..R)
            .map(|k| T::READINGS[k].quantity.to_file(x[k]) + zeros[k])
            .collect())
    }

    fn design(&self, errors: &[f64], targets: &[Vector3<f64>]) -> Result<DMatrix<f64>, String> {
        let (machine, _) = self.split(errors)?;
        let mut h = DMatrix::zeros(R * targets.len(), P + R);
        for (j, t) in targets.iter().enumerate() {
            let at = |e: String| format!("pose {}: {e}", j + 1);
            let (_, x) = self.solve(&machine, t).map_err(at)?;
            let jac = T::error_jacobian(&machine, &x).map_err(|e| at(e.to_string()))?;
            for k in 0..R {
                let q = T::READINGS[k].quantity;
                for c in 0..P {
                    h[(R * j + k, c)] = q.to_file(jac[(k, c)]);
                }
                h[(R * j + k, P + k)] = 1.0;
            }
        }
        Ok(h)
    }

    fn free_directions(&self) -> DMatrix<f64> {
        DMatrix::identity(P + R, P + R)
    }

    fn judged(&self) -> &'static [Judged] {
        &[POSITION]
    }

    /// The topology's [`Kinematic::position_sensitivity`] (central
    /// differences of exact forward kinematics unless it has a closed
    /// form); a reading's zero moves no tool point.
    fn sensitivity(
        &self,
        target: &Vector3<f64>,
        _tool: &Vector3<f64>,
    ) -> Result<DMatrix<f64>, String> {
        let sp = T::position_sensitivity(self.layout, target).map_err(|e| e.to_string())?;
        let mut s = DMatrix::zeros(3, P + R);
        s.columns_mut(0, P).copy_from(&sp);
        Ok(s)
    }
}

/// A topology's pose set: each target, the nominal machine's commands and
/// readings there (pose 0 is the reference the sensors are homed at).
pub struct PoseSet<T: Kinematic<P, R>, const P: usize, const R: usize> {
    pub targets: Vec<Vector3<f64>>,
    pub commands: Vec<T::Command>,
    pub nominal: Vec<SVector<f64, R>>,
}

// By hand: the topology is a marker type and need not be Clone or Debug.
impl<T: Kinematic<P, R>, const P: usize, const R: usize> Clone for PoseSet<T, P, R> {
    fn clone(&self) -> Self {
        PoseSet {
            targets: self.targets.clone(),
            commands: self.commands.clone(),
            nominal: self.nominal.clone(),
        }
    }
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> std::fmt::Debug for PoseSet<T, P, R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PoseSet")
            .field("targets", &self.targets)
            .field("nominal", &self.nominal)
            .finish_non_exhaustive()
    }
}

impl<T: Kinematic<P, R>, const P: usize, const R: usize> PoseSet<T, P, R> {
    /// Nominal inverse kinematics at every target; the error names the pose.
    pub fn new(nominal: &T::Machine, targets: &[Vector3<f64>]) -> Result<Self, PoseError> {
        let mut commands = Vec::with_capacity(targets.len());
        let mut readings = Vec::with_capacity(targets.len());
        for (k, r) in targets.iter().enumerate() {
            let (q, x) = T::command(nominal, r).map_err(|e| PoseError::new(k, e))?;
            commands.push(q);
            readings.push(x);
        }
        Ok(PoseSet {
            targets: targets.to_vec(),
            commands,
            nominal: readings,
        })
    }

    pub fn len(&self) -> usize {
        self.targets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Rows of the observation vector l: R for every pose but the reference.
    pub fn rows(&self) -> usize {
        R * self.len().saturating_sub(1)
    }

    /// The readings `machine` gives at every pose (exact forward
    /// kinematics from the nominal solution), written into `out`.
    pub fn actual_into(
        &self,
        machine: &T::Machine,
        out: &mut [SVector<f64, R>],
    ) -> Result<(), PoseError> {
        for (k, (q, guess)) in self.commands.iter().zip(&self.nominal).enumerate() {
            out[k] = T::readings(machine, q, guess).map_err(|e| PoseError::new(k, e))?;
        }
        Ok(())
    }

    /// l of readings `a` (eq. 10 with homing; [`homed_rows`]).
    pub fn observation_into(&self, a: &[SVector<f64, R>], out: &mut [f64]) {
        homed_rows(self.len(), |j| self.nominal[j], a, out);
    }
}

/// The observation of eq. 10, for every topology: l_j = (a_j − a_0) −
/// (nominal_j − nominal_0) for j ≥ 1, written to `out[R(j−1)..Rj]`, where
/// `nominal(j)` is pose j's nominal readings (n poses) and `a` the readings.
/// Equal to reading_j − nominal_j when the reference reads nominal_0, as
/// homing makes it; robust to a controller that logs a homing offset. No
/// pose, no row.
#[inline(always)]
pub fn homed_rows<const R: usize>(
    n: usize,
    nominal: impl Fn(usize) -> SVector<f64, R>,
    a: &[SVector<f64, R>],
    out: &mut [f64],
) {
    if n == 0 {
        return;
    }
    let n0 = nominal(0);
    let a0 = a[0];
    for j in 1..n {
        let d = (a[j] - a0) - (nominal(j) - n0);
        out[R * (j - 1)..R * j].copy_from_slice(d.as_slice());
    }
}

/// Largest angle offset (rad) from the anchor evaluated by the series; the first
/// omitted terms are then below 1e-18.
pub const MAX_OFFSET_RAD: f64 = 0.02;

/// sin and cos of a0 + d from s0 = sin a0, c0 = cos a0, for |d| ≤
/// [`MAX_OFFSET_RAD`]: cos d = 1 − d²/2 + d⁴/24 − d⁶/720 and
/// sin d = d − d³/6 + d⁵/120 − d⁷/5040 (remainders below 1e-18).
#[inline(always)]
pub fn sin_cos_near(s0: f64, c0: f64, d: f64) -> (f64, f64) {
    // Horner form with the coefficients as constants (no division).
    const C: [f64; 3] = [-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0];
    const S: [f64; 3] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0];
    let d2 = d * d;
    let cd = 1.0 + d2 * (C[0] + d2 * (C[1] + d2 * C[2]));
    let sd = d + d * d2 * (S[0] + d2 * (S[1] + d2 * S[2]));
    (s0 * cd + c0 * sd, c0 * cd - s0 * sd)
}
