//! `[axis.controller]`, declared once: the TOML section of the general discrete controller
//! ([`super::DiscreteController`]) and the entries the dictionary offers for writing in
//! pre-operational: the coefficients one entry per slot (`q0_per_m` … `q5_per_m`, `p1` … `p6`),
//! the output limits in the axis' command unit. Its rules are between keys (a state-space file
//! or coefficients, `output_min < output_max`, the limits and the safe command, a duty's
//! range): they stay with the configuration, which names the keys from here.

use std::path::PathBuf;

use crate::declare_section;
use crate::param::{COMMAND_PER_M_UNIT, COMMAND_UNIT};

/// Coefficients are refused beyond this magnitude.
const COEFFICIENT_BOUND: f64 = 1e12;

declare_section! {
    /// `[axis.controller]`: `u(k) = -Σ p_i u(k-i) + Σ q_j e(k-j)`, e in m, u in the command
    /// unit, within `[output_min, output_max]`; or a state-space controller from a file.
    pub struct ControllerSection {
        /// Numerator coefficients q_0..q_m, command unit per m of error.
        q_per_m: Vec<f64> = {
            unit: COMMAND_PER_M_UNIT, min: -COEFFICIENT_BOUND, max: COEFFICIENT_BOUND,
            access: PreOperational,
            doc: "numerator coefficient q_j of u(k) = -sum p_i u(k-i) + sum q_j e(k-j)",
            points: [q0_per_m, q1_per_m, q2_per_m, q3_per_m, q4_per_m, q5_per_m],
            // A write of a zero to the last slot shortens the array, never below one
            // coefficient: without a state-space file the controller needs one.
            kept: 1,
            default: Vec::new(),
        },
        /// A state-space controller file (`actuator design robust`) instead of `q_per_m`/`p`;
        /// relative paths are taken from the configuration file's folder.
        state_space_file: Option<PathBuf> = { unit: "", access: Restart, doc: "" },
        /// Denominator coefficients p_1..p_n (without the leading 1).
        p: Vec<f64> = {
            unit: "", min: -COEFFICIENT_BOUND, max: COEFFICIENT_BOUND, access: PreOperational,
            doc: "denominator coefficient p_i (without the leading 1)",
            points: [p1, p2, p3, p4, p5, p6],
            default: Vec::new(),
        },
        /// Output limits in the command unit; the dictionary bounds them by the command's own
        /// range (±1 for a duty).
        output_min: f64 = {
            unit: COMMAND_UNIT, access: PreOperational, doc: "lower output limit",
            command_bound: true,
        },
        output_max: f64 = {
            unit: COMMAND_UNIT, access: PreOperational, doc: "upper output limit",
            command_bound: true,
        },
    }
}

impl ControllerSection {
    /// A controller that outputs nothing within `[output_min, output_max]`: what a dictionary
    /// built without a configuration shows.
    pub fn unconfigured(output_min: f64, output_max: f64) -> Self {
        Self {
            q_per_m: Vec::new(),
            state_space_file: None,
            p: Vec::new(),
            output_min,
            output_max,
        }
    }
}
