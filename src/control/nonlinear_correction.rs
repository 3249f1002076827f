//! Static nonlinearity correction `U* = f*(U, Y)` (Isermann & Raab, "static nonlinearity
//! correction"): the inverse of the solenoid's force characteristic `f(I, Y) = I Σ_{i=0..2} c_i
//! (Y_0 - Y)^i`, so that the path from the controller output `U` to the position `Y` is close to
//! linear.
//!
//! With `g(Y) = Σ c_i (Y_0 - Y)^i` the magnet force is `K_Mag g(Y) I`. Feeding
//! `U* = U g(Y_ref) / g(Y)` makes the static force `K g(Y_ref) U` at every position: the plant seen
//! by the controller is the plant at the reference position, where the controller was designed.

use super::param_error::{finite, positive, range, ParamError};
use super::CorrectionSection as Section;
use crate::param_key;

/// Configuration of [`NonlinearCorrection`]; `c_i` with the same normalisation as the plant's
/// `position_stiffness` effect (any common factor cancels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonlinearCorrectionConfig {
    /// `Y_0` (m), 26 mm for the paper's magnet.
    pub pole_m: f64,
    pub c0: f64,
    pub c1_per_m: f64,
    pub c2_per_m2: f64,
    /// Position at which the correction is the identity (where the controller was tuned), m.
    pub reference_position_m: f64,
    /// `g(Y)` below this fraction of `g(Y_ref)` is taken as this fraction (limits the boost).
    pub min_gain_ratio: f64,
    /// Output limits of the corrected command.
    pub output_min: f64,
    pub output_max: f64,
}

/// Inverse static characteristic. Allocation-free.
#[derive(Debug, Clone)]
pub struct NonlinearCorrection {
    config: NonlinearCorrectionConfig,
    g_ref: f64,
}

impl NonlinearCorrection {
    /// Needs `g(Y_ref) > 0` and `0 < min_gain_ratio <= 1`.
    pub fn new(config: NonlinearCorrectionConfig) -> Result<Self, ParamError> {
        // Named by the keys of `[axis.correction]` they come from.
        finite(param_key!(Section, pole_m), config.pole_m)?;
        finite(param_key!(Section, c0), config.c0)?;
        finite(param_key!(Section, c1_per_m), config.c1_per_m)?;
        finite(param_key!(Section, c2_per_m2), config.c2_per_m2)?;
        let reference = param_key!(Section, reference_position_m);
        finite(reference, config.reference_position_m)?;
        let ratio = param_key!(Section, min_gain_ratio);
        positive(ratio, config.min_gain_ratio)?;
        if config.min_gain_ratio > 1.0 {
            return Err(ParamError::new(
                ratio,
                format!("must be <= 1, got {}", config.min_gain_ratio),
            ));
        }
        range("output", config.output_min, config.output_max)?;
        let g_ref = characteristic(&config, config.reference_position_m);
        if !(g_ref.is_finite() && g_ref > 0.0) {
            return Err(ParamError::new(
                reference,
                format!("needs a characteristic there that is finite and > 0, got {g_ref}"),
            ));
        }
        Ok(Self { config, g_ref })
    }

    /// `g(Y) = Σ c_i (Y_0 - Y)^i` (Isermann & Raab, force characteristic `f(I, Y) / I`).
    pub fn gain(&self, position: f64) -> f64 {
        characteristic(&self.config, position)
    }

    /// `U* = U g(Y_ref) / max(g(Y), r_min g(Y_ref))`, limited (inverse static characteristic).
    pub fn step(&mut self, command: f64, position: f64) -> f64 {
        let c = &self.config;
        let g = self.gain(position);
        let g = if g.is_finite() {
            g.max(c.min_gain_ratio * self.g_ref)
        } else {
            self.g_ref
        };
        let u = command * self.g_ref / g;
        if u.is_finite() {
            u.clamp(c.output_min, c.output_max)
        } else {
            c.output_min.max(0.0).min(c.output_max)
        }
    }
}

fn characteristic(c: &NonlinearCorrectionConfig, y: f64) -> f64 {
    let gap = c.pole_m - y;
    c.c0 + gap * (c.c1_per_m + gap * c.c2_per_m2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> NonlinearCorrectionConfig {
        // The plant file's example: 0.75 at rest (26 mm gap), 1.5 pulled in (1 mm gap).
        NonlinearCorrectionConfig {
            pole_m: 0.026,
            c0: 1.53,
            c1_per_m: -30.0,
            c2_per_m2: 0.0,
            reference_position_m: 0.0,
            min_gain_ratio: 0.2,
            output_min: 0.0,
            output_max: 24.0,
        }
    }

    #[test]
    fn corrected_force_is_the_reference_force_at_every_position() {
        let mut c = NonlinearCorrection::new(cfg()).expect("valid");
        for &y in &[0.0, 0.005, 0.012, 0.02, 0.025] {
            let u = c.step(6.0, y);
            let force = u * c.gain(y);
            assert!((force - 6.0 * c.gain(0.0)).abs() < 1e-9, "y={y}");
        }
        assert!((c.step(6.0, 0.0) - 6.0).abs() < 1e-12);
    }

    #[test]
    fn limits_and_rejects() {
        let mut c = NonlinearCorrection::new(cfg()).expect("valid");
        assert_eq!(c.step(100.0, 0.01), 24.0);
        let mut bad = cfg();
        bad.min_gain_ratio = 0.0;
        assert!(NonlinearCorrection::new(bad).is_err());
    }
}
