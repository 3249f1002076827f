//! State-variable filters: filtered signal and its time derivatives for continuous-time
//! equation-error regressions (Isermann & Raab 1993: continuous-time parameters need
//! derivatives; state-variable filters provide them).
//!
//! The filter is the cascade `F(s) = (ω / (s + ω))^K` of `K` equal first-order lags, realised with
//! the stage outputs as states, `x_1' = ω (u - x_1)`, `x_j' = ω (x_{j-1} - x_j)`, a well-conditioned
//! form even for large `ω`. The `i`-th derivative of the filter output `x_K`, for `i <= K`, is
//! exact in the states: `d^i x_K / dt^i = ω^i Σ_{j=0..i} C(i, j) (-1)^j x_{K-i+j}` with `x_0 = u`.
//!
//! Discretisation is exact for an input that is linear between samples (first-order hold,
//! triangle hold): `x(k+1) = Φ x(k) + Γ_0 u(k) + Γ_1 (u(k+1) - u(k))`, with `Φ, Γ_0, Γ_1` read from
//! the exponential of the augmented matrix `T [[A, B, 0], [0, 0, 1/T], [0, 0, 0]]`. So the
//! derivative outputs carry no half-sample delay, unlike a zero-order-hold discretisation.
//!
//! Because every signal of a linear differential equation passes through the same `F(s)`, the
//! equation holds for the filtered signals: `y_F^{(n)} + a_{n-1} y_F^{(n-1)} + ... = b_0 u_F + ...`.

use nalgebra::DMatrix;

use super::error::{check_finite, IdentError};

/// Cascaded low-pass state-variable filter. [`StateVariableFilter::step`] does not allocate.
#[derive(Debug, Clone)]
pub struct StateVariableFilter {
    order: usize,
    derivatives: usize,
    omega: f64,
    period: f64,
    /// `Φ`, row-major `K × K`.
    phi: Vec<f64>,
    gamma0: Vec<f64>,
    gamma1: Vec<f64>,
    x: Vec<f64>,
    x_next: Vec<f64>,
    /// `ω^i C(i, j) (-1)^j`, row-major `(n+1) × (n+1)`.
    weights: Vec<f64>,
    out: Vec<f64>,
    u_prev: f64,
    started: bool,
}

impl StateVariableFilter {
    /// Filter of order `K = order` with corner frequency `omega_rad_s`, sampled every
    /// `period_s`, giving the filtered signal and its first `derivatives` derivatives
    /// (`derivatives <= order`).
    pub fn new(
        order: usize,
        derivatives: usize,
        omega_rad_s: f64,
        period_s: f64,
    ) -> Result<Self, IdentError> {
        if order == 0 {
            return Err(IdentError::InvalidParameter {
                name: "order",
                reason: "filter order must be at least 1".into(),
            });
        }
        if derivatives > order {
            return Err(IdentError::InvalidParameter {
                name: "derivatives",
                reason: format!(
                    "at most {order} derivatives from an order-{order} filter, asked {derivatives}"
                ),
            });
        }
        if !(omega_rad_s > 0.0 && omega_rad_s.is_finite()) {
            return Err(IdentError::InvalidParameter {
                name: "omega_rad_s",
                reason: format!("must be finite and > 0, got {omega_rad_s}"),
            });
        }
        if !(period_s > 0.0 && period_s.is_finite()) {
            return Err(IdentError::InvalidParameter {
                name: "period_s",
                reason: format!("must be finite and > 0, got {period_s}"),
            });
        }
        let k = order;
        let mut m = DMatrix::<f64>::zeros(k + 2, k + 2);
        for i in 0..k {
            m[(i, i)] = -omega_rad_s * period_s;
            if i > 0 {
                m[(i, i - 1)] = omega_rad_s * period_s;
            }
        }
        m[(0, k)] = omega_rad_s * period_s;
        m[(k, k + 1)] = 1.0;
        let e = m.exp();
        let mut phi = vec![0.0; k * k];
        let mut gamma0 = vec![0.0; k];
        let mut gamma1 = vec![0.0; k];
        for i in 0..k {
            for j in 0..k {
                phi[i * k + j] = e[(i, j)];
            }
            gamma0[i] = e[(i, k)];
            gamma1[i] = e[(i, k + 1)];
        }
        check_finite("filter discretisation", &phi)?;
        let n = derivatives;
        let mut weights = vec![0.0; (n + 1) * (n + 1)];
        for i in 0..=n {
            let mut binom = 1.0;
            for j in 0..=i {
                let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                weights[i * (n + 1) + j] = omega_rad_s.powi(i as i32) * binom * sign;
                binom = binom * (i - j) as f64 / (j + 1) as f64;
            }
        }
        Ok(Self {
            order,
            derivatives,
            omega: omega_rad_s,
            period: period_s,
            phi,
            gamma0,
            gamma1,
            x: vec![0.0; k],
            x_next: vec![0.0; k],
            weights,
            out: vec![0.0; n + 1],
            u_prev: 0.0,
            started: false,
        })
    }

