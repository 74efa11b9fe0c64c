//! What a mechanism of any size is to identification and its checks: its
//! errors by name, the readings a pose gives at a target, how they move
//! with the errors, the convention that fixes what no internal sensor sees,
//! and what accuracy is judged by at a target (the tool point's position;
//! the platform's orientation where the target is a pose). Sizes are the
//! mechanism's own, known when it is built, not when the tool is compiled:
//! 54 errors and 12 readings a pose for the hexapod, 18 and 3 for the
//! Tricept as [`super::kinematic::Homed`] sees it.
//!
//! Units are the files': errors in mm or degrees ([`Mechanism::is_angle`]),
//! readings in their [`super::Quantity::file_unit`].

use super::facts::ReadingFact;
use nalgebra::{DMatrix, DVector, Vector3};

/// One quantity accuracy is judged by at a target: a 3-vector per target
/// (a displacement in mm, a rotation vector in rad), judged by its length
/// in `unit` (`per_model` of them per mm or rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judged {
    /// As a report names it ("position", "orientation").
    pub name: &'static str,
    /// The unit of its statements ("mm", "arcsec").
    pub unit: &'static str,
    pub per_model: f64,
}

/// The tool point's position, mm.
pub const POSITION: Judged = Judged {
    name: "position",
    unit: "mm",
    per_model: 1.0,
};

/// The platform's orientation, arc seconds.
pub const ORIENTATION: Judged = Judged {
    name: "orientation",
    unit: "arcsec",
    per_model: super::facts::ARCSEC_PER_RAD,
};

