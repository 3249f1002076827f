//! `[axis.schedule]`, declared once: the TOML section of the supply schedule. Part of the
//! structure of the loop: changed by a reload; the dictionary shows its points read-only, one
//! entry per point (`supply_0`, `gain_factor_0`, `drive_gain_down_0`, ...; the drive gains'
//! entries carry their unit), at most eight.

use crate::declare_section;

/// "> 0", finite.
const POSITIVE: f64 = f64::MIN_POSITIVE;

declare_section! {
    /// `[axis.schedule]`: a table of points, one column per key, linear between points and held
    /// beyond the ends. Exactly one of `supply_voltage_v` / `supply_pressure_pa` names the
    /// measured variable; `gain_factor` multiplies the controller's gains, or, on a duty axis,
    /// `drive_gain_down_m_per_s` / `drive_gain_up_m_per_s` (`K_I1`, `K_I2`) give the direction P
    /// gains by the quadratic-cost design with `effort_weight_m2`.
    pub struct ScheduleSection {
        supply_voltage_v: Option<Vec<f64>> = {
            unit: "V", access: ReadOnly, doc: "",
            points: [supply_0, supply_1, supply_2, supply_3, supply_4, supply_5, supply_6,
                     supply_7],
        },
        supply_pressure_pa: Option<Vec<f64>> = {
            unit: "Pa", access: ReadOnly, doc: "",
            points: [supply_0, supply_1, supply_2, supply_3, supply_4, supply_5, supply_6,
                     supply_7],
        },
        /// Factor on the controller's gains at each point.
        gain_factor: Option<Vec<f64>> = {
            unit: "", min: POSITIVE, max: f64::MAX, access: ReadOnly, doc: "",
            points: [gain_factor_0, gain_factor_1, gain_factor_2, gain_factor_3, gain_factor_4,
                     gain_factor_5, gain_factor_6, gain_factor_7],
        },
        /// With `gain_factor`: the share of `output_min`/`output_max` the supply allows, in
        /// (0, 1] (a PWM stage at a surge would put more than the drive's rated voltage on it);
        /// 1 when absent.
        command_limit_factor: Option<Vec<f64>> = {
            unit: "", min: POSITIVE, max: 1.0, access: Restart, doc: "",
        },
        drive_gain_down_m_per_s: Option<Vec<f64>> = {
            unit: "m/s", access: ReadOnly, doc: "",
            points: [drive_gain_down_0, drive_gain_down_1, drive_gain_down_2, drive_gain_down_3,
                     drive_gain_down_4, drive_gain_down_5, drive_gain_down_6, drive_gain_down_7],
        },
        drive_gain_up_m_per_s: Option<Vec<f64>> = {
            unit: "m/s", access: ReadOnly, doc: "",
            points: [drive_gain_up_0, drive_gain_up_1, drive_gain_up_2, drive_gain_up_3,
                     drive_gain_up_4, drive_gain_up_5, drive_gain_up_6, drive_gain_up_7],
        },
        /// `r` of the cost `Σ e² + r U²`, m² per duty².
        effort_weight_m2: Option<f64> = { unit: "m2", access: Restart, doc: "" },
        /// With drive gains: the supply pressure the gains are tuned at; a drive stronger than
        /// there keeps the nominal gains (see `PneumaticAdaptiveConfig::nominal_supply_pa`).
        nominal_supply_pa: Option<f64> = { unit: "Pa", access: Restart, doc: "" },
        /// Errors within this give no command on a direction-P axis, m.
        deadband_m: f64 = {
            unit: "m", min: 0.0, max: f64::MAX, access: Restart, doc: "", default: 0.0,
        },
    }
}

/// What the schedule reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScheduleVariable {
    SupplyVoltage,
    SupplyPressure,
}

impl ScheduleSection {
    /// The measured variable and its column (validated: exactly one is given).
    pub fn variable(&self) -> (ScheduleVariable, &[f64]) {
        match (&self.supply_voltage_v, &self.supply_pressure_pa) {
            (Some(v), _) => (ScheduleVariable::SupplyVoltage, v),
            (None, Some(p)) => (ScheduleVariable::SupplyPressure, p),
            (None, None) => (ScheduleVariable::SupplyVoltage, &[]),
        }
    }

    /// True when the schedule gives drive gains (direction P on a duty axis).
    pub fn schedules_drive_gains(&self) -> bool {
        self.drive_gain_down_m_per_s.is_some() || self.drive_gain_up_m_per_s.is_some()
    }
}
