//! Control algorithms, sans-I/O and allocation-free per cycle.

mod discrete;
mod friction_ff;

pub use discrete::{ControllerError, DiscreteController, MAX_ORDER};
pub use friction_ff::FrictionFeedForward;
