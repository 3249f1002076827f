//! The objects of an actuatord node in the dictionary: the CiA 301 communication objects it
//! serves and one manufacturer block per axis, built with the stack's dictionary machinery.

pub mod axis_intelligence;
mod axis_keys;
mod daemon_objects;

pub use axis_keys::{AxisKeys, SetpointKeys};
pub use daemon_objects::{
    consumer_heartbeat_entry, daemon_dictionary, index, AxisParameters, CommandKind,
    DeviceParameters, MAX_AXES,
};

#[cfg(test)]
mod eds_tests;
#[cfg(test)]
mod tests;
