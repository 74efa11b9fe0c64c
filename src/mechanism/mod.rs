//! Mechanisms other than the Tricept, each a folder of its own.
//!
//! The Tricept's model still lives in [`crate::model`] and the pipeline
//! around it; the hexapod (6-UPS Gough–Stewart platform self-calibrated
//! from its legs' base U-joint encoders, docs/method.md §20) is built
//! here, self-contained: its geometry and errors, exact kinematics and
//! readings, the convention that fixes what no internal sensor sees, the
//! design matrix and identification, and its config. It imports the
//! shared numerical pieces (the rank analysis) and nothing of the Tricept.

pub mod hexapod;
