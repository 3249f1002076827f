//! Parameter-adaptive control of the pneumatic drive (Isermann & Raab, "parameter-adaptive
//! control"): online identification of the integrator gains per direction, quadratic-cost redesign
//! of the direction-dependent P controller, a supervision level, and scheduling as the fallback.
//!
//! - model per direction, with an offset that absorbs friction (the paper's `C_DC±`):
//!   `(Y(k) - Y(k-1)) / T_0 = K_I± U(k-1) + c±`, estimated by DSFI with `λ = 0.975`, one estimator
//!   per direction, fed only samples of monotone motion in the direction of the valve opened
//!   (`U(k-1)`, `U(k-2)` of one sign, `ΔY(k)`, `ΔY(k-1)` of that sign);
//! - supervision ([`EstimatorSupervisor`]): estimation only under excitation, `z = 1 - ψᵀγ`
//!   watched, `K_I±` checked against a plausibility band;
//! - scheduled gains `[K_I1, K_I2] = f(P_L)` from a table ([`GainSchedule`]) are the fallback and
//!   the starting point; `q0± = integrator_lq_gain(K_I±, T_0, r)` ([`integrator_lq_gain`]).

use super::direction_p::{DirectionalP, DirectionalPConfig};
use super::integrator_design::integrator_lq_gain;
use super::param_error::{positive, ParamError};
use super::scheduling::{GainSchedule, SchedulePoint};
use super::{PneumaticAdaptiveSection, ScheduleSection};
use crate::ident::{Dsfi, DsfiConfig, RecursiveEstimator};
use crate::param_key;
use crate::supervise::{EstimatorHealth, EstimatorSupervisor, EstimatorSupervisorConfig};

/// Configuration of [`PneumaticAdaptive`].
#[derive(Debug, Clone, PartialEq)]
pub struct PneumaticAdaptiveConfig {
    /// `T_0` (s), 20 ms in the paper.
    pub period_s: f64,
    /// Schedule points: supply pressure (Pa, absolute) → `[K_I1 down, K_I2 up]` (m/s).
    pub schedule: Vec<SchedulePoint>,
    /// `r` of the quadratic cost (m² per duty²).
    pub effort_weight_m2: f64,
    /// The supply the gains are tuned at (Pa). Where the drive is stronger than there, the loop
    /// keeps its nominal gains: the design's `K_I` is at most its nominal value (the extra drive
    /// gain is loop gain the tuning's margin covers, and it only tightens tracking); where it is
    /// weaker, the gains rise with the schedule. Without it every `K_I` is designed for.
    pub nominal_supply_pa: Option<f64>,
    /// Identify and use the estimates (false: scheduling only).
    pub adapt: bool,
    /// DSFI forgetting factor λ (0.975 in the paper).
    pub forgetting: f64,
    /// Estimator supervision: excitation thresholds (`min_input` duty, `min_output_step` m),
    /// `min_updates`, `eigenvalue_valid`; `plausible` holds the band of `K_I` (m/s) first.
    pub supervision: EstimatorSupervisorConfig,
    /// Errors within this give no command (m).
    pub deadband_m: f64,
    /// Duty limits, usually -1..1.
    pub output_min: f64,
    pub output_max: f64,
}

impl PneumaticAdaptiveConfig {
    /// The paper's membrane drive: forgetting 0.975, duty limits ±1, a 1 µm deadband, and
    /// estimator supervision that waits for duty steps of 0.15 and moves of 2 µm over at least
    /// four updates, with `K_I` plausible between 5 and 100 mm/s.
    pub fn membrane_drive(
        period_s: f64,
        schedule: Vec<SchedulePoint>,
        effort_weight_m2: f64,
        adapt: bool,
    ) -> Self {
        PneumaticAdaptiveConfig {
            period_s,
            schedule,
            effort_weight_m2,
            nominal_supply_pa: None,
            adapt,
            forgetting: 0.975,
            supervision: EstimatorSupervisorConfig {
                min_input: 0.15,
                min_output_step: 2e-6,
                min_updates: 4,
                eigenvalue_valid: 0.5,
                plausible: vec![(0.005, 0.1)],
            },
            deadband_m: 1e-6,
            output_min: -1.0,
            output_max: 1.0,
        }
    }
}

/// Where the gains in use come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GainSource {
    #[default]
    Scheduled,
    Adapted,
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PneumaticStep {
    /// Duty to apply.
    pub duty: f64,
    /// `q01`, `q02` in use (duty per m).
    pub gain_down_per_m: f64,
    pub gain_up_per_m: f64,
    /// `K_I1`, `K_I2` in use (m/s).
    pub drive_gain_down_m_per_s: f64,
    pub drive_gain_up_m_per_s: f64,
    /// Estimates (m/s), whatever their health.
    pub estimate_down_m_per_s: f64,
    pub estimate_up_m_per_s: f64,
    pub source_down: GainSource,
    pub source_up: GainSource,
    pub health_down: EstimatorHealth,
    pub health_up: EstimatorHealth,
    /// `z` of the estimator updated this step, 1 when none was.
    pub eigenvalue: f64,
}

