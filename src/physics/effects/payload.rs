//! `payload`: load that grows with position, `F_L = -F_max · clamp(y / y_full, -1, 1)`
//! (Bao et al.: `T_l = T_lmax δ_5`, payload proportional to the load angle).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Position-dependent load force or torque.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Payload {
    /// Load at full scale (N or N·m).
    pub max_load: f64,
    /// Position of full load (m or rad).
    pub full_scale: f64,
}

impl Payload {
    /// Load force at position `y` (opposes positive `y` for a positive `max_load`).
    #[inline]
    pub fn force(&self, y: f64) -> f64 {
        -self.max_load * (y / self.full_scale).clamp(-1.0, 1.0)
    }
}

impl EffectDef for Payload {
    const NAME: &'static str = "payload";
    const EQUATION: &'static str = "F_L = -F_max clamp(y / y_full, -1, 1)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::any("max_load", Quantity::Force, 1.0, "load at full scale"),
        ParamDef::positive(
            "full_scale",
            Quantity::Position,
            1.0,
            "position of full load",
        ),
    ];
    fn from_values(v: &[f64]) -> Self {
        Payload {
            max_load: v[0],
            full_scale: v[1],
        }
    }
    #[inline(always)]
    fn load_force(&self, y: f64, _v: f64) -> Option<f64> {
        Some(self.force(y))
    }
}
