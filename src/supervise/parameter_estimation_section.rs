//! `[axis.parameter_estimation]`, declared once: the TOML section, its ranges, and the window
//! and symptom settings the dictionary offers for writing in pre-operational (the model's
//! constants, the floors and the table need a reload).

use super::{FaultSymptomTable, FaultTableError, ParameterEstimatorConfig, SymptomThresholds};
use crate::declare_section;
use crate::param::{Kind, ParamError, ParamValue};
use serde::Deserialize;
use std::path::PathBuf;

/// "> 0" for a physical constant of the model.
const POSITIVE: f64 = f64::MIN_POSITIVE;
/// The smallest value the dictionary takes for "> 0".
const POSITIVE_MIN: f64 = 1e-12;

declare_section! {
    /// `[axis.parameter_estimation]`: θ by state-variable filters and least squares over windows
    /// of moving samples in operation → `p` → symptoms against the nominal `p` → fault-symptom
    /// table.
    pub struct ParameterEstimationSection {
        /// Corner of the state-variable filters, above the plant's poles, rad/s.
        filter_omega_rad_s: f64 = {
            unit: "rad/s", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Known mass of the model (not identifiable), kg.
        mass_kg: f64 = {
            unit: "kg", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Known current-loop time constant `T_I`: picks the current pole among the roots, s.
        current_time_constant_s: f64 = {
            unit: "s", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Speed above which a sample counts as moving, m/s.
        moving_speed_m_per_s: f64 = {
            unit: "m/s", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Consecutive moving samples before they enter the regression (the filters' memory).
        min_moving_samples: u32 = {
            unit: "", access: Restart, doc: "",
        },
        /// The same after an arrival relief: the stop it leaves holds a force static friction
        /// set, which the filters carry further into the next move (at least
        /// `min_moving_samples`).
        disturbed_moving_samples: u32 = {
            unit: "", access: Restart, doc: "", default: 16,
        },
        /// Regression updates per estimation window: at least ten for the six parameters.
        window_updates: u64 = {
            unit: "", min: 10.0, access: PreOperational,
            doc: "estimator updates per window (one short test)",
        },
        /// Windows averaged into the learned nominal `p` (when `nominal` is not given).
        nominal_windows: u32 = {
            unit: "", min: 1.0, access: PreOperational,
            doc: "first windows averaged into the nominal values (unless configured)",
            default: 1,
        },
        /// Consecutive windows with the same diagnosis before it counts as present.
        confirm_windows: u32 = {
            unit: "", min: 1.0, access: PreOperational,
            doc: "windows in a row that must agree on a fault",
            default: 1,
        },
        /// A deviation from the nominal beyond this many standard deviations is a symptom (the
        /// deviation propagated from the estimator's covariance, or the spread of the windows
        /// that gave the nominal values when that is larger).
        symptom_sigmas: f64 = {
            unit: "", min: POSITIVE_MIN, max: 100.0, access: PreOperational,
            doc: "a symptom needs |p - p_nom| above this many standard deviations",
        },
        /// Relative floor per `[T_I, D, ω0, K_P, F_C, F_0]`: deviations within
        /// `floor · |p_nom|` are never symptoms; `inf` = not judged.
        relative_floor: [f64; 6] = {
            unit: "", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Largest number of differing symptoms (of six) for the nearest table row to count.
        max_distance: u8 = {
            unit: "", max: 6.0, access: PreOperational,
            doc: "most symptoms a diagnosis may differ from its table row",
        },
        /// Fault-symptom table file (relative to the configuration file); absent: the table
        /// built into the program, `config/fault_symptoms.toml` of its sources.
        fault_table: Option<PathBuf> = { unit: "", access: Restart, doc: "" },
        /// Configured nominal `p`; absent: learned from the first windows.
        nominal: Option<NominalParameters> = {
            unit: "", min: f64::MIN, max: f64::MAX, access: Restart, doc: "",
        },
    }
}

impl ParameterEstimationSection {
    /// The symptom test's settings.
    pub fn symptom_thresholds(&self) -> SymptomThresholds {
        SymptomThresholds {
            sigmas: self.symptom_sigmas,
            relative_floor: self.relative_floor,
        }
    }

    /// The configured fault-symptom table, or the built-in one.
    pub fn load_fault_table(&self) -> Result<FaultSymptomTable, FaultTableError> {
        match &self.fault_table {
            Some(path) => FaultSymptomTable::load(path),
            None => FaultSymptomTable::shipped(),
        }
    }

    /// The estimator of a cycle of `period_s`.
    pub fn estimator_config(&self, period_s: f64) -> ParameterEstimatorConfig {
        ParameterEstimatorConfig {
            period_s,
            filter_omega_rad_s: self.filter_omega_rad_s,
            // One window is one short test: no forgetting inside it.
            forgetting: 1.0,
            mass_kg: self.mass_kg,
            nominal_current_time_constant_s: self.current_time_constant_s,
            moving_speed_m_per_s: self.moving_speed_m_per_s,
            min_moving_samples: self.min_moving_samples,
            disturbed_moving_samples: self.disturbed_moving_samples,
        }
    }
}

/// Nominal physical parameters `p = [T_I, D, ω0, K_P, F_C, F_0]`, as configured and as kept in
/// the state file.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct NominalParameters {
    pub current_time_constant_s: f64,
    pub damping_ratio: f64,
    pub natural_frequency_rad_per_s: f64,
    pub static_gain_m_per_v: f64,
    pub coulomb_friction_n: f64,
    pub pretension_n: f64,
}

impl NominalParameters {
    pub fn values(&self) -> [f64; 6] {
        [
            self.current_time_constant_s,
            self.damping_ratio,
            self.natural_frequency_rad_per_s,
            self.static_gain_m_per_v,
            self.coulomb_friction_n,
            self.pretension_n,
        ]
    }
}

/// A table of six numbers, each checked against the range declared for the key.
impl ParamValue for NominalParameters {
    const KIND: Kind = Kind::Table;
    fn each(&self, f: &mut dyn FnMut(f64) -> Result<(), ParamError>) -> Result<(), ParamError> {
        self.values().into_iter().try_for_each(f)
    }
}
