//! The Tricept 3-DOF parallel module: geometry, the 15 geometric errors and
//! exact kinematics (SPEC §2–§4; Hong 2009, eqs. 1–9).
//!
//! This folder is the only topology-specific code: everything above it sees
//! the machine through [`Machine`] (IK, FK, the error Jacobian), the
//! [`ErrorVector`] of its geometric errors and the passive-limb [`Joints`]
//! its sensors read. Another parallel module would be another folder with
//! the same boundary. Pure maths: no I/O, no randomness, no config.

pub mod geometry;
pub mod jacobian;
pub mod kinematics;
pub mod near;
pub mod params;
pub mod poses;

pub use geometry::{Geometry, Machine};
pub use jacobian::{error_jacobian, ErrorJacobian};
pub use kinematics::{Joints, Pose};
pub use params::{ErrorVector, N_PARAMS, PAPER_ERRORS_MM, PARAM_NAMES};
pub use poses::{NominalPoses, Workspace};
