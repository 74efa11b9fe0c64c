//! The facts of a mechanism that the rest of the tool reads: how many
//! geometric errors and their names, which passive-joint readings with
//! their symbols, units and file columns, how many legs, the rules a
//! nominal layout must satisfy, where a pose is usable (reach, tilt,
//! singularity), and the travel a length sensor must cover. The Tricept
//! implements [`Topology`] in `tricept/topology.rs`; what still assumes
//! the Tricept's shape is listed in ARCHITECTURE.md.

use nalgebra::Vector3;

/// Arcseconds per radian.
pub const ARCSEC_PER_RAD: f64 = 206_264.806_247_096_36;

/// What a reading measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// An angle: radians inside, degrees in files, arcseconds for sensors.
    Angle,
    /// A length: mm inside and in files, µm for sensors.
    Length,
}

impl Quantity {
    /// The unit of the reading's file column.
    pub fn file_unit(self) -> &'static str {
        match self {
            Quantity::Angle => "deg",
            Quantity::Length => "mm",
        }
    }

    /// The ASCII name of the unit a sensor's accuracy is given in (CSV
    /// cells): arcsec, um.
    pub fn sensor_unit_ascii(self) -> &'static str {
        match self {
            Quantity::Angle => "arcsec",
            Quantity::Length => "um",
        }
    }

    /// Sensor units per model unit: arcseconds per radian, µm per mm.
    /// The symbol a sensor's unit is written with in sentences (″, µm).
    pub fn sensor_symbol(self) -> &'static str {
        match self {
            Quantity::Angle => "″",
            Quantity::Length => " µm",
        }
    }

    pub fn sensor_per_model(self) -> f64 {
        match self {
            Quantity::Angle => ARCSEC_PER_RAD,
            Quantity::Length => 1e3,
        }
    }

    /// A sensor's value (″, µm) in the model's unit (rad, mm).
    pub fn from_sensor(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v / ARCSEC_PER_RAD,
            Quantity::Length => v * 1e-3,
        }
    }

    /// A value in the model's unit (rad, mm) in the file's (deg, mm).
    pub fn to_file(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v.to_degrees(),
            Quantity::Length => v,
        }
    }

    /// A value in the file's unit (deg, mm) in the model's (rad, mm).
    pub fn from_file(self, v: f64) -> f64 {
        match self {
            Quantity::Angle => v.to_radians(),
            Quantity::Length => v,
        }
    }
}

/// One pose's R readings, each by its index in the mechanism's reading
/// order (internal units: rad, mm): what a sensor model of R slots reads
/// of a pose, whatever the mechanism (a pose of another mechanism's
/// readings is another type, and does not compile against it).
pub trait PoseReadings<const R: usize> {
    fn reading(&self, k: usize) -> f64;
}

impl<const R: usize> PoseReadings<R> for nalgebra::SVector<f64, R> {
    #[inline]
    fn reading(&self, k: usize) -> f64 {
        self[k]
    }
}

