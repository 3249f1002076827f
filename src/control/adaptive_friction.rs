//! Adaptive friction compensation (Isermann & Raab, "adaptive compensation"): a linear reference
//! model gives `y_M` from the set-point, the deviation `e_M(k) = y(k) - y_M(k)` is read as the
//! effect of friction, and a slow friction controller adapts the compensation `U_comp±` per
//! direction; the compensation applied is `U_comp(k) = U_comp± sign(e_w(k))`.
//!
//! - reference model, first order: `y_M(k) = a y_M(k-1) + (1 - a) w(k)`, `a = exp(-T_0 / T_M)`;
//! - friction controller, integral, for the direction `d = sign(w - y_M)` in which the model
//!   approached the present set-point (held once it has settled):
//!   `U_comp+(k) = U_comp+(k-1) - γ T_0 e_M(k)` while `d = +`,
//!   `U_comp-(k) = U_comp-(k-1) + γ T_0 e_M(k)` while `d = -`, both held in `[0, U_max]`;
//!   adaptation only once the model has settled (`|w - y_M| < s_M`) and `|e_M| > e_M,db`, so the
//!   linear transient and sensor noise are not taken for friction, and not for the rest of a
//!   set-point whose transient already carried the position past it by more than `e_M,db`.
//!
//! The law is two-sided. A position stuck short of the settled model (`d e_M < 0`) says the
//! compensation of the approach direction is too small and raises it; a position pushed past the
//! set-point after the model settled (`d e_M > 0`) says that compensation carried it over and
//! lowers it. Choosing the adapted direction by `sign(e_w)` instead would charge an overshoot to
//! the opposite compensation, where it reads as "too small" again: both values could then only
//! grow, and noise and the loop's small limit cycles ratchet them up to `U_max`, which the
//! supervision then reads as a friction rise. An overshoot the linear transient made before the
//! model settled (the loop's own dynamics, stuck there by friction) says nothing about the
//! compensation, hence the freeze for that set-point.
//!
//! External loads look exactly like friction to this law: a load that pulls against the `+`
//! direction raises `U_comp+` like friction would, and when the load goes away (or reverses) the
//! compensation is too large until the controller has adapted down again: a transient
//! over-compensation, expected and bounded by `U_max` and the adaptation rate `γ`.

use super::param_error::{non_negative, positive, ParamError};
use super::AdaptiveFrictionSection;
use crate::param::Declared;

/// Configuration of [`AdaptiveFriction`]: the declared section and what the axis adds.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveFrictionConfig {
    /// `T_0` (s).
    pub period_s: f64,
    /// `[axis.adaptive_friction]`: `T_M`, `γ`, `U_max` and the bands, as declared.
    pub params: AdaptiveFrictionSection,
    /// Starting `U_comp+` and `U_comp-` (e.g. the feed-forward value `α F_C± / K`).
    pub initial_pos: f64,
    pub initial_neg: f64,
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
    /// `d`: direction in which the model approached the present set-point: `+1`, `-1`, or `0`
    /// before the first move.
    approach: f64,
    /// The set-point of the last step, to tell a new one.
    last_setpoint: f64,
    /// The transient of the present set-point carried the position past it: no adaptation.
    transient_overshoot: bool,
    comp_pos: f64,
    comp_neg: f64,
}

