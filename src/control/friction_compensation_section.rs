//! `[axis.friction_compensation]`, declared once: the TOML section, its ranges, and the
//! entries the dictionary offers for writing in pre-operational.

use super::{ArrivalReliefConfig, FrictionFeedForward};
use crate::declare_section;
use crate::param::{COMMAND_UNIT, FORCE_PER_COMMAND_UNIT};

declare_section! {
    /// `[axis.friction_compensation]`: the feed-forward `U_comp = α F_C± / K sign(e)` (see
    /// [`FrictionFeedForward`]); with `[axis.adaptive_friction]`, its starting values.
    pub struct FrictionCompensationSection {
        /// Safety factor `α`, 0 < α ≤ 1.
        alpha: f64 = {
            unit: "", min: 1e-3, max: 1.0, access: PreOperational,
            doc: "safety factor of U_comp = alpha F_C / K sign(e)",
        },
        /// Coulomb friction `F_C+` for motion in + direction, N.
        coulomb_pos_n: f64 = {
            unit: "N", min: 0.0, max: 1e6, access: PreOperational, doc: "",
        },
        /// Coulomb friction `F_C-` for motion in - direction, N.
        coulomb_neg_n: f64 = {
            unit: "N", min: 0.0, max: 1e6, access: PreOperational, doc: "",
        },
        /// `K`, the actuator's force per command unit: N/V, or N per unit duty.
        force_gain_n_per_command: f64 = {
            unit: FORCE_PER_COMMAND_UNIT, min: 1e-9, max: 1e9, access: PreOperational, doc: "",
        },
        /// Errors below this count as zero for the sign, m.
        deadband_m: f64 = {
            unit: "m", min: 0.0, max: 1.0, access: PreOperational, doc: "", default: 0.0,
        },
        /// `R_max` of the arrival relief (see [`super::ArrivalRelief`]): the largest part of
        /// the stored integral taken out just before the body arrives, command unit; 0 (the
        /// default) switches the relief off.
        arrival_relief_max: f64 = {
            unit: COMMAND_UNIT, min: 0.0, max: 1e3, access: Restart, doc: "", default: 0.0,
        },
        /// `γ_R`: relief learned per m of end error per s.
        arrival_relief_gain_per_m_s: f64 = {
            unit: "", min: 0.0, max: 1e9, access: Restart, doc: "", default: 0.0,
        },
        /// `T_lead`: relieve when the body is predicted to arrive within this time, s.
        arrival_lead_s: f64 = {
            unit: "s", min: 1e-6, max: 1.0, access: Restart, doc: "", default: 0.005,
        },
        /// `v_max`: faster arrivals (large steps, the loop's own transient) are left alone, m/s.
        arrival_speed_max_m_per_s: f64 = {
            unit: "m/s", min: 1e-9, max: 1e3, access: Restart, doc: "", default: 0.02,
        },
    }
}

impl FrictionCompensationSection {
    /// A compensation that compensates nothing: what the dictionary shows for an axis without
    /// the section, and what a first write to one of its entries starts from.
    pub fn neutral() -> Self {
        Self {
            alpha: 1.0,
            coulomb_pos_n: 0.0,
            coulomb_neg_n: 0.0,
            force_gain_n_per_command: 1.0,
            deadband_m: 0.0,
            arrival_relief_max: 0.0,
            arrival_relief_gain_per_m_s: 0.0,
            arrival_lead_s: 0.005,
            arrival_speed_max_m_per_s: 0.02,
        }
    }

    /// The arrival relief of these values with control period `period_s`, `None` when it is
    /// off (`arrival_relief_max` 0). Ends within the feed-forward's deadband do not adapt it.
    pub fn arrival_relief(&self, period_s: f64) -> Option<ArrivalReliefConfig> {
        (self.arrival_relief_max > 0.0).then_some(ArrivalReliefConfig {
            period_s,
            lead_s: self.arrival_lead_s,
            gain_per_m_s: self.arrival_relief_gain_per_m_s,
            max: self.arrival_relief_max,
            deadband_m: self.deadband_m,
            speed_max_m_per_s: self.arrival_speed_max_m_per_s,
        })
    }

    /// The feed-forward of these values.
    pub fn feed_forward(&self) -> FrictionFeedForward {
        FrictionFeedForward::from_forces(
            self.alpha,
            self.coulomb_pos_n,
            self.coulomb_neg_n,
            self.force_gain_n_per_command,
            self.deadband_m,
        )
    }
}
