//! Fault diagnosis by parameter estimation (Isermann & Raab, "with parameter estimation"):
//! estimate `θ` of `Y''' + a2 Y'' + a1 Y' + a0 Y = b0 U + C_FC` with state-variable filters,
//! map it to physical parameters `p`, compare with nominal values → symptoms (+, -, 0), and
//! diagnose with a fault-symptom table derived by simulating the model with each fault.
//!
//! # Model
//! Current loop `T_I I' + I = K_I U`, mechanics `m Y'' + d Y' + c Y = K_Mag I - F_C sign(Y') - F_0`
//! (`F_0` the spring pretension). Applying `(T_I s + 1)` and dividing by `T_I m`:
//! `a2 = 1/T_I + d/m`, `a1 = d/(T_I m) + c/m`, `a0 = c/(T_I m)`, `b0 = K_I K_Mag/(T_I m)`, and
//! `C_FC = C_0 + C_F sign(Y')` with `C_0 = -F_0/(T_I m)`, `C_F = -F_C/(T_I m)`. The estimator
//! regresses `θ = [a2, a1, a0, b0, C_0, C_F]` (the paper's `C_FC` split into its constant and its
//! direction-dependent part).
//!
//! # Physical parameters
//! `s³ + a2 s² + a1 s + a0 = (s + 1/T_I)(s² + 2 D ω0 s + ω0²)`: `-1/T_I` is the real root nearest
//! the nominal current pole (with three real roots, overdamped mechanics, the other two form the
//! quadratic factor and `D >= 1`), the quadratic factor gives `ω0` and
//! `D = d / (2 √(c m))`; `K_P = b0 / a0 = K_I K_Mag / c` (static gain, m/V); with the nominal mass
//! `m` (not identifiable, and not changed by any of the faults): `F_C = -C_F T_I m`,
//! `F_0 = -C_0 T_I m`. So `p = [T_I, D, ω0, K_P, F_C, F_0]`.
//!
//! # Symptoms
//! A window's estimate `p` is compared with the nominal `p_nom`: `+` when
//! `p - p_nom > max(k σ, floor |p_nom|)`, `-` when `p - p_nom < -max(k σ, floor |p_nom|)`, else
//! `0`. `σ` is the standard deviation of the difference: the estimate's own, propagated from the
//! estimator's covariance (or, when larger, the spread of the estimates seen while learning the
//! nominal values), combined with that of the nominal mean. The relative floor keeps almost
//! noise-free estimates from flagging deviations too small to matter, and the model's own bias
//! (friction, stiction, a dead time) that the covariance does not see.
//!
//! # Fault-symptom table
//! Which pattern each fault gives is not written here: `actuator bench fault-table` simulates the
//! solenoid healthy and with each fault of [`crate::physics::FaultKind`], estimates `p` as the
//! daemon does, and writes the patterns to `config/fault_symptoms.toml`
//! ([`super::fault_table`]). From the equations one expects F1 (pretension) to move only `F_0`,
//! F2 (spring drop) to lower `ω0 = √(c/m)` and raise `D ∝ 1/√c` and `K_P ∝ 1/c`, F3 (friction)
//! to raise `F_C` and `D`, F4 (current gain) to lower `K_P`; the simulation also shows what the
//! equation-error estimate does with the model's simplifications (under high friction, with
//! stick-slip, the estimates of `T_I`, `ω0` and `F_0` move as well). Diagnosis takes the table row nearest to the observed symptoms
//! (number of differing entries); the confidence is `1 - distance / 6`, and a fault is reported
//! only when the nearest row is unique and at most `max_distance` entries away.

use super::fault_table::FaultSymptomTable;
use super::parameter_estimation_section::NominalParameters;
use crate::ident::{Dsfi, DsfiConfig, RecursiveEstimator, StateVariableFilter};
use crate::param::ParamError;

/// Number of physical parameters.
pub const PHYSICAL_PARAMS: usize = 6;
/// Names of the physical parameters, in order: the keys of `[axis.parameter_estimation]`'s
/// `nominal` table.
pub const PHYSICAL_NAMES: [&str; PHYSICAL_PARAMS] = [
    crate::param_key!(NominalParameters, current_time_constant_s),
    crate::param_key!(NominalParameters, damping_ratio),
    crate::param_key!(NominalParameters, natural_frequency_rad_per_s),
    crate::param_key!(NominalParameters, static_gain_m_per_v),
    crate::param_key!(NominalParameters, coulomb_friction_n),
    crate::param_key!(NominalParameters, pretension_n),
];

/// A symptom: the parameter compared with its nominal value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum Symptom {
    Minus,
    #[default]
    Zero,
    Plus,
}

impl Symptom {
    /// `-`, `0`, `+`.
    pub fn as_char(self) -> char {
        match self {
            Symptom::Minus => '-',
            Symptom::Zero => '0',
            Symptom::Plus => '+',
        }
    }

