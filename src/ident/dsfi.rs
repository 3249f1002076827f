//! DSFI: discrete square-root filter in information form (Kaminski, Bryson & Schmidt 1971;
//! the recursive estimator of Isermann & Raab 1993 for the pneumatic drive, λ = 0.975).
//!
//! Instead of the covariance `P`, the estimator keeps an upper-triangular square root `R` of the
//! information matrix, `P⁻¹ = RᵀR`, and the transformed right-hand side `b = R θ̂`. One step:
//! - `e(k) = y(k) - ψᵀ(k) θ̂(k-1)` (a-priori error);
//! - forgetting `[R; bᵀ] ← √λ [R; bᵀ]` (information `λ P⁻¹`);
//! - optional information floor: append the `n` rows `√((1-λ)δ) [e_iᵀ | θ̂_i(k-1)]`, which keeps
//!   `P⁻¹ ≥ δ I` in steady state without moving the estimate (they agree with `θ̂(k-1)`);
//! - append the row `[ψᵀ(k) | y(k)]` and restore the triangle by Givens rotations;
//! - back-substitution `R θ̂(k) = b`.
//!
//! `R` only ever sees orthogonal transformations and a positive scaling, so `RᵀR` is positive
//! (semi)definite by construction, whatever the rounding; the floor keeps it definite and the
//! numbers bounded when the excitation vanishes for millions of steps. The estimator eigenvalue is
//! the product of the rotation cosines, `z(k) = Π c_j² = 1 - ψᵀ(k) γ(k)`.
//!
//! Storage is allocated in the constructor; [`Dsfi::step`] does not allocate. Cost per step is
//! `O(n²)`, or `O(n³)` with the floor enabled (n is small for adaptive control).

use nalgebra::DMatrix;

use super::error::{check_finite, check_len, IdentError};
use super::recursive::{RecursiveEstimator, RecursiveUpdate};
use super::rls::validate_forgetting;

/// Configuration of [`Dsfi`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DsfiConfig {
    /// Forgetting factor λ in (0, 1].
    pub forgetting: f64,
    /// Initial covariance `P(0) = p0 I`, i.e. `R(0) = I / √p0`.
    pub initial_covariance: f64,
    /// Information floor δ > 0 (units of `P⁻¹ = Σ ψψᵀ`, i.e. of ψ²): with forgetting, the information
    /// in unexcited directions decays towards δ instead of to zero, so `P ≤ I/δ` in steady state.
    /// `None` disables it (then `R` decays like `λ^{k/2}` in unexcited directions and eventually
    /// underflows; the estimate of such directions is then held). Default `Some(1e-6)`.
    pub information_floor: Option<f64>,
}

impl Default for DsfiConfig {
    fn default() -> Self {
        Self {
            forgetting: 0.99,
            initial_covariance: 1e4,
            information_floor: Some(1e-6),
        }
    }
}

/// Square-root information-form recursive least squares.
#[derive(Debug, Clone)]
pub struct Dsfi {
    n: usize,
    config: DsfiConfig,
    theta0: Vec<f64>,
    theta: Vec<f64>,
    /// Upper-triangular information square root, row-major `n × n`.
    r: Vec<f64>,
    /// `b = R θ̂`.
    b: Vec<f64>,
    /// Scratch row for the rotations.
    row: Vec<f64>,
    /// Exponentially weighted residual sum of squares `V(k) = λ V(k-1) + ρ²(k)`.
    loss: f64,
    steps: u64,
}

impl Dsfi {
    /// Estimator for `n` parameters starting at `θ̂ = 0`.
    pub fn new(n: usize, config: DsfiConfig) -> Result<Self, IdentError> {
        Self::with_initial(&vec![0.0; n], config)
    }

    /// Estimator starting at `θ̂(0) = theta0`.
    pub fn with_initial(theta0: &[f64], config: DsfiConfig) -> Result<Self, IdentError> {
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
        if let Some(d) = config.information_floor {
            if !(d > 0.0 && d.is_finite()) {
                return Err(IdentError::InvalidParameter {
                    name: "information_floor",
                    reason: format!("must be finite and > 0, got {d}"),
                });
            }
        }
        check_finite("initial estimate", theta0)?;
        let mut est = Self {
            n,
            config,
            theta0: theta0.to_vec(),
            theta: theta0.to_vec(),
            r: vec![0.0; n * n],
            b: vec![0.0; n],
            row: vec![0.0; n],
            loss: 0.0,
            steps: 0,
        };
        est.reset_covariance();
        Ok(est)
    }

