//! The Tricept 3-DOF parallel module: geometry, the 15 geometric errors and
//! exact kinematics (docs/method.md §2–§4; Hong 2009, eqs. 1–9).
//!
//! This folder is the Tricept's topology-specific code: everything above it sees
//! the machine through [`Machine`] (IK, FK, the error Jacobian), the
//! [`ErrorVector`] of its geometric errors, the passive-limb [`Joints`] its
//! sensors read, and the facts of [`topology`] (the errors' number and
//! names, the readings with their units and columns, the legs, the layout
//! rules, the pose check, the scale's travel). Another parallel module is
//! another folder beside this one, implementing
//! [`Topology`](crate::mechanism::Topology) and
//! [`Kinematic`](crate::mechanism::Kinematic) (a planar
//! toy in `tests/toy_topology.rs` runs through identification and a
//! sweep). Pure maths: no I/O, no randomness, no config.

pub mod geometry;
pub mod jacobian;
pub mod kinematic;
pub mod kinematics;
pub mod near;
pub mod params;
pub mod poses;
pub mod second_class;
pub mod topology;

pub use geometry::{Geometry, Machine};
pub use jacobian::{error_jacobian, ErrorJacobian};
pub use kinematics::{Joints, Pose, Reading};
pub use params::{ErrorVector, N_PARAMS, PAPER_ERRORS_MM, PARAM_NAMES};
pub use poses::{NominalPoses, Workspace};
pub use topology::{
    check_layout, check_pose, file_values, from_file_values, length_travel, Mechanism, Tricept,
    GAUGE_FIXED, LENGTH_READING, N_LEGS, N_READINGS, READINGS, SLOTS,
};