/// Scheduled and parameter-adaptive direction-dependent P control. `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct PneumaticAdaptive {
    period_s: f64,
    effort_weight_m2: f64,
    adapt: bool,
    schedule: GainSchedule,
    /// `[K_I1, K_I2]` at the nominal supply: the largest the design uses (infinite without one).
    design_max: [f64; 2],
    controller: DirectionalP,
    estimators: [Dsfi; 2],
    supervisors: [EstimatorSupervisor; 2],
    y_prev: Option<f64>,
    dy_prev: f64,
    u_prev: [f64; 2],
}

const DOWN: usize = 0;
const UP: usize = 1;

impl PneumaticAdaptive {
    pub fn new(config: &PneumaticAdaptiveConfig) -> Result<Self, ParamError> {
        positive("period_s", config.period_s)?;
        let mut schedule = GainSchedule::new(&config.schedule)?;
        if schedule.len() != 2 {
            return Err(ParamError::new(
                "schedule",
                format!(
                    "needs [K_I1, K_I2] per point, got {} values",
                    schedule.len()
                ),
            ));
        }
        for p in &config.schedule {
            for &k in &p.params {
                positive("schedule", k)?;
            }
        }
        if !(config.effort_weight_m2 >= 0.0 && config.effort_weight_m2.is_finite()) {
            return Err(ParamError::new(
                param_key!(ScheduleSection, effort_weight_m2),
                "must be finite and >= 0",
            ));
        }
        let design_max = match config.nominal_supply_pa {
            Some(p) if p.is_finite() => {
                let k = schedule.step(p);
                [k[0], k[1]]
            }
            Some(p) => {
                return Err(ParamError::new(
                    param_key!(ScheduleSection, nominal_supply_pa),
                    format!("must be finite, got {p}"),
                ))
            }
            None => [f64::INFINITY; 2],
        };
        let k0 = schedule.step(f64::NEG_INFINITY);
        let (k_down, k_up) = (k0[0].min(design_max[0]), k0[1].min(design_max[1]));
        let q = |k| integrator_lq_gain(k, config.period_s, config.effort_weight_m2);
        let (Some(q_down), Some(q_up)) = (q(k_down), q(k_up)) else {
            return Err(ParamError::new("schedule", "gives no valid gain"));
        };
        let controller = DirectionalP::new(DirectionalPConfig {
            gain_neg_per_m: q_down,
            gain_pos_per_m: q_up,
            deadband_m: config.deadband_m,
            output_min: config.output_min,
            output_max: config.output_max,
        })?;
        let dsfi = |k: f64| {
            Dsfi::with_initial(
                &[k, 0.0],
                DsfiConfig {
                    forgetting: config.forgetting,
                    initial_covariance: 1.0,
                    information_floor: Some(1e-3),
                },
            )
            .map_err(|e| {
                ParamError::new(
                    param_key!(PneumaticAdaptiveSection, forgetting),
                    e.to_string(),
                )
            })
        };
        let sup = EstimatorSupervisor::new(&config.supervision)?;
        Ok(Self {
            period_s: config.period_s,
            effort_weight_m2: config.effort_weight_m2,
            adapt: config.adapt,
            schedule,
            design_max,
            controller,
            estimators: [dsfi(k_down)?, dsfi(k_up)?],
            supervisors: [sup.clone(), sup],
            y_prev: None,
            dy_prev: 0.0,
            u_prev: [0.0; 2],
        })
    }

    /// Identification with `ΔY(k)` and `U(k-1)`; returns the eigenvalue of the update, if any.
    fn identify(&mut self, position: f64) -> f64 {
        let Some(y_prev) = self.y_prev else {
            return 1.0;
        };
        let dy = position - y_prev;
        let u1 = self.u_prev[0];
        let u2 = self.u_prev[1];
        let dir = if u1 < 0.0 && u2 < 0.0 && dy < 0.0 && self.dy_prev < 0.0 {
            DOWN
        } else if u1 > 0.0 && u2 > 0.0 && dy > 0.0 && self.dy_prev > 0.0 {
            UP
        } else {
            return 1.0;
        };
        if !self.supervisors[dir].excited(u1, dy) {
            return 1.0;
        }
        // v(k) = K_I± U(k-1) + c±  (signed: down has U < 0 and v < 0)
        let psi = [u1, 1.0];
        let v = dy / self.period_s;
        match self.estimators[dir].step(&psi, v) {
            Ok(update) => {
                let theta = self.estimators[dir].theta();
                self.supervisors[dir].observe(&update, &theta[..1]);
                update.eigenvalue
            }
            Err(_) => 1.0,
        }
    }

    /// One cycle: set-point `w` (m), position `Y` (m), measured supply pressure `P_L` (Pa).
    /// The same as [`PneumaticAdaptive::estimate`] followed by [`PneumaticAdaptive::control`].
    pub fn step(&mut self, setpoint: f64, position: f64, supply_pa: f64) -> PneumaticStep {
        let eigenvalue = self.estimate(position);
        self.control(setpoint, position, supply_pa, eigenvalue)
    }

