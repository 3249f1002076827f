//! Plant families. The three linear families share one body ([`body::BodyPlant`]) and differ in
//! their drive; `motor_gear` has its own multi-body model.

pub mod body;
pub mod linear_axis;
pub mod motor_gear;
pub mod pneumatic;
pub mod solenoid;
