//! `[axis.learned_table]`, declared once: the TOML section of the grid the adapted friction
//! compensation is learned on. Part of the structure of the loop: changed by a reload, not over
//! the dictionary. The grid is checked by [`super::LearnedTable::new`].

use crate::declare_section;

declare_section! {
    /// `[axis.learned_table]`: the grid of operating points the adapted friction compensation
    /// is learned on. The sensor frames carry no load, so the grid has one load band; the
    /// supply is the one the axis measures (voltage for a voltage axis, pressure for a duty
    /// axis).
    pub struct LearnedTableSection {
        /// Band edges of the position (m), at least 2, increasing; outside: first or last band.
        position_edges_m: Vec<f64> = { unit: "m", access: Restart, doc: "" },
        /// Band edges of the supply voltage (V); exactly one of this and
        /// `supply_pressure_edges_pa`.
        supply_voltage_edges_v: Option<Vec<f64>> = { unit: "V", access: Restart, doc: "" },
        supply_pressure_edges_pa: Option<Vec<f64>> = { unit: "Pa", access: Restart, doc: "" },
        /// A cell averages over at most this many values (then forgets slowly).
        averaging_count: u32 = { unit: "", access: Restart, doc: "", default: 20 },
        /// A cell's values are used after this many.
        min_count: u32 = { unit: "", access: Restart, doc: "", default: 3 },
        /// How often the adapted values are folded into the present cell, s.
        learn_interval_s: f64 = {
            // Finite and > 0.
            unit: "s", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart, doc: "",
            default: 1.0,
        },
    }
}
