//! `solenoid`: current loop `T_I I' + I = K_I U` (U the PWM terminal voltage, 0..supply), magnet
//! force `F = K_Mag I` (its position dependence `f(I, Y)` is the `position_stiffness` effect),
//! moving mass and end stops (Isermann & Raab, solenoid drive). The return spring is the `spring`
//! effect. Position 0 is the rest stop, positive is pulled in by the magnet.

use super::body::Drive;
use crate::physics::effects::SupplyGain;
use crate::physics::family::Family;
use crate::physics::params::{ParamDef, Quantity};

/// Base parameters of the `[solenoid]` table.
pub const PARAMS: &[ParamDef] = &[
    ParamDef::positive("mass_kg", Quantity::Named("kg"), 0.4956, "moving mass m"),
    ParamDef::positive(
        "current_time_constant_s",
        Quantity::Named("s"),
        0.00859,
        "T_I of the current loop",
    ),
    ParamDef::positive(
        "current_gain_a_per_v",
        Quantity::Named("A/V"),
        0.1,
        "K_I, steady current per volt",
    ),
    ParamDef::positive(
        "force_constant_n_per_a",
        Quantity::Named("N/A"),
        16.3,
        "K_Mag, force per ampere",
    ),
    ParamDef::any("stroke_min_m", Quantity::Named("m"), 0.0, "rest end stop"),
    ParamDef::any(
        "stroke_max_m",
        Quantity::Named("m"),
        0.025,
        "pulled-in end stop",
    ),
    ParamDef::positive(
        "supply_voltage_v",
        Quantity::Named("V"),
        24.0,
        "nominal supply voltage",
    ),
];

/// Coil and magnet of the solenoid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolenoidDrive {
    /// `T_I` (s).
    pub time_constant: f64,
    /// `K_I` (A/V).
    pub current_gain: f64,
    /// `K_Mag` (N/A).
    pub force_constant: f64,
    /// Nominal supply (V).
    pub supply_v: f64,
}

impl SolenoidDrive {
    /// From values in [`PARAMS`] order.
    pub fn from_values(v: &[f64]) -> Self {
        SolenoidDrive {
            time_constant: v[1],
            current_gain: v[2],
            force_constant: v[3],
            supply_v: v[6],
        }
    }
}

impl Drive for SolenoidDrive {
    const FAMILY: Family = Family::Solenoid;

    /// PWM stage: `U = clamp(u, 0, V_supply)`; with `supply_gain` the duty is computed for the
    /// nominal supply, so `U = clamp(u, 0, V_nom) (V / V_nom)^κ`.
    #[inline]
    fn power(&self, u: f64, ratio: f64, sg: Option<SupplyGain>, gain: f64) -> f64 {
        let v = match sg {
            Some(s) => u.clamp(0.0, self.supply_v) * s.factor(ratio),
            None => u.clamp(0.0, self.supply_v * ratio),
        };
        v * gain
    }

    #[inline(always)]
    fn aux_rate(&self, p: f64, x: &[f64; 3]) -> f64 {
        (self.current_gain * p - x[2]) / self.time_constant
    }

    #[inline(always)]
    fn force(&self, _p: f64, x: &[f64; 3]) -> f64 {
        self.force_constant * x[2]
    }

    fn current(&self, x: &[f64; 3]) -> f64 {
        x[2]
    }

    fn supply(&self, ratio: f64) -> (f64, f64) {
        (self.supply_v * ratio, 0.0)
    }

    fn supply_ratio_of(&self, value: f64) -> f64 {
        value / self.supply_v
    }
}
