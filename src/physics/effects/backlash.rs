//! `backlash`: dead zone between drive and load, `T = K_g (Δ - b sign Δ)` for `|Δ| >= b`, 0 in
//! the gap (Bao et al. eq. 1-2, contact and backlash modes), with `b` half the total play.

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Backlash: the total play (lost motion at a reversal) between the drive and the load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Backlash {
    /// Total play `2b` (m or rad).
    pub gap: f64,
}

impl Backlash {
    /// Half the play, Bao et al.'s `b`.
    #[inline]
    pub fn half(&self) -> f64 {
        0.5 * self.gap
    }
}

impl EffectDef for Backlash {
    const NAME: &'static str = "backlash";
    const EQUATION: &'static str = "T = K_g (Δ - b sign Δ) if |Δ| >= b else 0, gap = 2b";
    const PARAMS: &'static [ParamDef] = &[ParamDef::non_negative(
        "gap",
        Quantity::Position,
        0.005,
        "total play, lost motion at a reversal",
    )];
    fn from_values(v: &[f64]) -> Self {
        Backlash { gap: v[0] }
    }
}
