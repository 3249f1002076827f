//! What every recursive estimator reports per step, and the trait that lets the adaptive
//! controller and the lab swap the covariance form ([`super::rls::Rls`]) for the square-root
//! form ([`super::dsfi::Dsfi`]).

use super::error::IdentError;

/// Outcome of one recursive update with regressor `ψ(k)` and measurement `y(k)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecursiveUpdate {
    /// A-priori prediction error `e(k) = y(k) - ψᵀ(k) θ̂(k-1)`.
    pub prediction_error: f64,
    /// A-posteriori error `ε(k) = y(k) - ψᵀ(k) θ̂(k) = z(k) e(k)`.
    pub posterior_error: f64,
    /// Estimator eigenvalue / a-priori error gain `z(k) = 1 - ψᵀ(k) γ(k)` (Isermann & Raab
    /// 1993, monitored by the supervision level). In `(0, 1]`: near 1 the step taught nothing
    /// new (poor excitation), near 0 the new sample dominates the estimate.
    pub eigenvalue: f64,
    /// True when the covariance guard clipped or reset the covariance in this step.
    pub guarded: bool,
}

/// A recursive least-squares estimator of `θ` in `y(k) = ψᵀ(k) θ + e(k)`.
pub trait RecursiveEstimator {
    /// Number of parameters.
    fn parameters(&self) -> usize;
    /// Processes one sample. Allocation-free. On error (wrong length, non-finite data) the
    /// state is left unchanged.
    fn step(&mut self, psi: &[f64], y: f64) -> Result<RecursiveUpdate, IdentError>;
    /// Current estimate `θ̂(k)`.
    fn theta(&self) -> &[f64];
    /// Restarts from the initial estimate and covariance given at construction.
    fn reset(&mut self);
}
