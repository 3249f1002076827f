//! `[axis.adaptive_friction]`, declared once: the TOML section, its ranges, and the entries the
//! dictionary offers for writing in pre-operational. The algorithm takes it as it is.

use crate::declare_section;
use crate::param::COMMAND_UNIT;

/// The smallest value the dictionary takes for "> 0".
const POSITIVE_MIN: f64 = 1e-12;

declare_section! {
    /// `[axis.adaptive_friction]`: `U_comp±` adapted from the reference-model deviation
    /// `e_M = y - y_M` (see [`super::AdaptiveFriction`]). Command unit: V or duty, as `command`.
    pub struct AdaptiveFrictionSection {
        /// `T_M`, time constant of the first-order reference model: the loop's speed without
        /// friction, s.
        model_time_constant_s: f64 = {
            unit: "s", min: POSITIVE_MIN, max: 1e3, access: PreOperational,
            doc: "T_M of the reference model y_M",
        },
        /// `γ`, command unit per m of model deviation per s.
        adaptation_gain_per_m_s: f64 = {
            unit: "", min: 0.0, max: 1e9, access: PreOperational,
            doc: "gamma: compensation change per m of model deviation per s",
        },
        /// `U_max`, the largest compensation per direction, command unit.
        compensation_max: f64 = {
            unit: COMMAND_UNIT, min: 0.0, max: 1e3, access: PreOperational,
            doc: "largest U_comp per direction",
        },
        /// `e_db`: control errors within this give no compensation, m.
        error_deadband_m: f64 = {
            unit: "m", min: 0.0, max: 1.0, access: PreOperational, doc: "",
        },
        /// `e_M,db`: model deviations within this do not adapt (sensor noise), m.
        model_deadband_m: f64 = {
            unit: "m", min: 0.0, max: 1.0, access: PreOperational, doc: "",
        },
        /// `s_M`: adapt only when `|w - y_M|` is below this (the model has settled), m.
        settled_band_m: f64 = {
            unit: "m", min: POSITIVE_MIN, max: 1.0, access: PreOperational, doc: "",
        },
        /// `Δw_max`: set-point changes larger than this adapt nothing, m: the stops of a large
        /// step are the loop's transient, which a compensation held by the controller's
        /// integral away from the set-point cannot change.
        step_max_m: f64 = {
            unit: "m", min: 0.0, max: 1e3, access: PreOperational,
            doc: "set-point changes larger than this adapt nothing", default: 1e3,
        },
    }
}
