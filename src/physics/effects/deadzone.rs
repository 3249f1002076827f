//! `deadzone`: input dead zone of the power stage, `u' = u - u_0 sign(u)` for `|u| > u_0`, else 0.

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Dead zone on the command, in command units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deadzone {
    /// Threshold `u_0` below which nothing comes out.
    pub threshold: f64,
}

impl Deadzone {
    /// Command after the dead zone.
    #[inline]
    pub fn apply(&self, u: f64) -> f64 {
        if u > self.threshold {
            u - self.threshold
        } else if u < -self.threshold {
            u + self.threshold
        } else {
            0.0
        }
    }
}

impl EffectDef for Deadzone {
    const NAME: &'static str = "deadzone";
    const EQUATION: &'static str = "u' = u - u_0 sign(u) if |u| > u_0 else 0";
    const PARAMS: &'static [ParamDef] = &[ParamDef::non_negative(
        "threshold",
        Quantity::Command,
        0.05,
        "half width of the dead zone",
    )];
    fn from_values(v: &[f64]) -> Self {
        Deadzone { threshold: v[0] }
    }
}