/// The words a study's report uses for a mechanism and its sensors: the
/// pipeline writes the sentences, the mechanism gives the nouns.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Words {
    /// The machine ("hexapod").
    pub machine: &'static str,
    /// The sensor a study prices, singular ("U-joint encoder").
    pub sensor: &'static str,
    /// Where one goes, singular ("U-joint", as in "one per U-joint").
    pub joint: &'static str,
    /// The length errors, singular and plural ("joint centre and leg
    /// offset", "joint centres and leg offsets").
    pub length_errors: [&'static str; 2],
    /// The angle errors, the same ("encoder zero", "encoder zeros").
    pub angle_errors: [&'static str; 2],
    /// What the price axis sums ("6 or 12 U-joint encoders").
    pub fitted: &'static str,
    /// The sensors' heading ("U-joint encoders (6 fitted with one a joint,
    /// 12 with two)").
    pub sensors_heading: &'static str,
    /// A further sensor, as a way to meet a target ("both encoders per
    /// joint").
    pub more_sensors: &'static str,
    /// The workspace's targets ("poses about the home pose").
    pub workspace: &'static str,
    /// How a reading is computed ("the exact U-joint angle formula").
    pub reading: &'static str,
    /// The frames accuracy is judged in, a sentence.
    pub frames: &'static str,
    /// What moves to a target ("platform", "tool point").
    pub moving: &'static str,
    /// The sensors whose readings say where it stands ("the encoders").
    pub readers: &'static str,
    /// What a check against its own sensors cannot see, and what tests it:
    /// a clause after "what it cannot see: ".
    pub cannot_see: &'static str,
}

/// A mechanism as identification sees it.
pub trait Mechanism: Sync + Clone {
    /// What a pose is commanded to reach: a point (the Tricept) or a pose
    /// (the hexapod).
    type Target: Copy + Send + Sync + std::fmt::Debug;

    /// How it may be instrumented, a study's axis (the hexapod: one or two
    /// encoders a joint); `()` where there is one way.
    type Variant: Copy + PartialEq + Send + Sync + std::fmt::Debug;

    /// This machine instrumented as `v`.
    fn with_variant(&self, v: Self::Variant) -> Self;

    /// The config's word for instrumentation `v` ("both").
    fn variant_name(&self, v: Self::Variant) -> &'static str;

    /// Instrumentation `v` as a buyer says it: what each joint gets, as
    /// the verdict puts it before "per U-joint" ("one φ encoder", or "one"
    /// where a joint has one place for a sensor), and in full ("two a
    /// joint (φ and ψ)").
    fn variant_words(&self, v: Self::Variant) -> [&'static str; 2];

    /// Sensors fitted with instrumentation `v`.
    fn fitted(&self, v: Self::Variant) -> usize {
        self.with_variant(v).reading_facts().len()
    }

    /// The words a study's report uses for it.
    fn words(&self) -> Words;

    /// The sensors the machine can carry, each reading one joint at every
    /// pose (the hexapod: 12 encoders, fitted or not).
    fn slots(&self) -> usize;

    /// Which slot reading `k` of a pose is read by.
    fn slot(&self, k: usize) -> usize;

    /// The error that is reading `k`'s zero, if the model has one: the
    /// reading less it is where the joint stands.
    fn zero_of(&self, k: usize) -> Option<usize>;

    /// The config's word for it ("hexapod").
    fn name(&self) -> &'static str;

    /// A target's columns in readings and targets files, in order
    /// ("x_mm", …; the hexapod's add "a_deg", "b_deg", "c_deg").
    fn target_columns(&self) -> &'static [&'static str];

    /// The target a file row's cells (in [`Mechanism::target_columns`]
    /// order) name, or why they name none.
    fn target_of(&self, cells: &[f64]) -> Result<Self::Target, String>;

    /// The convention in words (reports, identified files).
    fn convention(&self) -> &'static str;

    /// What the convention does with error `j`: "identified", "convention"
    /// (held at nominal) or how it confines it.
    fn error_source(&self, j: usize) -> &'static str;

    /// What the calibrated-geometry file (geometry.json) says of this
    /// machine beside its errors, by key: its units and its layout, nominal
    /// and with `errors` (the hexapod's legs, joints, home pose and encoder
    /// zeros). A mechanism that states none says its units alone.
    fn layout(&self, errors: &[f64]) -> Result<serde_json::Map<String, serde_json::Value>, String> {
        let _ = errors;
        let mut units = serde_json::Map::new();
        units.insert("length".into(), "mm".into());
        units.insert("angle".into(), "deg".into());
        Ok([("units".to_string(), units.into())].into_iter().collect())
    }

    /// The config keys that set this machine's nominal geometry, with their
    /// values (identify records them; compensate, export and verify refuse
    /// a fit identified on another, the store's nominal record). A mechanism
    /// without a config of its own records none.
    fn nominal(&self) -> Vec<(String, Vec<f64>)> {
        Vec::new()
    }

    /// How closely (file unit) a slip of a log (two columns swapped, a
    /// sign flipped, a unit) must explain reading `k` of a row to be
    /// named: the size a typical machine's errors move it by.
    fn slip_tolerance(&self, k: usize) -> f64;

    /// Every error of the model, in order; [`Mechanism::readings`] and
    /// [`Mechanism::design`] take them in this order.
    fn error_names(&self) -> Vec<String>;

    /// Whether error `j` is an angle (degrees) rather than a length (mm).
    fn is_angle(&self, j: usize) -> bool;

    /// The errors this machine can have (the rest are absent: an encoder
    /// not fitted has no zero). Their columns of the design are zero.
    fn present(&self) -> Vec<usize> {
        (0..self.error_names().len()).collect()
    }

    /// Whether error `j` may be held at a value measured elsewhere: one no
    /// choice of frame changes (a joint centre's error is in the frames the
    /// convention picks, which a measurement elsewhere does not share).
    fn fixable(&self, j: usize) -> bool;

    /// The readings a pose gives, in order.
    fn reading_facts(&self) -> Vec<ReadingFact>;

    /// The readings (file units) of the machine with `errors`, commanded
    /// to `target` by the nominal machine's inverse kinematics: exact
    /// forward kinematics.
    fn readings(&self, errors: &[f64], target: &Self::Target) -> Result<Vec<f64>, String>;

    /// Every target's readings (as [`Mechanism::readings`]), appended to
    /// `out` target after target: a mechanism may build its machine once.
    fn readings_into(
        &self,
        errors: &[f64],
        targets: &[Self::Target],
        out: &mut Vec<f64>,
    ) -> Result<(), String> {
        for (j, t) in targets.iter().enumerate() {
            out.extend(
                self.readings(errors, t)
                    .map_err(|e| format!("pose {}: {e}", j + 1))?,
            );
        }
        Ok(())
    }

    /// ∂readings/∂errors over `targets`, target after target (readings ×
    /// errors; file units per file unit), of the machine with `errors`.
    fn design(&self, errors: &[f64], targets: &[Self::Target]) -> Result<DMatrix<f64>, String>;

    /// The convention: a basis N (errors × free, orthonormal columns) of
    /// the error vectors it admits, N·y; zero rows for absent errors.
    fn free_directions(&self) -> DMatrix<f64>;

    /// What accuracy is judged by at a target.
    fn judged(&self) -> &'static [Judged];

    /// Where the tool point `tool` (mm, in the moving frame; a point
    /// target's tool is the target itself) stands at `target`, nominally.
    fn tool_point(&self, target: &Self::Target, tool: &Vector3<f64>) -> Vector3<f64>;

    /// How each [`Mechanism::judged`] quantity moves at `target` per unit
    /// of each error, the machine commanded by nominal inverse kinematics
    /// (3 rows a quantity × errors), `tool` the tool point where the
    /// target is a pose (mm, in the platform's frame).
    fn sensitivity(
        &self,
        target: &Self::Target,
        tool: &Vector3<f64>,
    ) -> Result<DMatrix<f64>, String>;
}

/// What compensation and verification ask of a mechanism beyond
/// identification: its actuators' commands at a target, where a machine
/// lands commanded with them, and where its sensors' readings put it.
/// Errors are in [`Mechanism::error_names`]' order and units.
pub trait Commanded: Mechanism {
    /// The actuators' command columns, in order ("q1_mm", …).
    fn command_columns(&self) -> Vec<String>;

    /// The commands the machine with `errors` needs to reach `target`: its
    /// own inverse kinematics (all errors zero: the nominal machine's, the
    /// uncompensated commands).
    fn commands(&self, errors: &[f64], target: &Self::Target) -> Result<Vec<f64>, String>;

    /// Where the machine with `errors` lands commanded with `commands`:
    /// exact forward kinematics, solved from `near`.
    fn reach(
        &self,
        errors: &[f64],
        commands: &[f64],
        near: &Self::Target,
    ) -> Result<Self::Target, String>;

    /// Where one pose's `readings` (file units, [`Mechanism::reading_facts`]
    /// order) put the machine with `errors`, solved from `near`: the
    /// sensors' own account, independent of the actuators.
    fn seen(
        &self,
        errors: &[f64],
        readings: &[f64],
        near: &Self::Target,
    ) -> Result<Self::Target, String>;

    /// How far `a` is from `b` by each [`Mechanism::judged`] quantity, in
    /// its unit (the moving frame's origin for a pose).
    fn miss(&self, a: &Self::Target, b: &Self::Target) -> Vec<f64>;
}

/// Every target's readings of the machine with `errors`, stacked.
pub fn predict<M: Mechanism>(
    m: &M,
    errors: &[f64],
    targets: &[M::Target],
) -> Result<DVector<f64>, String> {
    let per = m.reading_facts().len();
    let mut out = Vec::with_capacity(per * targets.len());
    m.readings_into(errors, targets, &mut out)?;
    Ok(DVector::from_vec(out))
}

/// The largest length of each judged quantity over stacked errors (the
/// rows [`Mechanism::sensitivity`] gives, target after target), in its unit.
pub fn worst_of(judged: &[Judged], x: &DVector<f64>) -> Vec<f64> {
    let mut out = vec![0.0f64; judged.len()];
    worst_into(judged, x, &mut out);
    out
}

/// [`worst_of`] into `out` (one per judged quantity), allocating nothing:
/// the study's per-trial form.
pub fn worst_into(judged: &[Judged], x: &DVector<f64>, out: &mut [f64]) {
    out.fill(0.0);
    for t in x.as_slice().chunks_exact(3 * judged.len()) {
        for (i, (q, v)) in judged.iter().zip(t.chunks_exact(3)).enumerate() {
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt() * q.per_model;
            out[i] = out[i].max(len);
        }
    }
}

/// The free direction of basis `n` that moves error `j` (None where the
/// convention holds it, or the machine lacks it).
pub fn column_of(n: &DMatrix<f64>, j: usize) -> Option<usize> {
    (0..n.ncols()).find(|&c| n[(j, c)] != 0.0)
}

/// The first error free direction `c` of basis `n` moves.
pub fn error_of(n: &DMatrix<f64>, c: usize) -> usize {
    (0..n.nrows()).find(|&j| n[(j, c)] != 0.0).unwrap_or(0)
}
