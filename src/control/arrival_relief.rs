//! Arrival relief: the integral a loop with dry friction stores on its way to a set-point,
//! taken out just before the body arrives, by an amount learned per direction.
//!
//! With friction the integral part has to supply the force that keeps the body moving, and it
//! keeps winding while the body is on its way; the body then reaches the set-point with more
//! drive than holding it there needs and crosses it at speed. The coil's lag and the sample
//! delay let it run on by about `v T_lag` before the braking force builds up, and friction holds
//! it there: a steady error of the size of the overshoot, growing with friction (a higher
//! viscous part makes the approach a slow creep driven by the integral, a higher stiction lets
//! more integral pile up before breakaway). The sign-switched Coulomb compensation cannot
//! remove it: it acts only after the crossing.
//!
//! So, once per set-point, when the body moving towards it is predicted to arrive within the
//! lead time, the controller's stored output is lowered by `R±` in the direction of the move:
//! - arrival predicted: `d (w - y) < max(d v, 0) T_lead`, `d = sign(w - y)` at the set-point's
//!   start, `v = (y(k) - y(k-1)) / T_0`; an arrival faster than `v_max` is the linear loop's
//!   own transient (a large step), and its set-point is left alone;
//! - relief: `Δu = -d R±`, once, to the controller's state (not as an added signal: the integral
//!   itself is what carries the body past).
//!
//! `R±` is learned from what follows the relief, two-sided like Isermann & Raab's friction
//! controller: a body that ends past the set-point was relieved too little, one that stops short
//! of it too much:
//! - `R±(k) = R±(k-1) + γ_R T_0 d (y(k) - w)` while `|y - w| > e_db`, held in `[0, R_max]`.
//!
//! Allocation-free; the caller applies the relief to its controller.

use super::param_error::{non_negative, positive, ParamError};
use super::FrictionCompensationSection as Section;
use crate::param_key;

/// Configuration of [`ArrivalRelief`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArrivalReliefConfig {
    /// `T_0` (s).
    pub period_s: f64,
    /// `T_lead`: relieve when the body is predicted to arrive within this time (about the
    /// loop's lag: current build-up plus a sample), s.
    pub lead_s: f64,
    /// `γ_R`, command unit per m of end error per s.
    pub gain_per_m_s: f64,
    /// `R_max`, the largest relief per direction, command unit.
    pub max: f64,
    /// `e_db`: end errors within this do not adapt (sensor quanta), m.
    pub deadband_m: f64,
    /// `v_max`: an arrival faster than this is the linear loop's own transient (a large step),
    /// not friction's creep: neither relieved nor learned from, m/s.
    pub speed_max_m_per_s: f64,
}

/// What the relief did in one cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ArrivalReliefStep {
    /// Change to apply to the controller's stored output this cycle, command unit (0 but in
    /// the cycle of an arrival).
    pub relief: f64,
    /// `R+`, `R-` after this cycle.
    pub relief_pos: f64,
    pub relief_neg: f64,
}

/// Learned arrival relief per direction. Allocation-free.
#[derive(Debug, Clone)]
pub struct ArrivalRelief {
    config: ArrivalReliefConfig,
    /// `R+`, `R-`.
    levels: [f64; 2],
    /// The set-point being approached, to tell a new one.
    setpoint: f64,
    /// `d`: +1, -1, or 0 for a set-point the body already stood at.
    direction: f64,
    relieved: bool,
    /// The arrival of the present set-point was relieved (not skipped as too fast): its end
    /// adapts `R±`.
    learning: bool,
    last_position: f64,
}

