//! `[axis.pneumatic_adaptive]`, declared once: the TOML section of the drive-gain estimation.
//! Part of the structure of the loop: changed by a reload, not over the dictionary. Its values
//! are checked by [`super::PneumaticAdaptive::new`].

use crate::declare_section;

declare_section! {
    /// `[axis.pneumatic_adaptive]`: DSFI estimation of `K_I1`, `K_I2` with supervision; the
    /// scheduled drive gains of `[axis.schedule]` are the start and the fallback.
    pub struct PneumaticAdaptiveSection {
        /// DSFI forgetting factor λ (the paper: 0.975).
        forgetting: f64 = { unit: "", access: Restart, doc: "" },
        /// Estimate only with |duty| at least this.
        min_duty: f64 = { unit: "", access: Restart, doc: "" },
        /// ... and |ΔY| per sample at least this, m.
        min_position_step_m: f64 = { unit: "m", access: Restart, doc: "" },
        /// Updates with `z >= eigenvalue_valid` before an estimate is used (the paper: 3-4).
        min_updates: u32 = { unit: "", access: Restart, doc: "" },
        /// Estimator eigenvalue `z = 1 - ψᵀγ` above which an update counts as converged, in
        /// (0, 1).
        eigenvalue_valid: f64 = { unit: "", access: Restart, doc: "" },
        /// Plausible band of `K_I`, m/s; outside it the scheduled gains are used.
        drive_gain_min_m_per_s: f64 = { unit: "m/s", access: Restart, doc: "" },
        drive_gain_max_m_per_s: f64 = { unit: "m/s", access: Restart, doc: "" },
    }
}
