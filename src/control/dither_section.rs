//! `[axis.dither]`, declared once: the TOML section and its ranges. A dither is part of the
//! structure of the loop and is changed by a reload, not over the dictionary.

use super::DitherConfig;
use crate::declare_section;
use crate::param::{Declared, ParamError, COMMAND_UNIT};

/// "> 0".
const POSITIVE: f64 = f64::MIN_POSITIVE;

declare_section! {
    /// `[axis.dither]`: `u_d = A sin(2π f t)`, fixed or self-adapting (see [`super::Dither`]).
    /// The keys after `adapt` are needed only with `adapt = true`.
    pub struct DitherSection {
        /// Starting (or fixed) amplitude `A`, command unit.
        amplitude: f64 = {
            unit: COMMAND_UNIT, min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Starting (or fixed) frequency `f`, at most `1 / (2 T_0)`, Hz.
        frequency_hz: f64 = {
            unit: "Hz", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Adapt amplitude and frequency.
        adapt: bool = { unit: "", access: Restart, doc: "", default: false },
        /// Amplitude band `[A_min, A_max]`, command unit.
        amplitude_min: Option<f64> = {
            unit: COMMAND_UNIT, min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        amplitude_max: Option<f64> = {
            unit: COMMAND_UNIT, min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Frequency band `[f_min, f_max]`, Hz.
        frequency_min_hz: Option<f64> = {
            unit: "Hz", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        frequency_max_hz: Option<f64> = {
            unit: "Hz", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// `ρ_A`, amplitude change rate, command unit per s.
        amplitude_rate_per_s: Option<f64> = {
            unit: "", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// `ρ_f`, relative frequency change rate, 1/s.
        frequency_rate_per_s: Option<f64> = {
            unit: "1/s", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// `e_tol`: errors within this count as on target, m.
        error_tolerance_m: Option<f64> = {
            unit: "m", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// `r_move`: mean |Δy| per sample below this counts as standstill, m.
        ripple_moving_m: Option<f64> = {
            unit: "m", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// `r_max`: mean |Δy| per sample above this is too much ripple, m.
        ripple_max_m: Option<f64> = {
            unit: "m", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Time constant of the ripple smoothing, s.
        ripple_time_constant_s: Option<f64> = {
            unit: "s", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
    }
}

impl DitherSection {
    /// With `adapt = true` every optional key is needed: the error names the first left out.
    pub fn check_adaptation(&self) -> Result<(), ParamError> {
        if !self.adapt {
            return Ok(());
        }
        match Self::PARAMS
            .iter()
            .find(|p| p.optional && !self.present(p.name))
        {
            Some(p) => Err(ParamError::new(p.name, "is needed with adapt = true")),
            None => Ok(()),
        }
    }

    /// The generator of a cycle of `period_s`; without adaptation the bands collapse onto the
    /// fixed values.
    pub fn config(&self, period_s: f64) -> DitherConfig {
        DitherConfig {
            period_s,
            amplitude: self.amplitude,
            frequency_hz: self.frequency_hz,
            adapt: self.adapt,
            amplitude_min: self.amplitude_min.unwrap_or(self.amplitude),
            amplitude_max: self.amplitude_max.unwrap_or(self.amplitude),
            frequency_min_hz: self.frequency_min_hz.unwrap_or(self.frequency_hz),
            frequency_max_hz: self.frequency_max_hz.unwrap_or(self.frequency_hz),
            amplitude_rate_per_s: self.amplitude_rate_per_s.unwrap_or(0.0),
            frequency_rate_per_s: self.frequency_rate_per_s.unwrap_or(0.0),
            error_tolerance_m: self.error_tolerance_m.unwrap_or(0.0),
            ripple_moving_m: self.ripple_moving_m.unwrap_or(0.0),
            ripple_max_m: self.ripple_max_m.unwrap_or(f64::MAX),
            ripple_time_constant_s: self.ripple_time_constant_s.unwrap_or(period_s),
        }
    }
}
