//! Output-error estimation: minimise `Σ_k (y(k) - y_M(k, θ))²` over `θ` with the model simulated
//! (Isermann & Raab 1993, output-error estimation, less biased than equation error), by the
//! Levenberg–Marquardt method.
//!
//! The caller supplies a residual function that fills `r(θ)` (typically: simulate the plant with
//! parameters θ on the measured input, write `y - y_M`). Each iteration:
//! - Jacobian `J = ∂r/∂θ` by forward or central finite differences with steps
//!   `h_j = η max(|θ_j|, typical_j)` (η ≈ √ε forward, ∛ε central), one-sided at the bounds;
//! - step `δ = argmin ‖J δ + r‖² + μ ‖D δ‖²` (Marquardt scaling `D = diag` of the largest column
//!   norms of J seen so far), solved from the QR factor of J, never via `JᵀJ`; with μ → 0 this is
//!   the Gauss–Newton step;
//! - box bounds by projection, with parameters at a bound whose gradient points outwards held
//!   fixed for the step;
//! - gain ratio `ρ = (cost - cost(θ+δ)) / (cost - ‖r + Jδ‖²)` accepts the step when `ρ > 1e-4` and
//!   updates `μ ← μ max(1/3, 1 - (2ρ-1)³)` (Nielsen), else `μ ← μ ν`, `ν ← 2ν`.
//!
//! At the end, `cov(θ̂) = σ̂² (JᵀJ)⁻¹` with `σ̂² = cost / (N - p)` at the solution.

use std::ops::ControlFlow;

use nalgebra::{DMatrix, DVector};

use super::error::{check_finite, check_len, IdentError};
use super::stats::student_t_quantile;

/// Box bounds `lower <= θ <= upper`; use infinities for free directions.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Bounds {
    /// Bounds from the two corner vectors.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, IdentError> {
        check_len("upper bounds", lower.len(), upper.len())?;
        for (l, u) in lower.iter().zip(&upper) {
            if l.is_nan() || u.is_nan() || l > u {
                return Err(IdentError::InvalidParameter {
                    name: "bounds",
                    reason: format!("need lower <= upper, got [{l}, {u}]"),
                });
            }
        }
        Ok(Self { lower, upper })
    }

    /// No bounds on `n` parameters.
    pub fn unbounded(n: usize) -> Self {
        Self {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
        }
    }

    /// Lower bounds.
    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    /// Upper bounds.
    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    /// Clamps `theta` into the box.
    pub fn project(&self, theta: &mut [f64]) {
        for ((t, l), u) in theta.iter_mut().zip(&self.lower).zip(&self.upper) {
            *t = t.clamp(*l, *u);
        }
    }
}

/// Finite-difference scheme for the Jacobian.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FiniteDifference {
    /// `(r(θ + h e_j) - r(θ)) / h`: `p` extra evaluations.
    Forward,
    /// `(r(θ + h e_j) - r(θ - h e_j)) / 2h`: `2p` evaluations, second-order accurate.
    Central,
}

/// Stopping rules and tuning of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct LmOptions {
    /// Maximum number of Jacobian evaluations (outer iterations).
    pub max_iterations: usize,
    /// Maximum number of residual evaluations, Jacobians included.
    pub max_evaluations: usize,
    /// Stop when both the actual and the predicted relative reduction of the cost are below this.
    pub cost_tolerance: f64,
    /// Stop when `‖Δθ‖ <= step_tolerance (‖θ‖ + step_tolerance)`.
    pub step_tolerance: f64,
    /// Stop when the largest cosine between the residual and a Jacobian column is below this.
    pub gradient_tolerance: f64,
    /// Finite-difference scheme.
    pub jacobian: FiniteDifference,
    /// Relative difference step η; `None` picks √ε (forward) or ∛ε (central).
    pub relative_step: Option<f64>,
    /// Typical magnitude of each parameter, the floor of the difference step scale; `None` uses
    /// `|θ0_j|` (or 1 where that is zero).
    pub typical_magnitude: Option<Vec<f64>>,
    /// Initial damping μ relative to the squared column scale; 0 starts with Gauss–Newton steps.
    pub initial_damping: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            max_evaluations: 100_000,
            cost_tolerance: 1e-10,
            step_tolerance: 1e-10,
            gradient_tolerance: 1e-10,
            jacobian: FiniteDifference::Central,
            relative_step: None,
            typical_magnitude: None,
            initial_damping: 1e-3,
        }
    }
}