    /// Sets `P = p0 I` (i.e. `R = I/√p0`), keeping the estimate.
    pub fn reset_covariance(&mut self) {
        let d = 1.0 / self.config.initial_covariance.sqrt();
        self.r.fill(0.0);
        for i in 0..self.n {
            self.r[i * self.n + i] = d;
            self.b[i] = d * self.theta[i];
        }
        self.loss = 0.0;
    }

    /// Sets the estimate to `theta0` and `P = p0 I`.
    pub fn reset_to(&mut self, theta0: &[f64]) -> Result<(), IdentError> {
        check_len("initial estimate", self.n, theta0.len())?;
        check_finite("initial estimate", theta0)?;
        self.theta.copy_from_slice(theta0);
        self.reset_covariance();
        Ok(())
    }

    /// Changes the forgetting factor λ ∈ (0, 1].
    pub fn set_forgetting(&mut self, lambda: f64) -> Result<(), IdentError> {
        validate_forgetting(lambda)?;
        self.config.forgetting = lambda;
        Ok(())
    }

    /// The configuration in use.
    pub fn config(&self) -> &DsfiConfig {
        &self.config
    }

    /// Upper-triangular information square root `R`, row-major `n × n` (`P⁻¹ = RᵀR`).
    pub fn information_sqrt(&self) -> &[f64] {
        &self.r
    }

    /// Exponentially weighted residual sum of squares `V(k)`.
    pub fn loss(&self) -> f64 {
        self.loss
    }

    /// Samples processed since construction.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// True when all entries of `R` are finite and its diagonal is strictly positive, which makes
    /// `P = (RᵀR)⁻¹` symmetric positive definite.
    pub fn is_positive_definite(&self) -> bool {
        self.r.iter().all(|v| v.is_finite()) && (0..self.n).all(|i| self.r[i * self.n + i] > 0.0)
    }

    /// Ratio of largest to smallest diagonal entry of `R`, a cheap lower bound of `√cond(P)`.
    pub fn diagonal_ratio(&self) -> f64 {
        let d = (0..self.n).map(|i| self.r[i * self.n + i].abs());
        let (lo, hi) = d.fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        hi / lo
    }

    /// Covariance `P = R⁻¹R⁻ᵀ` (allocates; for reporting). `None` if `R` is singular.
    pub fn covariance_matrix(&self) -> Option<DMatrix<f64>> {
        let r = DMatrix::from_row_slice(self.n, self.n, &self.r);
        let r_inv = r.solve_upper_triangular(&DMatrix::identity(self.n, self.n))?;
        Some(&r_inv * r_inv.transpose())
    }

    /// Rotates the scratch row (nonzero from column `start` on) with right-hand side `rhs` into
    /// `[R | b]`. Returns the remaining residual and the product of the squared cosines.
    fn rotate_in(&mut self, start: usize, mut rhs: f64) -> (f64, f64) {
        let n = self.n;
        let mut z = 1.0;
        for j in start..n {
            let x = self.row[j];
            if x == 0.0 {
                continue;
            }
            let rjj = self.r[j * n + j];
            let rho = rjj.hypot(x);
            let c = rjj / rho;
            let s = x / rho;
            z *= c * c;
            self.r[j * n + j] = rho;
            self.row[j] = 0.0;
            for l in (j + 1)..n {
                let a = self.r[j * n + l];
                let w = self.row[l];
                self.r[j * n + l] = c * a + s * w;
                self.row[l] = -s * a + c * w;
            }
            let bj = self.b[j];
            self.b[j] = c * bj + s * rhs;
            rhs = -s * bj + c * rhs;
        }
        (rhs, z)
    }

    fn back_substitute(&mut self) {
        let n = self.n;
        for i in (0..n).rev() {
            let rii = self.r[i * n + i];
            if rii.is_nan() || rii <= f64::MIN_POSITIVE {
                // No information on this direction: hold the estimate.
                continue;
            }
            let mut acc = self.b[i];
            for l in (i + 1)..n {
                acc -= self.r[i * n + l] * self.theta[l];
            }
            self.theta[i] = acc / rii;
        }
    }
}

impl RecursiveEstimator for Dsfi {
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
        let prediction_error = y - psi.iter().zip(&self.theta).map(|(a, b)| a * b).sum::<f64>();

