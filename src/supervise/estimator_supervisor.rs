//! Supervision of a recursive estimator (Isermann & Raab, parameter-adaptive control: "a
//! supervision/coordination level that starts estimation only when excitation is sufficient and
//! checks the estimator"; the estimator eigenvalue `z(k) = 1 - ψᵀ(k) γ(k)` is monitored).
//!
//! - excitation: estimate only when `|u| >= u_min` and `|Δy| >= Δy_min` (the caller asks
//!   [`EstimatorSupervisor::excited`] before feeding the estimator);
//! - convergence: valid after `n_min` updates with `z >= z_valid` (a new sample no longer moves the
//!   estimate much); a `z < z_valid` afterwards (the information has decayed, the estimate moves
//!   again) counts the updates from zero;
//! - plausibility: every parameter inside its band `[θ_min, θ_max]`, else implausible, and the
//!   caller falls back to its scheduled parameters.

use crate::ident::RecursiveUpdate;
use crate::param::ParamError;

/// Largest number of supervised parameters.
pub const MAX_SUPERVISED: usize = 4;

/// Configuration of [`EstimatorSupervisor`].
#[derive(Debug, Clone, PartialEq)]
pub struct EstimatorSupervisorConfig {
    /// `u_min` (input unit).
    pub min_input: f64,
    /// `Δy_min` (output unit per sample).
    pub min_output_step: f64,
    /// `n_min`, updates before an estimate may be used (the paper: valid after 3–4 samples).
    pub min_updates: u32,
    /// `z_valid` in (0, 1).
    pub eigenvalue_valid: f64,
    /// Plausibility band per parameter, `(θ_min, θ_max)`; parameters beyond the list are not checked.
    pub plausible: Vec<(f64, f64)>,
}

/// What the supervision says about the estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EstimatorHealth {
    /// No update yet.
    #[default]
    Idle,
    /// Updating, not yet `n_min` updates with `z >= z_valid`.
    Converging,
    /// Converged and plausible: use it.
    Valid,
    /// Outside its plausibility band or a non-finite step: do not use it.
    Implausible,
}

/// Estimator supervision. `observe` and `excited` are allocation-free.
#[derive(Debug, Clone)]
pub struct EstimatorSupervisor {
    min_input: f64,
    min_output_step: f64,
    min_updates: u32,
    eigenvalue_valid: f64,
    bands: [(f64, f64); MAX_SUPERVISED],
    n_bands: usize,
    good_updates: u32,
    health: EstimatorHealth,
    last_eigenvalue: f64,
}

impl EstimatorSupervisor {
    pub fn new(config: &EstimatorSupervisorConfig) -> Result<Self, ParamError> {
        if !(config.min_input >= 0.0 && config.min_input.is_finite()) {
            return Err(ParamError::new("min_input", "must be finite and >= 0"));
        }
        if !(config.min_output_step >= 0.0 && config.min_output_step.is_finite()) {
            return Err(ParamError::new(
                "min_output_step",
                "must be finite and >= 0",
            ));
        }
        if !(config.eigenvalue_valid > 0.0 && config.eigenvalue_valid < 1.0) {
            return Err(ParamError::new(
                "eigenvalue_valid",
                format!("must be in (0, 1), got {}", config.eigenvalue_valid),
            ));
        }
        if config.plausible.len() > MAX_SUPERVISED {
            return Err(ParamError::new(
                "plausible",
                format!("at most {MAX_SUPERVISED} bands"),
            ));
        }
        let mut bands = [(f64::NEG_INFINITY, f64::INFINITY); MAX_SUPERVISED];
        for (i, &(lo, hi)) in config.plausible.iter().enumerate() {
            if lo.is_nan() || hi.is_nan() || lo >= hi {
                return Err(ParamError::new(
                    "plausible",
                    format!("band {i} needs min < max, got [{lo}, {hi}]"),
                ));
            }
            bands[i] = (lo, hi);
        }
        Ok(Self {
            min_input: config.min_input,
            min_output_step: config.min_output_step,
            min_updates: config.min_updates.max(1),
            eigenvalue_valid: config.eigenvalue_valid,
            bands,
            n_bands: config.plausible.len(),
            good_updates: 0,
            health: EstimatorHealth::Idle,
            last_eigenvalue: 1.0,
        })
    }

    /// Sufficient excitation: `|u| >= u_min` and `|Δy| >= Δy_min`.
    pub fn excited(&self, input: f64, output_step: f64) -> bool {
        input.abs() >= self.min_input && output_step.abs() >= self.min_output_step
    }

    /// Judge the estimator after one update with its new estimate.
    pub fn observe(&mut self, update: &RecursiveUpdate, theta: &[f64]) -> EstimatorHealth {
        self.last_eigenvalue = update.eigenvalue;
        if !update.eigenvalue.is_finite() || theta.iter().any(|t| !t.is_finite()) {
            self.good_updates = 0;
            self.health = EstimatorHealth::Implausible;
            return self.health;
        }
        if update.eigenvalue >= self.eigenvalue_valid {
            self.good_updates = self.good_updates.saturating_add(1);
        } else {
            self.good_updates = 0;
        }
        let plausible = theta
            .iter()
            .zip(&self.bands[..self.n_bands])
            .all(|(t, (lo, hi))| t >= lo && t <= hi);
        self.health = if !plausible {
            EstimatorHealth::Implausible
        } else if self.good_updates >= self.min_updates {
            EstimatorHealth::Valid
        } else {
            EstimatorHealth::Converging
        };
        self.health
    }

    /// The judgement of the last update.
    pub fn health(&self) -> EstimatorHealth {
        self.health
    }

    /// `z` of the last update.
    pub fn last_eigenvalue(&self) -> f64 {
        self.last_eigenvalue
    }

    /// Back to idle (estimation restarted).
    pub fn reset(&mut self) {
        self.good_updates = 0;
        self.health = EstimatorHealth::Idle;
        self.last_eigenvalue = 1.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn upd(z: f64) -> RecursiveUpdate {
        RecursiveUpdate {
            prediction_error: 0.0,
            posterior_error: 0.0,
            eigenvalue: z,
            guarded: false,
        }
    }

    fn sup() -> EstimatorSupervisor {
        EstimatorSupervisor::new(&EstimatorSupervisorConfig {
            min_input: 0.1,
            min_output_step: 1e-6,
            min_updates: 3,
            eigenvalue_valid: 0.5,
            plausible: vec![(0.005, 0.1)],
        })
        .expect("valid")
    }

    #[test]
    fn valid_after_enough_informative_updates_and_implausible_outside_the_band() {
        let mut s = sup();
        assert_eq!(s.health(), EstimatorHealth::Idle);
        assert!(!s.excited(0.05, 1e-5));
        assert!(s.excited(-0.5, -1e-5));
        assert_eq!(s.observe(&upd(0.1), &[0.03]), EstimatorHealth::Converging);
        assert_eq!(s.observe(&upd(0.6), &[0.03]), EstimatorHealth::Converging);
        assert_eq!(s.observe(&upd(0.7), &[0.03]), EstimatorHealth::Converging);
        assert_eq!(s.observe(&upd(0.8), &[0.03]), EstimatorHealth::Valid);
        assert_eq!(s.observe(&upd(0.9), &[0.3]), EstimatorHealth::Implausible);
        assert_eq!(
            s.observe(&upd(0.9), &[f64::NAN]),
            EstimatorHealth::Implausible
        );
        assert_eq!(s.observe(&upd(0.2), &[0.03]), EstimatorHealth::Converging);
    }
}