/// Why the minimiser stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Termination {
    /// Relative cost reduction below `cost_tolerance`.
    CostTolerance,
    /// Step below `step_tolerance`.
    StepTolerance,
    /// Gradient (residual orthogonal to the Jacobian columns) below `gradient_tolerance`.
    GradientTolerance,
    /// The residual is exactly zero.
    ZeroResidual,
    /// `max_iterations` reached.
    MaxIterations,
    /// `max_evaluations` reached.
    MaxEvaluations,
    /// The progress callback asked to stop.
    Stopped,
    /// The damping grew without bound: no step reduces the cost.
    NoProgress,
}

impl Termination {
    /// True for the convergence criteria.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Self::CostTolerance
                | Self::StepTolerance
                | Self::GradientTolerance
                | Self::ZeroResidual
        )
    }
}

/// Snapshot handed to the progress callback after every iteration.
#[derive(Debug, Clone, Copy)]
pub struct LmProgress<'a> {
    /// Iterations done.
    pub iteration: usize,
    /// Residual evaluations done.
    pub evaluations: usize,
    /// Current cost `Σ r²`.
    pub cost: f64,
    /// Current damping μ.
    pub damping: f64,
    /// Norm of the last accepted step.
    pub step_norm: f64,
    /// Current parameters.
    pub theta: &'a [f64],
    /// Iteration limit, for a progress bar.
    pub max_iterations: usize,
}

/// Result of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    /// Estimated parameters.
    pub theta: Vec<f64>,
    /// Cost `Σ r²(θ̂)` (residual sum of squares).
    pub cost: f64,
    /// Residuals at the solution.
    pub residuals: Vec<f64>,
    /// `σ̂² = cost / (N - p)` (NaN when `N <= p`).
    pub residual_variance: f64,
    /// `σ̂² (JᵀJ)⁻¹` at the solution (pseudo-inverse if J is rank deficient).
    pub covariance: DMatrix<f64>,
    /// Standard errors; infinite for parameters the data do not determine.
    pub std_errors: Vec<f64>,
    /// Parameters that ended on a bound.
    pub at_bound: Vec<bool>,
    /// Gauss–Newton step from `theta` with the bounds lifted, `-(JᵀJ)⁺ Jᵀ r`: where the cost's
    /// quadratic model has its minimum, so `theta + step` is what the data ask of a parameter
    /// held at a bound (about zero for the others at convergence; NaN without a variance).
    pub unbounded_step: Vec<f64>,
    /// Outer iterations.
    pub iterations: usize,
    /// Residual evaluations, Jacobians included.
    pub evaluations: usize,
    /// Why it stopped.
    pub termination: Termination,
    /// `termination.converged()`.
    pub converged: bool,
}

impl Fit {
    /// Two-sided confidence intervals at `level` (e.g. 0.95), Student-t with `N - p` degrees of
    /// freedom (asymptotic, linearised at the solution).
    pub fn confidence_intervals(&self, level: f64) -> Vec<(f64, f64)> {
        let dof = (self.residuals.len().saturating_sub(self.theta.len())).max(1) as f64;
        let t = student_t_quantile(0.5 * (1.0 + level), dof);
        self.theta
            .iter()
            .zip(&self.std_errors)
            .map(|(th, se)| (th - t * se, th + t * se))
            .collect()
    }
}

/// Levenberg–Marquardt minimisation of `Σ r_i(θ)²`; see [`minimize_with_progress`].
pub fn minimize<F>(
    residual_fn: F,
    n_residuals: usize,
    theta0: &[f64],
    bounds: Option<&Bounds>,
    options: &LmOptions,
) -> Result<Fit, IdentError>
where
    F: FnMut(&[f64], &mut [f64]),
{
    minimize_with_progress(residual_fn, n_residuals, theta0, bounds, options, |_| {
        ControlFlow::Continue(())
    })
}

struct Evaluator<F> {
    f: F,
    count: usize,
}

