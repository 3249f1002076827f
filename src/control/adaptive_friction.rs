//! Adaptive friction compensation (Isermann & Raab, "adaptive compensation"): a linear reference
//! model gives `y_M` from the set-point, the deviation `e_M(k) = y(k) - y_M(k)` is read as the
//! effect of friction, and a slow friction controller adapts the compensation `U_comp±` per
//! direction; the compensation applied is `U_comp(k) = U_comp± sign(e_w(k))`.
//!
//! - reference model, first order: `y_M(k) = a y_M(k-1) + (1 - a) w(k)`, `a = exp(-T_0 / T_M)`;
//! - friction controller, integral on `|e_M|`, once the model has settled (`|w - y_M| < s_M`):
//!   `U_comp,d(k) = U_comp,d(k-1) + γ T_0 |e_M(k)|` while the position stands stuck short of
//!   the set-point approached in direction `d = sign(w - y_M)` (held once the model settled);
//!   `U_comp,c(k) = U_comp,c(k-1) - γ T_0 |e_M(k)|` while it is past the set-point after a
//!   crossing in direction `c` that the compensation made; both held in `[0, U_max]`, and
//!   nothing within `|e_M| <= e_M,db` (sensor noise, the linear model's own error).
//!
//! The law is two-sided: stuck short says the approach's compensation is too small, carried over
//! says the crossing direction's is too large. Choosing the adapted direction by `sign(e_w)`
//! instead would charge an overshoot to the opposite compensation, where it reads as "too small"
//! again: both values could then only grow, and noise and the loop's small limit cycles ratchet
//! them up to `U_max`, which the supervision then reads as a friction rise.
//!
//! What does not count, and why:
//! - **Not stuck.** A position is stuck when it stayed within `e_db` of where it stopped for at
//!   least `T_M`: a turning point, a large step's halt while the current catches up, or a creep
//!   towards the set-point is not friction holding it.
//! - **A breakaway slip.** With static friction above the moving one (`F_S > F_C`) a position
//!   stuck short is freed by the integral part only at the breakaway force, and the excess
//!   `F_S - F_C` carries it past the set-point: a slip that says the approach compensation was
//!   too small, not too large. A crossing after a stuck phase lowers nothing, and nothing more
//!   is raised at that set-point (with strong stiction every step ends that way; lowering there
//!   took both levels to zero).
//! - **The transient's overshoot.** An overshoot the linear transient made before the model
//!   settled is the loop's own dynamics: nothing is raised for that set-point.
//! - **Large steps** (`|Δw| > Δw_max`): such a step stalls on its way, and away from the
//!   set-point the controller's integral holds a constant compensation as part of its output,
//!   so raising it there helps nothing; nothing is raised for that set-point. A crossing that
//!   the compensation made still lowers, also while the loop hunts around the set-point.
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
    /// Nothing more is raised at the present set-point: it is a large step, its transient
    /// carried the position past it, or the position slipped past it after sticking short.
    frozen: bool,
    /// The position stood short of the settled model at this set-point.
    stuck_short: bool,
    /// Where the position stopped, to tell a standing position.
    last_position: f64,
    /// How long the position has stood (within `e_db` of where it stopped), s.
    standing_s: f64,
    /// Side of the set-point (`+1` below, `-1` above, beyond `e_M,db`) last seen, `0` before.
    side: f64,
    /// The position stood stuck off the set-point since it last crossed it.
    stood_off: bool,
    /// Direction whose compensation carried the position over the set-point at the last
    /// crossing (after the model settled, without a stuck phase before it), `0` for none.
    carried: f64,
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
            frozen: false,
            stuck_short: false,
            last_position: f64::NAN,
            standing_s: 0.0,
            side: 0.0,
            stood_off: false,
            carried: 0.0,
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
        self.frozen = false;
        self.stuck_short = false;
        self.last_position = f64::NAN;
        self.standing_s = 0.0;
        self.side = 0.0;
        self.stood_off = false;
        self.carried = 0.0;
    }

    /// Changes the level of direction `d` (`+1`: `U_comp+`, `-1`: `U_comp-`) by `delta`, held in
    /// `[0, U_max]`.
    fn adapt(&mut self, d: f64, delta: f64) {
        let max = self.config.params.compensation_max;
        if d > 0.0 {
            self.comp_pos = (self.comp_pos + delta).clamp(0.0, max);
        } else if d < 0.0 {
            self.comp_neg = (self.comp_neg + delta).clamp(0.0, max);
        }
    }

    /// One step with set-point `w` and measured position `y`.
    pub fn step(&mut self, setpoint: f64, position: f64) -> AdaptiveFrictionOutput {
        let c = self.config.params.clone();
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
        // Standing: within e_db of where it stopped (NaN before the first step: not standing).
        if (position - self.last_position).abs() <= c.error_deadband_m {
            self.standing_s += period_s;
        } else {
            self.last_position = position;
            self.standing_s = 0.0;
        }
        // Stuck, not turning or creeping: a stop the loop makes on its way (a large step's
        // armature halting while the current catches up) ends within the model's time constant,
        // and a creep covers more than e_db in it.
        let stuck = self.standing_s >= c.model_time_constant_s;
        if setpoint != self.last_setpoint {
            self.frozen = (setpoint - self.last_setpoint).abs() > c.step_max_m;
            self.last_setpoint = setpoint;
            self.stuck_short = false;
            self.carried = 0.0;
        }
        if !settled {
            // d = sign(w - y_M): the direction of the move the model is making.
            self.approach = (setpoint - y_m).signum();
            if self.approach * e_w < -c.model_deadband_m {
                self.frozen = true;
            }
        }
        // Which side of the set-point the position is on, beyond e_M,db: +1 below, -1 above.
        let side = if e_w > c.model_deadband_m {
            1.0
        } else if e_w < -c.model_deadband_m {
            -1.0
        } else {
            0.0
        };
        if side != 0.0 && side != self.side {
            // Crossed the set-point moving in the direction -side. After a stuck phase it is a
            // breakaway slip; otherwise the compensation of that direction carried it over.
            self.carried = if settled && self.side != 0.0 && !self.stood_off {
                -side
            } else {
                0.0
            };
            self.side = side;
            self.stood_off = false;
        }
        if stuck && side != 0.0 {
            self.stood_off = true;
        }
        // d e_M: < 0 stuck short of the model, > 0 past it.
        let past = self.approach * e_m;
        if settled && past > c.model_deadband_m && self.stuck_short {
            // Broke away from short of the set-point and slipped past it: stiction, not the
            // compensation.
            self.frozen = true;
        }
        let rate = c.adaptation_gain_per_m_s * period_s;
        if settled && stuck && !self.frozen && past < -c.model_deadband_m {
            self.stuck_short = true;
            // ΔU_comp,d = γ T_0 |e_M|: stuck short of the model, the approach's level rises.
            self.adapt(self.approach, rate * e_m.abs());
        } else if settled && self.carried != 0.0 && side == -self.carried {
            // ΔU_comp,d = -γ T_0 |e_M|: carried past the set-point by the compensation of the
            // crossing's direction, that level falls, whether the position stands there or the
            // loop hunts around the set-point.
            self.adapt(self.carried, -rate * e_m.abs());
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
                step_max_m: 1.0,
            },
            initial_pos: 0.0,
            initial_neg: 0.0,
        }
    }

    /// The law of [`cfg`] starting from `initial` in both directions, adapting on set-point
    /// changes up to `step_max_m`.
    fn law(initial: f64, step_max_m: f64) -> AdaptiveFriction {
        AdaptiveFriction::new(AdaptiveFrictionConfig {
            params: AdaptiveFrictionSection {
                step_max_m,
                ..cfg().params
            },
            initial_pos: initial,
            initial_neg: initial,
            ..cfg()
        })
        .expect("valid")
    }

    /// At rest at 0 with the set-point 0.
    fn rest_at_zero(f: &mut AdaptiveFriction) {
        for _ in 0..10 {
            f.step(0.0, 0.0);
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
        let mut f = law(0.2, 1.0);
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
        let mut f = law(0.1, 1.0);
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
        let mut f = law(0.1, 1.0);
        // At rest at 0, then a step up: the position jumps 50 µm past at once and sticks there.
        rest_at_zero(&mut f);
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

    #[test]
    fn a_slip_past_the_set_point_after_sticking_short_does_not_lower_the_compensation() {
        let mut f = law(0.2, 1.0);
        rest_at_zero(&mut f);
        // A step up; the position stops 40 µm short once the model has settled ...
        for _ in 0..200 {
            f.step(0.001, 0.00096);
        }
        let raised = f.compensation_values().0;
        assert!(raised > 0.2 + 0.01, "U_comp+ {raised}");
        // ... breaks away and slips 40 µm past, where static friction holds it.
        for k in 0..400 {
            f.step(0.001, 0.00096 + 80e-6 * f64::from((k + 1).min(4)) / 4.0);
        }
        assert_eq!(f.compensation_values().0, raised);
        // The next set-point's overshoot without a stuck phase lowers it again.
        settle_from_below(&mut f, 0.002);
        for _ in 0..200 {
            f.step(0.002, 0.00205);
        }
        assert!(f.compensation_values().0 < raised - 0.01);
    }

    #[test]
    fn a_position_still_travelling_behind_the_settled_model_adapts_nothing() {
        let mut f = AdaptiveFriction::new(cfg()).expect("valid");
        rest_at_zero(&mut f);
        // A drive at its limit: 20 µm per period (8 mm/s) towards a set-point 10 mm away, long
        // after the 20 ms model settled.
        for k in 0..400 {
            f.step(0.01, 20e-6 * f64::from(k));
        }
        assert_eq!(f.compensation_values(), (0.0, 0.0));
    }

    #[test]
    fn a_large_step_stuck_short_teaches_nothing() {
        let mut f = law(0.0, 1e-3);
        rest_at_zero(&mut f);
        // 5 mm, stuck 300 µm short: the loop's stop, not the compensation's.
        for _ in 0..400 {
            f.step(0.005, 0.0047);
        }
        assert_eq!(f.compensation_values(), (0.0, 0.0));
        // A small step from there, stuck short: adapts.
        for _ in 0..400 {
            f.step(0.0055, 0.0054);
        }
        assert!(f.compensation_values().0 > 0.05);
    }

    #[test]
    fn hunting_around_the_set_point_after_a_large_step_lowers_both_levels() {
        let mut f = law(0.4, 1e-3);
        rest_at_zero(&mut f);
        // A 5 mm step; once the model has settled the position swings 60 µm either side of the
        // set-point every 8 periods, never standing: the compensation drives a relay cycle.
        for _ in 0..100 {
            f.step(0.005, 0.005);
        }
        for k in 0..800 {
            let y = if (k / 8) % 2 == 0 { 0.00494 } else { 0.00506 };
            f.step(0.005, y + 1e-6 * f64::from(k % 8));
        }
        let (pos, neg) = f.compensation_values();
        // 60 µm for 8 periods per swing: γ T_0 |e_M| 8 = 1.2 mV per swing and direction.
        assert!(pos < 0.35 && neg < 0.35, "U_comp+ {pos}, U_comp- {neg}");
    }
}
