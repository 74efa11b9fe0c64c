//! The Tricept 3-DOF parallel module: geometry, the 15 geometric errors and
//! exact kinematics (SPEC §2–§4; Hong 2009, eqs. 1–9).

pub mod geometry;
pub mod jacobian;
pub mod kinematics;
pub mod params;
pub mod poses;

pub use geometry::{Geometry, Machine};
pub use jacobian::{error_jacobian, ErrorJacobian};
pub use kinematics::{Joints, Pose};
pub use params::{ErrorVector, N_PARAMS, PAPER_ERRORS_MM, PARAM_NAMES};