impl<F: FnMut(&[f64], &mut [f64])> Evaluator<F> {
    /// Fills `out`; returns `Σ r²`, infinite when any residual is not finite.
    fn eval(&mut self, theta: &[f64], out: &mut [f64]) -> f64 {
        self.count += 1;
        (self.f)(theta, out);
        let cost: f64 = out.iter().map(|r| r * r).sum();
        if cost.is_finite() {
            cost
        } else {
            f64::INFINITY
        }
    }
}

/// Levenberg–Marquardt minimisation of `Σ r_i(θ)²`.
///
/// `residual_fn(θ, r)` must fill all `n_residuals` entries of `r`; non-finite residuals mark
/// `θ` as infeasible (e.g. a diverging simulation) and the step is rejected. `progress` is
/// called after every iteration; returning `ControlFlow::Break(())` stops with
/// [`Termination::Stopped`] and the best parameters so far.
pub fn minimize_with_progress<F, P>(
    residual_fn: F,
    n_residuals: usize,
    theta0: &[f64],
    bounds: Option<&Bounds>,
    options: &LmOptions,
    mut progress: P,
) -> Result<Fit, IdentError>
where
    F: FnMut(&[f64], &mut [f64]),
    P: FnMut(&LmProgress<'_>) -> ControlFlow<()>,
{
    let p = theta0.len();
    let m = n_residuals;
    if p == 0 {
        return Err(IdentError::InvalidParameter {
            name: "theta0",
            reason: "need at least one parameter".into(),
        });
    }
    if m == 0 {
        return Err(IdentError::TooFewSamples { needed: 1, got: 0 });
    }
    check_finite("initial parameters", theta0)?;
    let unbounded = Bounds::unbounded(p);
    let bounds = bounds.unwrap_or(&unbounded);
    check_len("bounds", p, bounds.lower.len())?;
    let typical: Vec<f64> = match &options.typical_magnitude {
        Some(t) => {
            check_len("typical magnitudes", p, t.len())?;
            t.iter().map(|v| v.abs()).collect()
        }
        None => theta0
            .iter()
            .map(|v| if *v != 0.0 { v.abs() } else { 1.0 })
            .collect(),
    };
    let eta = options.relative_step.unwrap_or(match options.jacobian {
        FiniteDifference::Forward => f64::EPSILON.sqrt(),
        FiniteDifference::Central => f64::EPSILON.cbrt(),
    });

    let mut ev = Evaluator {
        f: residual_fn,
        count: 0,
    };
    let mut theta = theta0.to_vec();
    bounds.project(&mut theta);
    let mut r = vec![0.0; m];
    let mut cost = ev.eval(&theta, &mut r);
    if !cost.is_finite() {
        return Err(IdentError::NonFinite {
            what: "residuals at the initial parameters",
        });
    }

    let mut jac = DMatrix::<f64>::zeros(m, p);
    let mut scratch_a = vec![0.0; m];
    let mut scratch_b = vec![0.0; m];
    let mut r_trial = vec![0.0; m];
    let mut theta_trial = vec![0.0; p];
    let mut scale = vec![0.0_f64; p];
    let mut mu = options.initial_damping.max(0.0);
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut step_norm;
    let termination;

    'outer: loop {
        if cost == 0.0 {
            termination = Termination::ZeroResidual;
            break;
        }
        if iterations >= options.max_iterations {
            termination = Termination::MaxIterations;
            break;
        }
        if ev.count + jacobian_cost(options.jacobian, p) > options.max_evaluations {
            termination = Termination::MaxEvaluations;
            break;
        }
        jacobian(
            &mut ev,
            &theta,
            &r,
            bounds,
            &typical,
            eta,
            options.jacobian,
            &mut jac,
            &mut scratch_a,
            &mut scratch_b,
        )?;
        iterations += 1;

        // Gradient g = Jᵀ r, free set and the scale-invariant gradient test.
        let r_vec = DVector::from_column_slice(&r);
        let g = jac.tr_mul(&r_vec);
        let r_norm = cost.sqrt();
        let mut free = Vec::with_capacity(p);
        let mut max_cos = 0.0_f64;
        for j in 0..p {
            let col_norm = jac.column(j).norm();
            scale[j] = scale[j].max(col_norm);
            let blocked = (theta[j] <= bounds.lower[j] && g[j] > 0.0)
                || (theta[j] >= bounds.upper[j] && g[j] < 0.0);
            if !blocked && col_norm > 0.0 {
                free.push(j);
                max_cos = max_cos.max(g[j].abs() / (col_norm * r_norm));
            }
        }
        if free.is_empty() || max_cos <= options.gradient_tolerance {
            termination = Termination::GradientTolerance;
            break;
        }

        // QR of the free columns: R δ ≈ -Qᵀ r.
        let nf = free.len();
        let jf = DMatrix::from_fn(m, nf, |i, j| jac[(i, free[j])]);
        let qr = jf.clone().qr();
        let rf = qr.r();
        let mut qtr = r_vec.clone();
        qr.q_tr_mul(&mut qtr);
        let c = qtr.rows(0, nf.min(m)).into_owned();

        loop {
            // Damped step from the stacked system [R; √μ D] δ = [-c; 0].
            let rows = rf.nrows();
            let mut a = DMatrix::<f64>::zeros(rows + nf, nf);
            let mut b = DVector::<f64>::zeros(rows + nf);
            a.view_mut((0, 0), (rows, nf)).copy_from(&rf);
            for i in 0..rows {
                b[i] = -c[i];
            }
            let sq = mu.sqrt();
            for (j, &fj) in free.iter().enumerate() {
                let d = if scale[fj] > 0.0 { scale[fj] } else { 1.0 };
                a[(rows + j, j)] = sq * d;
            }
            let delta = solve_ls(a, b);
            theta_trial.copy_from_slice(&theta);
            if let Some(delta) = delta {
                for (j, &fj) in free.iter().enumerate() {
                    theta_trial[fj] += delta[j];
                }
            }
            bounds.project(&mut theta_trial);
            let step: Vec<f64> = theta_trial.iter().zip(&theta).map(|(a, b)| a - b).collect();
            let step_len = step.iter().map(|v| v * v).sum::<f64>().sqrt();
            let theta_len = theta.iter().map(|v| v * v).sum::<f64>().sqrt();
            if step_len <= options.step_tolerance * (theta_len + options.step_tolerance) {
                termination = Termination::StepTolerance;
                break 'outer;
            }
            // Predicted cost ‖r + J δ‖².
            let jd = &jac * DVector::from_column_slice(&step);
            let predicted_cost: f64 = r
                .iter()
                .zip(jd.iter())
                .map(|(a, b)| (a + b) * (a + b))
                .sum();
            let predicted = cost - predicted_cost;
            if ev.count + 1 > options.max_evaluations {
                termination = Termination::MaxEvaluations;
                break 'outer;
            }
            let trial_cost = ev.eval(&theta_trial, &mut r_trial);
            let actual = cost - trial_cost;
            let rho = if predicted > 0.0 {
                actual / predicted
            } else {
                -1.0
            };
            if rho > 1e-4 {
                let small = actual <= options.cost_tolerance * cost
                    && predicted <= options.cost_tolerance * cost;
                theta.copy_from_slice(&theta_trial);
                r.copy_from_slice(&r_trial);
                cost = trial_cost;
                step_norm = step_len;
                mu *= (1.0_f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                if small {
                    termination = Termination::CostTolerance;
                    break 'outer;
                }
                break;
            }
            mu = if mu > 0.0 {
                mu * nu
            } else {
                options.initial_damping.max(1e-3)
            };
            nu *= 2.0;
            if mu > 1e20 {
                termination = Termination::NoProgress;
                break 'outer;
            }
        }

        let snapshot = LmProgress {
            iteration: iterations,
            evaluations: ev.count,
            cost,
            damping: mu,
            step_norm,
            theta: &theta,
            max_iterations: options.max_iterations,
        };
        if progress(&snapshot).is_break() {
            termination = Termination::Stopped;
            break;
        }
    }

    // Statistics at the solution.
    jacobian(
        &mut ev,
        &theta,
        &r,
        bounds,
        &typical,
        eta,
        options.jacobian,
        &mut jac,
        &mut scratch_a,
        &mut scratch_b,
    )?;
    let residual_variance = if m > p {
        cost / (m - p) as f64
    } else {
        f64::NAN
    };
    let (covariance, std_errors) = covariance(&jac, residual_variance);
    // -(JᵀJ)⁺ Jᵀ r = -(Cov / σ̂²) Jᵀ r.
    let gradient = jac.transpose() * DVector::from_column_slice(&r);
    let unbounded_step = (-(&covariance * gradient) / residual_variance)
        .iter()
        .copied()
        .collect();
    let at_bound = theta
        .iter()
        .enumerate()
        .map(|(j, t)| *t <= bounds.lower[j] || *t >= bounds.upper[j])
        .collect();
    Ok(Fit {
        theta,
        cost,
        residuals: r,
        residual_variance,
        covariance,
        std_errors,
        at_bound,
        unbounded_step,
        iterations,
        evaluations: ev.count,
        termination,
        converged: termination.converged(),
    })
}

fn jacobian_cost(scheme: FiniteDifference, p: usize) -> usize {
    match scheme {
        FiniteDifference::Forward => p,
        FiniteDifference::Central => 2 * p,
    }
}

#[allow(clippy::too_many_arguments)]
fn jacobian<F: FnMut(&[f64], &mut [f64])>(
    ev: &mut Evaluator<F>,
    theta: &[f64],
    r: &[f64],
    bounds: &Bounds,
    typical: &[f64],
    eta: f64,
    scheme: FiniteDifference,
    jac: &mut DMatrix<f64>,
    plus: &mut [f64],
    minus: &mut [f64],
) -> Result<(), IdentError> {
    let mut probe = theta.to_vec();
    for j in 0..theta.len() {
        let h = eta * theta[j].abs().max(typical[j]);
        let (lo, hi) = (bounds.lower[j], bounds.upper[j]);
        let up_ok = theta[j] + h <= hi;
        let down_ok = theta[j] - h >= lo;
        let central = scheme == FiniteDifference::Central && up_ok && down_ok;
        if central {
            probe[j] = theta[j] + h;
            let hp = probe[j] - theta[j];
            let c1 = ev.eval(&probe, plus);
            probe[j] = theta[j] - h;
            let hm = theta[j] - probe[j];
            let c2 = ev.eval(&probe, minus);
            if !(c1.is_finite() && c2.is_finite()) {
                return Err(IdentError::NonFinite {
                    what: "residuals during the Jacobian",
                });
            }
            for i in 0..r.len() {
                jac[(i, j)] = (plus[i] - minus[i]) / (hp + hm);
            }
        } else {
            probe[j] = if up_ok || !down_ok {
                theta[j] + h
            } else {
                theta[j] - h
            };
            let hd = probe[j] - theta[j];
            let c1 = ev.eval(&probe, plus);
            if !c1.is_finite() {
                return Err(IdentError::NonFinite {
                    what: "residuals during the Jacobian",
                });
            }
            for i in 0..r.len() {
                jac[(i, j)] = (plus[i] - r[i]) / hd;
            }
        }
        probe[j] = theta[j];
    }
    Ok(())
}

/// Least-squares solution of a tall system by QR (`None` if singular).
fn solve_ls(a: DMatrix<f64>, mut b: DVector<f64>) -> Option<DVector<f64>> {
    let n = a.ncols();
    let qr = a.qr();
    qr.q_tr_mul(&mut b);
    let r = qr.r();
    r.solve_upper_triangular(&b.rows(0, n).into_owned())
}

/// `σ² (JᵀJ)⁺` from the SVD of J, with infinite standard errors for undetermined parameters.
fn covariance(jac: &DMatrix<f64>, sigma2: f64) -> (DMatrix<f64>, Vec<f64>) {
    let p = jac.ncols();
    let svd = jac.clone().svd(false, true);
    let s = &svd.singular_values;
    let s_max = s.max();
    let tol = s_max * 1e-10 * (jac.nrows().max(p) as f64);
    let mut cov = DMatrix::<f64>::zeros(p, p);
    let mut undetermined = vec![false; p];
    if let Some(v_t) = &svd.v_t {
        for (i, &si) in s.iter().enumerate() {
            if si > tol {
                let vi = v_t.row(i);
                for a in 0..p {
                    for b in 0..p {
                        cov[(a, b)] += sigma2 * vi[a] * vi[b] / (si * si);
                    }
                }
            } else {
                for (j, flag) in undetermined.iter_mut().enumerate() {
                    if v_t[(i, j)].abs() > 1e-3 {
                        *flag = true;
                    }
                }
            }
        }
    }
    let std_errors = (0..p)
        .map(|j| {
            if undetermined[j] {
                f64::INFINITY
            } else {
                cov[(j, j)].max(0.0).sqrt()
            }
        })
        .collect();
    (cov, std_errors)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
mod tests {
    use super::*;
    use crate::ident::testutil::TestRng;

    /// `K ω0² / (s² + 2ζω0 s + ω0²)` with zero-order-hold input, simulated exactly.
    fn simulate_second_order(theta: &[f64], u: &[f64], period: f64, y: &mut [f64]) {
        let (k, w0, zeta) = (theta[0], theta[1], theta[2]);
        let mut m = DMatrix::<f64>::zeros(3, 3);
        m[(0, 1)] = period;
        m[(1, 0)] = -w0 * w0 * period;
        m[(1, 1)] = -2.0 * zeta * w0 * period;
        m[(1, 2)] = k * w0 * w0 * period;
        let e = m.exp();
        let (mut x0, mut x1) = (0.0, 0.0);
        for (uk, yk) in u.iter().zip(y.iter_mut()) {
            *yk = x0;
            let n0 = e[(0, 0)] * x0 + e[(0, 1)] * x1 + e[(0, 2)] * uk;
            let n1 = e[(1, 0)] * x0 + e[(1, 1)] * x1 + e[(1, 2)] * uk;
            x0 = n0;
            x1 = n1;
        }
    }

    #[test]
    fn recovers_second_order_continuous_time_system_from_noisy_output() {
        let truth = [2.0, 15.0, 0.25];
        let period = 0.005;
        let n = 2000;
        let sigma = 0.02;
        let mut rng = TestRng::new(21);
        let mut u = vec![0.0; n];
        let mut level = 1.0;
        for (k, uk) in u.iter_mut().enumerate() {
            if k % 60 == 0 {
                level = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            }
            *uk = level;
        }
        let mut y = vec![0.0; n];
        simulate_second_order(&truth, &u, period, &mut y);
        y.iter_mut().for_each(|v| *v += sigma * rng.normal());

        let mut sim = vec![0.0; n];
        let residual = |th: &[f64], r: &mut [f64]| {
            simulate_second_order(th, &u, period, &mut sim);
            for k in 0..n {
                r[k] = y[k] - sim[k];
            }
        };
        let bounds = Bounds::new(vec![0.01, 0.5, 0.02], vec![100.0, 200.0, 5.0]).expect("valid");
        let mut calls = 0;
        let fit = minimize_with_progress(
            residual,
            n,
            &[1.0, 8.0, 0.7],
            Some(&bounds),
            &LmOptions::default(),
            |p| {
                calls += 1;
                assert!(p.cost.is_finite() && p.iteration <= p.max_iterations);
                ControlFlow::Continue(())
            },
        )
        .expect("fit runs");
        assert!(fit.converged, "{:?}", fit.termination);
        eprintln!(
            "OE theta {:?} (true {truth:?}) se {:?} iterations {} evaluations {} {:?}",
            fit.theta, fit.std_errors, fit.iterations, fit.evaluations, fit.termination
        );
        // Called after every completed iteration; the last one may end inside the step search.
        assert!(calls <= fit.iterations && calls + 1 >= fit.iterations && calls > 0);
        for j in 0..3 {
            let rel = (fit.theta[j] / truth[j] - 1.0).abs();
            assert!(rel < 0.02, "theta[{j}] = {} (rel err {rel})", fit.theta[j]);
            let z = (fit.theta[j] - truth[j]) / fit.std_errors[j];
            assert!(z.abs() < 4.0, "theta[{j}] off by {z} standard errors");
        }
        assert!((fit.residual_variance.sqrt() / sigma - 1.0).abs() < 0.05);
    }

    #[test]
    fn recovers_coulomb_and_viscous_friction_by_output_error() {
        // m v' = F(t) - F_C tanh(v / v_s) - d v, measured velocity; θ = [m, F_C, d].
        let truth = [2.0, 3.0, 1.5];
        let period = 0.002;
        let n = 3000;
        let v_s = 0.01;
        let force: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 * period;
                8.0 * (2.0 * std::f64::consts::PI * 0.5 * t).sin()
                    + 2.0 * (2.0 * std::f64::consts::PI * 1.7 * t).sin()
            })
            .collect();
        let simulate = |th: &[f64], out: &mut [f64]| {
            let (m, fc, d) = (th[0], th[1], th[2]);
            let acc = |v: f64, f: f64| (f - fc * (v / v_s).tanh() - d * v) / m;
            let mut v = 0.0;
            let sub = 4;
            let h = period / sub as f64;
            for k in 0..n {
                out[k] = v;
                let f = force[k];
                for _ in 0..sub {
                    let k1 = acc(v, f);
                    let k2 = acc(v + 0.5 * h * k1, f);
                    let k3 = acc(v + 0.5 * h * k2, f);
                    let k4 = acc(v + h * k3, f);
                    v += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
                }
            }
        };
        let mut rng = TestRng::new(8);
        let mut v_meas = vec![0.0; n];
        simulate(&truth, &mut v_meas);
        let peak = v_meas.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let sigma = 0.01 * peak;
        v_meas.iter_mut().for_each(|v| *v += sigma * rng.normal());

        let mut sim = vec![0.0; n];
        let residual = |th: &[f64], r: &mut [f64]| {
            simulate(th, &mut sim);
            for k in 0..n {
                r[k] = v_meas[k] - sim[k];
            }
        };
        let bounds = Bounds::new(vec![0.1, 0.0, 0.0], vec![50.0, 50.0, 50.0]).expect("valid");
        let options = LmOptions {
            jacobian: FiniteDifference::Forward,
            ..LmOptions::default()
        };
        let fit = minimize(residual, n, &[1.0, 1.0, 0.5], Some(&bounds), &options).expect("runs");
        assert!(fit.converged, "{:?}", fit.termination);
        eprintln!(
            "OE theta {:?} (true {truth:?}) se {:?} iterations {} evaluations {} {:?}",
            fit.theta, fit.std_errors, fit.iterations, fit.evaluations, fit.termination
        );
        for j in 0..3 {
            let rel = (fit.theta[j] / truth[j] - 1.0).abs();
            assert!(rel < 0.03, "theta[{j}] = {} (rel err {rel})", fit.theta[j]);
        }
        let ci = fit.confidence_intervals(0.999);
        for j in 0..3 {
            assert!(ci[j].0 < truth[j] && truth[j] < ci[j].1, "{j}: {:?}", ci[j]);
        }
    }

    #[test]
    fn rosenbrock_bounds_and_stopping() {
        let rosen = |th: &[f64], r: &mut [f64]| {
            r[0] = 10.0 * (th[1] - th[0] * th[0]);
            r[1] = 1.0 - th[0];
        };
        let fit = minimize(rosen, 2, &[-1.2, 1.0], None, &LmOptions::default()).expect("runs");
        assert!(fit.converged);
        assert!((fit.theta[0] - 1.0).abs() < 1e-6 && (fit.theta[1] - 1.0).abs() < 1e-6);
        // Minimum outside the box: ends on the bound with the bound flagged.
        let bounds = Bounds::new(vec![-2.0, -2.0], vec![0.5, 2.0]).expect("valid");
        let fit =
            minimize(rosen, 2, &[-1.2, 1.0], Some(&bounds), &LmOptions::default()).expect("runs");
        assert!((fit.theta[0] - 0.5).abs() < 1e-12, "{:?}", fit.theta);
        assert!((fit.theta[1] - 0.25).abs() < 1e-6, "{:?}", fit.theta);
        assert_eq!(fit.at_bound, vec![true, false]);
        // The callback can stop the search.
        let fit =
            minimize_with_progress(rosen, 2, &[-1.2, 1.0], None, &LmOptions::default(), |p| {
                if p.iteration >= 2 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })
            .expect("runs");
        assert_eq!(fit.termination, Termination::Stopped);
        assert_eq!(fit.iterations, 2);
        assert!(!fit.converged);
        // Infeasible start is an error, not a panic.
        let bad = |_: &[f64], r: &mut [f64]| r.fill(f64::NAN);
        assert!(minimize(bad, 3, &[1.0], None, &LmOptions::default()).is_err());
    }
}