    /// Filter order `K`.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Number of derivatives produced.
    pub fn derivatives(&self) -> usize {
        self.derivatives
    }

    /// Corner frequency ω in rad/s.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// Sampling period in s.
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Zero state: the next sample is the first.
    pub fn reset(&mut self) {
        self.x.fill(0.0);
        self.started = false;
    }

    /// Steady state for a constant input `u0` (all stages at `u0`), avoiding the start-up
    /// transient for signals that begin at rest away from zero.
    pub fn reset_to(&mut self, u0: f64) {
        self.x.fill(u0);
        self.u_prev = u0;
        self.started = true;
    }

    /// Takes `u(k)`, returns `[u_F(k), u_F'(k), ..., u_F^{(n)}(k)]` (units of u per sⁱ).
    pub fn step(&mut self, u: f64) -> &[f64] {
        let k = self.order;
        if self.started {
            let du = u - self.u_prev;
            for i in 0..k {
                let row = &self.phi[i * k..(i + 1) * k];
                let mut acc = self.gamma0[i] * self.u_prev + self.gamma1[i] * du;
                for (p, x) in row.iter().zip(&self.x) {
                    acc += p * x;
                }
                self.x_next[i] = acc;
            }
            self.x.copy_from_slice(&self.x_next);
        }
        self.started = true;
        self.u_prev = u;
        let n = self.derivatives;
        for i in 0..=n {
            let mut acc = 0.0;
            for j in 0..=i {
                // stage index K - i + j, stage 0 is the input
                let s = k - i + j;
                let xs = if s == 0 { u } else { self.x[s - 1] };
                acc += self.weights[i * (n + 1) + j] * xs;
            }
            self.out[i] = acc;
        }
        &self.out
    }