    /// The estimation half of a cycle: this cycle's position into the drive-gain estimators
    /// (when adapting). Returns the eigenvalue `z` of the update, 1 when none was made.
    pub fn estimate(&mut self, position: f64) -> f64 {
        let mut eigenvalue = 1.0;
        if position.is_finite() {
            if self.adapt {
                eigenvalue = self.identify(position);
            }
            if let Some(y_prev) = self.y_prev {
                self.dy_prev = position - y_prev;
            }
            self.y_prev = Some(position);
        }
        eigenvalue
    }

    /// The control half of a cycle, after [`PneumaticAdaptive::estimate`]: gains from the
    /// schedule or the valid estimates, redesign, and the duty.
    pub fn control(
        &mut self,
        setpoint: f64,
        position: f64,
        supply_pa: f64,
        eigenvalue: f64,
    ) -> PneumaticStep {
        let scheduled = self.schedule.step(supply_pa);
        let (mut k, mut source) = ([scheduled[0], scheduled[1]], [GainSource::Scheduled; 2]);
        let mut estimate = [0.0; 2];
        for d in [DOWN, UP] {
            estimate[d] = self.estimators[d].theta()[0];
            if self.adapt && self.supervisors[d].health() == EstimatorHealth::Valid {
                k[d] = estimate[d];
                source[d] = GainSource::Adapted;
            }
        }
        // K_I,design = min(K_I, K_I(P_nominal)): a drive stronger than at the nominal supply
        // keeps the nominal gains.
        let design = [
            k[DOWN].min(self.design_max[DOWN]),
            k[UP].min(self.design_max[UP]),
        ];
        let q = |k| integrator_lq_gain(k, self.period_s, self.effort_weight_m2);
        if let (Some(qd), Some(qu)) = (q(design[DOWN]), q(design[UP])) {
            self.controller.set_gains(qd, qu);
        }
        let duty = self.controller.step(setpoint, position);
        self.u_prev = [duty, self.u_prev[0]];
        let (qd, qu) = self.controller.gains();
        PneumaticStep {
            duty,
            gain_down_per_m: qd,
            gain_up_per_m: qu,
            drive_gain_down_m_per_s: k[DOWN],
            drive_gain_up_m_per_s: k[UP],
            estimate_down_m_per_s: estimate[DOWN],
            estimate_up_m_per_s: estimate[UP],
            source_down: source[DOWN],
            source_up: source[UP],
            health_down: self.supervisors[DOWN].health(),
            health_up: self.supervisors[UP].health(),
            eigenvalue,
        }
    }

    /// Restart estimation from the scheduled gains (after a fault reset or a big supply change).
    pub fn restart_estimation(&mut self, supply_pa: f64) {
        let k = self.schedule.step(supply_pa);
        let k = [k[0], k[1]];
        for d in [DOWN, UP] {
            let _ = self.estimators[d].reset_to(&[k[d], 0.0]);
            self.supervisors[d].reset();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(nominal_supply_pa: Option<f64>) -> PneumaticAdaptiveConfig {
        let p = |supply: f64, k: f64| SchedulePoint {
            supply,
            params: vec![k, k],
        };
        PneumaticAdaptiveConfig {
            nominal_supply_pa,
            // The drive twice as strong at 40 kPa as at the nominal 60 kPa, half at 80 kPa.
            ..PneumaticAdaptiveConfig::membrane_drive(
                0.02,
                vec![p(40_000.0, 0.06), p(60_000.0, 0.03), p(80_000.0, 0.015)],
                0.0,
                false,
            )
        }
    }

    fn gains_at(c: &PneumaticAdaptiveConfig, supply_pa: f64) -> (f64, f64) {
        let mut a = PneumaticAdaptive::new(c).expect("valid");
        let s = a.control(0.001, 0.0, supply_pa, 1.0);
        (s.gain_down_per_m, s.gain_up_per_m)
    }

    #[test]
    fn a_drive_stronger_than_at_the_nominal_supply_keeps_the_nominal_gains() {
        let capped = config(Some(60_000.0));
        let free = config(None);
        // Deadbeat design (r = 0): q = 1 / (K_I T0).
        let nominal = 1.0 / (0.03 * 0.02);
        let (down, up) = gains_at(&capped, 60_000.0);
        assert!((down - nominal).abs() < 1e-6 * nominal, "{down}");
        assert!((up - nominal).abs() < 1e-6 * nominal, "{up}");
        // Stronger drive: the schedule alone halves the gains, the cap keeps them.
        assert!((gains_at(&free, 40_000.0).0 - nominal / 2.0).abs() < 1e-6 * nominal);
        assert!((gains_at(&capped, 40_000.0).0 - nominal).abs() < 1e-6 * nominal);
        // Weaker drive: both raise the gains with the schedule.
        for c in [&capped, &free] {
            assert!((gains_at(c, 80_000.0).1 - 2.0 * nominal).abs() < 1e-6 * nominal);
        }
        assert!(PneumaticAdaptive::new(&config(Some(f64::NAN))).is_err());
    }
}