impl ArrivalRelief {
    /// Checks the period and lead time (> 0) and the gain, maximum and deadband (>= 0).
    pub fn new(config: ArrivalReliefConfig) -> Result<Self, ParamError> {
        positive("period_s", config.period_s)?;
        // Named by the keys of `[axis.friction_compensation]` they come from.
        positive(param_key!(Section, arrival_lead_s), config.lead_s)?;
        positive(
            param_key!(Section, arrival_speed_max_m_per_s),
            config.speed_max_m_per_s,
        )?;
        non_negative(
            param_key!(Section, arrival_relief_gain_per_m_s),
            config.gain_per_m_s,
        )?;
        non_negative(param_key!(Section, arrival_relief_max), config.max)?;
        non_negative(param_key!(Section, deadband_m), config.deadband_m)?;
        Ok(Self {
            config,
            levels: [0.0; 2],
            setpoint: f64::NAN,
            direction: 0.0,
            relieved: false,
            learning: false,
            last_position: f64::NAN,
        })
    }

    /// `(R+, R-)`.
    pub fn levels(&self) -> (f64, f64) {
        (self.levels[0], self.levels[1])
    }

    /// Start from levels learned before, clamped to `[0, R_max]`.
    pub fn set_levels(&mut self, pos: f64, neg: f64) {
        for (l, v) in self.levels.iter_mut().zip([pos, neg]) {
            if v.is_finite() {
                *l = v.clamp(0.0, self.config.max);
            }
        }
    }

    /// Forget the set-point in progress (after a fault reset): the next one starts afresh.
    pub fn reset(&mut self) {
        self.setpoint = f64::NAN;
        self.direction = 0.0;
        self.relieved = false;
        self.learning = false;
        self.last_position = f64::NAN;
    }

