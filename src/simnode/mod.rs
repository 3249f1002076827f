//! A simulated actuator node: a physics plant behind the CANopen-style protocol.

mod node;
mod run;

pub use node::{SimCounters, SimEvent, SimNode};
pub use run::run_sim_node;
