//! `spring`: linear return spring with pretension, `F = -(F_0 + c·y)` (Isermann & Raab:
//! `m Y'' + d Y' + c Y = ...`; fault F1 changes `F_0`, fault F2 changes `c`).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Linear spring; at `y = 0` it already pushes with the pretension `F_0` towards negative `y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// Stiffness `c` (N/m or N·m/rad).
    pub stiffness: f64,
    /// Pretension `F_0` at `y = 0` (N or N·m).
    pub pretension: f64,
}

impl Spring {
    /// Spring force at position `y`.
    #[inline]
    pub fn force(&self, y: f64) -> f64 {
        -(self.pretension + self.stiffness * y)
    }
}

impl EffectDef for Spring {
    const NAME: &'static str = "spring";
    const EQUATION: &'static str = "F = -(F_0 + c y)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::positive(
            "stiffness",
            Quantity::Stiffness,
            1000.0,
            "spring constant c",
        ),
        ParamDef::any("pretension", Quantity::Force, 0.0, "force F_0 at y = 0"),
    ];
    fn from_values(v: &[f64]) -> Self {
        Spring {
            stiffness: v[0],
            pretension: v[1],
        }
    }
    #[inline(always)]
    fn load_force(&self, y: f64, _v: f64) -> Option<f64> {
        Some(self.force(y))
    }
}
