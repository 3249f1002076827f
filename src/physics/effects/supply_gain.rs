//! `supply_gain`: gain that follows the supply, `K = K_nom (S / S_nom)^κ`, with `S` the supply
//! voltage or the pressure difference to atmosphere (Isermann & Raab: `K_I` of the pneumatic
//! drive from 12 to 50 mm/s for `P_L` from 800 to 400 mbar; PWM voltage proportional to supply).
//! The paper's pneumatic drive has a law per direction, `K_I1(P_L)` and `K_I2(P_L)`: the two
//! directions are two valves, so the positive command may take another exponent, `κ + Δκ`. A
//! PWM stage scales both directions alike (`Δκ = 0`).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Supply dependence of the power stage gain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyGain {
    /// Exponent `κ`: 1 for a PWM voltage stage, about 1.35 for the paper's pneumatic drive.
    pub exponent: f64,
    /// `Δκ`: the positive command's exponent minus the negative command's (pneumatic only).
    pub exponent_pos_shift: f64,
}

impl SupplyGain {
    /// Gain factor for a supply at `ratio = S / S_nom`.
    #[inline]
    pub fn factor(&self, ratio: f64) -> f64 {
        ratio_power(ratio, self.exponent)
    }

    /// Gain factor for a command of sign `positive`: `(S / S_nom)^(κ + Δκ)` for a positive
    /// command, `(S / S_nom)^κ` for a negative one (Isermann & Raab's `K_I2(P_L)`, `K_I1(P_L)`).
    #[inline]
    pub fn factor_for(&self, ratio: f64, positive: bool) -> f64 {
        let shift = if positive {
            self.exponent_pos_shift
        } else {
            0.0
        };
        ratio_power(ratio, self.exponent + shift)
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
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::range(
            "exponent",
            Quantity::Ratio,
            0.0,
            5.0,
            1.0,
            "exponent κ of the supply ratio (the negative command's, when Δκ is not 0)",
        ),
        ParamDef::range(
            "exponent_pos_shift",
            Quantity::Ratio,
            -5.0,
            5.0,
            0.0,
            "Δκ: the positive command's exponent minus the negative command's (pneumatic only)",
        ),
    ];
    fn from_values(v: &[f64]) -> Self {
        SupplyGain {
            exponent: v[0],
            exponent_pos_shift: v[1],
        }
    }
    fn check(v: &[f64]) -> Result<(), (usize, String)> {
        if v[0] + v[1] < 0.0 {
            return Err((
                1,
                format!(
                    "exponent + exponent_pos_shift must be >= 0 (the gain never falls as the \
                     supply rises), got {} + {}",
                    v[0], v[1]
                ),
            ));
        }
        Ok(())
    }
}
