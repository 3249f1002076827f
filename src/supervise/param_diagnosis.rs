//! Fault diagnosis by parameter estimation (Isermann & Raab, "with parameter estimation"):
//! estimate `θ` of `Y''' + a2 Y'' + a1 Y' + a0 Y = b0 U + C_FC` with state-variable filters,
//! map it to physical parameters `p`, compare with nominal values → symptoms (+, -, 0), and
//! diagnose with a fault-symptom table derived from the model.
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
//! # Fault-symptom table (derived from the equations above)
//! | fault | T_I | D | ω0 | K_P | F_C | F_0 | why |
//! |---|---|---|---|---|---|---|---|
//! | F1 pretension up | 0 | 0 | 0 | 0 | 0 | + | only `F_0` changes |
//! | F2 spring drop | 0 | + | - | + | 0 | 0 | `ω0 = √(c/m)` falls, `D ∝ 1/√c` and `K_P ∝ 1/c` rise |
//! | F3 friction up | 0 | + | 0 | 0 | + | 0 | Coulomb `F_C` and viscous `d` (hence `D`) rise |
//! | F4 current gain drop | 0 | 0 | 0 | - | 0 | 0 | `K_P ∝ K_I` falls, the lag `T_I` stays |
//!
//! Every fault has its own pattern. Diagnosis takes the table row nearest to the observed symptoms
//! (number of differing entries); the confidence is `1 - distance / 6`, and a fault is reported
//! only when the nearest row is unique and at most `max_distance` entries away.

use crate::control::ParamError;
use crate::ident::{Dsfi, DsfiConfig, RecursiveEstimator, StateVariableFilter};

/// Number of physical parameters.
pub const PHYSICAL_PARAMS: usize = 6;
/// Names of the physical parameters, in order.
pub const PHYSICAL_NAMES: [&str; PHYSICAL_PARAMS] = [
    "current_time_constant_s",
    "damping_ratio",
    "natural_frequency_rad_per_s",
    "static_gain_m_per_v",
    "coulomb_friction_n",
    "pretension_n",
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
}

/// The faults the table knows.
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
}

impl DiagnosedFault {
    /// All, in table order F1..F4.
    pub const ALL: [DiagnosedFault; 4] = [
        DiagnosedFault::SpringPretension,
        DiagnosedFault::SpringStiffness,
        DiagnosedFault::FrictionIncrease,
        DiagnosedFault::CurrentGain,
    ];

    /// The paper's label, F1..F4.
    pub fn label(self) -> &'static str {
        match self {
            DiagnosedFault::SpringPretension => "F1",
            DiagnosedFault::SpringStiffness => "F2",
            DiagnosedFault::FrictionIncrease => "F3",
            DiagnosedFault::CurrentGain => "F4",
        }
    }

    /// Name used on the bus and in configuration.
    pub fn name(self) -> &'static str {
        match self {
            DiagnosedFault::SpringPretension => "spring_pretension",
            DiagnosedFault::SpringStiffness => "spring_stiffness",
            DiagnosedFault::FrictionIncrease => "friction_increase",
            DiagnosedFault::CurrentGain => "current_gain",
        }
    }
}

use Symptom::{Minus as M, Plus as P, Zero as Z};

/// The fault-symptom table over `[T_I, D, ω0, K_P, F_C, F_0]` (see the module documentation).
pub const FAULT_SYMPTOM_TABLE: [(DiagnosedFault, [Symptom; PHYSICAL_PARAMS]); 4] = [
    (DiagnosedFault::SpringPretension, [Z, Z, Z, Z, Z, P]),
    (DiagnosedFault::SpringStiffness, [Z, P, M, P, Z, Z]),
    (DiagnosedFault::FrictionIncrease, [Z, P, Z, Z, P, Z]),
    (DiagnosedFault::CurrentGain, [Z, Z, Z, M, Z, Z]),
];

/// Physical parameters `p = [T_I, D, ω0, K_P, F_C, F_0]` (s, 1, rad/s, m/V, N, N).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct PhysicalParameters {
    pub values: [f64; PHYSICAL_PARAMS],
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

