//! The runtime: configuration, the real-time cycle, the controller node, recording.
//! It wires the layers below and has no maths of its own.

pub mod axis;
pub mod axis_section;
pub mod bus_load;
pub mod config;
pub mod config_reference;
pub mod cycle;
pub mod dictionary;
pub mod learned;
pub mod node;
pub mod node_sections;
pub mod notify;
pub mod profile_config;
pub mod profile_dbc;
pub mod profile_homing;
pub mod profile_link;
pub mod profile_rejoin;
pub mod profile_setup;
pub mod reconfigure;
pub use crate::recording::record;
pub mod record_dir;
pub mod recorder;
pub mod rt;
pub mod slot;
pub mod state;

pub use config::Config;
pub use cycle::{
    run_cycle, run_cycle_with, CycleReport, CycleRunner, CycleServices, CycleSettings,
};
pub use node::ControllerNode;
pub use recorder::{RecordSink, Recorder, RecorderReport};
