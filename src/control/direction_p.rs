//! P controller with a gain per direction (Isermann & Raab, pneumatic drive):
//! `U1 = q01 e_w` for `e_w < 0` (valve V1, down), `U2 = q02 e_w` for `e_w > 0` (valve V2, up).

use super::param_error::{non_negative, positive, range, ParamError};
use super::ScheduleSection;
use crate::param_key;

/// Configuration of [`DirectionalP`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalPConfig {
    /// `q01`, gain for negative error (command per m).
    pub gain_neg_per_m: f64,
    /// `q02`, gain for positive error (command per m).
    pub gain_pos_per_m: f64,
    /// Errors with `|e_w|` at or below this give no command (m).
    pub deadband_m: f64,
    /// Output limits (command unit, e.g. duty -1..1).
    pub output_min: f64,
    pub output_max: f64,
}

/// Direction-dependent proportional controller. Allocation-free.
#[derive(Debug, Clone)]
pub struct DirectionalP {
    config: DirectionalPConfig,
}

impl DirectionalP {
    /// Checks the gains (> 0), the dead band (>= 0) and the limits (min < max).
    pub fn new(config: DirectionalPConfig) -> Result<Self, ParamError> {
        positive("gain_neg_per_m", config.gain_neg_per_m)?;
        positive("gain_pos_per_m", config.gain_pos_per_m)?;
        // The deadband of a direction-P axis is `[axis.schedule]`'s.
        non_negative(param_key!(ScheduleSection, deadband_m), config.deadband_m)?;
        range("output", config.output_min, config.output_max)?;
        Ok(Self { config })
    }

    /// Replace both gains (scheduling, adaptation); non-finite or non-positive gains are ignored.
    pub fn set_gains(&mut self, gain_neg_per_m: f64, gain_pos_per_m: f64) {
        if gain_neg_per_m.is_finite() && gain_neg_per_m > 0.0 {
            self.config.gain_neg_per_m = gain_neg_per_m;
        }
        if gain_pos_per_m.is_finite() && gain_pos_per_m > 0.0 {
            self.config.gain_pos_per_m = gain_pos_per_m;
        }
    }

    /// `(q01, q02)`.
    pub fn gains(&self) -> (f64, f64) {
        (self.config.gain_neg_per_m, self.config.gain_pos_per_m)
    }

    /// `U = q01 e_w (e_w < 0)`, `U = q02 e_w (e_w > 0)`, limited (Isermann & Raab, pneumatic drive).
    pub fn step(&mut self, setpoint: f64, position: f64) -> f64 {
        let c = &self.config;
        let e = setpoint - position;
        if !e.is_finite() || e.abs() <= c.deadband_m {
            return 0.0_f64.clamp(c.output_min, c.output_max);
        }
        let q = if e < 0.0 {
            c.gain_neg_per_m
        } else {
            c.gain_pos_per_m
        };
        (q * e).clamp(c.output_min, c.output_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> DirectionalPConfig {
        DirectionalPConfig {
            gain_neg_per_m: 200.0,
            gain_pos_per_m: 400.0,
            deadband_m: 1e-6,
            output_min: -1.0,
            output_max: 1.0,
        }
    }

    #[test]
    fn each_direction_has_its_gain_and_the_output_is_limited() {
        let mut p = DirectionalP::new(cfg()).expect("valid");
        assert!((p.step(0.0, 0.001) + 0.2).abs() < 1e-12);
        assert!((p.step(0.001, 0.0) - 0.4).abs() < 1e-12);
        assert_eq!(p.step(0.01, 0.0), 1.0);
        assert_eq!(p.step(0.0, 0.5e-6), 0.0);
        assert_eq!(p.step(f64::NAN, 0.0), 0.0);
    }

    #[test]
    fn rejects_bad_gains() {
        let mut c = cfg();
        c.gain_pos_per_m = -1.0;
        assert_eq!(
            DirectionalP::new(c).err().map(|e| e.name),
            Some("gain_pos_per_m")
        );
    }
}
