//! `actuator tune`: from a fitted model (the lab's model file with its intervals) and an axis
//! configuration, the axis configuration for the identified plant.
//!
//! Isermann & Raab's intelligent actuator designs its controller from the identified
//! direction-dependent models (its PIDT1 for the slower direction, the other one checked) and
//! starts its friction compensation and supervision from the identified parameters. Here:
//!
//! | file | job |
//! |---|---|
//! | [`fitted`] | the fitted model file and its 95 % intervals |
//! | [`plant`] | the linear model per direction (a geared drive's also flexible), the corners of the intervals |
//! | [`design`] | pole placement of the daemon's discrete controller; poles, step, margins |
//! | [`edit`] | writing values into the configuration, keeping its comments; what changed |
//! | [`axis`] | the whole tuning of one axis: design, robustness, friction, supervision, schedule |
//! | [`pneumatic`] | a pneumatic axis: its drive gains per supply point for the daemon's direction P design |
//! | [`predict`] | a configuration run in lock step on the fitted model over the tour: its figures |
//! | [`choice`] | designs judged by prediction: the best against the given configuration, never worse |
//! | [`search`] | the designs an electromechanical axis' search tries |
//! | [`pneumatic_search`] | the poles a pneumatic schedule's search tries, at every supply point |
//!
//! The layer uses the lab (model files), the daemon's configuration (its types and validation)
//! and the control layer's linear systems; nothing uses it but the `actuator` binary.

pub mod axis;
pub mod choice;
pub mod design;
pub mod edit;
pub mod fitted;
pub mod keys;
pub mod plant;
pub mod pneumatic;
pub mod pneumatic_search;
pub mod predict;
pub mod search;

pub use axis::{regenerate_fault_table, robust_plant_file, tune, Goal, TuneOptions, Tuning};
pub use choice::{Choice, Objective};
pub use fitted::Fitted;
pub use pneumatic::{tune_pneumatic, PneumaticTuning};
pub use pneumatic_search::choose_pneumatic;
pub use predict::{predict, Tour};
pub use search::{choose, Aim};
