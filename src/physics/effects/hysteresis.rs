//! `hysteresis`: rate-independent play operator on the drive force,
//! `z = min(max(z, F - w/2), F + w/2)`, loop width `w` (magnetic hysteresis in Isermann & Raab's
//! static characteristic).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Play (backlash-type) hysteresis operator with total width `w` in force units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hysteresis {
    /// Loop width along the force axis (N or N·m).
    pub width: f64,
}

impl Hysteresis {
    /// Output of the play operator for input `f` given the previous output `z`.
    #[inline]
    pub fn play(&self, z: f64, f: f64) -> f64 {
        let r = 0.5 * self.width;
        z.clamp(f - r, f + r)
    }
}

impl EffectDef for Hysteresis {
    const NAME: &'static str = "hysteresis";
    const EQUATION: &'static str = "z = clamp(z, F - w/2, F + w/2)";
    const PARAMS: &'static [ParamDef] = &[ParamDef::non_negative(
        "width",
        Quantity::Force,
        0.2,
        "loop width along the drive force axis",
    )];
    fn from_values(v: &[f64]) -> Self {
        Hysteresis { width: v[0] }
    }
}
