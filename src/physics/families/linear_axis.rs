//! `linear_axis`: one rigid body driven by a force, `m y'' = F + ...`, or by a voltage times a
//! gain, `F = K_F clamp(U, -V_supply, V_supply)` (ball-screw axes; the base of the other families).

use super::body::Drive;
use crate::physics::effects::SupplyGain;
use crate::physics::family::Family;
use crate::physics::params::{ParamDef, Quantity};

/// Base parameters of the `[linear_axis]` table.
pub const PARAMS: &[ParamDef] = &[
    ParamDef::positive("mass_kg", Quantity::Named("kg"), 1.0, "moving mass m"),
    ParamDef::positive(
        "force_gain_n_per_v",
        Quantity::Named("N/V"),
        10.0,
        "force per volt (voltage command)",
    ),
    ParamDef::any("travel_min_m", Quantity::Named("m"), -1.0, "lower end stop"),
    ParamDef::any("travel_max_m", Quantity::Named("m"), 1.0, "upper end stop"),
    ParamDef::positive(
        "supply_voltage_v",
        Quantity::Named("V"),
        24.0,
        "supply (voltage command)",
    ),
];

/// Force or voltage drive of the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisDrive {
    /// True when the command is a voltage.
    pub voltage: bool,
    /// `K_F` (N/V).
    pub force_gain: f64,
    /// Nominal supply (V).
    pub supply_v: f64,
}

impl AxisDrive {
    /// From values in [`PARAMS`] order.
    pub fn from_values(v: &[f64], voltage: bool) -> Self {
        AxisDrive {
            voltage,
            force_gain: v[1],
            supply_v: v[4],
        }
    }
}

impl Drive for AxisDrive {
    const FAMILY: Family = Family::LinearAxis;

    #[inline]
    fn power(&self, u: f64, ratio: f64, sg: Option<SupplyGain>, gain: f64) -> f64 {
        if !self.voltage {
            return u * gain;
        }
        let v = match sg {
            Some(s) => u.clamp(-self.supply_v, self.supply_v) * s.factor(ratio),
            None => {
                let lim = self.supply_v * ratio;
                u.clamp(-lim, lim)
            }
        };
        v * self.force_gain * gain
    }

    #[inline(always)]
    fn aux_rate(&self, _p: f64, _x: &[f64; 3]) -> f64 {
        0.0
    }

    #[inline(always)]
    fn force(&self, p: f64, _x: &[f64; 3]) -> f64 {
        p
    }

    fn current(&self, _x: &[f64; 3]) -> f64 {
        0.0
    }

    fn supply(&self, ratio: f64) -> (f64, f64) {
        // A force command has no power stage of its own, but the supply of whatever makes the
        // force is still measured (seal friction may follow it: `supply_friction`).
        (self.supply_v * ratio, 0.0)
    }

    fn supply_ratio_of(&self, value: f64) -> f64 {
        value / self.supply_v
    }
}