impl AdaptiveFriction {
    /// Checks the period (> 0), the section against its declaration, initial values within
    /// `[0, U_max]`.
    pub fn new(config: AdaptiveFrictionConfig) -> Result<Self, ParamError> {
        let c = &config;
        positive("period_s", c.period_s)?;
        c.params.check()?;
        let max = c.params.compensation_max;
        for (name, v) in [
            ("initial_pos", c.initial_pos),
            ("initial_neg", c.initial_neg),
        ] {
            non_negative(name, v)?;
            if v > max {
                return Err(ParamError::new(
                    name,
                    format!(
                        "must be <= {} {max}, got {v}",
                        crate::param_key!(AdaptiveFrictionSection, compensation_max)
                    ),
                ));
            }
        }
        Ok(Self {
            a: (-c.period_s / c.params.model_time_constant_s).exp(),
            y_model: None,
            approach: 0.0,
            last_setpoint: f64::NAN,
            transient_overshoot: false,
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
        let m = self.config.params.compensation_max;
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
        self.approach = 0.0;
        self.last_setpoint = f64::NAN;
        self.transient_overshoot = false;
    }

    /// One step with set-point `w` and measured position `y`.
    pub fn step(&mut self, setpoint: f64, position: f64) -> AdaptiveFrictionOutput {
        let c = &self.config.params;
        let period_s = self.config.period_s;
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
        if setpoint != self.last_setpoint {
            self.last_setpoint = setpoint;
            self.transient_overshoot = false;
        }
        if !settled {
            // d = sign(w - y_M): the direction of the move the model is making.
            self.approach = (setpoint - y_m).signum();
            if self.approach * e_w < -c.model_deadband_m {
                self.transient_overshoot = true;
            }
        }
        if settled && !self.transient_overshoot && e_m.abs() > c.model_deadband_m {
            // ΔU_comp± = ∓γ T_0 e_M: short of the model raises, pushed past it lowers.
            let step = c.adaptation_gain_per_m_s * period_s * e_m;
            if self.approach > 0.0 {
                self.comp_pos = (self.comp_pos - step).clamp(0.0, c.compensation_max);
            } else if self.approach < 0.0 {
                self.comp_neg = (self.comp_neg + step).clamp(0.0, c.compensation_max);
            }
        }
        // U_comp(k) = U_comp± sign(e_w(k)), zero within the error deadband.
        let compensation = if e_w > c.error_deadband_m {
            self.comp_pos
        } else if e_w < -c.error_deadband_m {
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
            params: AdaptiveFrictionSection {
                model_time_constant_s: 0.02,
                adaptation_gain_per_m_s: 1000.0,
                compensation_max: 0.5,
                error_deadband_m: 3e-6,
                model_deadband_m: 5e-6,
                settled_band_m: 20e-6,
            },
            initial_pos: 0.0,
            initial_neg: 0.0,
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

    /// Settles on `w` with the position following the model exactly (no deviation, no
    /// adaptation), approaching from below.
    fn settle_from_below(f: &mut AdaptiveFriction, w: f64) {
        let mut y = 0.0;
        for _ in 0..200 {
            y = f.step(w, y).model_position;
        }
    }

    #[test]
    fn pushed_past_the_set_point_after_settling_lowers_the_approach_compensation() {
        let mut f = AdaptiveFriction::new(AdaptiveFrictionConfig {
            initial_pos: 0.2,
            initial_neg: 0.2,
            ..cfg()
        })
        .expect("valid");
        settle_from_below(&mut f, 0.001);
        assert_eq!(f.compensation_values(), (0.2, 0.2));
        let mut out = AdaptiveFrictionOutput::default();
        for _ in 0..200 {
            out = f.step(0.001, 0.00105);
        }
        // 50 µm past a set-point approached from below: U_comp+ pushed too hard.
        assert!(out.compensation_pos < 0.2 - 0.02, "{out:?}");
        assert_eq!(out.compensation_neg, 0.2);
        // The compensation applied on this side is still the negative one.
        assert_eq!(out.compensation, -0.2);
    }

    #[test]
    fn a_limit_cycle_around_the_set_point_does_not_ratchet_the_compensation_up() {
        let mut f = AdaptiveFriction::new(AdaptiveFrictionConfig {
            initial_pos: 0.1,
            initial_neg: 0.1,
            ..cfg()
        })
        .expect("valid");
        settle_from_below(&mut f, 0.001);
        // 30 µm either side of the set-point, 20 cycles on each side, for 10 s.
        for k in 0..4000 {
            let y = if (k / 20) % 2 == 0 { 0.00097 } else { 0.00103 };
            f.step(0.001, y);
        }
        let (pos, neg) = f.compensation_values();
        assert!((pos - 0.1).abs() < 0.01, "U_comp+ {pos}");
        assert_eq!(neg, 0.1);
    }

    #[test]
    fn an_overshoot_of_the_transient_freezes_the_adaptation_until_the_next_set_point() {
        let mut f = AdaptiveFriction::new(AdaptiveFrictionConfig {
            initial_pos: 0.1,
            initial_neg: 0.1,
            ..cfg()
        })
        .expect("valid");
        // At rest at 0, then a step up: the position jumps 50 µm past at once and sticks there.
        for _ in 0..10 {
            f.step(0.0, 0.0);
        }
        for _ in 0..400 {
            f.step(0.001, 0.00105);
        }
        assert_eq!(f.compensation_values(), (0.1, 0.1));
        // A new set-point below, approached from above and stuck short: U_comp- adapts again.
        for _ in 0..400 {
            f.step(0.0005, 0.0006);
        }
        let (pos, neg) = f.compensation_values();
        assert_eq!(pos, 0.1);
        assert!(neg > 0.15, "U_comp- {neg}");
    }
}