    /// From `+`, `-`, `0`.
    pub fn from_text(text: &str) -> Option<Self> {
        match text {
            "+" => Some(Symptom::Plus),
            "-" => Some(Symptom::Minus),
            "0" => Some(Symptom::Zero),
            _ => None,
        }
    }
}

/// The faults the fault-symptom table can name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum DiagnosedFault {
    /// F1: too much spring pretension.
    SpringPretension,
    /// F2: spring constant drop.
    SpringStiffness,
    /// F3: friction increase.
    FrictionIncrease,
    /// F4: current circuit fault (weak gain).
    CurrentGain,
    /// F5: position sensor offset.
    SensorOffset,
}

impl DiagnosedFault {
    /// All, in table order.
    pub const ALL: [DiagnosedFault; 5] = [
        DiagnosedFault::SpringPretension,
        DiagnosedFault::SpringStiffness,
        DiagnosedFault::FrictionIncrease,
        DiagnosedFault::CurrentGain,
        DiagnosedFault::SensorOffset,
    ];

    /// The code in the table: the paper's F1..F4, then F5 on.
    pub fn label(self) -> &'static str {
        match self {
            DiagnosedFault::SpringPretension => "F1",
            DiagnosedFault::SpringStiffness => "F2",
            DiagnosedFault::FrictionIncrease => "F3",
            DiagnosedFault::CurrentGain => "F4",
            DiagnosedFault::SensorOffset => "F5",
        }
    }

    /// Name used on the bus, in configuration and in the table file.
    pub fn name(self) -> &'static str {
        match self {
            DiagnosedFault::SpringPretension => "spring_pretension",
            DiagnosedFault::SpringStiffness => "spring_stiffness",
            DiagnosedFault::FrictionIncrease => "friction_increase",
            DiagnosedFault::CurrentGain => "current_gain",
            DiagnosedFault::SensorOffset => "sensor_offset",
        }
    }

    /// The fault of [`Self::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// Physical parameters `p = [T_I, D, ω0, K_P, F_C, F_0]` (s, 1, rad/s, m/V, N, N).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct PhysicalParameters {
    pub values: [f64; PHYSICAL_PARAMS],
}

/// An estimate of `p` with the standard deviation of each entry (same units).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct PhysicalEstimate {
    pub p: PhysicalParameters,
    pub deviation: [f64; PHYSICAL_PARAMS],
}

/// What a window's estimate is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Nominal {
    pub p: PhysicalParameters,
    /// Standard deviation of the nominal values themselves (0 when configured).
    pub deviation: [f64; PHYSICAL_PARAMS],
    /// Spread of single windows' estimates seen while learning (0 when configured): a window's
    /// deviation is taken as at least this, since the covariance of an equation-error estimate
    /// from filtered, correlated residuals tends to be too small.
    pub window_spread: [f64; PHYSICAL_PARAMS],
}

impl Nominal {
    /// Configured values, known exactly.
    pub fn exact(p: PhysicalParameters) -> Self {
        Nominal {
            p,
            deviation: [0.0; PHYSICAL_PARAMS],
            window_spread: [0.0; PHYSICAL_PARAMS],
        }
    }
}

/// Learns [`Nominal`] from the estimates of healthy windows: mean, its standard deviation, and
/// the spread of single windows. Allocation-free.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NominalLearner {
    count: u32,
    sum: [f64; PHYSICAL_PARAMS],
    sum_sq: [f64; PHYSICAL_PARAMS],
    sum_var: [f64; PHYSICAL_PARAMS],
}

impl NominalLearner {
    /// One more healthy window.
    pub fn add(&mut self, e: &PhysicalEstimate) {
        self.count = self.count.saturating_add(1);
        for j in 0..PHYSICAL_PARAMS {
            let v = e.p.values[j];
            self.sum[j] += v;
            self.sum_sq[j] += v * v;
            self.sum_var[j] += e.deviation[j] * e.deviation[j];
        }
    }

    /// Windows so far.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The nominal from the windows so far; `None` before the first.
    /// Window spread: the larger of the mean propagated variance and the sample variance
    /// `(Σp² - n p̄²) / (n - 1)` (n ≥ 2); the mean's variance is that spread over `n`.
    pub fn nominal(&self) -> Option<Nominal> {
        if self.count == 0 {
            return None;
        }
        let n = f64::from(self.count);
        let mut out = Nominal::default();
        for j in 0..PHYSICAL_PARAMS {
            let mean = self.sum[j] / n;
            let mut var = self.sum_var[j] / n;
            if self.count >= 2 {
                var = var.max(((self.sum_sq[j] - n * mean * mean) / (n - 1.0)).max(0.0));
            }
            out.p.values[j] = mean;
            out.window_spread[j] = var.sqrt();
            out.deviation[j] = (var / n).sqrt();
        }
        Some(out)
    }
}

