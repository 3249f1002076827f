//! Recursive least squares with exponential forgetting, covariance form.
//!
//! Per sample (Isermann & Raab 1993, recursive LS; λ the forgetting factor):
//! - `e(k) = y(k) - ψᵀ(k) θ̂(k-1)`
//! - `γ(k) = P(k-1) ψ(k) / (λ + ψᵀ(k) P(k-1) ψ(k))`
//! - `θ̂(k) = θ̂(k-1) + γ(k) e(k)`
//! - `P(k) = (I - γ(k) ψᵀ(k)) P(k-1) / λ`
//! - `z(k) = 1 - ψᵀ(k) γ(k) = λ / (λ + ψᵀ P ψ)`, the estimator eigenvalue.
//!
//! With λ < 1 and poor excitation `P` grows like `λ⁻ᵏ` in the unexcited directions
//! ("estimator wind-up") until it loses symmetry and positive definiteness or overflows. The
//! [`CovarianceGuard`] bounds it; for long unattended runs prefer the square-root form
//! [`super::dsfi::Dsfi`].
//!
//! Storage is allocated in the constructor; [`Rls::step`] does not allocate.

use nalgebra::DMatrix;

use super::error::{check_finite, check_len, IdentError};
use super::recursive::{RecursiveEstimator, RecursiveUpdate};

/// Protection of the covariance matrix against wind-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CovarianceGuard {
    /// No protection (the textbook form).
    None,
    /// Scale `P` down so that `trace(P) <= max_trace`.
    ClampTrace {
        /// Upper bound of `trace(P)`.
        max_trace: f64,
    },
    /// Reset `P` to the initial `p0 I` when `trace(P) > max_trace` or `P` becomes non-finite.
    ResetAbove {
        /// Trace above which the covariance is reset.
        max_trace: f64,
    },
}

/// Configuration of [`Rls`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsConfig {
    /// Forgetting factor λ in (0, 1]; 1 means no forgetting. The paper's pneumatic drive uses
    /// 0.975.
    pub forgetting: f64,
    /// Initial covariance `P(0) = p0 I`, large (e.g. 1e3..1e6 in units of θ²/y²) when little
    /// is known.
    pub initial_covariance: f64,
    /// Wind-up protection.
    pub guard: CovarianceGuard,
}

impl Default for RlsConfig {
    fn default() -> Self {
        Self {
            forgetting: 0.99,
            initial_covariance: 1e4,
            guard: CovarianceGuard::None,
        }
    }
}

pub(crate) fn validate_forgetting(lambda: f64) -> Result<(), IdentError> {
    if lambda > 0.0 && lambda <= 1.0 {
        Ok(())
    } else {
        Err(IdentError::InvalidParameter {
            name: "forgetting",
            reason: format!("forgetting factor must be in (0, 1], got {lambda}"),
        })
    }
}

/// Recursive least squares, covariance form, with forgetting factor.
#[derive(Debug, Clone)]
pub struct Rls {
    n: usize,
    config: RlsConfig,
    theta0: Vec<f64>,
    theta: Vec<f64>,
    /// Covariance, row-major `n × n`.
    p: Vec<f64>,
    /// Scratch `P ψ`.
    p_psi: Vec<f64>,
    steps: u64,
    guard_events: u64,
}

impl Rls {
    /// Estimator for `n` parameters starting at `θ̂ = 0`.
    pub fn new(n: usize, config: RlsConfig) -> Result<Self, IdentError> {
        Self::with_initial(&vec![0.0; n], config)
    }

    /// Estimator starting at `θ̂(0) = theta0`.
    pub fn with_initial(theta0: &[f64], config: RlsConfig) -> Result<Self, IdentError> {
        let n = theta0.len();
        if n == 0 {
            return Err(IdentError::InvalidParameter {
                name: "parameters",
                reason: "need at least one parameter".into(),
            });
        }
        validate_forgetting(config.forgetting)?;
        if !(config.initial_covariance > 0.0 && config.initial_covariance.is_finite()) {
            return Err(IdentError::InvalidParameter {
                name: "initial_covariance",
                reason: format!("must be finite and > 0, got {}", config.initial_covariance),
            });
        }
        match config.guard {
            CovarianceGuard::ClampTrace { max_trace }
            | CovarianceGuard::ResetAbove { max_trace }
                if max_trace.is_nan() || max_trace <= 0.0 =>
            {
                return Err(IdentError::InvalidParameter {
                    name: "max_trace",
                    reason: format!("must be > 0, got {max_trace}"),
                });
            }
            _ => {}
        }
        check_finite("initial estimate", theta0)?;
        let mut rls = Self {
            n,
            config,
            theta0: theta0.to_vec(),
            theta: theta0.to_vec(),
            p: vec![0.0; n * n],
            p_psi: vec![0.0; n],
            steps: 0,
            guard_events: 0,
        };
        rls.reset_covariance();
        Ok(rls)
    }

