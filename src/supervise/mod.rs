//! Supervision: limit checks, fault states, and (later) model-based fault detection.

mod fault;
mod limits;

pub use fault::{FaultFlags, FaultKind, FaultState};
pub use limits::{Band, LimitSupervisor, Limits, SupervisionInput, SupervisionOutput};
