//! `supply_gain`: gain that follows the supply, `K = K_nom (S / S_nom)^κ`, with `S` the supply
//! voltage or the pressure difference to atmosphere (Isermann & Raab: `K_I` of the pneumatic
//! drive from 12 to 50 mm/s for `P_L` from 800 to 400 mbar; PWM voltage proportional to supply).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Supply dependence of the power stage gain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyGain {
    /// Exponent `κ`: 1 for a PWM voltage stage, about 1.35 for the paper's pneumatic drive.
    pub exponent: f64,
}

impl SupplyGain {
    /// Gain factor for a supply at `ratio = S / S_nom`.
    #[inline]
    pub fn factor(&self, ratio: f64) -> f64 {
        ratio_power(ratio, self.exponent)
    }
}

/// `(S / S_nom)^κ` for a supply ratio, never negative; exactly 1 at the nominal supply.
#[inline]
pub(crate) fn ratio_power(ratio: f64, exponent: f64) -> f64 {
    if ratio == 1.0 {
        return 1.0;
    }
    ratio.max(0.0).powf(exponent)
}

impl EffectDef for SupplyGain {
    const NAME: &'static str = "supply_gain";
    const EQUATION: &'static str = "K = K_nom (S / S_nom)^κ";
    const PARAMS: &'static [ParamDef] = &[ParamDef::range(
        "exponent",
        Quantity::Ratio,
        0.0,
        5.0,
        1.0,
        "exponent κ of the supply ratio",
    )];
    fn from_values(v: &[f64]) -> Self {
        SupplyGain { exponent: v[0] }
    }
}
