//! The axis' supply schedule as one part: the gain factor and command limit factor scheduled on
//! the measured supply voltage or pressure, and the scheduled band outside which the loop goes
//! on with a warning. Built once from `[axis.schedule]` and the scheduled limits of
//! `[axis.limits]`, stepped in the scheduling stage.

use super::super::config::{cycles, AxisConfig, ScheduleVariable};
use crate::control::{BandStatus, ControllerError, GainSchedule, ParamError, SupplyBand};

pub struct SupplySchedule {
    gain_schedule: Option<(ScheduleVariable, GainSchedule)>,
    /// The scheduled band of the measured supply and what it reads.
    band: Option<(ScheduleVariable, SupplyBand)>,
    /// Factor on the controller's gains this cycle (1 without a schedule).
    gain_factor: f64,
    /// Share of the output limits the supply allows (the schedule's `command_limit_factor`).
    command_limit_factor: f64,
}

/// What `variable` reads among the supply measurements.
fn reading(variable: ScheduleVariable, supply_voltage_v: f64, supply_pressure_pa: f64) -> f64 {
    match variable {
        ScheduleVariable::SupplyVoltage => supply_voltage_v,
        ScheduleVariable::SupplyPressure => supply_pressure_pa,
    }
}

impl SupplySchedule {
    /// The schedule and band an axis configuration asks for (neither: factors 1, no band).
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        let unvalidated = |e: ParamError| ControllerError::NotFinite(e.name);
        let gain_schedule = match (cfg.gain_factor_points(), &cfg.schedule) {
            (Ok(Some(points)), Some(s)) => Some((
                s.variable().0,
                GainSchedule::new(&points).map_err(unvalidated)?,
            )),
            (Err(_), _) => {
                return Err(ControllerError::NotFinite(crate::param_key!(
                    AxisConfig, schedule
                )))
            }
            _ => None,
        };
        let l = &cfg.limits;
        let scheduled_band = |lo: Option<f64>, hi: Option<f64>| {
            if lo.is_none() && hi.is_none() {
                return Ok(None);
            }
            SupplyBand::new(
                lo.unwrap_or(f64::MIN),
                hi.unwrap_or(f64::MAX),
                cycles(l.supply_time_s, period_s),
            )
            .map(Some)
        };
        let band = match (
            scheduled_band(
                l.supply_voltage_scheduled_min_v,
                l.supply_voltage_scheduled_max_v,
            )
            .map_err(unvalidated)?,
            scheduled_band(
                l.supply_pressure_scheduled_min_pa,
                l.supply_pressure_scheduled_max_pa,
            )
            .map_err(unvalidated)?,
        ) {
            (Some(b), _) => Some((ScheduleVariable::SupplyVoltage, b)),
            (None, Some(b)) => Some((ScheduleVariable::SupplyPressure, b)),
            (None, None) => None,
        };
        Ok(Self {
            gain_schedule,
            band,
            gain_factor: 1.0,
            command_limit_factor: 1.0,
        })
    }

    /// One scheduling stage with this cycle's supply readings; the band judges only fresh ones.
    pub fn step(&mut self, supply_voltage_v: f64, supply_pressure_pa: f64, fresh: bool) {
        if let Some((variable, schedule)) = self.gain_schedule.as_mut() {
            // A lost reading keeps the last factors (the schedule ignores non-finite input).
            let out = schedule.step(reading(*variable, supply_voltage_v, supply_pressure_pa));
            if let Some(&factor) = out.first() {
                self.gain_factor = factor;
            }
            self.command_limit_factor = out.get(1).copied().unwrap_or(1.0);
        }
        if let (Some((variable, band)), true) = (self.band.as_mut(), fresh) {
            band.step(reading(*variable, supply_voltage_v, supply_pressure_pa));
        }
    }

    /// Factor on the controller's gains.
    pub fn gain_factor(&self) -> f64 {
        self.gain_factor
    }

    /// Share of the output limits the supply allows.
    pub fn command_limit_factor(&self) -> f64 {
        self.command_limit_factor
    }

    /// Where the supply is against the scheduled band (inside without one).
    pub fn band(&self) -> BandStatus {
        self.band
            .as_ref()
            .map_or(BandStatus::Inside, |(_, b)| b.status())
    }

    /// The scheduled band watches the supply pressure (else the supply voltage).
    pub fn band_is_pressure(&self) -> bool {
        matches!(self.band, Some((ScheduleVariable::SupplyPressure, _)))
    }
}