/// The names a mechanism's identified model is written and read under
/// (identified.csv's rows): its P errors (mm), then its A second-class
/// unknowns, which are angles (degrees), with what they are in words for
/// a message.
#[derive(Debug, Clone, Copy)]
pub struct Unknowns<const P: usize, const A: usize> {
    pub errors: [&'static str; P],
    pub angles: [&'static str; A],
    /// The angles together ("the Hooke axes' angles").
    pub angles_are: &'static str,
    /// What one angle is ("Hooke-axis misalignment").
    pub angle_is: &'static str,
    /// Whose axes the angles turn ("the passive limb's Hooke axes").
    pub angles_turn: &'static str,
    /// The axes themselves, as "the …" names them in a sentence ("Hooke
    /// axes").
    pub axes: &'static str,
    /// A second-class error of theirs the angles leave out because the
    /// errors move the readings as it does ("the guide's twist"); empty
    /// when none.
    pub beyond: &'static str,
}

/// One row of a mechanism's log whose targets are tool-point positions:
/// the target it was commanded to (mm) and the R readings it gave there.
/// A log's file is written and read from these facts alone (the target's
/// columns, then each reading in its file unit under its column), so any
/// such mechanism's log is one format.
pub trait LogRow<const R: usize>: Sized {
    /// The readings' facts, in the log's column order.
    const FACTS: &'static [ReadingFact; R];
    /// Where the tool point was commanded (mm).
    fn target(&self) -> Vector3<f64>;
    /// The readings in model units (rad, mm), in [`LogRow::FACTS`] order.
    fn readings(&self) -> nalgebra::SVector<f64, R>;
    /// The row of target `target` and readings `x` (model units).
    fn new(target: Vector3<f64>, x: &nalgebra::SVector<f64, R>) -> Self;
    /// The readings in the files' units (deg, mm).
    fn file_values(&self) -> [f64; R] {
        let x = self.readings();
        std::array::from_fn(|k| Self::FACTS[k].quantity.to_file(x[k]))
    }
    /// The row of target `target` and readings `values` in the files'
    /// units.
    fn from_file(target: Vector3<f64>, values: [f64; R]) -> Self {
        let x = nalgebra::SVector::from_fn(|k, _| Self::FACTS[k].quantity.from_file(values[k]));
        Self::new(target, &x)
    }
}

/// One passive-joint reading of every pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadingFact {
    /// As the paper writes it ("ψ4").
    pub symbol: &'static str,
    /// In ASCII ("psi4").
    pub ascii: &'static str,
    /// Its column in readings files ("psi4_deg"), in [`Quantity::file_unit`].
    pub column: &'static str,
    pub quantity: Quantity,
    /// The sensor that reads it, as a person names it ("ψ4 encoder").
    pub sensor: &'static str,
    /// The same in ASCII ("psi4 encoder").
    pub sensor_ascii: &'static str,
    /// The sensor as a CSV cell names it ("psi4_encoder").
    pub sensor_key: &'static str,
    /// The largest difference (file unit) between a reading and the nominal
    /// joint value at its target that geometric errors of a few mm can
    /// make: more says units, column order or signs are wrong.
    pub plausible: f64,
}

/// A layout that breaks one of the topology's rules: which joints (base or
/// platform) and why.
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryRule {
    /// `true` when the rule is about the base joints, else the platform's.
    pub base: bool,
    pub why: String,
}

/// The facts of one parallel-module topology. Everything outside the mechanism's
/// folder reads them (the Tricept's through `tricept::Mechanism`); kinematics, the error Jacobian and
/// the error vector are the topology's own types beside them.
pub trait Topology {
    /// The config's word for it ("tricept").
    const NAME: &'static str;
    /// The independent geometric errors, in canonical order.
    const ERROR_NAMES: &'static [&'static str];
    /// Raw errors the frame gauge fixes (not estimated, named when a config
    /// gives one).
    const GAUGE_FIXED: &'static [&'static str];
    /// The passive-joint readings of a pose, in order.
    const READINGS: &'static [ReadingFact];
    /// Active legs (commands per pose).
    const LEGS: usize;
    /// The frame definitions that fix what no reading can set, in words
    /// (its calibrated-geometry file states them).
    const CONVENTION: &'static str;
    /// Its nominal layout.
    type Layout;
    /// Its machine (layout + errors), which solves the kinematics.
    type Machine;

    /// Does the nominal layout obey the topology's rules (the frame gauge
    /// the errors are defined in, distinct joints)?
    fn check_layout(layout: &Self::Layout) -> Result<(), GeometryRule>;

    /// Is the tool-centre position `r` usable with the nominal machine: it
    /// reaches it, within `max_tilt_deg`, away from a singularity?
    fn check_pose(
        nominal: &Self::Machine,
        r: &Vector3<f64>,
        max_tilt_deg: f64,
    ) -> Result<(), String>;

    /// The workspace accuracy is judged over.
    type Workspace;

    /// The travel of the length reading over the workspace (mm): what a
    /// linear scale must cover.
    fn length_travel(ws: &Self::Workspace) -> f64;

    /// What its calibrated-geometry file says of its joints beside its
    /// errors, by key: each nominal and as `identified` puts it. None by
    /// default.
    fn joints_json(
        nominal: &Self::Machine,
        identified: &Self::Machine,
    ) -> serde_json::Map<String, serde_json::Value> {
        let _ = (nominal, identified);
        serde_json::Map::new()
    }
}

impl ReadingFact {
    /// A reading fact named `sensor` everywhere, for tests of a layout of
    /// slots that is no mechanism's.
    #[cfg(test)]
    pub(crate) const fn named(sensor: &'static str, quantity: Quantity) -> ReadingFact {
        ReadingFact {
            symbol: sensor,
            ascii: sensor,
            column: sensor,
            quantity,
            sensor,
            sensor_ascii: sensor,
            sensor_key: sensor,
            plausible: 1.0,
        }
    }
}
