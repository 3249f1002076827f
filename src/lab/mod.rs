//! The model lab: compare a model with measurements, see where it fails, learn which physical
//! effect is missing, add it and watch the error fall.
//!
//! ```text
//! MCAP or CSV ─▶ data ─▶ model (family + effects) ─▶ compare (free_run, k_step, inverse_dynamics)
//!             ─▶ residuals ─▶ regimes + residual tests ─▶ diagnose (which effect is missing)
//!             ─▶ fit (add it, refit) ─▶ report (plots, before/after)
//! ```
//!
//! | file | job |
//! |---|---|
//! | [`data`] | CSV and MCAP data sets, column mapping, errors with file/row/column |
//! | [`model`] | model files (`config/models/*.toml`) and `--family F --with a,b` |
//! | [`params`] | a model's parameters named once in code and resolved to handles; an unknown name is an error |
//! | [`command`] | what the `u` column is (`--command`), per family |
//! | [`signals`] | zero-phase filtering and derivatives for the regression |
//! | [`drive`] | the drive constants the data determine, and the declared ones they contradict |
//! | [`effects`] | each effect's lab side, one file each: when representable, columns, grid, power stage, evidence |
//! | [`regress`] | inverse-dynamics regression: the balance of forces, linear in its parameters |
//! | [`regress_gear`] | the same for `motor_gear`: the load balance with the torque the gear transmits |
//! | [`motion`] | the balance where the body sticks and slips: moving samples masked to where it surely slides |
//! | [`compare`] | prediction modes and the fit / NRMSE / RMSE of a model |
//! | [`regimes`] | error by regime and residual tests: where a model fails |
//! | [`structure`] | the residual mapped against every signal; structure no effect of the catalogue makes (periodic in position, an oscillation, a drift) |
//! | [`predict`] | whether a model predicts motion: its k-step prediction of held-out samples against coasting |
//! | [`collapse`] | a fit that collapsed (a parameter at a bound it cannot reach, a vanished residual): refused |
//! | [`diagnose`] | candidate effects, their refit, penalised ranking and verdict |
//! | [`undecided`] | candidates the record cannot tell apart (Vuong's test), and the record that would |
//! | [`story`] | several records of one machine: each diagnosed alone beside the joint answer, the effects in every record and in some |
//! | [`discover`] | diagnose, add the verdict, refit, repeat: the ladder of effects |
//! | [`methods`] | the identification methods of `fit`: least squares, recursive, output error |
//! | [`report`] | HTML page with SVG plots |
//! | [`cli`] | the `actuator compare / diagnose / discover / fit / report` commands |
//!
//! The lab uses the physics and identification layers and reads the daemon's recordings; it
//! never uses the runtime otherwise.

pub mod collapse;
pub mod command;
pub mod compare;
pub mod data;
pub mod diagnose;
pub mod discover;
pub mod drive;
pub mod effects;
#[cfg(test)]
mod fixtures;
pub mod methods;
pub mod model;
pub mod motion;
pub mod params;
pub mod predict;
pub mod regimes;
pub mod regress;
pub mod regress_gear;
pub mod report;
pub mod signals;
pub mod story;
pub mod structure;
mod svg;
pub mod terms;
pub mod undecided;

pub use command::Command;
pub use compare::{compare, Comparison, Mode};
pub use data::{Columns, Dataset};
pub use diagnose::{diagnose, Candidate, DiagnoseOptions, Diagnosis};
pub use methods::{fit_model, FitMethod, FitOptions, MethodFit};
pub use model::Model;
