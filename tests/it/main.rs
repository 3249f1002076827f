//! The integration tests, in one binary: the crate is linked once and the tests of every
//! module share the test threads. The vcan suites (`tests/vcan.rs`, `tests/vcan_profiles.rs`)
//! run apart, inside the user-mode kernel, and `tests/alloc_free.rs` apart because it installs
//! a counting global allocator. Run one module with `cargo test --test it MODULE::`.

#[path = "../common/mod.rs"]
mod common;
mod lab_common;
mod lab_indep;
#[path = "../robust_common/mod.rs"]
mod robust_common;
mod sdo_common;

mod cli;
mod closed_loop;
mod dbc;
mod deb;
mod declared_section;
mod demo;
mod error_history;
mod friction_stick_slip;
mod intel_bench;
mod intel_daemon;
mod intel_state;
mod lab_discover;
mod lab_drive;
mod lab_fit_methods;
mod lab_gear_own_sim;
mod lab_gear_torque;
mod lab_gear_voltage;
mod lab_hidden_effects;
mod lab_independent;
mod lab_pneumatic_gains;
mod lab_real_cylinder;
mod lab_supply;
mod lab_terms;
mod lab_walkthrough;
mod layering;
mod node_fuzz;
mod physics_linear_axis;
mod physics_motor_gear;
mod physics_plant_files;
mod physics_pneumatic;
mod physics_solenoid;
mod physics_speed;
mod physics_terms;
mod profiles_lockstep;
mod quick_stop;
mod reconfigure;
mod recording;
mod robust_comparison;
mod robust_daemon;
mod robust_design;
mod robust_hinf;
mod sdo_eds;
mod sdo_fuzz;
mod sdo_roundtrip;
mod setpoint_timeout;
mod startup;
mod supply_schedule;
mod systemd_unit;
mod tune_loop;
mod tune_never_loses;
