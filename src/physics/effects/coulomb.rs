//! `coulomb`: `F = -F_C± sign(v)` while moving, and holds any net force up to `F_C±` at rest
//! (Isermann & Raab: `F_F = F_C± sign(y')`; Bao et al. eq. 4: `f_pc`, `f_nc`).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Coulomb (dry, velocity-independent) friction with a level per direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coulomb {
    /// Level while moving positive (N or N·m).
    pub level_pos: f64,
    /// Level while moving negative.
    pub level_neg: f64,
}

impl EffectDef for Coulomb {
    const NAME: &'static str = "coulomb";
    const EQUATION: &'static str = "F = -F_C± sign(v)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::non_negative("coulomb_pos", Quantity::Force, 0.3, "level while v > 0"),
        ParamDef::non_negative("coulomb_neg", Quantity::Force, 0.3, "level while v < 0"),
    ];
    fn from_values(v: &[f64]) -> Self {
        Coulomb {
            level_pos: v[0],
            level_neg: v[1],
        }
    }
}
