//! What an axis learns while it runs and must not lose: the adapted friction compensation, the
//! observer's nominal `x4` bands, the nominal physical parameters of the diagnosis, and the
//! learned table of tuned parameters by operating point. [`AxisLearned`] carries the fixed-size
//! part between cycles, reloads and restarts; [`OperatingPointMemory`] runs the learned table
//! in the cycle. Both are allocation-free per cycle.

use crate::control::{AdaptiveFriction, LearnedTable, OperatingPoint};
use crate::supervise::Nominal;

/// Names of the values a friction-compensating axis stores per operating point.
pub const FRICTION_TABLE_PARAMS: [&str; 2] =
    ["friction_compensation_pos", "friction_compensation_neg"];

/// The fixed-size part of what an axis has learned; `None` where it has not learned it (yet).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisLearned {
    /// `(U_comp+, U_comp-)` of the adaptive friction compensation, command unit.
    pub friction_compensation: Option<(f64, f64)>,
    /// `[(low, high) of x4+, (low, high) of x4-]`, m.
    pub observer_bands: Option<[(f64, f64); 2]>,
    /// Nominal `[T_I, D, ω0, K_P, F_C, F_0]` of the parameter-estimation diagnosis with their
    /// spreads, learned from the first healthy windows.
    pub nominal: Option<Nominal>,
}

/// The learned table in the cycle: while the axis stays in one cell of the operating-point grid
/// and its friction compensation adapts, the adapted values are folded into that cell every
/// `learn_every` cycles; on entering a cell that has learned enough, the compensation restarts
/// from the cell's values instead of from wherever the last cell left it.
#[derive(Debug, Clone)]
pub struct OperatingPointMemory {
    table: LearnedTable,
    learn_every: u32,
    countdown: u32,
    cell: Option<usize>,
    /// Compensation values when the axis entered the present cell.
    entered_with: (f64, f64),
    /// The adaptation has moved the values since the axis entered the present cell.
    adapted_here: bool,
}

impl OperatingPointMemory {
    pub fn new(table: LearnedTable, learn_every: u32) -> Self {
        Self {
            table,
            learn_every: learn_every.max(1),
            countdown: learn_every.max(1),
            cell: None,
            entered_with: (f64::NAN, f64::NAN),
            adapted_here: false,
        }
    }

    pub fn table(&self) -> &LearnedTable {
        &self.table
    }

    /// Take a table learned before (a stored state or the axis this one replaces), if its grid
    /// and names are this one's; returns whether it was taken.
    pub fn restore(&mut self, table: &LearnedTable) -> bool {
        if table.config() != self.table.config() {
            return false;
        }
        self.table.copy_cells_from(table)
    }

    /// One cycle at `op` with the adaptive friction compensation `friction`.
    pub fn step(&mut self, op: &OperatingPoint, friction: &mut AdaptiveFriction) {
        let Some(cell) = self.table.cell_of(op) else {
            return;
        };
        if self.cell != Some(cell) {
            self.cell = Some(cell);
            if let Some(&[pos, neg]) = self.table.lookup(op) {
                friction.set_compensation_values(pos, neg);
            }
            self.entered_with = friction.compensation_values();
            self.adapted_here = false;
            return;
        }
        self.countdown -= 1;
        if self.countdown > 0 {
            return;
        }
        self.countdown = self.learn_every;
        let now = friction.compensation_values();
        // Only what the adaptation found here is learned, not the values the axis came in with;
        // once it has found something, the settled values are learned too.
        self.adapted_here |= now != self.entered_with;
        if self.adapted_here {
            self.table.learn(op, &[now.0, now.1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{AdaptiveFrictionConfig, LearnedTableConfig};

    fn friction() -> AdaptiveFriction {
        AdaptiveFriction::new(AdaptiveFrictionConfig {
            period_s: 0.01,
            params: crate::control::AdaptiveFrictionSection {
                model_time_constant_s: 0.05,
                adaptation_gain_per_m_s: 1e4,
                compensation_max: 2.0,
                error_deadband_m: 1e-6,
                model_deadband_m: 1e-6,
                settled_band_m: 1e-5,
                step_max_m: 1e-3,
            },
            initial_pos: 0.1,
            initial_neg: 0.1,
        })
        .expect("valid")
    }

    fn table() -> LearnedTable {
        LearnedTable::new(LearnedTableConfig {
            position_edges_m: vec![0.0, 0.005, 0.010],
            load_edges_n: vec![0.0, 1.0],
            supply_edges: vec![20.0, 30.0],
            param_names: FRICTION_TABLE_PARAMS.map(String::from).to_vec(),
            averaging_count: 10,
            min_count: 2,
        })
        .expect("valid")
    }

    fn at(position_m: f64) -> OperatingPoint {
        OperatingPoint {
            position_m,
            load_n: 0.0,
            supply: 24.0,
        }
    }

    /// The axis stays below its set-point `w` until the compensation reaches `breakaway`, then
    /// it is on target: friction of that size, seen `n` cycles.
    fn friction_of(
        breakaway: f64,
        m: &mut OperatingPointMemory,
        f: &mut AdaptiveFriction,
        w: f64,
        n: usize,
    ) {
        for _ in 0..n {
            let y = if f.compensation_values().0 < breakaway {
                w - 1e-4
            } else {
                w
            };
            f.step(w, y);
            m.step(&at(w), f);
        }
    }

    #[test]
    fn adapted_values_are_learned_per_cell_and_restored_on_return() {
        let mut f = friction();
        let mut m = OperatingPointMemory::new(table(), 5);
        // Low band: friction pulls the compensation up to a value of its own.
        friction_of(0.3, &mut m, &mut f, 0.002, 400);
        let low = f.compensation_values();
        assert!((0.3..0.32).contains(&low.0), "adapted: {low:?}");
        assert!(m.table().lookup(&at(0.002)).is_some());
        // High band: the compensation is set back by hand to show that the cell restores it.
        f.set_compensation_values(0.5, 0.5);
        for _ in 0..20 {
            f.step(0.007, 0.007);
            m.step(&at(0.007), &mut f);
        }
        assert_eq!(f.compensation_values(), (0.5, 0.5), "nothing adapted there");
        assert!(
            m.table().lookup(&at(0.007)).is_none(),
            "nothing learned there"
        );
        m.step(&at(0.002), &mut f);
        let back = f.compensation_values();
        let stored = m.table().lookup(&at(0.002)).expect("learned");
        assert_eq!(back, (stored[0], stored[1]));
        assert!((back.0 - low.0).abs() < 0.02, "{back:?} vs {low:?}");
    }

    #[test]
    fn a_table_of_another_grid_is_not_restored() {
        let mut m = OperatingPointMemory::new(table(), 5);
        let mut other = LearnedTable::new(LearnedTableConfig {
            position_edges_m: vec![0.0, 0.02],
            ..table().config().clone()
        })
        .expect("valid");
        other.learn(&at(0.001), &[0.3, 0.3]);
        assert!(!m.restore(&other));
        assert_eq!(m.table().populated_cells(), 0);
        let mut same = table();
        same.learn(&at(0.001), &[0.3, 0.3]);
        assert!(m.restore(&same));
        assert_eq!(m.table().populated_cells(), 1);
    }
}
