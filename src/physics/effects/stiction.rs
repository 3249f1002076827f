//! `stiction`: at `v = 0` the body sticks while `-F_S- <= F_net <= F_S+` and breaks away beyond
//! (Bao et al. eq. 4: `f_ps`, `f_ns`; true stick, no creep).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Static friction: breakaway force per direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stiction {
    /// Net force needed to start moving positive (N or N·m).
    pub breakaway_pos: f64,
    /// Net force needed to start moving negative (magnitude).
    pub breakaway_neg: f64,
}

impl EffectDef for Stiction {
    const NAME: &'static str = "stiction";
    const EQUATION: &'static str = "v = 0 while -F_S- <= F_net <= F_S+";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::non_negative(
            "breakaway_pos",
            Quantity::Force,
            0.4,
            "breakaway force, positive",
        ),
        ParamDef::non_negative(
            "breakaway_neg",
            Quantity::Force,
            0.4,
            "breakaway force, negative",
        ),
    ];
    fn from_values(v: &[f64]) -> Self {
        Stiction {
            breakaway_pos: v[0],
            breakaway_neg: v[1],
        }
    }
}