/// How far an estimate may stray from the nominal before it is a symptom.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SymptomThresholds {
    /// `k`: a deviation beyond `k σ` counts (σ of the difference estimate - nominal).
    pub sigmas: f64,
    /// Relative floor per parameter: a deviation within `floor |p_nom|` never counts; infinite:
    /// the parameter is not judged.
    pub relative_floor: [f64; PHYSICAL_PARAMS],
}

/// The result of a diagnosis.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Diagnosis {
    pub symptoms: [Symptom; PHYSICAL_PARAMS],
    /// The nearest fault, `None` when all symptoms are 0 or the match is ambiguous or too far.
    pub fault: Option<DiagnosedFault>,
    /// `1 - distance / 6` of the nearest row; 1 for "no fault" with all symptoms 0.
    pub confidence: f64,
}

/// The bound on `|p_j - p_nom,j|` below which parameter `j` shows no symptom:
/// `max(k √(max(σ_j, s_j)² + σ_nom,j²), floor_j |p_nom,j|)` with `σ_j` the estimate's deviation,
/// `s_j` the learned window spread and `σ_nom,j` the nominal's deviation.
pub fn symptom_bound(
    estimate: &PhysicalEstimate,
    nominal: &Nominal,
    thresholds: &SymptomThresholds,
    j: usize,
) -> f64 {
    let window = estimate.deviation[j].max(nominal.window_spread[j]);
    let sigma = window.hypot(nominal.deviation[j]);
    let by_variance = thresholds.sigmas * sigma;
    let floor = thresholds.relative_floor[j] * nominal.p.values[j].abs();
    if by_variance.is_nan() {
        // No variance known: the floor alone decides.
        floor
    } else {
        by_variance.max(floor)
    }
}

/// Symptoms: `+` if `p - p_nom` is above [`symptom_bound`], `-` if below its negative, else 0.
/// Allocation-free.
pub fn symptoms(
    estimate: &PhysicalEstimate,
    nominal: &Nominal,
    thresholds: &SymptomThresholds,
) -> [Symptom; PHYSICAL_PARAMS] {
    let mut s = [Symptom::Zero; PHYSICAL_PARAMS];
    for (j, out) in s.iter_mut().enumerate() {
        let d = estimate.p.values[j] - nominal.p.values[j];
        let bound = symptom_bound(estimate, nominal, thresholds, j);
        *out = if !(d.is_finite() && bound.is_finite()) {
            Symptom::Zero
        } else if d > bound {
            Symptom::Plus
        } else if d < -bound {
            Symptom::Minus
        } else {
            Symptom::Zero
        };
    }
    s
}

/// Nearest row of `table`, reported when unique and within `max_distance`. Allocation-free.
pub fn diagnose(
    table: &FaultSymptomTable,
    symptoms: &[Symptom; PHYSICAL_PARAMS],
    max_distance: usize,
) -> Diagnosis {
    if symptoms.iter().all(|s| *s == Symptom::Zero) {
        return Diagnosis {
            symptoms: *symptoms,
            fault: None,
            confidence: 1.0,
        };
    }
    let mut best = usize::MAX;
    let mut best_fault = None;
    let mut ties = 0;
    for row in table.rows() {
        let d = row
            .symptoms
            .iter()
            .zip(symptoms)
            .filter(|(a, b)| a != b)
            .count();
        if d < best {
            best = d;
            best_fault = Some(row.fault);
            ties = 1;
        } else if d == best {
            ties += 1;
        }
    }
    let confidence = if best == usize::MAX {
        0.0
    } else {
        1.0 - best as f64 / PHYSICAL_PARAMS as f64
    };
    Diagnosis {
        symptoms: *symptoms,
        fault: if ties == 1 && best <= max_distance {
            best_fault
        } else {
            None
        },
        confidence,
    }
}

/// Configuration of [`ParameterEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterEstimatorConfig {
    /// `T_0` (s).
    pub period_s: f64,
    /// Corner frequency of the state-variable filters (rad/s), above the plant's poles.
    pub filter_omega_rad_s: f64,
    /// Forgetting factor (1 for a short test).
    pub forgetting: f64,
    /// Nominal mass (kg) for the force parameters.
    pub mass_kg: f64,
    /// Nominal `T_I` (s): picks the real root.
    pub nominal_current_time_constant_s: f64,
    /// `|ΔY| / T_0` above this sets `sign(Y')` (m/s); below, the last sign is kept.
    pub moving_speed_m_per_s: f64,
    /// Regress only after this many consecutive moving samples (the filters' memory): standstill
    /// (stiction) breaks the model, so those samples are left out, as the paper selects samples
    /// of non-zero velocity.
    pub min_moving_samples: u32,
    /// The same after a disturbed sample ([`ParameterEstimator::exclude_disturbed`]), at least
    /// `min_moving_samples`: the standstill that follows a disturbance holds a force static
    /// friction set far from the model's `±F_C`, and the filters carry it further into the next
    /// move than an ordinary stop.
    pub disturbed_moving_samples: u32,
}