    /// Sets `P = p0 I` and keeps the estimate (restart of adaptation after a detected change).
    pub fn reset_covariance(&mut self) {
        self.p.fill(0.0);
        for i in 0..self.n {
            self.p[i * self.n + i] = self.config.initial_covariance;
        }
    }

    /// Sets the estimate to `theta0` and `P = p0 I`.
    pub fn reset_to(&mut self, theta0: &[f64]) -> Result<(), IdentError> {
        check_len("initial estimate", self.n, theta0.len())?;
        check_finite("initial estimate", theta0)?;
        self.theta.copy_from_slice(theta0);
        self.reset_covariance();
        Ok(())
    }

    /// Changes the forgetting factor λ ∈ (0, 1] (e.g. from the supervision level).
    pub fn set_forgetting(&mut self, lambda: f64) -> Result<(), IdentError> {
        validate_forgetting(lambda)?;
        self.config.forgetting = lambda;
        Ok(())
    }

    /// The configuration in use.
    pub fn config(&self) -> &RlsConfig {
        &self.config
    }

    /// Covariance `P(k)`, row-major `n × n`.
    pub fn covariance(&self) -> &[f64] {
        &self.p
    }

    /// Covariance as a matrix (allocates; for reporting).
    pub fn covariance_matrix(&self) -> DMatrix<f64> {
        DMatrix::from_row_slice(self.n, self.n, &self.p)
    }

    /// `trace(P(k))`.
    pub fn covariance_trace(&self) -> f64 {
        (0..self.n).map(|i| self.p[i * self.n + i]).sum()
    }

    /// Whether `P(k)` is finite, symmetric and positive definite (Cholesky test; allocates).
    pub fn is_positive_definite(&self) -> bool {
        self.p.iter().all(|v| v.is_finite()) && self.covariance_matrix().cholesky().is_some()
    }

    /// Samples processed since construction.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// How often the covariance guard intervened.
    pub fn guard_events(&self) -> u64 {
        self.guard_events
    }

    fn apply_guard(&mut self) -> bool {
        let finite = self.p.iter().all(|v| v.is_finite());
        let trace = self.covariance_trace();
        match self.config.guard {
            CovarianceGuard::None => false,
            CovarianceGuard::ClampTrace { max_trace } => {
                if !finite {
                    self.reset_covariance();
                    true
                } else if trace > max_trace {
                    let s = max_trace / trace;
                    self.p.iter_mut().for_each(|v| *v *= s);
                    true
                } else {
                    false
                }
            }
            CovarianceGuard::ResetAbove { max_trace } => {
                if !finite || trace > max_trace {
                    self.reset_covariance();
                    true
                } else {
                    false
                }
            }
        }
    }
}

impl RecursiveEstimator for Rls {
    fn parameters(&self) -> usize {
        self.n
    }

    fn step(&mut self, psi: &[f64], y: f64) -> Result<RecursiveUpdate, IdentError> {
        let n = self.n;
        check_len("regressor", n, psi.len())?;
        check_finite("regressor", psi)?;
        if !y.is_finite() {
            return Err(IdentError::NonFinite {
                what: "measurement",
            });
        }
        let lambda = self.config.forgetting;
        // P ψ and ψᵀ P ψ
        let mut psi_p_psi = 0.0;
        for i in 0..n {
            let row = &self.p[i * n..(i + 1) * n];
            let v: f64 = row.iter().zip(psi).map(|(a, b)| a * b).sum();
            self.p_psi[i] = v;
            psi_p_psi += psi[i] * v;
        }
        let prediction_error = y - psi.iter().zip(&self.theta).map(|(a, b)| a * b).sum::<f64>();
        let denom = lambda + psi_p_psi;
        // γ = Pψ / denom; θ += γ e
        for i in 0..n {
            self.theta[i] += self.p_psi[i] / denom * prediction_error;
        }
        // P = (P - Pψ ψᵀP / denom) / λ, kept symmetric.
        for i in 0..n {
            for j in i..n {
                let v = (self.p[i * n + j] - self.p_psi[i] * self.p_psi[j] / denom) / lambda;
                self.p[i * n + j] = v;
                self.p[j * n + i] = v;
            }
        }
        let eigenvalue = lambda / denom;
        let guarded = self.apply_guard();
        if guarded {
            self.guard_events += 1;
        }
        self.steps += 1;
        Ok(RecursiveUpdate {
            prediction_error,
            posterior_error: eigenvalue * prediction_error,
            eigenvalue,
            guarded,
        })
    }

