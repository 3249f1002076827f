//! The general discrete state-space controller run once per cycle:
//! `u(k) = C x(k) + D e(k)`, `x(k+1) = A x(k) + B e(k)` (single input, single output), with
//! output limits and optional anti-windup by Hanus conditioning, and its TOML file.

use std::path::Path;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::lti::Ss;
use super::RobustError;

/// Largest controller order the fixed-size controller holds.
pub const MAX_STATES: usize = 16;

/// The `[controller]` table of `controller.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateSpaceConfig {
    /// Always `"state_space"`.
    pub kind: String,
    /// Cycle period the matrices were discretised for (s).
    pub period_s: f64,
    /// Output limits (V).
    pub u_min: f64,
    pub u_max: f64,
    /// Hanus conditioning when the output saturates (needs `D ≠ 0` and `A - B C / D` stable).
    #[serde(default)]
    pub anti_windup: bool,
    /// `A`, rows of length n.
    pub a: Vec<Vec<f64>>,
    /// `B`, n entries (input: servo error, rad).
    pub b: Vec<f64>,
    /// `C`, n entries (output: armature voltage, V).
    pub c: Vec<f64>,
    /// `D`.
    pub d: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct ControllerFile {
    controller: StateSpaceConfig,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    design: Option<toml::Table>,
}

impl StateSpaceConfig {
    /// From a discrete SISO system.
    pub fn from_ss(sys: &Ss, period_s: f64, u_min: f64, u_max: f64, anti_windup: bool) -> Self {
        let n = sys.order();
        Self {
            kind: "state_space".into(),
            period_s,
            u_min,
            u_max,
            anti_windup,
            a: (0..n)
                .map(|i| (0..n).map(|j| sys.a[(i, j)]).collect())
                .collect(),
            b: (0..n).map(|i| sys.b[(i, 0)]).collect(),
            c: (0..n).map(|j| sys.c[(0, j)]).collect(),
            d: sys.d.get((0, 0)).copied().unwrap_or(0.0),
        }
    }

    /// As a discrete system.
    pub fn to_ss(&self) -> Result<Ss, RobustError> {
        let n = self.b.len();
        let bad = |what: String| RobustError::ControllerFile {
            origin: String::new(),
            what,
        };
        if self.a.len() != n || self.a.iter().any(|r| r.len() != n) || self.c.len() != n {
            return Err(bad(format!(
                "A must be {n}x{n} and C have {n} entries to match B"
            )));
        }
        let a = DMatrix::from_fn(n, n, |i, j| self.a[i][j]);
        Ss::new(
            a,
            DMatrix::from_column_slice(n, 1, &self.b),
            DMatrix::from_row_slice(1, n, &self.c),
            DMatrix::from_element(1, 1, self.d),
        )
    }

    /// `controller.toml` text: the `[controller]` table and an informational `[design]` table.
    pub fn to_toml(&self, design: Option<toml::Table>) -> Result<String, RobustError> {
        let file = ControllerFile {
            controller: self.clone(),
            design,
        };
        toml::to_string(&file).map_err(|e| RobustError::ControllerFile {
            origin: String::new(),
            what: e.to_string(),
        })
    }

    /// Parse `controller.toml` text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, RobustError> {
        let file: ControllerFile =
            toml::from_str(text).map_err(|e| RobustError::ControllerFile {
                origin: origin.to_string(),
                what: e.to_string(),
            })?;
        if file.controller.kind != "state_space" {
            return Err(RobustError::ControllerFile {
                origin: origin.to_string(),
                what: format!(
                    "[controller] kind must be \"state_space\", got {:?}",
                    file.controller.kind
                ),
            });
        }
        Ok(file.controller)
    }
}

/// Discrete SISO state-space controller, fixed-size storage, no allocation per step.
#[derive(Debug, Clone)]
pub struct StateSpaceController {
    n: usize,
    a: [[f64; MAX_STATES]; MAX_STATES],
    b: [f64; MAX_STATES],
    c: [f64; MAX_STATES],
    d: f64,
    x: [f64; MAX_STATES],
    u_min: f64,
    u_max: f64,
    period_s: f64,
    anti_windup: bool,
}

impl StateSpaceController {
    /// Build from a configuration, checking sizes, finiteness, limits and (for anti-windup)
    /// that `D ≠ 0` and `A - B D⁻¹ C` is stable.
    pub fn new(cfg: &StateSpaceConfig) -> Result<Self, RobustError> {
        let err = |what: String| RobustError::ControllerFile {
            origin: String::new(),
            what,
        };
        let sys = cfg.to_ss()?;
        let n = sys.order();
        if n > MAX_STATES {
            return Err(err(format!("order {n} above {MAX_STATES}")));
        }
        if cfg.u_min.is_nan() || cfg.u_max.is_nan() || cfg.u_min >= cfg.u_max {
            return Err(err(format!(
                "limits need u_min < u_max, got [{}, {}]",
                cfg.u_min, cfg.u_max
            )));
        }
        if !(cfg.period_s > 0.0 && cfg.period_s.is_finite()) {
            return Err(err(format!("period_s must be > 0, got {}", cfg.period_s)));
        }
        if cfg.anti_windup {
            if cfg.d == 0.0 {
                return Err(err("anti_windup needs d != 0".into()));
            }
            let inv = &sys.a - &sys.b * &sys.c / cfg.d;
            let stable = n == 0 || inv.complex_eigenvalues().iter().all(|l| l.norm() < 1.0);
            if !stable {
                return Err(err(
                    "anti_windup needs A - B C / d stable (controller zeros inside the unit circle)"
                        .into(),
                ));
            }
        }
        let mut a = [[0.0; MAX_STATES]; MAX_STATES];
        let mut b = [0.0; MAX_STATES];
        let mut c = [0.0; MAX_STATES];
        for (row, src) in a.iter_mut().zip(&cfg.a) {
            row[..n].copy_from_slice(src);
        }
        b[..n].copy_from_slice(&cfg.b);
        c[..n].copy_from_slice(&cfg.c);
        Ok(Self {
            n,
            a,
            b,
            c,
            d: cfg.d,
            x: [0.0; MAX_STATES],
            u_min: cfg.u_min,
            u_max: cfg.u_max,
            period_s: cfg.period_s,
            anti_windup: cfg.anti_windup,
        })
    }

