//! `offset`: constant bias force or torque, `F = F_b` (gravity on an inclined axis, cable drag;
//! the `C_DC±` term of Isermann & Raab's direction-dependent models).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Constant force or torque on the moving body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Offset {
    /// Bias (N or N·m), positive pushes towards positive positions.
    pub bias: f64,
}

impl EffectDef for Offset {
    const NAME: &'static str = "offset";
    const EQUATION: &'static str = "F = F_b";
    const PARAMS: &'static [ParamDef] = &[ParamDef::any(
        "bias",
        Quantity::Force,
        0.0,
        "constant force",
    )];
    fn from_values(v: &[f64]) -> Self {
        Offset { bias: v[0] }
    }
    #[inline(always)]
    fn load_force(&self, _y: f64, _v: f64) -> Option<f64> {
        Some(self.bias)
    }
}
