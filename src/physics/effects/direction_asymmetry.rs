//! `direction_asymmetry`: input gain per direction of motion, `u' = K± u` (Isermann & Raab's
//! direction-dependent models `G+`, `G-`).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Gain applied to the power stage output, chosen by the direction of motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionAsymmetry {
    /// Gain while moving (or last moved) positive.
    pub gain_pos: f64,
    /// Gain while moving (or last moved) negative.
    pub gain_neg: f64,
}

impl DirectionAsymmetry {
    /// Gain for direction `dir` (+1 or -1).
    #[inline]
    pub fn gain(&self, dir: f64) -> f64 {
        if dir >= 0.0 {
            self.gain_pos
        } else {
            self.gain_neg
        }
    }
}

impl EffectDef for DirectionAsymmetry {
    const NAME: &'static str = "direction_asymmetry";
    const EQUATION: &'static str = "u' = K± u";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::non_negative("gain_pos", Quantity::Ratio, 1.0, "gain, positive motion"),
        ParamDef::non_negative("gain_neg", Quantity::Ratio, 1.0, "gain, negative motion"),
    ];
    fn from_values(v: &[f64]) -> Self {
        DirectionAsymmetry {
            gain_pos: v[0],
            gain_neg: v[1],
        }
    }
}
