//! Learned parameters by operating point (Isermann & Raab, knowledge base, heuristic part:
//! "stored learned behaviour, e.g. controller parameters as functions of position and load").
//!
//! The operating point `(y, F_L, V)` (position, load, supply) falls into one cell of a grid of
//! bands; each cell keeps a running mean of the tuned parameters,
//! `θ_cell ← θ_cell + (θ - θ_cell) / min(n + 1, N_avg)`, so the first values average exactly and
//! later ones forget slowly. [`LearnedTable::to_state`] / [`LearnedTable::from_state`] give a
//! serde structure the runtime stores atomically and reloads after a restart; `learn` and `lookup`
//! are allocation-free.

use serde::{Deserialize, Serialize};

use super::param_error::{finite, ParamError};
use super::scheduling::MAX_SCHEDULED;
use super::LearnedTableSection as Section;
use crate::param_key;

/// Version of [`LearnedTableState`]; a stored table of another version is refused.
pub const LEARNED_TABLE_VERSION: u32 = 1;

/// Band edges of the grid (each strictly increasing, at least 2 edges: `b` edges give `b - 1`
/// bands; values outside fall into the first or last band).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnedTableConfig {
    pub position_edges_m: Vec<f64>,
    /// Load force edges (N).
    pub load_edges_n: Vec<f64>,
    /// Supply edges (V or Pa, as the axis measures it).
    pub supply_edges: Vec<f64>,
    /// Names of the stored parameters, in order (1 to 8), e.g. `["q01_per_m", "q02_per_m"]`.
    pub param_names: Vec<String>,
    /// `N_avg`: a cell averages over at most this many values.
    pub averaging_count: u32,
    /// A cell is used by `lookup` only after this many values.
    pub min_count: u32,
}

/// One populated cell of a stored table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnedCellState {
    /// Band index of position, load, supply.
    pub position_band: usize,
    pub load_band: usize,
    pub supply_band: usize,
    pub count: u32,
    pub params: Vec<f64>,
}

/// The stored form of a learned table (serde; the runtime writes it atomically, e.g. to a
/// temporary file and a rename).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnedTableState {
    pub version: u32,
    pub config: LearnedTableConfig,
    pub cells: Vec<LearnedCellState>,
}

/// An operating point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OperatingPoint {
    pub position_m: f64,
    pub load_n: f64,
    pub supply: f64,
}

#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    count: u32,
    params: [f64; MAX_SCHEDULED],
}

/// The learned table. Allocates in the constructor only.
#[derive(Debug, Clone)]
pub struct LearnedTable {
    config: LearnedTableConfig,
    cells: Vec<Cell>,
    n: usize,
}

fn check_edges(name: &'static str, edges: &[f64]) -> Result<(), ParamError> {
    if edges.len() < 2 {
        return Err(ParamError::new(name, "needs at least 2 edges"));
    }
    for w in edges.windows(2) {
        finite(name, w[0])?;
        finite(name, w[1])?;
        if w[1] <= w[0] {
            return Err(ParamError::new(name, "edges must increase strictly"));
        }
    }
    Ok(())
}

fn band(edges: &[f64], x: f64) -> usize {
    let bands = edges.len() - 1;
    edges[1..bands].partition_point(|&e| e <= x)
}

impl LearnedTable {
    /// An empty table.
    pub fn new(config: LearnedTableConfig) -> Result<Self, ParamError> {
        // Named by the keys of `[axis.learned_table]` where they come from one.
        check_edges(
            param_key!(Section, position_edges_m),
            &config.position_edges_m,
        )?;
        check_edges("load_edges_n", &config.load_edges_n)?;
        check_edges("supply_edges", &config.supply_edges)?;
        let n = config.param_names.len();
        if n == 0 || n > MAX_SCHEDULED {
            return Err(ParamError::new(
                "param_names",
                format!("needs 1 to {MAX_SCHEDULED} names, got {n}"),
            ));
        }
        if config.averaging_count == 0 {
            return Err(ParamError::new(
                param_key!(Section, averaging_count),
                "must be >= 1",
            ));
        }
        let cells = (config.position_edges_m.len() - 1)
            * (config.load_edges_n.len() - 1)
            * (config.supply_edges.len() - 1);
        Ok(Self {
            cells: vec![Cell::default(); cells],
            config,
            n,
        })
    }

    fn dims(&self) -> (usize, usize, usize) {
        (
            self.config.position_edges_m.len() - 1,
            self.config.load_edges_n.len() - 1,
            self.config.supply_edges.len() - 1,
        )
    }

    fn index(&self, op: &OperatingPoint) -> Option<usize> {
        if !(op.position_m.is_finite() && op.load_n.is_finite() && op.supply.is_finite()) {
            return None;
        }
        let (_, nl, ns) = self.dims();
        let p = band(&self.config.position_edges_m, op.position_m);
        let l = band(&self.config.load_edges_n, op.load_n);
        let s = band(&self.config.supply_edges, op.supply);
        Some((p * nl + l) * ns + s)
    }

    /// Number of parameters per cell.
    pub fn param_count(&self) -> usize {
        self.n
    }

    /// Fold tuned parameters `θ` (length = number of names, all finite) into the cell of `op`.
    /// Returns false (and changes nothing) for a wrong length or non-finite data.
    pub fn learn(&mut self, op: &OperatingPoint, params: &[f64]) -> bool {
        if params.len() != self.n || params.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let Some(i) = self.index(op) else {
            return false;
        };
        let cap = self.config.averaging_count;
        let cell = &mut self.cells[i];
        let w = 1.0 / f64::from(cell.count.saturating_add(1).min(cap));
        for (c, p) in cell.params[..self.n].iter_mut().zip(params) {
            *c += w * (p - *c);
        }
        cell.count = cell.count.saturating_add(1);
        true
    }