/// Scale of the regression: positions in mm, time in units of `1/Ω`.
const POSITION_SCALE: f64 = 1e3;
const TIME_SCALE: f64 = 100.0;

/// Online estimation of `θ = [a2, a1, a0, b0, C_0, C_F]` with state-variable filters and DSFI.
/// `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct ParameterEstimator {
    config: ParameterEstimatorConfig,
    svf_y: StateVariableFilter,
    svf_u: StateVariableFilter,
    svf_sign: StateVariableFilter,
    estimator: Dsfi,
    y_prev: Option<f64>,
    sign: f64,
    moving_run: u32,
    /// The next sample is disturbed: it does not count as moving.
    disturbed: bool,
    /// Moving samples in a row the next regression needs: `min_moving_samples`, or
    /// `disturbed_moving_samples` until they have come after a disturbance.
    required_run: u32,
    updates: u64,
}

impl ParameterEstimator {
    pub fn new(config: ParameterEstimatorConfig) -> Result<Self, ParamError> {
        use crate::param_key;
        // Named by the keys of `[axis.parameter_estimation]` they come from.
        use super::ParameterEstimationSection as S;
        let filter_omega = param_key!(S, filter_omega_rad_s);
        for (name, v) in [
            ("period_s", config.period_s),
            (filter_omega, config.filter_omega_rad_s),
            (param_key!(S, mass_kg), config.mass_kg),
            (
                param_key!(S, current_time_constant_s),
                config.nominal_current_time_constant_s,
            ),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(ParamError::new(
                    name,
                    format!("must be finite and > 0, got {v}"),
                ));
            }
        }
        let svf = |d| {
            StateVariableFilter::new(4, d, config.filter_omega_rad_s, config.period_s)
                .map_err(|e| ParamError::new(filter_omega, e.to_string()))
        };
        let estimator = Dsfi::new(
            6,
            DsfiConfig {
                forgetting: config.forgetting,
                initial_covariance: 1e4,
                information_floor: if config.forgetting < 1.0 {
                    Some(1e-6)
                } else {
                    None
                },
            },
        )
        .map_err(|e| ParamError::new("forgetting", e.to_string()))?;
        Ok(Self {
            svf_y: svf(3)?,
            svf_u: svf(0)?,
            svf_sign: svf(0)?,
            estimator,
            config,
            y_prev: None,
            sign: 0.0,
            moving_run: 0,
            disturbed: false,
            required_run: config.min_moving_samples,
            updates: 0,
        })
    }

    /// Start again (a new test).
    pub fn reset(&mut self) {
        self.svf_y.reset();
        self.svf_u.reset();
        self.svf_sign.reset();
        self.estimator.reset();
        self.y_prev = None;
        self.sign = 0.0;
        self.moving_run = 0;
        self.disturbed = false;
        self.required_run = self.config.min_moving_samples;
        self.updates = 0;
    }

    /// Number of regression updates so far.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// This sample is disturbed by a command step the loop put in on its own (the arrival
    /// relief of the controller's integral) and by what follows it until the next set-point:
    /// leave it out, and the moving samples after it until `disturbed_moving_samples` of them
    /// have come in a row again (the filters' memory of the disturbed ones). The relief moves
    /// the armature's stop and the force static friction holds there, which the model has no
    /// term for: regressed, those samples move `C_F`, and so do the first moves after the stop
    /// while the filters still remember it.
    pub fn exclude_disturbed(&mut self) {
        self.disturbed = true;
    }

    /// One sample: position `Y(k)` (m) and the voltage `U(k)` applied (V).
    /// Regression `y_F''' = -a2 y_F'' - a1 y_F' - a0 y_F + b0 u_F + C_0 + C_F s_F`.
    pub fn step(&mut self, position: f64, command: f64) {
        if !(position.is_finite() && command.is_finite()) {
            return;
        }
        let c = self.config;
        if let Some(prev) = self.y_prev {
            let v = (position - prev) / c.period_s;
            if v > c.moving_speed_m_per_s {
                self.sign = 1.0;
                self.moving_run = self.moving_run.saturating_add(1);
            } else if v < -c.moving_speed_m_per_s {
                self.sign = -1.0;
                self.moving_run = self.moving_run.saturating_add(1);
            } else {
                self.moving_run = 0;
            }
        } else {
            self.svf_y.reset_to(position * POSITION_SCALE);
            self.svf_u.reset_to(command);
        }
        if self.disturbed {
            self.moving_run = 0;
            self.disturbed = false;
            self.required_run = c.disturbed_moving_samples.max(c.min_moving_samples);
        }
        self.y_prev = Some(position);
        let s_f = self.svf_sign.step(self.sign)[0];
        let u_f = self.svf_u.step(command)[0];
        let y = self.svf_y.step(position * POSITION_SCALE);
        let (y0, y1, y2, y3) = (
            y[0],
            y[1] / TIME_SCALE,
            y[2] / (TIME_SCALE * TIME_SCALE),
            y[3] / TIME_SCALE.powi(3),
        );
        if self.moving_run < self.required_run {
            return;
        }
        self.required_run = c.min_moving_samples;
        let psi = [-y2, -y1, -y0, u_f, 1.0, s_f];
        if self.estimator.step(&psi, y3).is_ok() {
            self.updates += 1;
        }
    }

    /// `θ = [a2, a1, a0, b0, C_0, C_F]` in SI units (1/s, 1/s², 1/s³, m/(V s³), m/s³, m/s³).
    pub fn theta(&self) -> [f64; 6] {
        let mut t = [0.0; 6];
        t.copy_from_slice(self.estimator.theta());
        theta_si(&t)
    }

    /// `p` with the standard deviation of each entry, propagated from the estimate's covariance
    /// `cov(θ) = σ_e² P`, `σ_e² = V / (N - 6)` (residual variance of the regression), through a
    /// numerical Jacobian `J` of the mapping `θ → p`: `σ_p,j² = (J cov(θ) Jᵀ)_jj`. Infinite where
    /// the covariance is not known yet (fewer than seven updates) or the mapping breaks down in a
    /// neighbourhood of the estimate. Allocation-free.
    pub fn physical_with_deviation(&self) -> Option<PhysicalEstimate> {
        let mut t = [0.0; 6];
        t.copy_from_slice(self.estimator.theta());
        let c = self.config;
        let map = |t: &[f64; 6]| {
            physical_from_theta(&theta_si(t), c.mass_kg, c.nominal_current_time_constant_s)
        };
        let p = map(&t)?;
        let mut sigma = [f64::INFINITY; PHYSICAL_PARAMS];
        let n = self.updates as f64;
        let Some(cov) = covariance_of(self.estimator.information_sqrt()) else {
            return Some(PhysicalEstimate {
                p,
                deviation: sigma,
            });
        };
        if n <= 6.0 {
            return Some(PhysicalEstimate {
                p,
                deviation: sigma,
            });
        }
        // Residual variance of the regression, `σ_e² = V / (N - n_θ)`.
        let residual_variance = self.estimator.loss() / (n - 6.0);
        // Central differences, steps relative to each parameter (scaled θ is of order one);
        // one-sided where the mapping breaks down on the other side.
        let mut jac = [[0.0; 6]; PHYSICAL_PARAMS];
        for i in 0..6 {
            let h = 1e-6 * t[i].abs().max(1e-3);
            let (mut up, mut down) = (t, t);
            up[i] += h;
            down[i] -= h;
            let (hi, lo, width) = match (map(&up), map(&down)) {
                (Some(u), Some(d)) => (u, d, 2.0 * h),
                (Some(u), None) => (u, p, h),
                (None, Some(d)) => (p, d, h),
                (None, None) => {
                    return Some(PhysicalEstimate {
                        p,
                        deviation: sigma,
                    })
                }
            };
            for (row, (a, b)) in jac.iter_mut().zip(hi.values.iter().zip(lo.values)) {
                row[i] = (a - b) / width;
            }
        }
        for (s, row) in sigma.iter_mut().zip(&jac) {
            let mut v = 0.0;
            for i in 0..6 {
                for k in 0..6 {
                    v += row[i] * cov[i][k] * row[k];
                }
            }
            *s = (residual_variance * v).max(0.0).sqrt();
        }
        Some(PhysicalEstimate {
            p,
            deviation: sigma,
        })
    }

    /// `p = [T_I, D, ω0, K_P, F_C, F_0]` from `θ`; `None` when the polynomial has no real root
    /// near the current pole or no oscillatory (or critically damped) quadratic factor.
    pub fn physical(&self) -> Option<PhysicalParameters> {
        physical_from_theta(
            &self.theta(),
            self.config.mass_kg,
            self.config.nominal_current_time_constant_s,
        )
    }
}

