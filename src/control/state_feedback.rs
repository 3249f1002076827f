//! State feedback `u = -kᵀx + k_w w` (Isermann & Raab, control: state feedback `u = -kᵀx`), with a
//! set-point gain `k_w` and output limits.

use super::param_error::{finite, range, ParamError};

/// Largest state dimension.
pub const MAX_STATES: usize = 6;

/// State feedback controller. Allocation-free.
#[derive(Debug, Clone)]
pub struct StateFeedback {
    k: [f64; MAX_STATES],
    n: usize,
    setpoint_gain: f64,
    output_min: f64,
    output_max: f64,
}

impl StateFeedback {
    /// `gains = kᵀ` (1 to [`MAX_STATES`] entries), `setpoint_gain = k_w`.
    pub fn new(
        gains: &[f64],
        setpoint_gain: f64,
        output_min: f64,
        output_max: f64,
    ) -> Result<Self, ParamError> {
        if gains.is_empty() || gains.len() > MAX_STATES {
            return Err(ParamError::new(
                "gains",
                format!("needs 1 to {MAX_STATES} entries, got {}", gains.len()),
            ));
        }
        for &g in gains {
            finite("gains", g)?;
        }
        finite("setpoint_gain", setpoint_gain)?;
        range("output", output_min, output_max)?;
        let mut k = [0.0; MAX_STATES];
        k[..gains.len()].copy_from_slice(gains);
        Ok(Self {
            k,
            n: gains.len(),
            setpoint_gain,
            output_min,
            output_max,
        })
    }

    /// `k_w`, as configured (for unit static gain of a discrete model
    /// `k_w = 1 / (cᵀ (I - A + b kᵀ)⁻¹ b)`, computed by whoever designs `k`).
    pub fn setpoint_gain(&self) -> f64 {
        self.setpoint_gain
    }

    /// `u = -kᵀx + k_w w`, limited. Extra entries of `x` beyond the gain vector are ignored;
    /// a non-finite result is replaced by 0 (clamped into the limits).
    pub fn step(&mut self, x: &[f64], setpoint: f64) -> f64 {
        let mut u = self.setpoint_gain * setpoint;
        for (k, xi) in self.k[..self.n].iter().zip(x) {
            u -= k * xi;
        }
        if !u.is_finite() {
            u = 0.0;
        }
        u.clamp(self.output_min, self.output_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feeds_back_the_states_and_limits() {
        let mut c = StateFeedback::new(&[2.0, 0.5], 3.0, -10.0, 10.0).expect("valid");
        assert!((c.step(&[1.0, 2.0], 1.0) - (3.0 - 2.0 - 1.0)).abs() < 1e-12);
        assert_eq!(c.step(&[-10.0, 0.0], 0.0), 10.0);
        assert!(StateFeedback::new(&[], 1.0, -1.0, 1.0).is_err());
    }

    #[test]
    fn stabilises_a_double_integrator() {
        // x1' = x2, x2' = u at T0 = 10 ms; k from the poles of a well-damped PD loop.
        let t0 = 0.01;
        let mut c = StateFeedback::new(&[100.0, 20.0], 100.0, -1e3, 1e3).expect("valid");
        let (mut x1, mut x2) = (0.0, 0.0);
        for _ in 0..500 {
            let u = c.step(&[x1, x2], 1.0);
            x1 += t0 * x2 + 0.5 * t0 * t0 * u;
            x2 += t0 * u;
        }
        assert!((x1 - 1.0).abs() < 1e-3, "x1 = {x1}");
    }
}