        // Forgetting: information λ P⁻¹.
        if lambda < 1.0 {
            let s = lambda.sqrt();
            self.r.iter_mut().for_each(|v| *v *= s);
            self.b.iter_mut().for_each(|v| *v *= s);
            self.loss *= lambda;
            // Information floor: pseudo-measurements θ_i = θ̂_i(k-1) with weight (1-λ)δ.
            if let Some(delta) = self.config.information_floor {
                let w = ((1.0 - lambda) * delta).sqrt();
                for i in 0..n {
                    self.row.fill(0.0);
                    self.row[i] = w;
                    let th = self.theta[i];
                    self.rotate_in(i, w * th);
                }
            }
        }

        // The measurement row.
        self.row.copy_from_slice(psi);
        let (residual, eigenvalue) = self.rotate_in(0, y);
        self.loss += residual * residual;
        self.back_substitute();
        self.steps += 1;
        Ok(RecursiveUpdate {
            prediction_error,
            posterior_error: eigenvalue * prediction_error,
            eigenvalue,
            guarded: false,
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
    use crate::ident::rls::{CovarianceGuard, Rls, RlsConfig};
    use crate::ident::testutil::TestRng;

    #[test]
    fn equals_covariance_form_on_well_conditioned_data() {
        let mut rng = TestRng::new(31);
        let lambda = 0.98;
        let mut rls = Rls::new(
            3,
            RlsConfig {
                forgetting: lambda,
                initial_covariance: 100.0,
                guard: CovarianceGuard::None,
            },
        )
        .expect("valid");
        let mut dsfi = Dsfi::new(
            3,
            DsfiConfig {
                forgetting: lambda,
                initial_covariance: 100.0,
                information_floor: None,
            },
        )
        .expect("valid");
        for _ in 0..2000 {
            let psi = [rng.normal(), rng.normal(), 1.0];
            let y = 0.5 * psi[0] - 2.0 * psi[1] + 0.1 + 0.01 * rng.normal();
            let a = rls.step(&psi, y).expect("finite");
            let b = dsfi.step(&psi, y).expect("finite");
            assert!((a.eigenvalue - b.eigenvalue).abs() < 1e-10);
            assert!((a.prediction_error - b.prediction_error).abs() < 1e-9);
        }
        for j in 0..3 {
            assert!((rls.theta()[j] - dsfi.theta()[j]).abs() < 1e-10);
        }
        let p = dsfi.covariance_matrix().expect("regular");
        let q = rls.covariance_matrix();
        assert!((&p - &q).amax() < 1e-8 * q.amax());
        assert!((dsfi.theta()[0] - 0.5).abs() < 0.01 && (dsfi.theta()[1] + 2.0).abs() < 0.01);
    }

    /// Outcome of a long run with (near) constant regressor.
    #[derive(Debug)]
    struct LongRun {
        /// Step at which the plain covariance form first lost positive definiteness or finiteness.
        plain_failed_at: Option<u64>,
        plain_max_trace: f64,
        plain_max_abs_theta: f64,
        dsfi_max_abs_theta: f64,
        dsfi_max_abs_error: f64,
        dsfi_max_trace: f64,
    }

    /// Actuator at rest: position and command constant (`dither = 0`, a quantised sensor) or
    /// nearly so (`dither` relative), for `steps` samples; then rich excitation.
    fn long_run(lambda: f64, steps: u64, seed: u64, dither: f64) -> LongRun {
        let theta_true = [0.9, 0.05, 0.002];
        let mut rng = TestRng::new(seed);
        let mut plain = Rls::new(
            3,
            RlsConfig {
                forgetting: lambda,
                initial_covariance: 1e3,
                guard: CovarianceGuard::None,
            },
        )
        .expect("valid");
        let mut dsfi = Dsfi::new(
            3,
            DsfiConfig {
                forgetting: lambda,
                ..DsfiConfig::default()
            },
        )
        .expect("valid");
        let mut run = LongRun {
            plain_failed_at: None,
            plain_max_trace: 0.0,
            plain_max_abs_theta: 0.0,
            dsfi_max_abs_theta: 0.0,
            dsfi_max_abs_error: 0.0,
            dsfi_max_trace: 0.0,
        };
        let max_abs = |th: &[f64]| th.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        for k in 0..steps {
            let psi = [
                0.01 * (1.0 + dither * rng.normal()),
                0.5 * (1.0 + dither * rng.normal()),
                1.0,
            ];
            let y: f64 =
                psi.iter().zip(theta_true).map(|(a, b)| a * b).sum::<f64>() + 1e-6 * rng.normal();
            let up = dsfi.step(&psi, y).expect("finite data");
            if run.plain_failed_at.is_none() {
                // An error from non-finite internal state counts as failure too.
                let ok = plain.step(&psi, y).is_ok();
                if !ok || (k % 1000 == 0 && !plain.is_positive_definite()) {
                    run.plain_failed_at = Some(k);
                } else {
                    run.plain_max_trace = run.plain_max_trace.max(plain.covariance_trace());
                    run.plain_max_abs_theta = run.plain_max_abs_theta.max(max_abs(plain.theta()));
                }
            }
            if k % 1000 == 0 {
                assert!(
                    dsfi.is_positive_definite(),
                    "DSFI lost definiteness at step {k}"
                );
                let p = dsfi.covariance_matrix().expect("regular factor");
                assert!(p.iter().all(|v| v.is_finite()));
                run.dsfi_max_trace = run.dsfi_max_trace.max(p.trace());
            }
            let th = dsfi.theta();
            assert!(
                th.iter().all(|v| v.is_finite()),
                "DSFI estimate not finite at step {k}"
            );
            run.dsfi_max_abs_theta = run.dsfi_max_abs_theta.max(max_abs(th));
            if k > 100 {
                run.dsfi_max_abs_error = run.dsfi_max_abs_error.max(up.prediction_error.abs());
            }
            assert!(up.eigenvalue >= 0.0 && up.eigenvalue <= 1.0);
        }
        // After the long rest, rich excitation must still be learned quickly.
        for _ in 0..300 {
            let psi = [rng.normal(), rng.normal(), 1.0];
            let y: f64 =
                psi.iter().zip(theta_true).map(|(a, b)| a * b).sum::<f64>() + 1e-6 * rng.normal();
            dsfi.step(&psi, y).expect("finite");
        }
        for j in 0..3 {
            assert!(
                (dsfi.theta()[j] - theta_true[j]).abs() < 1e-4,
                "after excitation theta[{j}] = {}",
                dsfi.theta()[j]
            );
        }
        run
    }

    #[test]
    fn square_root_form_survives_two_million_steps_of_poor_excitation() {
        let floor = DsfiConfig::default()
            .information_floor
            .expect("default floor");
        for (lambda, seed) in [(0.975, 1), (0.99, 2)] {
            for dither in [0.0, 1e-7] {
                let run = long_run(lambda, 2_000_000, seed, dither);
                eprintln!("lambda {lambda}, dither {dither:e}: {run:?}");
                // The square-root form stays definite, bounded and predicting.
                assert!(run.dsfi_max_abs_theta < 10.0);
                assert!(run.dsfi_max_abs_error < 1e-4);
                // P <= I/δ in steady state: trace bounded by n/δ (plus the start-up value).
                assert!(
                    run.dsfi_max_trace <= 3.0 / floor + 3e3,
                    "{}",
                    run.dsfi_max_trace
                );
                if dither == 0.0 {
                    // The textbook covariance form winds up (P ~ λ^-k) and breaks down.
                    assert!(
                        run.plain_failed_at.is_some(),
                        "plain RLS unexpectedly survived"
                    );
                }
            }
        }
    }

    #[test]
    fn holds_the_estimate_without_floor_and_rejects_bad_config() {
        let mut d = Dsfi::with_initial(
            &[1.0, 2.0],
            DsfiConfig {
                forgetting: 0.9,
                initial_covariance: 1.0,
                information_floor: None,
            },
        )
        .expect("valid");
        // Only the first parameter is excited; the second decays to no information and is held.
        for _ in 0..20_000 {
            d.step(&[1.0, 0.0], 3.0).expect("finite");
        }
        assert!((d.theta()[0] - 3.0).abs() < 1e-12);
        assert_eq!(d.theta()[1], 2.0);
        assert!(d.theta().iter().all(|v| v.is_finite()));
        assert!(Dsfi::new(
            2,
            DsfiConfig {
                information_floor: Some(-1.0),
                ..DsfiConfig::default()
            }
        )
        .is_err());
        assert!(Dsfi::new(0, DsfiConfig::default()).is_err());
        assert!(d.step(&[1.0, f64::INFINITY], 1.0).is_err());
    }
}
