//! Helpers shared by the integration tests, one module per kind of rig.
#![allow(dead_code)]

pub mod lockstep;
pub mod paths;
pub mod vcan;