/// Scaled regression parameters (positions in mm, time in units of `1/TIME_SCALE`) to SI.
fn theta_si(t: &[f64; 6]) -> [f64; 6] {
    let w = TIME_SCALE;
    let w3 = w * w * w / POSITION_SCALE;
    [
        t[0] * w,
        t[1] * w * w,
        t[2] * w * w * w,
        t[3] * w3,
        t[4] * w3,
        t[5] * w3,
    ]
}

/// `P = R⁻¹ R⁻ᵀ` from the upper-triangular information square root `R` (6 × 6, row-major) of
/// the DSFI estimator; `None` when `R` is singular. Allocation-free.
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
fn covariance_of(r: &[f64]) -> Option<[[f64; 6]; 6]> {
    const N: usize = 6;
    if r.len() != N * N {
        return None;
    }
    // Back substitution column by column: R X = I with X upper triangular.
    let mut inv = [[0.0; N]; N];
    for i in (0..N).rev() {
        let rii = r[i * N + i];
        if !(rii.is_finite() && rii > f64::MIN_POSITIVE) {
            return None;
        }
        inv[i][i] = 1.0 / rii;
        for j in (i + 1)..N {
            let mut acc = 0.0;
            for k in (i + 1)..=j {
                acc += r[i * N + k] * inv[k][j];
            }
            inv[i][j] = -acc / rii;
        }
    }
    let mut p = [[0.0; N]; N];
    for i in 0..N {
        for k in 0..N {
            p[i][k] = (i.max(k)..N).map(|j| inv[i][j] * inv[k][j]).sum();
        }
    }
    p.iter().flatten().all(|v| v.is_finite()).then_some(p)
}

