//! Robust control after Bao, Mao & Luo (2016): the multi-state `motor_gear` model with its
//! perturbations separated (descriptor form, `δ_i ∈ [-1, 1]`), H∞ mixed-sensitivity synthesis
//! by the two-Riccati formulae with the γ-iteration, balanced truncation, Tustin
//! discretisation, and the discrete state-space controller that runs once per cycle.
//!
//! Layout:
//! - [`lti`]: state-space systems, frequency response, H∞ norm, LFT, discretisation;
//! - [`riccati`]: CARE by the matrix sign function with Newton refinement, Lyapunov/Sylvester;
//! - [`hinf`]: generalised plant, existence conditions, central controller, γ-iteration;
//! - [`reduce`]: balanced truncation;
//! - [`model`]: nominal model and perturbation structure from a `motor_gear` plant file;
//! - [`synthesis`]: the weights and the whole design chain with its checks;
//! - [`controller`]: [`StateSpaceController`] and `controller.toml`.
//!
//! Only [`StateSpaceController`] runs per cycle (allocation-free); the rest is design time.

pub mod controller;
mod error;
pub mod hinf;
pub mod lti;
pub mod model;
pub mod reduce;
pub mod riccati;
pub mod synthesis;

pub use controller::{StateSpaceConfig, StateSpaceController, MAX_STATES};
pub use error::RobustError;
pub use hinf::{
    hinf_controller, hinf_feasible, hinfsyn, GeneralizedPlant, HinfOptions, HinfSolution,
};
pub use lti::Ss;
pub use model::{Envelope, MotorGearParams, UncertainModel};
pub use synthesis::{
    sampled_loop_spectral_radius, synthesize, synthesize_for_spec, DesignOptions, RobustSynthesis,
};
