// Numerical code indexes parallel arrays (poses, rows, parameters) by one
// index; iterator chains would hide the equation being implemented.
#![allow(clippy::needless_range_loop)]

//! tricept-calib: self-calibration of a Tricept-type parallel module from
//! its passive-limb sensors (Hong Zhenyu, Acta Aeronautica et Astronautica
//! Sinica 30(4), 2009), with Monte-Carlo studies of the sensor grades.
//!
//! Data flows one way: [`config`] → [`model`] → [`sensors`] (simulated or
//! measured readings) → [`identify`] → [`compensate`] / metrics → [`export`].

pub mod error;
pub mod model;

pub use error::{Error, KinematicsError, Result};
pub mod cli;
pub mod compensate;
pub mod config;
pub mod design;
pub mod export;
pub mod identify;
pub mod io;
pub mod report;
pub mod sensors;
pub mod sweep;
