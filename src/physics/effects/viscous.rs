//! `viscous`: `F = -d± · v`, damping per direction (Isermann & Raab: `F_F = F_C± sign(y') + d± y'`;
//! Bao et al. eq. 4: `f_pv ω`, `f_nv ω`).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Viscous friction with one coefficient per direction of motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Viscous {
    /// Coefficient for v > 0 (N·s/m or N·m·s/rad).
    pub damping_pos: f64,
    /// Coefficient for v < 0.
    pub damping_neg: f64,
}

impl Viscous {
    /// Friction force at velocity `v` (opposes the motion).
    #[inline]
    pub fn force(&self, v: f64) -> f64 {
        if v >= 0.0 {
            -self.damping_pos * v
        } else {
            -self.damping_neg * v
        }
    }
}

impl EffectDef for Viscous {
    const NAME: &'static str = "viscous";
    const EQUATION: &'static str = "F = -d± v";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::non_negative(
            "damping_pos",
            Quantity::Damping,
            1.0,
            "coefficient for v > 0",
        ),
        ParamDef::non_negative(
            "damping_neg",
            Quantity::Damping,
            1.0,
            "coefficient for v < 0",
        ),
    ];
    fn from_values(v: &[f64]) -> Self {
        Viscous {
            damping_pos: v[0],
            damping_neg: v[1],
        }
    }
}
