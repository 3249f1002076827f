//! A simulated actuator node: a physics plant behind the CANopen-style protocol.

mod node;
pub mod profile;
mod run;

pub use node::{SimCounters, SimEvent, SimNode};
pub use profile::{DriveFault, Profile, ProfileNode};
pub use run::run_sim_node;
