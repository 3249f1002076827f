//! `stribeck`: extra friction decaying from the static to the Coulomb level,
//! `F = -sign(v) (F_S± - F_C±) e^(-|v / v_S±|)` (Bao et al. eq. 4).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Stribeck effect: the friction excess at low speed and its decay velocity, per direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stribeck {
    /// `F_S+ - F_C+`, excess over Coulomb at zero speed, positive motion (N or N·m).
    pub excess_pos: f64,
    /// `F_S- - F_C-`.
    pub excess_neg: f64,
    /// Stribeck velocity for v > 0 (m/s or rad/s).
    pub velocity_pos: f64,
    /// Stribeck velocity for v < 0 (magnitude).
    pub velocity_neg: f64,
}

impl Stribeck {
    /// Magnitude of the extra friction at speed `v` moving in direction `dir` (+1 or -1).
    #[inline]
    pub fn excess(&self, dir: f64, v: f64) -> f64 {
        if dir > 0.0 {
            self.excess_pos * (-(v.abs() / self.velocity_pos)).exp()
        } else {
            self.excess_neg * (-(v.abs() / self.velocity_neg)).exp()
        }
    }
}

impl EffectDef for Stribeck {
    const NAME: &'static str = "stribeck";
    const EQUATION: &'static str = "F = -sign(v) (F_S± - F_C±) exp(-|v / v_S±|)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::non_negative(
            "excess_pos",
            Quantity::Force,
            0.1,
            "static minus Coulomb level, v > 0",
        ),
        ParamDef::non_negative(
            "excess_neg",
            Quantity::Force,
            0.1,
            "static minus Coulomb level, v < 0",
        ),
        ParamDef::positive(
            "velocity_pos",
            Quantity::Velocity,
            0.001,
            "Stribeck velocity, v > 0",
        ),
        ParamDef::positive(
            "velocity_neg",
            Quantity::Velocity,
            0.001,
            "Stribeck velocity, v < 0",
        ),
    ];
    fn from_values(v: &[f64]) -> Self {
        Stribeck {
            excess_pos: v[0],
            excess_neg: v[1],
            velocity_pos: v[2],
            velocity_neg: v[3],
        }
    }
}
