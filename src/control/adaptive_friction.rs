//! Adaptive friction compensation (Isermann & Raab, "adaptive compensation"): a linear reference
//! model gives `y_M` from the set-point, the deviation `e_M(k) = y(k) - y_M(k)` is read as the
//! effect of friction, and a slow friction controller adapts the compensation `U_comp±` per
//! direction; the compensation applied is `U_comp(k) = U_comp± sign(e_w(k))`.
//!
//! - reference model, first order: `y_M(k) = a y_M(k-1) + (1 - a) w(k)`, `a = exp(-T_0 / T_M)`;
//! - friction controller, integral, per direction of the control error:
//!   `U_comp+(k) = U_comp+(k-1) - γ T_0 e_M(k)` while `e_w > e_db`,
//!   `U_comp-(k) = U_comp-(k-1) + γ T_0 e_M(k)` while `e_w < -e_db`, both held in `[0, U_max]`;
//!   adaptation only once the model has settled (`|w - y_M| < s_M`) and `|e_M| > e_M,db`, so the
//!   linear transient and sensor noise are not taken for friction.
//!
//! External loads look exactly like friction to this law: a load that pulls against the `+`
//! direction raises `U_comp+` like friction would, and when the load goes away (or reverses) the
//! compensation is too large until the controller has adapted down again: a transient
//! over-compensation, expected and bounded by `U_max` and the adaptation rate `γ`.

use super::param_error::{non_negative, positive, ParamError};

/// Configuration of [`AdaptiveFriction`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveFrictionConfig {
    /// `T_0` (s).
    pub period_s: f64,
    /// `T_M`, time constant of the reference model (s): the closed loop's speed without friction.
    pub model_time_constant_s: f64,
    /// `γ`, adaptation gain (command unit per m per s).
    pub adaptation_gain_per_m_s: f64,
    /// `U_max`, largest compensation per direction (command unit).
    pub max_compensation: f64,
    /// Starting `U_comp+` and `U_comp-` (e.g. the feed-forward value `α F_C± / K`).
    pub initial_pos: f64,
    pub initial_neg: f64,
    /// `e_db` (m): control errors within this give no compensation.
    pub error_deadband_m: f64,
    /// `e_M,db` (m): model deviations within this do not adapt.
    pub model_deadband_m: f64,
    /// `s_M` (m): adapt only when `|w - y_M|` is below this (model settled).
    pub settled_band_m: f64,
}

/// What [`AdaptiveFriction::step`] computed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AdaptiveFrictionOutput {
    /// Compensation to add to the controller output (command unit).
    pub compensation: f64,
    /// `y_M` (m).
    pub model_position: f64,
    /// `e_M = y - y_M` (m).
    pub model_error: f64,
    /// `U_comp+`, `U_comp-` after this step.
    pub compensation_pos: f64,
    pub compensation_neg: f64,
}

/// Adaptive friction compensation with a reference model. Allocation-free.
#[derive(Debug, Clone)]
pub struct AdaptiveFriction {
    config: AdaptiveFrictionConfig,
    a: f64,
    y_model: Option<f64>,
    comp_pos: f64,
    comp_neg: f64,
}

impl AdaptiveFriction {
    /// Checks periods (> 0), gains and bands (>= 0), initial values within `[0, U_max]`.
    pub fn new(config: AdaptiveFrictionConfig) -> Result<Self, ParamError> {
        let c = &config;
        positive("period_s", c.period_s)?;
        positive("model_time_constant_s", c.model_time_constant_s)?;
        non_negative("adaptation_gain_per_m_s", c.adaptation_gain_per_m_s)?;
        non_negative("max_compensation", c.max_compensation)?;
        for (name, v) in [
            ("initial_pos", c.initial_pos),
            ("initial_neg", c.initial_neg),
        ] {
            non_negative(name, v)?;
            if v > c.max_compensation {
                return Err(ParamError::new(
                    name,
                    format!(
                        "must be <= max_compensation {}, got {v}",
                        c.max_compensation
                    ),
                ));
            }
        }
        non_negative("error_deadband_m", c.error_deadband_m)?;
        non_negative("model_deadband_m", c.model_deadband_m)?;
        positive("settled_band_m", c.settled_band_m)?;
        Ok(Self {
            a: (-c.period_s / c.model_time_constant_s).exp(),
            y_model: None,
            comp_pos: c.initial_pos,
            comp_neg: c.initial_neg,
            config,
        })
    }

