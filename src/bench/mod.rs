//! Benchmarks a user runs with `actuator bench ...`: measurements printed beside their
//! reference figures, never asserted in tests.

pub mod rt;
