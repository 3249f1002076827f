//! `dead_time`: input delay, `u'(t) = u(t - T_d)` (Isermann & Raab: `e^(-T_d s)` in `G±`, from
//! the asynchronous PWM).

use std::collections::VecDeque;

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Pure delay of the command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadTime {
    /// Delay `T_d` in s.
    pub delay: f64,
}

impl EffectDef for DeadTime {
    const NAME: &'static str = "dead_time";
    const EQUATION: &'static str = "u'(t) = u(t - T_d)";
    const PARAMS: &'static [ParamDef] = &[ParamDef::range(
        "delay",
        Quantity::Time,
        0.0,
        10.0,
        0.001,
        "delay T_d",
    )];
    fn from_values(v: &[f64]) -> Self {
        DeadTime { delay: v[0] }
    }
}

/// History of a piecewise-constant command, for reading it back `T_d` later.
/// Entries older than needed are dropped, so its size stays at about `T_d / dt + 2`.
#[derive(Debug, Clone, Default)]
pub struct DelayLine {
    /// (time the value was set, value), oldest first.
    history: VecDeque<(f64, f64)>,
}

impl DelayLine {
    /// A line with room for `capacity` entries before it has to grow.
    pub fn with_capacity(capacity: usize) -> Self {
        DelayLine {
            history: VecDeque::with_capacity(capacity),
        }
    }

    /// Record that the command became `u` at time `t`.
    pub fn push(&mut self, t: f64, u: f64) {
        self.history.push_back((t, u));
    }

    /// The command that was active at time `t` (0 before the first one). Queries must not go
    /// back in time: older entries are discarded.
    pub fn at(&mut self, t: f64) -> f64 {
        while self.history.len() >= 2 && self.history[1].0 <= t + 1e-12 {
            self.history.pop_front();
        }
        match self.history.front() {
            Some(&(t0, u)) if t0 <= t + 1e-12 => u,
            _ => 0.0,
        }
    }
}