    fn theta(&self) -> &[f64] {
        &self.theta
    }

    fn reset(&mut self) {
        self.theta.copy_from_slice(&self.theta0);
        self.reset_covariance();
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
mod tests {
    use super::*;
    use crate::ident::least_squares;
    use crate::ident::testutil::TestRng;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn without_forgetting_converges_to_batch_least_squares() {
        let mut rng = TestRng::new(11);
        let n = 500;
        let theta_true = [0.8, -1.5, 0.3];
        let rows: Vec<[f64; 3]> = (0..n).map(|_| [rng.normal(), rng.normal(), 1.0]).collect();
        let ys: Vec<f64> = rows
            .iter()
            .map(|r| {
                r.iter().zip(theta_true).map(|(a, b)| a * b).sum::<f64>() + 0.05 * rng.normal()
            })
            .collect();
        let mut rls = Rls::new(
            3,
            RlsConfig {
                forgetting: 1.0,
                initial_covariance: 1e8,
                guard: CovarianceGuard::None,
            },
        )
        .expect("valid config");
        for (r, y) in rows.iter().zip(&ys) {
            rls.step(r, *y).expect("finite data");
        }
        let psi = DMatrix::from_fn(n, 3, |k, j| rows[k][j]);
        let fit = least_squares(&psi, &DVector::from_vec(ys)).expect("full rank");
        for j in 0..3 {
            assert!((rls.theta()[j] - fit.theta[j]).abs() < 1e-5, "{j}");
            assert!((rls.theta()[j] - theta_true[j]).abs() < 0.02);
        }
        // Covariance form P ≈ (ΨᵀΨ)⁻¹ ≈ cov / σ²
        let p00 = rls.covariance()[0];
        let ratio = p00 * fit.residual_variance / fit.covariance[(0, 0)];
        assert!((ratio - 1.0).abs() < 1e-3, "ratio {ratio}");
        assert!(rls.is_positive_definite());
    }

    #[test]
    fn forgetting_tracks_a_parameter_jump_and_eigenvalue_reflects_excitation() {
        let mut rng = TestRng::new(5);
        let mut rls = Rls::new(
            2,
            RlsConfig {
                forgetting: 0.975,
                ..RlsConfig::default()
            },
        )
        .expect("valid config");
        let mut k_i = 0.030; // integrator gain, m/s
        let t0 = 0.02;
        let mut last = None;
        for k in 0..600 {
            if k == 300 {
                k_i = 0.012;
            }
            let u = if k % 7 < 3 { 1.0 } else { -0.6 } + 0.1 * rng.normal();
            let dy = k_i * t0 * u + 0.002 * 1e-3 + 1e-5 * rng.normal();
            last = Some(rls.step(&[t0 * u, 1.0], dy).expect("finite"));
        }
        assert!(
            (rls.theta()[0] - 0.012).abs() < 0.0005,
            "K_I estimate {}",
            rls.theta()[0]
        );
        let z = last.expect("ran").eigenvalue;
        assert!(z > 0.9 && z < 1.0, "z = {z}");
        // The first step after a reset learns a lot: small eigenvalue.
        rls.reset();
        let up = rls.step(&[t0, 1.0], 0.0).expect("finite");
        assert!(up.eigenvalue < 1e-3);
        assert_eq!(rls.theta(), &[0.0, 0.0][..]);
    }

    #[test]
    fn guard_bounds_covariance_and_rejects_bad_input() {
        let cfg = RlsConfig {
            forgetting: 0.9,
            initial_covariance: 1.0,
            guard: CovarianceGuard::ClampTrace { max_trace: 50.0 },
        };
        let mut rls = Rls::new(2, cfg).expect("valid");
        for _ in 0..1000 {
            rls.step(&[1.0, 1.0], 2.0).expect("finite");
            assert!(rls.covariance_trace() <= 50.0 + 1e-9);
        }
        assert!(rls.guard_events() > 0);
        assert!(rls.is_positive_definite());
        let before = rls.theta().to_vec();
        assert!(rls.step(&[f64::NAN, 1.0], 1.0).is_err());
        assert!(rls.step(&[1.0], 1.0).is_err());
        assert_eq!(rls.theta(), &before[..]);
        assert!(Rls::new(
            2,
            RlsConfig {
                forgetting: 1.2,
                ..cfg
            }
        )
        .is_err());
    }
}
