//! One file per command (the command line: README and docs/guide.md), each from a validated config.

pub mod compensate;
pub mod design_poses;
pub mod docs;
pub mod export;
pub mod general;
pub mod hexapod;
pub mod identifiability;
pub mod identify;
pub mod init;
pub mod merge;
pub mod reproduce;
pub mod simulate;
pub mod sweep;
pub mod sweep_checks;
pub mod verify;
