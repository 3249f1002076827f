//! `position_stiffness`: drive force that depends on position,
//! `F = F_drive · (c_0 + c_1 (Y_0 - y) + c_2 (Y_0 - y)²)` (Isermann & Raab's solenoid
//! characteristic `f(I, Y) = I Σ c_i (Y_0 - Y)^i`, normalised so that `c_0 = 1, c_1 = c_2 = 0`
//! is the plain drive).

use super::EffectDef;
use crate::physics::params::{ParamDef, Quantity};

/// Position-dependent drive gain (magnet force over air gap, membrane area over stroke).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionStiffness {
    /// `Y_0`, the position the polynomial is written around (26 mm for the paper's magnet).
    pub pole: f64,
    /// Constant term.
    pub c0: f64,
    /// Linear term (1/m or 1/rad).
    pub c1: f64,
    /// Quadratic term (1/m² or 1/rad²).
    pub c2: f64,
}

impl PositionStiffness {
    /// Gain factor at position `y`, never negative.
    #[inline]
    pub fn factor(&self, y: f64) -> f64 {
        let g = self.pole - y;
        (self.c0 + g * (self.c1 + g * self.c2)).max(0.0)
    }
}

impl EffectDef for PositionStiffness {
    const NAME: &'static str = "position_stiffness";
    const EQUATION: &'static str = "F = F_drive (c_0 + c_1 (Y_0 - y) + c_2 (Y_0 - y)^2)";
    const PARAMS: &'static [ParamDef] = &[
        ParamDef::any("pole", Quantity::Position, 0.026, "Y_0, reference position"),
        ParamDef::any("c0", Quantity::Ratio, 1.0, "constant term"),
        ParamDef::any("c1", Quantity::PerPosition, 0.0, "linear term"),
        ParamDef::any("c2", Quantity::PerPosition2, 0.0, "quadratic term"),
    ];
    fn from_values(v: &[f64]) -> Self {
        PositionStiffness {
            pole: v[0],
            c0: v[1],
            c1: v[2],
            c2: v[3],
        }
    }
}