    /// Filters a whole sequence from the steady state at `u[0]`; row `k` holds
    /// `[u_F(k), u_F'(k), ..., u_F^{(n)}(k)]`.
    pub fn filter(&mut self, u: &[f64]) -> Result<DMatrix<f64>, IdentError> {
        check_finite("signal", u)?;
        let mut out = DMatrix::zeros(u.len(), self.derivatives + 1);
        if let Some(&u0) = u.first() {
            self.reset_to(u0);
        }
        for (k, &uk) in u.iter().enumerate() {
            let row = self.step(uk);
            for (j, v) in row.iter().enumerate() {
                out[(k, j)] = *v;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
mod tests {
    use super::*;
    use crate::ident::least_squares;
    use crate::ident::testutil::TestRng;
    use nalgebra::DVector;
    use std::f64::consts::PI;

    /// Amplitude and phase of `x` at angular frequency `w` by projection over whole periods.
    fn amplitude_phase(x: &[f64], t: &[f64], w: f64) -> (f64, f64) {
        let (mut s, mut c) = (0.0, 0.0);
        for (xi, ti) in x.iter().zip(t) {
            s += xi * (w * ti).sin();
            c += xi * (w * ti).cos();
        }
        let n = x.len() as f64;
        let (s, c) = (2.0 * s / n, 2.0 * c / n);
        // x ≈ A sin(wt + φ) = A cos φ sin wt + A sin φ cos wt
        (s.hypot(c), c.atan2(s))
    }

    #[test]
    fn derivatives_of_a_sinusoid_match_the_analytic_response() {
        let (order, omega, period) = (4, 50.0, 1e-3);
        let w = 2.0 * PI * 2.0;
        let mut f = StateVariableFilter::new(order, 3, omega, period).expect("valid");
        let n = 5000;
        let (mut t_kept, mut kept) = (Vec::new(), vec![Vec::new(); 4]);
        for k in 0..n {
            let t = k as f64 * period;
            let out = f.step((w * t).sin()).to_vec();
            if k >= 1000 {
                t_kept.push(t);
                for i in 0..4 {
                    kept[i].push(out[i]);
                }
            }
        }
        // Filtered sinusoid: |F| sin(wt + φ); its i-th derivative: |F| wⁱ sin(wt + φ + iπ/2).
        let mag = (omega / omega.hypot(w)).powi(order as i32);
        let phase = -(order as f64) * (w / omega).atan();
        for i in 0..4 {
            let amp_true = mag * w.powi(i as i32);
            let ph_true = phase + i as f64 * PI / 2.0;
            let (amp, ph) = amplitude_phase(&kept[i], &t_kept, w);
            let amp_err = (amp / amp_true - 1.0).abs();
            eprintln!(
                "SVF derivative {i}: amplitude error {amp_err:.2e}, phase error {:.2e} rad",
                ((ph - ph_true + PI).rem_euclid(2.0 * PI) - PI)
            );
            let dph = (ph - ph_true + PI).rem_euclid(2.0 * PI) - PI;
            assert!(amp_err < 1e-4, "derivative {i}: amplitude error {amp_err}");
            assert!(dph.abs() < 1e-4, "derivative {i}: phase error {dph} rad");
            // Pointwise too.
            let worst = kept[i]
                .iter()
                .zip(&t_kept)
                .map(|(v, t)| (v - amp_true * (w * t + ph_true).sin()).abs())
                .fold(0.0, f64::max);
            assert!(
                worst < 1e-4 * amp_true,
                "derivative {i}: worst pointwise error {worst}"
            );
        }
    }

    #[test]
    fn exact_for_ramps_and_steady_at_rest() {
        let mut f = StateVariableFilter::new(3, 3, 20.0, 0.01).expect("valid");
        f.reset_to(5.0);
        let out = f.step(5.0).to_vec();
        assert!((out[0] - 5.0).abs() < 1e-12 && out[1].abs() < 1e-9 && out[3].abs() < 1e-6);
        // Ramp of slope 2/s: after the transient, u_F' = 2, u_F'' = u_F''' = 0 exactly.
        f.reset_to(0.0);
        let mut last = Vec::new();
        for k in 0..500 {
            last = f.step(2.0 * k as f64 * 0.01).to_vec();
        }
        assert!((last[1] - 2.0).abs() < 1e-9, "{:?}", last);
        assert!(last[2].abs() < 1e-7 && last[3].abs() < 1e-5, "{:?}", last);
        // Ramp output lags by K/ω = 0.15 s.
        assert!((last[0] - 2.0 * (4.99 - 0.15)).abs() < 1e-9);
        assert!(StateVariableFilter::new(2, 3, 20.0, 0.01).is_err());
        assert!(StateVariableFilter::new(2, 1, -1.0, 0.01).is_err());
    }

    #[test]
    fn continuous_time_parameters_from_filtered_signals() {
        // y'' + a1 y' + a0 y = b0 u with a1 = 2ζω0, a0 = ω0², b0 = K ω0².
        let (w0, zeta, gain) = (20.0_f64, 0.3, 2.0);
        let (a1, a0, b0) = (2.0 * zeta * w0, w0 * w0, gain * w0 * w0);
        let input = |t: f64| {
            (2.0 * PI * 0.7 * t).sin()
                + 0.5 * (2.0 * PI * 3.1 * t).sin()
                + 0.3 * (2.0 * PI * 7.3 * t).cos()
        };
        let period = 1e-3;
        let sub = 10;
        let h = period / sub as f64;
        let f = |t: f64, s: [f64; 2]| [s[1], b0 * input(t) - a1 * s[1] - a0 * s[0]];
        let mut rng = TestRng::new(4);
        let n = 10_000;
        let (mut us, mut ys) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut s = [0.0, 0.0];
        for k in 0..n {
            let t = k as f64 * period;
            us.push(input(t));
            ys.push(s[0] + 1e-3 * rng.normal());
            for j in 0..sub {
                let tt = t + j as f64 * h;
                let k1 = f(tt, s);
                let k2 = f(
                    tt + h / 2.0,
                    [s[0] + h / 2.0 * k1[0], s[1] + h / 2.0 * k1[1]],
                );
                let k3 = f(
                    tt + h / 2.0,
                    [s[0] + h / 2.0 * k2[0], s[1] + h / 2.0 * k2[1]],
                );
                let k4 = f(tt + h, [s[0] + h * k3[0], s[1] + h * k3[1]]);
                for i in 0..2 {
                    s[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
                }
            }
        }
        let mut fy = StateVariableFilter::new(3, 2, 60.0, period).expect("valid");
        let mut fu = StateVariableFilter::new(3, 2, 60.0, period).expect("valid");
        fy.reset();
        fu.reset();
        let skip = 500;
        let mut rows = Vec::new();
        let mut target = Vec::new();
        for k in 0..n {
            let yf = fy.step(ys[k]).to_vec();
            let uf = fu.step(us[k]).to_vec();
            if k >= skip {
                rows.extend_from_slice(&[-yf[1], -yf[0], uf[0]]);
                target.push(yf[2]);
            }
        }
        let psi = DMatrix::from_row_slice(target.len(), 3, &rows);
        let fit = least_squares(&psi, &DVector::from_vec(target)).expect("excited");
        eprintln!(
            "SVF+LS theta {:?} (true {:?})",
            fit.theta.as_slice(),
            [a1, a0, b0]
        );
        for (est, truth) in fit.theta.iter().zip([a1, a0, b0]) {
            assert!(
                (est / truth - 1.0).abs() < 0.01,
                "estimate {est} vs {truth}"
            );
        }
    }
}
