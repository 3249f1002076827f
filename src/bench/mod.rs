//! Benchmarks a user runs with `actuator bench ...`: measurements printed beside their
//! reference figures, never asserted in tests.
//!
//! - [`paper`]: closed-loop simulations of the physics plants with the intelligent-actuator
//!   algorithms, in lock-step at the papers' sampling times (no bus), beside the papers' figures.
//! - [`fault_table`]: the fault-symptom table of the parameter diagnosis, derived from
//!   simulations of the solenoid with each fault (`actuator bench fault-table`).
//! - [`rt`]: how well the real-time cycle keeps time, against a naive baseline.
//! - [`soak`]: the daemon and a simulated node as processes for minutes of floods, outages,
//!   reloads, SDO writes and stalls: crashes, memory, periods, faults and records.
//! - [`supply`]: parameter scheduling on the measured supply against fixed gains.

pub mod fault_table;
pub mod paper;
pub mod rt;
pub mod soak;
pub mod supply;

pub use paper::{run_paper_bench, PaperRow, PaperTable};
