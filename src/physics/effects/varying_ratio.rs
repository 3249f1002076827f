//! `varying_ratio`: transmission ratio that grows with the load angle, `h = h_0 / cos θ_l`
//! (Bao et al., fork-lever geometry), `|θ_l|` limited to `θ_max` to keep `h` finite.

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Load-angle-dependent gear ratio of the motor_gear family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VaryingRatio {
    /// Largest angle used in `1 / cos θ` (rad).
    pub max_angle: f64,
}

impl VaryingRatio {
    /// Factor `h / h_0` at load angle `theta`.
    #[inline]
    pub fn factor(&self, theta: f64) -> f64 {
        1.0 / theta.abs().min(self.max_angle).cos()
    }
}

impl EffectDef for VaryingRatio {
    const NAME: &'static str = "varying_ratio";
    const EQUATION: &'static str = "h = h_0 / cos(θ_l)";
    const PARAMS: &'static [ParamDef] = &[ParamDef::range(
        "max_angle",
        Quantity::Position,
        0.0,
        1.5,
        1.3,
        "largest |θ| used in 1/cos θ",
    )];
    fn from_values(v: &[f64]) -> Self {
        VaryingRatio { max_angle: v[0] }
    }
}