    /// `(U_comp+, U_comp-)`, the learned friction as command (what the tuned-parameters frame
    /// carries and the learned table may store).
    pub fn compensation_values(&self) -> (f64, f64) {
        (self.comp_pos, self.comp_neg)
    }

    /// Restart from stored values (e.g. from the learned table), clamped to `[0, U_max]`.
    pub fn set_compensation_values(&mut self, pos: f64, neg: f64) {
        let m = self.config.max_compensation;
        if pos.is_finite() {
            self.comp_pos = pos.clamp(0.0, m);
        }
        if neg.is_finite() {
            self.comp_neg = neg.clamp(0.0, m);
        }
    }

    /// Restart the reference model from the present position (after a fault reset).
    pub fn reset_model(&mut self) {
        self.y_model = None;
    }

    /// One step with set-point `w` and measured position `y`.
    pub fn step(&mut self, setpoint: f64, position: f64) -> AdaptiveFrictionOutput {
        let c = self.config;
        if !(setpoint.is_finite() && position.is_finite()) {
            return AdaptiveFrictionOutput {
                compensation_pos: self.comp_pos,
                compensation_neg: self.comp_neg,
                ..Default::default()
            };
        }
        // y_M(k) = a y_M(k-1) + (1 - a) w(k)
        let prev = self.y_model.unwrap_or(position);
        let y_m = self.a * prev + (1.0 - self.a) * setpoint;
        self.y_model = Some(y_m);
        let e_m = position - y_m;
        let e_w = setpoint - position;
        let settled = (setpoint - y_m).abs() < c.settled_band_m;
        let adapt = settled && e_m.abs() > c.model_deadband_m;
        let step = c.adaptation_gain_per_m_s * c.period_s * e_m;
        let compensation = if e_w > c.error_deadband_m {
            if adapt {
                self.comp_pos = (self.comp_pos - step).clamp(0.0, c.max_compensation);
            }
            self.comp_pos
        } else if e_w < -c.error_deadband_m {
            if adapt {
                self.comp_neg = (self.comp_neg + step).clamp(0.0, c.max_compensation);
            }
            -self.comp_neg
        } else {
            0.0
        };
        AdaptiveFrictionOutput {
            compensation,
            model_position: y_m,
            model_error: e_m,
            compensation_pos: self.comp_pos,
            compensation_neg: self.comp_neg,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> AdaptiveFrictionConfig {
        AdaptiveFrictionConfig {
            period_s: 0.0025,
            model_time_constant_s: 0.02,
            adaptation_gain_per_m_s: 1000.0,
            max_compensation: 0.5,
            initial_pos: 0.0,
            initial_neg: 0.0,
            error_deadband_m: 3e-6,
            model_deadband_m: 5e-6,
            settled_band_m: 20e-6,
        }
    }

    #[test]
    fn a_position_stuck_below_the_model_raises_the_positive_compensation() {
        let mut f = AdaptiveFriction::new(cfg()).expect("valid");
        let mut out = AdaptiveFrictionOutput::default();
        for _ in 0..400 {
            out = f.step(0.001, 0.0009);
        }
        // e_M = -100 µm once settled: γ T0 e_M = 0.25 mV per step... about 300 steps settled.
        assert!(out.compensation_pos > 0.05, "{out:?}");
        assert_eq!(out.compensation_neg, 0.0);
        assert_eq!(out.compensation, out.compensation_pos);
        for _ in 0..400 {
            out = f.step(0.0, 0.0001);
        }
        assert!(out.compensation_neg > 0.05, "{out:?}");
        assert_eq!(out.compensation, -out.compensation_neg);
    }

    #[test]
    fn no_adaptation_while_the_model_moves_and_bounded_by_the_maximum() {
        let mut f = AdaptiveFriction::new(cfg()).expect("valid");
        let out = f.step(0.01, 0.0);
        assert_eq!(out.compensation_pos, 0.0);
        for _ in 0..100_000 {
            f.step(0.01, 0.0);
        }
        assert_eq!(f.compensation_values().0, 0.5);
    }
}