    /// Read `controller.toml`.
    pub fn load(path: &Path) -> Result<Self, RobustError> {
        let text = std::fs::read_to_string(path).map_err(|source| RobustError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let origin = path.display().to_string();
        let cfg = StateSpaceConfig::from_toml(&text, &origin)?;
        Self::new(&cfg).map_err(|e| match e {
            RobustError::ControllerFile { what, .. } => {
                RobustError::ControllerFile { origin, what }
            }
            other => other,
        })
    }

    /// Unlimited output `u = C x + D e` for the error `e`, without committing.
    #[inline]
    pub fn propose(&self, e: f64) -> f64 {
        let mut u = self.d * e;
        for i in 0..self.n {
            u += self.c[i] * self.x[i];
        }
        u
    }

    /// Commit a step: `x ← A x + B e'`, where `e' = e` or, with anti-windup, the error that
    /// would have produced `u_applied` (Hanus): `e' = e + (u_applied - u)/D`.
    #[inline]
    pub fn commit(&mut self, e: f64, u_applied: f64) {
        let e_eff = if self.anti_windup {
            e + (u_applied - self.propose(e)) / self.d
        } else {
            e
        };
        let mut next = [0.0; MAX_STATES];
        for (i, nx) in next.iter_mut().enumerate().take(self.n) {
            let mut s = self.b[i] * e_eff;
            for j in 0..self.n {
                s += self.a[i][j] * self.x[j];
            }
            *nx = s;
        }
        self.x = next;
    }

    /// One cycle: `u = clamp(C x + D e)`, then the state update.
    #[inline]
    pub fn step(&mut self, e: f64) -> f64 {
        let e = if e.is_finite() { e } else { 0.0 };
        let u = self.propose(e).clamp(self.u_min, self.u_max);
        self.commit(e, u);
        u
    }

    /// Zero the state.
    pub fn reset(&mut self) {
        self.x = [0.0; MAX_STATES];
    }

    pub fn order(&self) -> usize {
        self.n
    }

    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    pub fn limits(&self) -> (f64, f64) {
        (self.u_min, self.u_max)
    }

    /// Current state, first `order()` entries.
    pub fn state(&self) -> &[f64] {
        &self.x[..self.n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn integrator_cfg(anti_windup: bool) -> StateSpaceConfig {
        // u = x + 0.5 e, x+ = x + 0.1 e: PI.
        StateSpaceConfig {
            kind: "state_space".into(),
            period_s: 0.001,
            u_min: -1.0,
            u_max: 1.0,
            anti_windup,
            a: vec![vec![1.0]],
            b: vec![0.1],
            c: vec![1.0],
            d: 0.5,
        }
    }

    #[test]
    fn steps_like_the_difference_equation() {
        let mut k = StateSpaceController::new(&integrator_cfg(false)).expect("valid");
        assert!((k.step(1.0) - 0.5).abs() < 1e-15);
        assert!((k.step(1.0) - 0.6).abs() < 1e-15);
        assert!((k.step(0.0) - 0.2).abs() < 1e-15);
    }

    #[test]
    fn anti_windup_leaves_saturation_at_once() {
        let mut with = StateSpaceController::new(&integrator_cfg(true)).expect("valid");
        let mut without = StateSpaceController::new(&integrator_cfg(false)).expect("valid");
        for _ in 0..1000 {
            with.step(5.0);
            without.step(5.0);
        }
        assert!(with.step(-5.0) < 1.0);
        assert_eq!(without.step(-5.0), 1.0);
    }

    #[test]
    fn toml_round_trip_and_errors() {
        let cfg = integrator_cfg(true);
        let text = cfg.to_toml(None).expect("serialise");
        let back = StateSpaceConfig::from_toml(&text, "mem").expect("parse");
        assert_eq!(back, cfg);
        let bad = text.replace("state_space", "pid");
        assert!(StateSpaceConfig::from_toml(&bad, "mem").is_err());
        let mut wrong = cfg.clone();
        wrong.c = vec![];
        assert!(StateSpaceController::new(&wrong).is_err());
        let mut limits = cfg;
        limits.u_min = 2.0;
        assert!(StateSpaceController::new(&limits).is_err());
    }
}
