//! `[axis.correction]`, declared once: the TOML section of the static correction. Part of the
//! structure of the loop: changed by a reload, not over the dictionary. Its values are checked
//! by [`super::NonlinearCorrection::new`].

use crate::declare_section;

declare_section! {
    /// `[axis.correction]`: `U* = U g(Y_ref) / g(Y)`, `g(Y) = c0 + c1 (Y0 - Y) + c2 (Y0 - Y)²`.
    pub struct CorrectionSection {
        /// `Y0`, the magnet's pole position, m.
        pole_m: f64 = { unit: "m", access: Restart, doc: "" },
        c0: f64 = { unit: "", access: Restart, doc: "" },
        c1_per_m: f64 = { unit: "1/m", access: Restart, doc: "" },
        c2_per_m2: f64 = { unit: "1/m2", access: Restart, doc: "", default: 0.0 },
        /// Position where the correction is the identity (where the controller was tuned), m.
        reference_position_m: f64 = { unit: "m", access: Restart, doc: "" },
        /// Smallest `g(Y) / g(Y_ref)` used, limits the boost.
        min_gain_ratio: f64 = { unit: "", access: Restart, doc: "" },
    }
}
