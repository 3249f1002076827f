//! The general linear discrete controller of Isermann & Raab:
//! `u(k) = -Σ_{i=1..n} p_i u(k-i) + Σ_{j=0..m} q_j e(k-j)`, covering P, PI, PID and PIDT1.

/// Largest number of `p` or `q` coefficients; enough for PIDT1 and a second-order lead-lag.
pub const MAX_ORDER: usize = 6;

/// Why a controller cannot be built from the given coefficients.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ControllerError {
    #[error("q needs 1 to {MAX_ORDER} coefficients, got {0}")]
    QLength(usize),
    #[error("p takes at most {MAX_ORDER} coefficients, got {0}")]
    PLength(usize),
    #[error("coefficient {0} is not a finite number")]
    NotFinite(&'static str),
    #[error("output limits need min < max, got [{0}, {1}]")]
    Limits(f64, f64),
    #[error("controller file: {0}")]
    File(String),
}

/// A discrete transfer function controller with output limits and anti-windup.
///
/// Anti-windup: the recursion is fed the output actually applied (after limiting and after any
/// signal added downstream), so an integrating denominator `(1 - q^-1)` cannot wind up.
/// Allocation-free: fixed arrays, no heap after construction.
#[derive(Debug, Clone)]
pub struct DiscreteController {
    p: [f64; MAX_ORDER],
    q: [f64; MAX_ORDER],
    n_p: usize,
    n_q: usize,
    u_past: [f64; MAX_ORDER],
    e_past: [f64; MAX_ORDER],
    u_min: f64,
    u_max: f64,
}

impl DiscreteController {
    /// `p = [p_1, .., p_n]` (denominator without its leading 1), `q = [q_0, .., q_m]`.
    pub fn new(p: &[f64], q: &[f64], u_min: f64, u_max: f64) -> Result<Self, ControllerError> {
        if q.is_empty() || q.len() > MAX_ORDER {
            return Err(ControllerError::QLength(q.len()));
        }
        if p.len() > MAX_ORDER {
            return Err(ControllerError::PLength(p.len()));
        }
        if p.iter().any(|x| !x.is_finite()) {
            return Err(ControllerError::NotFinite("p"));
        }
        if q.iter().any(|x| !x.is_finite()) {
            return Err(ControllerError::NotFinite("q"));
        }
        if u_min.partial_cmp(&u_max) != Some(std::cmp::Ordering::Less) {
            return Err(ControllerError::Limits(u_min, u_max));
        }
        let mut pa = [0.0; MAX_ORDER];
        let mut qa = [0.0; MAX_ORDER];
        pa[..p.len()].copy_from_slice(p);
        qa[..q.len()].copy_from_slice(q);
        Ok(Self {
            p: pa,
            q: qa,
            n_p: p.len(),
            n_q: q.len(),
            u_past: [0.0; MAX_ORDER],
            e_past: [0.0; MAX_ORDER],
            u_min,
            u_max,
        })
    }

    /// PIDT1 as `G_c = (q0 + q1 z^-1 + q2 z^-2) / ((1 - z^-1)(1 - c z^-1))`.
    pub fn pidt1(q: [f64; 3], c: f64, u_min: f64, u_max: f64) -> Result<Self, ControllerError> {
        Self::new(&[-(1.0 + c), c], &q, u_min, u_max)
    }

    /// The unlimited controller output for error `e` now, without committing the step.
    ///
    /// `u(k) = -Σ p_i u(k-i) + Σ q_j e(k-j)` (Isermann & Raab, general discrete controller).
    pub fn propose(&self, e: f64) -> f64 {
        let mut u = self.q[0] * e;
        for j in 1..self.n_q {
            u += self.q[j] * self.e_past[j - 1];
        }
        for i in 0..self.n_p {
            u -= self.p[i] * self.u_past[i];
        }
        u
    }

    /// Commit a step: `e` was the error, `u_applied` what really went to the actuator
    /// (the limited output, plus or minus whatever was added downstream).
    pub fn commit(&mut self, e: f64, u_applied: f64) {
        self.e_past.copy_within(0..MAX_ORDER - 1, 1);
        self.e_past[0] = e;
        self.u_past.copy_within(0..MAX_ORDER - 1, 1);
        self.u_past[0] = u_applied;
    }

    /// One step: output limited to `[u_min, u_max]`, history fed with the limited value.
    pub fn step(&mut self, e: f64) -> f64 {
        let u = self.propose(e).clamp(self.u_min, self.u_max);
        self.commit(e, u);
        u
    }

    /// Start from a steady state at output `u0` with zero error (bumpless start).
    pub fn preset(&mut self, u0: f64) {
        self.e_past = [0.0; MAX_ORDER];
        self.u_past = [u0; MAX_ORDER];
    }

    /// Move the controller's state so that its output is `du` higher from now on, the error
    /// history unchanged: for an integrating controller, a step of the stored integral.
    pub fn shift_output(&mut self, du: f64) {
        for u in &mut self.u_past {
            *u += du;
        }
    }

    pub fn limits(&self) -> (f64, f64) {
        (self.u_min, self.u_max)
    }

    /// Static gain `Σq / (1 + Σp)`; infinite for an integrating controller.
    pub fn dc_gain(&self) -> f64 {
        let num: f64 = self.q[..self.n_q].iter().sum();
        let den: f64 = 1.0 + self.p[..self.n_p].iter().sum::<f64>();
        num / den
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn p_controller_is_a_gain() {
        let mut c = DiscreteController::new(&[], &[2.5], -10.0, 10.0).expect("valid");
        assert_eq!(c.step(1.0), 2.5);
        assert_eq!(c.step(-2.0), -5.0);
        assert_eq!(c.step(100.0), 10.0);
    }

    #[test]
    fn pi_controller_integrates_a_constant_error() {
        // u(k) = u(k-1) + q0 e(k) + q1 e(k-1): PI with K = 1, T0/Ti = 0.1.
        let mut c = DiscreteController::new(&[-1.0], &[1.1, -1.0], -100.0, 100.0).expect("valid");
        let outputs: Vec<f64> = (0..5).map(|_| c.step(1.0)).collect();
        for (k, u) in outputs.iter().enumerate() {
            assert!((u - (1.1 + 0.1 * k as f64)).abs() < 1e-12, "k={k} u={u}");
        }
    }

    #[test]
    fn limited_output_does_not_wind_up() {
        let mut c = DiscreteController::new(&[-1.0], &[1.1, -1.0], -1.0, 1.0).expect("valid");
        for _ in 0..1000 {
            assert_eq!(c.step(5.0), 1.0);
        }
        // One step of reversed error must leave saturation at once, not after 1000 steps of unwinding.
        let u = c.step(-5.0);
        assert!(u < 1.0, "u={u}");
    }

    #[test]
    fn paper_pidt1_has_the_papers_polynomials() {
        let c = DiscreteController::pidt1([2.231, -4.204, 2.0], 0.616, -24.0, 24.0).expect("valid");
        assert!((c.p[0] + 1.616).abs() < 1e-12);
        assert!((c.p[1] - 0.616).abs() < 1e-12);
        assert!(c.dc_gain().is_infinite());
    }

    #[test]
    fn rejects_bad_coefficients() {
        assert!(DiscreteController::new(&[], &[], -1.0, 1.0).is_err());
        assert!(DiscreteController::new(&[f64::NAN], &[1.0], -1.0, 1.0).is_err());
        assert!(DiscreteController::new(&[], &[1.0], 1.0, 1.0).is_err());
    }
}