    /// One cycle with set-point `w` and measured position `y`.
    pub fn step(&mut self, setpoint: f64, position: f64) -> ArrivalReliefStep {
        let c = self.config;
        let mut out = ArrivalReliefStep::default();
        if !(setpoint.is_finite() && position.is_finite()) {
            (out.relief_pos, out.relief_neg) = self.levels();
            return out;
        }
        // v = (y(k) - y(k-1)) / T_0
        let speed = if self.last_position.is_finite() {
            (position - self.last_position) / c.period_s
        } else {
            0.0
        };
        self.last_position = position;
        let error = setpoint - position;
        if setpoint != self.setpoint {
            self.setpoint = setpoint;
            self.relieved = false;
            self.learning = false;
            // d = sign(w - y) at the start; a set-point within the deadband is no approach.
            self.direction = if error.abs() > c.deadband_m {
                error.signum()
            } else {
                0.0
            };
        }
        let d = self.direction;
        let i = usize::from(d < 0.0);
        if d != 0.0 && !self.relieved {
            // Arrival within T_lead: d (w - y) < max(d v, 0) T_lead.
            if d * error < (d * speed).max(0.0) * c.lead_s {
                self.relieved = true;
                // Only a creeping arrival (|v| <= v_max) is friction's: Δu = -d R±.
                self.learning = speed.abs() <= c.speed_max_m_per_s;
                if self.learning {
                    out.relief = -d * self.levels[i];
                }
            }
        } else if self.learning && error.abs() > c.deadband_m {
            // R± += γ_R T_0 d (y - w): past the set-point raises, short of it lowers.
            self.levels[i] =
                (self.levels[i] - c.gain_per_m_s * c.period_s * d * error).clamp(0.0, c.max);
        }
        (out.relief_pos, out.relief_neg) = self.levels();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn relief() -> ArrivalRelief {
        ArrivalRelief::new(ArrivalReliefConfig {
            period_s: 0.0025,
            lead_s: 0.005,
            gain_per_m_s: 20_000.0,
            max: 0.6,
            deadband_m: 3e-6,
            speed_max_m_per_s: 0.02,
        })
        .expect("valid")
    }

    /// Moves from `from` towards `to` at 2 mm/s (5 µm per period), then stands at `end`; the
    /// reliefs applied on the way.
    fn approach(r: &mut ArrivalRelief, from: f64, to: f64, end: f64, standing: usize) -> Vec<f64> {
        let mut out = vec![];
        let step = 5e-6 * (to - from).signum();
        let mut y = from;
        while (end - y) * step.signum() > 0.0 {
            out.push(r.step(to, y).relief);
            y += step;
        }
        for _ in 0..standing {
            out.push(r.step(to, end).relief);
        }
        out
    }

    #[test]
    fn relieves_once_just_before_arrival_against_the_direction_of_the_move() {
        let mut r = relief();
        r.set_levels(0.2, 0.3);
        let mut y = 0.0;
        let mut applied = vec![];
        while y < 0.0002 {
            applied.push((y, r.step(0.0002, y).relief));
            y += 5e-6;
        }
        let reliefs: Vec<_> = applied.iter().filter(|(_, u)| *u != 0.0).collect();
        assert_eq!(reliefs.len(), 1, "{reliefs:?}");
        let (at, du) = *reliefs[0];
        // 2 mm/s x 5 ms = 10 µm before the set-point.
        assert!((0.0002 - at) < 10e-6 + 1e-9 && 0.0002 - at > 4e-6, "{at}");
        assert_eq!(du, -0.2);
        // The way down uses R-, with the opposite sign.
        let down = approach(&mut r, 0.0002, 0.0, 0.0, 1);
        assert_eq!(down.iter().filter(|u| **u != 0.0).count(), 1);
        assert!(down.contains(&0.3), "{down:?}");
    }

    #[test]
    fn ending_past_the_set_point_raises_the_relief_and_short_of_it_lowers_it() {
        let mut r = relief();
        // 10 µm past for 0.5 s: 20000 x 2.5 ms x 10 µm = 0.5 mV per period, 0.1 V.
        approach(&mut r, 0.0, 0.0002, 0.00021, 200);
        let (pos, neg) = r.levels();
        assert!((pos - 0.1).abs() < 0.005, "{pos}");
        assert_eq!(neg, 0.0);
        // 5 µm short for 0.5 s takes half of it back.
        approach(&mut r, 0.0, 0.0004, 0.000395, 200);
        let (pos, _) = r.levels();
        assert!((pos - 0.05).abs() < 0.005, "{pos}");
        // Standing within the deadband changes nothing.
        approach(&mut r, 0.0, 0.0002, 0.000202, 1);
        let before = r.levels();
        for _ in 0..400 {
            r.step(0.0002, 0.000202);
        }
        assert_eq!(r.levels(), before);
        assert!((before.0 - pos).abs() < 1e-3, "{before:?} vs {pos}");
    }

    #[test]
    fn a_set_point_the_body_already_stands_at_and_a_standing_body_are_not_relieved() {
        let mut r = relief();
        r.set_levels(0.2, 0.2);
        for _ in 0..100 {
            assert_eq!(r.step(0.001, 0.001).relief, 0.0);
        }
        // Standing short of a new set-point: no speed, no predicted arrival.
        for _ in 0..100 {
            assert_eq!(r.step(0.0012, 0.001).relief, 0.0);
        }
        assert_eq!(r.levels(), (0.2, 0.2));
    }

    #[test]
    fn a_fast_arrival_is_neither_relieved_nor_learned_from() {
        let mut r = relief();
        r.set_levels(0.2, 0.2);
        // 25 mm/s: 62.5 µm per period, then 50 µm past for a second.
        let mut y = 0.0;
        while y < 0.001 {
            assert_eq!(r.step(0.001, y).relief, 0.0);
            y += 62.5e-6;
        }
        for _ in 0..400 {
            r.step(0.001, 0.00105);
        }
        assert_eq!(r.levels(), (0.2, 0.2));
    }

    #[test]
    fn bounded_by_the_maximum_and_rejects_a_bad_configuration() {
        let mut r = relief();
        approach(&mut r, 0.0, 0.0002, 0.0003, 100_000);
        assert_eq!(r.levels(), (0.6, 0.0));
        let bad = ArrivalReliefConfig {
            period_s: 0.0025,
            lead_s: 0.0,
            gain_per_m_s: 1.0,
            max: 1.0,
            deadband_m: 0.0,
            speed_max_m_per_s: 0.02,
        };
        let e = ArrivalRelief::new(bad).expect_err("lead 0");
        assert!(e.to_string().contains("arrival_lead_s"), "{e}");
    }
}