    /// The learned parameters at `op`, once its cell has at least `min_count` values.
    pub fn lookup(&self, op: &OperatingPoint) -> Option<&[f64]> {
        let i = self.index(op)?;
        let cell = &self.cells[i];
        (cell.count >= self.config.min_count.max(1)).then(|| &cell.params[..self.n])
    }

    /// The cell `op` falls into (an index into the grid), None for a non-finite point. Lets
    /// the caller notice that the operating point moved to another cell.
    pub fn cell_of(&self, op: &OperatingPoint) -> Option<usize> {
        self.index(op)
    }

    /// Cells holding at least one value.
    pub fn populated_cells(&self) -> usize {
        self.cells.iter().filter(|c| c.count > 0).count()
    }

    /// The grid and names this table was built with.
    pub fn config(&self) -> &LearnedTableConfig {
        &self.config
    }

    /// Copy the cells of `other`, a table of the same grid, without allocating (a snapshot
    /// for the writer thread). Returns false, changing nothing, when the grids differ.
    pub fn copy_cells_from(&mut self, other: &LearnedTable) -> bool {
        if self.cells.len() != other.cells.len() || self.n != other.n {
            return false;
        }
        self.cells.copy_from_slice(&other.cells);
        true
    }

    /// Values folded into the cell of `op`.
    pub fn count(&self, op: &OperatingPoint) -> u32 {
        self.index(op).map_or(0, |i| self.cells[i].count)
    }

    /// The stored form (populated cells only). Allocates; not for the cycle.
    pub fn to_state(&self) -> LearnedTableState {
        let (_, nl, ns) = self.dims();
        let cells = self
            .cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.count > 0)
            .map(|(i, c)| LearnedCellState {
                position_band: i / (nl * ns),
                load_band: (i / ns) % nl,
                supply_band: i % ns,
                count: c.count,
                params: c.params[..self.n].to_vec(),
            })
            .collect();
        LearnedTableState {
            version: LEARNED_TABLE_VERSION,
            config: self.config.clone(),
            cells,
        }
    }

    /// Rebuild from a stored form, checking version, grid, indices and values.
    pub fn from_state(state: &LearnedTableState) -> Result<Self, ParamError> {
        if state.version != LEARNED_TABLE_VERSION {
            return Err(ParamError::new(
                "version",
                format!(
                    "stored table has version {}, expected {LEARNED_TABLE_VERSION}",
                    state.version
                ),
            ));
        }
        let mut t = Self::new(state.config.clone())?;
        let (np, nl, ns) = t.dims();
        for c in &state.cells {
            if c.position_band >= np || c.load_band >= nl || c.supply_band >= ns {
                return Err(ParamError::new(
                    "cells",
                    format!(
                        "cell ({}, {}, {}) outside the {np}×{nl}×{ns} grid",
                        c.position_band, c.load_band, c.supply_band
                    ),
                ));
            }
            if c.params.len() != t.n {
                return Err(ParamError::new(
                    "cells",
                    format!("cell has {} parameters, expected {}", c.params.len(), t.n),
                ));
            }
            for &v in &c.params {
                finite("cells", v)?;
            }
            let i = (c.position_band * nl + c.load_band) * ns + c.supply_band;
            t.cells[i].count = c.count;
            t.cells[i].params[..t.n].copy_from_slice(&c.params);
        }
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> LearnedTableConfig {
        LearnedTableConfig {
            position_edges_m: vec![0.0, 0.01, 0.02],
            load_edges_n: vec![-10.0, 0.0, 10.0],
            supply_edges: vec![40_000.0, 60_000.0, 80_000.0],
            param_names: vec!["q01_per_m".into(), "q02_per_m".into()],
            averaging_count: 4,
            min_count: 2,
        }
    }

    #[test]
    fn learns_by_cell_and_survives_a_round_trip_through_json() {
        let mut t = LearnedTable::new(cfg()).expect("valid");
        let a = OperatingPoint {
            position_m: 0.005,
            load_n: 2.0,
            supply: 70_000.0,
        };
        let b = OperatingPoint {
            position_m: 0.015,
            ..a
        };
        assert!(t.learn(&a, &[100.0, 200.0]));
        assert!(t.lookup(&a).is_none(), "one value is below min_count");
        assert!(t.learn(&a, &[300.0, 400.0]));
        assert_eq!(t.lookup(&a), Some(&[200.0, 300.0][..]));
        assert!(t.lookup(&b).is_none());
        assert!(!t.learn(&b, &[1.0]));
        assert!(!t.learn(&b, &[f64::NAN, 1.0]));
        let json = serde_json::to_string(&t.to_state()).expect("serialise");
        let state: LearnedTableState = serde_json::from_str(&json).expect("parse");
        let back = LearnedTable::from_state(&state).expect("valid");
        assert_eq!(back.lookup(&a), Some(&[200.0, 300.0][..]));
        assert_eq!(back.count(&a), 2);
    }

    #[test]
    fn refuses_a_corrupt_state() {
        let t = LearnedTable::new(cfg()).expect("valid");
        let mut s = t.to_state();
        s.cells.push(LearnedCellState {
            position_band: 5,
            load_band: 0,
            supply_band: 0,
            count: 1,
            params: vec![1.0, 2.0],
        });
        assert!(LearnedTable::from_state(&s).is_err());
        let mut s = t.to_state();
        s.version = 99;
        assert!(LearnedTable::from_state(&s).is_err());
    }
}
