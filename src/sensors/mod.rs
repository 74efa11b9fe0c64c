//! Passive-limb sensors (docs/method.md §5): the only place where noise and sensor
//! errors enter a reading ([`noise`]) and where the observation l of eq. 10
//! is formed ([`observation`]).

pub mod batch;
pub mod covariance;
pub mod factored;
mod jitter;
pub mod noise;
mod normal;
pub mod observation;
pub mod structured;
pub mod trig;
mod units;
mod what_if;

pub use batch::{draws_alike, MachineDraws};
pub use covariance::{observation_covariance, SensorCovariance};
pub use factored::{ObservationCovariance, Whitening};
pub use noise::{homed_noise, homed_unit_noise, GradeReading, SensorModel, ARCSEC_PER_RAD};
pub use observation::{homed_readings, noisy_observation, observation_into, observation_vector};
pub use structured::{Axis, JitterTable, Phases, Structured};
pub use what_if::ErrorTerm;
