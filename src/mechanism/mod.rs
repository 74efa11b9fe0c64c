//! The mechanisms, a folder each, and what every mechanism is to the rest
//! of the tool: its facts ([`Topology`]: errors, readings with units and
//! columns, legs, layout rules, pose check) and its kinematics as
//! identification asks for them ([`Kinematic`], [`PoseSet`], the homed
//! observation [`homed_rows`]). The bottom of the house: it imports only
//! `error.rs` and `cpu.rs`.

pub mod facts;
pub mod general;
pub mod hexapod;
pub mod kinematic;
pub mod tricept;
pub mod workspace;

pub use facts::{
    GeometryRule, LogRow, PoseReadings, Quantity, ReadingFact, Topology, Unknowns, ARCSEC_PER_RAD,
};
pub use general::{Commanded, Judged, Mechanism, Words, ORIENTATION, POSITION};
pub use kinematic::{
    homed_rows, sin_cos_near, AxisAngles, Homed, Kinematic, PoseSet, Reach, MAX_OFFSET_RAD,
};
pub use workspace::Workspace;
