//! `supply_friction`: dry friction that follows the supply, `F_C±(S) = F_C± (S / S_nom)^κ_f`,
//! the Coulomb, Stribeck and breakaway levels alike: a seal pressed by the pressure it seals (an
//! O-ring's friction grows with the supply pressure, about in proportion, κ_f ≈ 1).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Supply dependence of the dry friction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyFriction {
    /// Exponent `κ_f` of the supply ratio: 0 is no dependence, 1 friction in proportion.
    pub exponent: f64,
}

impl SupplyFriction {
    /// Factor on the dry friction levels at `ratio = S / S_nom`: `(S / S_nom)^κ_f`.
    #[inline]
    pub fn factor(&self, ratio: f64) -> f64 {
        super::supply_gain::ratio_power(ratio, self.exponent)
    }
}

impl EffectDef for SupplyFriction {
    const NAME: &'static str = "supply_friction";
    const EQUATION: &'static str = "F_C±(S) = F_C± (S / S_nom)^κ_f";
    const PARAMS: &'static [ParamDef] = &[ParamDef::range(
        "exponent",
        Quantity::Ratio,
        0.0,
        5.0,
        1.0,
        "exponent κ_f of the supply ratio on the dry friction",
    )];
    fn from_values(v: &[f64]) -> Self {
        SupplyFriction { exponent: v[0] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn friction_follows_the_supply_ratio_by_its_exponent() {
        let proportional = SupplyFriction { exponent: 1.0 };
        assert_eq!(proportional.factor(3.0), 3.0);
        assert_eq!(SupplyFriction { exponent: 0.0 }.factor(7.0), 1.0);
        assert!((SupplyFriction { exponent: 2.0 }.factor(0.5) - 0.25).abs() < 1e-15);
        // No supply, no pressed seal: never a negative friction.
        assert_eq!(proportional.factor(-1.0), 0.0);
    }
}