/// Symptoms from relative deviations: `+` if `(p - p_nom) / |p_nom| > τ`, `-` if `< -τ`, else 0.
pub fn symptoms(
    estimate: &PhysicalParameters,
    nominal: &PhysicalParameters,
    relative_thresholds: &[f64; PHYSICAL_PARAMS],
) -> [Symptom; PHYSICAL_PARAMS] {
    let mut s = [Symptom::Zero; PHYSICAL_PARAMS];
    for i in 0..PHYSICAL_PARAMS {
        let nom = nominal.values[i];
        let r = (estimate.values[i] - nom) / nom.abs().max(1e-12);
        s[i] = if !r.is_finite() {
            Symptom::Zero
        } else if r > relative_thresholds[i] {
            Symptom::Plus
        } else if r < -relative_thresholds[i] {
            Symptom::Minus
        } else {
            Symptom::Zero
        };
    }
    s
}

/// Nearest row of [`FAULT_SYMPTOM_TABLE`], reported when unique and within `max_distance`.
pub fn diagnose(symptoms: &[Symptom; PHYSICAL_PARAMS], max_distance: usize) -> Diagnosis {
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
    for (fault, pattern) in FAULT_SYMPTOM_TABLE {
        let d = pattern.iter().zip(symptoms).filter(|(a, b)| a != b).count();
        if d < best {
            best = d;
            best_fault = Some(fault);
            ties = 1;
        } else if d == best {
            ties += 1;
        }
    }
    let confidence = 1.0 - best as f64 / PHYSICAL_PARAMS as f64;
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
    updates: u64,
}

impl ParameterEstimator {
    pub fn new(config: ParameterEstimatorConfig) -> Result<Self, ParamError> {
        for (name, v) in [
            ("period_s", config.period_s),
            ("filter_omega_rad_s", config.filter_omega_rad_s),
            ("mass_kg", config.mass_kg),
            (
                "nominal_current_time_constant_s",
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
                .map_err(|e| ParamError::new("filter_omega_rad_s", e.to_string()))
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
        self.updates = 0;
    }

    /// Number of regression updates so far.
    pub fn updates(&self) -> u64 {
        self.updates
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
        if self.moving_run < c.min_moving_samples {
            return;
        }
        let psi = [-y2, -y1, -y0, u_f, 1.0, s_f];
        if self.estimator.step(&psi, y3).is_ok() {
            self.updates += 1;
        }
    }

    /// `θ = [a2, a1, a0, b0, C_0, C_F]` in SI units (1/s, 1/s², 1/s³, m/(V s³), m/s³, m/s³).
    pub fn theta(&self) -> [f64; 6] {
        let t = self.estimator.theta();
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
mod tests {
    use super::*;

    #[test]
    fn every_fault_has_a_distinct_pattern() {
        for (i, (_, a)) in FAULT_SYMPTOM_TABLE.iter().enumerate() {
            for (_, b) in &FAULT_SYMPTOM_TABLE[i + 1..] {
                assert_ne!(a, b);
            }
            assert!(a.iter().any(|s| *s != Symptom::Zero));
        }
    }

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

    #[test]
    fn diagnosis_takes_the_nearest_unique_row() {
        let d = diagnose(&[Z, Z, M, P, Z, Z], 1);
        assert_eq!(d.fault, Some(DiagnosedFault::SpringStiffness));
        assert!((d.confidence - 5.0 / 6.0).abs() < 1e-12);
        assert_eq!(diagnose(&[Z; 6], 1).fault, None);
        assert_eq!(diagnose(&[P, P, P, M, M, M], 1).fault, None);
        let nominal = PhysicalParameters {
            values: [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        };
        let est = PhysicalParameters {
            values: [1.0, 1.0, 1.0, 0.5, 1.0, 1.0],
        };
        let s = symptoms(&est, &nominal, &[0.1; 6]);
        assert_eq!(diagnose(&s, 0).fault, Some(DiagnosedFault::CurrentGain));
    }
}
