//! `saturation`: input limits, `u' = min(max(u, u_min), u_max)`.

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Command limits, in command units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Saturation {
    /// Lower limit.
    pub min: f64,
    /// Upper limit.
    pub max: f64,
}

impl Saturation {
    /// Clipped command.
    #[inline]
    pub fn apply(&self, u: f64) -> f64 {
        u.max(self.min).min(self.max)
    }
}

impl EffectDef for Saturation {
    const NAME: &'static str = "saturation";
    const EQUATION: &'static str = "u' = min(max(u, u_min), u_max)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::any("min", Quantity::Command, -1.0, "lower limit"),
        ParamDef::any("max", Quantity::Command, 1.0, "upper limit"),
    ];
    fn from_values(v: &[f64]) -> Self {
        Saturation {
            min: v[0],
            max: v[1],
        }
    }
    fn check(v: &[f64]) -> Result<(), (usize, String)> {
        if v[1] < v[0] {
            return Err((1, format!("must be >= min ({}), got {}", v[0], v[1])));
        }
        Ok(())
    }
}
