//! Identification (docs/method.md §6; paper eqs. 10–12).
//!
//! Observation at pose j (eq. 10, formed in [`crate::sensors`]):
//! l_j = (J_j − J_0)·Δε; stacked, l = H·Δε (eq. 11, [`design`]) and solved by
//! least squares (eq. 12, [`linear`]) through an SVD of the
//! column-equilibrated (and, for WLS, row-weighted) H, never by inverting
//! HᵀH. Rank is decided on that SVD after numerically zero columns are
//! removed ([`analysis`]), so neither column scale nor a column of round-off
//! can fake an identifiable parameter. [`gauss_newton`] re-linearises at the
//! estimate and names why it stopped.

pub mod analysis;
pub mod constraints;
pub mod curves;
pub mod design;
pub mod estimate;
pub mod gauss_newton;
pub mod general;
pub mod linear;
pub mod method;
pub mod repeats;
pub mod second_class;
pub mod tricept;
pub mod weighting;

pub use analysis::{analyse_named, Identifiability, Observability};
pub use design::{design_of, stack_differences};
pub use estimate::{estimate_of, EstimateOf, Split, Termination};
pub use gauss_newton::{gauss_newton, identify_poses, Linearisation};
pub use linear::{Constraints, Solver};
pub use method::{IdentifyOptions, Method};
pub use weighting::Weighting;