/// The mapping `θ → p` of [`ParameterEstimator::physical`].
pub fn physical_from_theta(
    theta: &[f64; 6],
    mass_kg: f64,
    nominal_current_time_constant_s: f64,
) -> Option<PhysicalParameters> {
    let [a2, a1, a0, b0, c0, cf] = *theta;
    let f = |s: f64| ((s + a2) * s + a1) * s + a0;
    let df = |s: f64| (3.0 * s + 2.0 * a2) * s + a1;
    // Newton from the nominal current pole.
    let mut s = -1.0 / nominal_current_time_constant_s;
    for _ in 0..60 {
        let d = df(s);
        if d == 0.0 || !d.is_finite() {
            return None;
        }
        let step = f(s) / d;
        s -= step;
        if step.abs() < 1e-12 * s.abs().max(1.0) {
            break;
        }
    }
    if s.is_nan() || s >= 0.0 || f(s).abs() > 1e-6 * a0.abs().max(1.0) {
        return None;
    }
    let mut beta = a2 + s;
    let mut gamma = a1 + s * beta;
    let disc = beta * beta - 4.0 * gamma;
    if disc >= 0.0 {
        // Three real roots (overdamped mechanics): the current pole is the one nearest nominal.
        let target = -1.0 / nominal_current_time_constant_s;
        let r2 = 0.5 * (-beta + disc.sqrt());
        let r3 = 0.5 * (-beta - disc.sqrt());
        let mut roots = [s, r2, r3];
        roots.sort_by(|a, b| (a - target).abs().total_cmp(&(b - target).abs()));
        s = roots[0];
        beta = -(roots[1] + roots[2]);
        gamma = roots[1] * roots[2];
    }
    if !(gamma > 0.0 && beta > 0.0 && s < 0.0) {
        return None;
    }
    let t_i = -1.0 / s;
    let w0 = gamma.sqrt();
    let damping = beta / (2.0 * w0);
    let k_p = b0 / a0;
    let values = [
        t_i,
        damping,
        w0,
        k_p,
        -cf * t_i * mass_kg,
        -c0 * t_i * mass_kg,
    ];
    values
        .iter()
        .all(|v| v.is_finite())
        .then_some(PhysicalParameters { values })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
mod tests {
    use super::*;
    use crate::supervise::fault_table::TableRow;
    use Symptom::{Minus as M, Plus as P, Zero as Z};

    #[test]
    fn mapping_recovers_the_papers_positive_direction_model() {
        // G+(s) = 382400 / ((s + 116.4)(s² + 40.4 s + 3329.4)), Y in mm.
        let (p, q1, q0) = (116.4, 40.4, 3329.4);
        let theta = [
            p + q1,
            p * q1 + q0,
            p * q0,
            382.4,
            -3.0 * p / 0.4956,
            -0.2 * p / 0.4956,
        ];
        let phys = physical_from_theta(&theta, 0.4956, 0.0086).expect("maps");
        let v = phys.values;
        assert!((v[0] - 1.0 / 116.4).abs() < 1e-9);
        assert!((v[2] - 3329.4_f64.sqrt()).abs() < 1e-6);
        assert!((v[1] - 40.4 / (2.0 * 3329.4_f64.sqrt())).abs() < 1e-9);
        assert!((v[3] - 382.4 / (116.4 * 3329.4)).abs() < 1e-12);
        assert!((v[4] - 0.2).abs() < 1e-9);
        assert!((v[5] - 3.0).abs() < 1e-9);
    }

    fn table() -> FaultSymptomTable {
        let row = |fault, symptoms| TableRow { fault, symptoms };
        FaultSymptomTable::new(
            vec![
                row(DiagnosedFault::SpringPretension, [Z, Z, Z, Z, Z, P]),
                row(DiagnosedFault::SpringStiffness, [Z, P, M, P, Z, Z]),
                row(DiagnosedFault::CurrentGain, [Z, Z, Z, M, Z, Z]),
            ],
            "test",
        )
        .expect("valid")
    }

    #[test]
    fn diagnosis_takes_the_nearest_unique_row_of_the_table() {
        let t = table();
        let d = diagnose(&t, &[Z, Z, M, P, Z, Z], 1);
        assert_eq!(d.fault, Some(DiagnosedFault::SpringStiffness));
        assert!((d.confidence - 5.0 / 6.0).abs() < 1e-12);
        assert_eq!(diagnose(&t, &[Z; 6], 1).fault, None);
        assert_eq!(diagnose(&t, &[P, P, P, M, M, M], 1).fault, None);
        // Equally near to F1 and F4: ambiguous.
        assert_eq!(diagnose(&t, &[Z, Z, Z, M, Z, P], 2).fault, None);
        // Another table, another answer for the same symptoms.
        let swapped = FaultSymptomTable::new(
            vec![TableRow {
                fault: DiagnosedFault::FrictionIncrease,
                symptoms: [Z, P, M, P, Z, Z],
            }],
            "test",
        )
        .expect("valid");
        assert_eq!(
            diagnose(&swapped, &[Z, P, M, P, Z, Z], 0).fault,
            Some(DiagnosedFault::FrictionIncrease)
        );
    }

    fn estimate(values: [f64; 6], deviation: [f64; 6]) -> PhysicalEstimate {
        PhysicalEstimate {
            p: PhysicalParameters { values },
            deviation,
        }
    }

    #[test]
    fn a_symptom_needs_both_k_sigma_and_the_relative_floor() {
        let nominal = Nominal::exact(PhysicalParameters { values: [1.0; 6] });
        let thresholds = SymptomThresholds {
            sigmas: 3.0,
            relative_floor: [0.1, 0.1, 0.1, 0.1, 0.1, f64::INFINITY],
        };
        // Deviations 0.2: beyond the floor everywhere; σ 0.01 (3σ = 0.03) or 0.1 (3σ = 0.3).
        let e = estimate(
            [1.2, 0.8, 1.2, 0.8, 1.05, 1.2],
            [0.01, 0.01, 0.1, 0.1, 0.0, 0.01],
        );
        // Index 4: σ 0 but within the floor; index 5 is not judged.
        assert_eq!(symptoms(&e, &nominal, &thresholds), [P, M, Z, Z, Z, Z]);
        // No variance known at all: the floor alone decides.
        let e = estimate([1.2, 0.8, 1.2, 0.8, 1.05, 1.2], [f64::NAN; 6]);
        assert_eq!(symptoms(&e, &nominal, &thresholds), [P, M, P, M, Z, Z]);
        // Infinite variance: nothing can be told.
        let e = estimate([2.0; 6], [f64::INFINITY; 6]);
        assert_eq!(symptoms(&e, &nominal, &thresholds), [Z; 6]);
        // The learned window spread and the nominal's own deviation widen the bound.
        let learned = Nominal {
            p: PhysicalParameters { values: [1.0; 6] },
            deviation: [0.0, 0.1, 0.0, 0.0, 0.0, 0.0],
            window_spread: [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
        };
        let e = estimate([1.2, 1.2, 1.2, 1.0, 1.0, 1.0], [0.01; 6]);
        assert_eq!(symptoms(&e, &learned, &thresholds), [Z, Z, P, Z, Z, Z]);
        let b = symptom_bound(&e, &learned, &thresholds, 1);
        assert!((b - 3.0 * 0.01_f64.hypot(0.1)).abs() < 1e-12, "{b}");
    }

    #[test]
    fn the_learner_gives_mean_spread_and_the_means_deviation() {
        let mut l = NominalLearner::default();
        assert_eq!(l.nominal(), None);
        for v in [1.0, 2.0, 3.0, 4.0] {
            l.add(&estimate([v; 6], [0.1; 6]));
        }
        let n = l.nominal().expect("learned");
        // Sample variance of 1..4 is 5/3, above the propagated 0.01.
        assert!((n.p.values[0] - 2.5).abs() < 1e-12);
        assert!((n.window_spread[0] - (5.0_f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((n.deviation[0] - (5.0_f64 / 12.0).sqrt()).abs() < 1e-12);
        // Identical windows: the propagated deviation remains.
        let mut l = NominalLearner::default();
        l.add(&estimate([1.0; 6], [0.1; 6]));
        l.add(&estimate([1.0; 6], [0.1; 6]));
        let n = l.nominal().expect("learned");
        assert!((n.window_spread[3] - 0.1).abs() < 1e-12);
        assert!((n.deviation[3] - 0.1 / 2.0_f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn covariance_is_the_inverse_of_the_information() {
        // R upper triangular, P = (RᵀR)⁻¹: P RᵀR = I.
        let mut r = [0.0; 36];
        for i in 0..6 {
            for j in i..6 {
                r[i * 6 + j] = if i == j {
                    2.0 + i as f64
                } else {
                    0.3 * (i + 2 * j) as f64 - 1.0
                };
            }
        }
        let p = covariance_of(&r).expect("regular");
        for i in 0..6 {
            for j in 0..6 {
                let mut v = 0.0;
                for k in 0..6 {
                    let info_kj: f64 = (0..6).map(|l| r[l * 6 + k] * r[l * 6 + j]).sum();
                    v += p[i][k] * info_kj;
                }
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-10, "{i} {j} {v}");
            }
        }
        r[3 * 6 + 3] = 0.0;
        assert!(covariance_of(&r).is_none());
    }

    /// Open-loop square waves on the solenoid plant with `noise` times its sensor noise.
    fn estimate_with_noise(noise: f64) -> PhysicalEstimate {
        use crate::physics::{Fault, FaultKind};
        let text = include_str!("../../config/plants/solenoid.toml");
        let mut plant = crate::physics::plant_from_str(text, "solenoid.toml").expect("plant");
        plant.inject(Fault {
            kind: FaultKind::SensorNoise(noise),
            ramp_s: 0.0,
        });
        let t0 = 0.0025;
        let mut est = ParameterEstimator::new(ParameterEstimatorConfig {
            period_s: t0,
            filter_omega_rad_s: 150.0,
            forgetting: 1.0,
            mass_kg: 0.4956,
            nominal_current_time_constant_s: 0.00859,
            moving_speed_m_per_s: 1e-3,
            min_moving_samples: 8,
            disturbed_moving_samples: 8,
        })
        .expect("valid");
        for _ in 0..400 {
            plant.step(7.5, t0);
        }
        for k in 0..1600 {
            let t = k as f64 * t0;
            let sq = |f: f64| (std::f64::consts::TAU * f * t).sin().signum();
            let u = 7.5 + 2.4 * sq(1.3) + 1.35 * sq(3.7) + 0.6 * sq(9.1);
            est.step(plant.measure().position, u);
            plant.step(u, t0);
        }
        est.physical_with_deviation().expect("maps")
    }

    #[test]
    fn the_propagated_deviation_grows_with_the_measurement_noise() {
        // At the plant's own noise (0.5 µm) the residual is the model's error (friction,
        // stiction); 150 µm of noise dominates it.
        let quiet = estimate_with_noise(1.0);
        let noisy = estimate_with_noise(300.0);
        for j in 0..PHYSICAL_PARAMS {
            let (a, b) = (quiet.deviation[j], noisy.deviation[j]);
            assert!(a > 0.0 && a.is_finite(), "{j}: {a}");
            assert!(b > 2.0 * a, "{j}: quiet {a}, noisy {b}");
        }
    }

    /// Updates of an estimator fed a 10 mm/s ramp (standing still in `standing`) with a
    /// square-wave command over 400 samples, told that the samples in `disturbed` are disturbed,
    /// with `disturbed_moving_samples` = `after`.
    fn updates_with(
        disturbed: std::ops::Range<u32>,
        standing: std::ops::Range<u32>,
        after: u32,
    ) -> u64 {
        let mut est = ParameterEstimator::new(ParameterEstimatorConfig {
            period_s: 0.0025,
            filter_omega_rad_s: 150.0,
            forgetting: 1.0,
            mass_kg: 0.4956,
            nominal_current_time_constant_s: 0.00859,
            moving_speed_m_per_s: 1e-3,
            min_moving_samples: 8,
            disturbed_moving_samples: after,
        })
        .expect("valid");
        let mut y = 1e-3;
        for k in 0..400u32 {
            if disturbed.contains(&k) {
                est.exclude_disturbed();
            }
            if !standing.contains(&k) {
                y += 2.5e-5;
            }
            let u = if (k / 25) % 2 == 0 { 8.0 } else { 6.0 };
            est.step(y, u);
        }
        est.updates()
    }

    fn updates_with_disturbed(disturbed: std::ops::Range<u32>) -> u64 {
        updates_with(disturbed, 0..0, 8)
    }

    #[test]
    fn disturbed_samples_and_the_filters_memory_of_them_stay_out_of_the_regression() {
        // Moving throughout: every sample from the ninth on is regressed.
        let all = updates_with_disturbed(0..0);
        assert_eq!(all, 400 - 8);
        // 20 disturbed samples in the middle, then 7 more until 8 moving ones came in a row.
        assert_eq!(updates_with_disturbed(200..220), all - 20 - 7);
        // One disturbed sample costs the filters' memory too.
        assert_eq!(updates_with_disturbed(300..301), all - 1 - 7);
    }

    #[test]
    fn after_a_disturbance_the_longer_memory_is_waited_for_once() {
        // An ordinary stop of 10 samples costs itself and 7 more, whatever the disturbed memory.
        let stop = updates_with(0..0, 300..310, 8);
        assert_eq!(stop, 400 - 8 - 10 - 7);
        assert_eq!(updates_with(0..0, 300..310, 16), stop);
        // A disturbance waits for 16 moving samples in a row (15 after it); the stop that comes
        // later costs what an ordinary one does.
        assert_eq!(updates_with(200..201, 300..310, 16), stop - 1 - 15);
        assert_eq!(updates_with(200..220, 0..0, 16), 400 - 8 - 20 - 15);
        // Never less than the ordinary memory.
        assert_eq!(updates_with(200..220, 0..0, 2), 400 - 8 - 20 - 7);
    }
}
