//! `pneumatic`: membrane drive with two PWM on/off valves. The valves set a speed
//! `v_c = K_I1 d` (d < 0, V1 to the low pressure, down) or `v_c = K_I2 d` (d > 0, V2 to
//! atmosphere, up), Isermann & Raab's `Y(k) = Y(k-1) + K_I T_0 U(k-1)`; the membrane follows it
//! through the air's compliance, `F = (m / τ) (v_c - v)`, so that with no other force `v → v_c`
//! with time constant `τ` and friction or load slow it down. The dependence of `K_I` on the supply
//! pressure is the `supply_gain` effect.

use super::body::Drive;
use crate::physics::effects::SupplyGain;
use crate::physics::family::Family;
use crate::physics::params::{ParamDef, Quantity};

/// Base parameters of the `[pneumatic]` table.
pub const PARAMS: &[ParamDef] = &[
    ParamDef::positive(
        "mass_kg",
        Quantity::Named("kg"),
        0.2,
        "moving mass of membrane and rod",
    ),
    ParamDef::non_negative(
        "gain_down_m_per_s",
        Quantity::Named("m/s"),
        0.030,
        "K_I1, speed at full duty down",
    ),
    ParamDef::non_negative(
        "gain_up_m_per_s",
        Quantity::Named("m/s"),
        0.022,
        "K_I2, speed at full duty up",
    ),
    ParamDef::positive(
        "velocity_time_constant_s",
        Quantity::Named("s"),
        0.002,
        "τ, lag of the speed",
    ),
    ParamDef::any("stroke_min_m", Quantity::Named("m"), 0.0, "lower end stop"),
    ParamDef::any(
        "stroke_max_m",
        Quantity::Named("m"),
        0.020,
        "upper end stop",
    ),
    ParamDef::positive(
        "supply_pressure_pa",
        Quantity::Named("Pa"),
        60_000.0,
        "nominal low pressure P_L, absolute",
    ),
    ParamDef::positive(
        "atmosphere_pa",
        Quantity::Named("Pa"),
        101_325.0,
        "atmospheric pressure",
    ),
];

/// Valves and chamber of the membrane drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValveDrive {
    /// `K_I1` (m/s per unit duty), down.
    pub gain_down: f64,
    /// `K_I2` (m/s per unit duty), up.
    pub gain_up: f64,
    /// `m / τ` (N·s/m).
    pub coupling: f64,
    /// Nominal `P_L` (Pa, absolute).
    pub supply_pa: f64,
    /// Atmosphere (Pa).
    pub atmosphere_pa: f64,
}

impl ValveDrive {
    /// From values in [`PARAMS`] order.
    pub fn from_values(v: &[f64]) -> Self {
        ValveDrive {
            gain_down: v[1],
            gain_up: v[2],
            coupling: v[0] / v[3],
            supply_pa: v[6],
            atmosphere_pa: v[7],
        }
    }

    /// Steady speed for duty `d` at supply ratio `ratio` (no friction, no load).
    pub fn speed(&self, d: f64, ratio: f64, sg: Option<SupplyGain>) -> f64 {
        self.power(d, ratio, sg, 1.0)
    }
}

impl Drive for ValveDrive {
    const FAMILY: Family = Family::Pneumatic;

    #[inline]
    fn power(&self, u: f64, ratio: f64, sg: Option<SupplyGain>, gain: f64) -> f64 {
        let d = u.clamp(-1.0, 1.0);
        let v = if d < 0.0 {
            self.gain_down * d
        } else {
            self.gain_up * d
        };
        // Each valve its own law over the supply: `K_I1(P_L)` evacuating, `K_I2(P_L)` venting.
        let k = sg.map_or(1.0, |s| s.factor_for(ratio, d > 0.0));
        v * k * gain
    }

    #[inline(always)]
    fn aux_rate(&self, _p: f64, _x: &[f64; 3]) -> f64 {
        0.0
    }

    #[inline(always)]
    fn force(&self, p: f64, x: &[f64; 3]) -> f64 {
        self.coupling * (p - x[1])
    }

    fn current(&self, _x: &[f64; 3]) -> f64 {
        0.0
    }

    /// Supply ratio is the available pressure difference to atmosphere over its nominal value.
    fn supply(&self, ratio: f64) -> (f64, f64) {
        (
            0.0,
            self.atmosphere_pa - ratio * (self.atmosphere_pa - self.supply_pa),
        )
    }

    fn supply_ratio_of(&self, value: f64) -> f64 {
        (self.atmosphere_pa - value) / (self.atmosphere_pa - self.supply_pa)
    }
}
