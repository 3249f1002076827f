//! `[axis.observer]`, declared once: the TOML section, its ranges, and the supervision
//! thresholds the dictionary offers for writing (the model and poles need a restart).

use crate::declare_section;

/// A length or speed threshold: > 0 and at most this.
const THRESHOLD_MAX: f64 = 1e3;
/// The smallest threshold the dictionary takes for "> 0".
const POSITIVE_MIN: f64 = 1e-12;
/// "> 0" for a physical constant of the model.
const POSITIVE: f64 = f64::MIN_POSITIVE;

declare_section! {
    /// `[axis.observer]`: model `[Y, Y', I, x4]` of the solenoid drive, pole placement, x4 bands.
    pub struct ObserverSection {
        mass_kg: f64 = {
            unit: "kg", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        damping_n_s_per_m: f64 = {
            unit: "N s/m", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        spring_n_per_m: f64 = {
            unit: "N/m", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        force_constant_n_per_a: f64 = {
            unit: "N/A", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        current_gain_a_per_v: f64 = {
            unit: "A/V", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        current_time_constant_s: f64 = {
            unit: "s", min: POSITIVE, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Discrete observer poles, inside the unit circle.
        poles: [f64; 4] = {
            unit: "", min: -1.0, max: 1.0, access: Restart, doc: "",
        },
        /// |y - Ŷ| below this counts as a small residual, m.
        residual_max_m: f64 = {
            unit: "m", min: POSITIVE_MIN, max: THRESHOLD_MAX, access: PreOperational,
            doc: "x4 is judged only while |y - Y_hat| is below this",
        },
        /// |Ŷ'| above this counts as moving, m/s.
        moving_speed_m_per_s: f64 = {
            unit: "m/s", min: POSITIVE_MIN, max: THRESHOLD_MAX, access: PreOperational, doc: "",
        },
        /// Time after start before anything is learned or compared, s.
        warmup_s: f64 = {
            unit: "s", min: 0.0, max: f64::INFINITY, access: Restart, doc: "",
        },
        /// Moving samples per direction that make the learned band.
        learn_samples: u32 = {
            unit: "", min: 1.0, max: f64::INFINITY, access: PreOperational,
            doc: "samples per direction that make the nominal band",
        },
        /// Band half-width `max(band_sigmas σ, band_min_halfwidth_m)`.
        band_sigmas: f64 = {
            unit: "", min: POSITIVE_MIN, max: 100.0, access: PreOperational, doc: "",
        },
        band_min_halfwidth_m: f64 = {
            unit: "m", min: 0.0, max: THRESHOLD_MAX, access: PreOperational, doc: "",
        },
        smoothing_time_constant_s: f64 = {
            unit: "s", min: 0.0, max: 1e3, access: PreOperational, doc: "",
        },
        /// Compared moving samples outside the band before the deviation counts.
        persistence_samples: u32 = {
            unit: "", min: 1.0, max: f64::INFINITY, access: PreOperational, doc: "",
        },
    }
}
