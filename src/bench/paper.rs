//! `actuator bench paper`: the seed experiments of Isermann & Raab (1993) on the simulated plants,
//! beside the paper's figures. Every experiment is a small lock-step loop
//! (`plant.step(command, T_0)`, `plant.measure()`, the algorithms), deterministic for the plant
//! files' seeds.

use std::fmt;

use serde::Serialize;

use super::fault_table::{FaultTableOptions, Simulation};
use crate::control::{
    integrator_lq_gain, AdaptiveFriction, AdaptiveFrictionConfig, DirectionalP, DirectionalPConfig,
    DiscreteController, Dither, DitherConfig, LinearController, ParamError, PneumaticAdaptive,
    PneumaticAdaptiveConfig, SchedulePoint,
};
use crate::daemon::axis::ControlLaw;
use crate::physics::{plant_from_str, Fault, FaultKind};
use crate::supervise::{
    diagnose, symptoms, DiagnosedFault, Diagnosis, DisturbanceObserver, FaultSymptomTable,
    ObserverConfig, PhysicalEstimate,
};

/// The shipped solenoid plant (`config/plants/solenoid.toml`).
pub const SOLENOID_PLANT: &str = include_str!("../../config/plants/solenoid.toml");
/// The shipped pneumatic plant (`config/plants/pneumatic.toml`).
pub const PNEUMATIC_PLANT: &str = include_str!("../../config/plants/pneumatic.toml");

/// Solenoid sampling time, 2.5 ms (paper).
pub const SOLENOID_PERIOD_S: f64 = 0.0025;
/// Pneumatic sampling time, 20 ms (paper).
pub const PNEUMATIC_PERIOD_S: f64 = 0.02;

/// Why an experiment could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Plant(#[from] crate::physics::PhysicsError),
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error(transparent)]
    Controller(#[from] crate::control::ControllerError),
    #[error("{0}")]
    Failed(String),
}

/// Which way a figure is better than the paper's band.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    /// Smaller is better (offsets, errors, settling times, detection times).
    Lower,
    /// Larger is better (shares, bandwidths).
    Higher,
    /// Neither: a model figure that should match (identified poles and gains).
    Match,
}

/// The paper's band for a figure, `[min, max]` in the row's unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    pub min: f64,
    pub max: f64,
    pub better: Better,
}

impl Band {
    pub const fn new(min: f64, max: f64, better: Better) -> Self {
        Band { min, max, better }
    }

    /// `inside`, `better`, `worse` (or `off` for a model figure outside its band, `failed`
    /// for a missing figure).
    pub fn verdict(&self, ours: f64) -> &'static str {
        if !ours.is_finite() {
            "failed"
        } else if ours >= self.min && ours <= self.max {
            "inside"
        } else {
            match (self.better, ours < self.min) {
                (Better::Lower, true) | (Better::Higher, false) => "better",
                (Better::Lower, false) | (Better::Higher, true) => "worse",
                (Better::Match, _) => "off",
            }
        }
    }
}

/// One row of the bench: the experiment, the paper's figure, ours, the verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PaperRow {
    pub experiment: String,
    /// The paper's figure, as text.
    pub paper: String,
    /// Our figure (NaN, serialised as null, when the experiment failed or has no number).
    pub ours: f64,
    pub unit: String,
    /// Our result in words.
    pub ours_text: String,
    /// The paper's band in `unit` (null where the paper gives no number).
    pub paper_min: Option<f64>,
    pub paper_max: Option<f64>,
    /// `inside` the paper's band, `better`, `worse`, `off` (a model figure outside its band),
    /// `no band`, or `failed`.
    pub verdict: String,
}

/// A table of rows for printing.
pub struct PaperTable<'a>(pub &'a [PaperRow]);

impl fmt::Display for PaperTable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w0 = self
            .0
            .iter()
            .map(|r| r.experiment.len())
            .max()
            .unwrap_or(10)
            .max(10);
        let w1 = self
            .0
            .iter()
            .map(|r| r.paper.len())
            .max()
            .unwrap_or(5)
            .max(5);
        writeln!(
            f,
            "{:<w0$}  {:<w1$}  {:>10} {:<5}  {:<7}  result",
            "experiment", "paper", "ours", "", "verdict"
        )?;
        for r in self.0 {
            writeln!(
                f,
                "{:<w0$}  {:<w1$}  {:>10.4} {:<5}  {:<7}  {}",
                r.experiment, r.paper, r.ours, r.unit, r.verdict, r.ours_text
            )?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Solenoid: small-step steady offset, linear control vs adaptive friction compensation.

/// Operating point of the small-step experiment (m): the paper's Fig. 17 runs around 17.5 mm,
/// in the range (17-25 mm) where linear control without the correction was unstable.
pub const SMALL_STEP_CENTRE_M: f64 = 0.0175;
/// Size of the small set-point steps (m): Fig. 17 steps between about 17.3 and 17.7 mm.
pub const SMALL_STEP_SIZE_M: f64 = 0.0002;
/// Dwell of each small step (s): Fig. 17 shows five or so steps over 5.5 s.
pub const SMALL_STEP_HOLD_S: f64 = 1.0;
/// The offset is read as the mean `|e|` over the last part of each dwell (s): "in steady state".
pub const SMALL_STEP_READ_S: f64 = 0.1;
/// Steps of the warm-up (not measured): the approach to the operating point from the rest stop
/// and the first reversals, while the adaptive compensation starts from zero.
const SMALL_STEP_WARMUP: usize = 3;
/// Measured steps.
const SMALL_STEP_MEASURED: usize = 12;

/// Set-points of the small-step experiment (m): the approach, then steps of
/// `±SMALL_STEP_SIZE_M / 2` around the centre, alternating up and down.
pub fn small_step_setpoints() -> Vec<f64> {
    let half = 0.5 * SMALL_STEP_SIZE_M;
    (0..SMALL_STEP_WARMUP + SMALL_STEP_MEASURED)
        .map(|i| {
            if i == 0 {
                SMALL_STEP_CENTRE_M
            } else if i % 2 == 1 {
                SMALL_STEP_CENTRE_M + half
            } else {
                SMALL_STEP_CENTRE_M - half
            }
        })
        .collect()
}

/// How the small steps are controlled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SmallStepMode {
    /// The paper's PIDT1 alone.
    Linear,
    /// PIDT1 plus adaptive friction compensation (reference model and friction controller).
    AdaptiveFriction,
    /// PIDT1 plus a dither that adapts its amplitude and frequency.
    AdaptiveDither,
}

/// Result of one small-step run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SmallStepResult {
    /// Mean `|e|` over the read window of the measured steps (m).
    pub offset_m: f64,
    /// Largest of the per-step offsets (m).
    pub worst_offset_m: f64,
    /// `U_comp+`, `U_comp-` at the end (V; zero without adaptive compensation).
    pub compensation: (f64, f64),
    /// Dither amplitude (V) and frequency (Hz) at the end (zero without dither).
    pub dither: (f64, f64),
}

/// The adaptive friction compensation the daemon ships (`[axis.adaptive_friction]` of
/// `config/solenoid.toml`), starting from its feed-forward values
/// `α F_C / (K_I K_Mag) = 0.8 · 0.55 N / 1.63 N/V = 0.27 V`.
pub fn solenoid_adaptive_friction_config() -> Result<AdaptiveFrictionConfig, BenchError> {
    let name = "config/solenoid.toml";
    let config = crate::daemon::Config::from_toml(
        super::fault_table::SOLENOID_CONFIG,
        std::path::Path::new(name),
    )
    .map_err(|e| BenchError::Failed(e.to_string()))?;
    config
        .axis
        .first()
        .and_then(|a| a.adaptive_friction_config(SOLENOID_PERIOD_S))
        .ok_or_else(|| BenchError::Failed(format!("{name}: no [axis.adaptive_friction]")))
}

/// The self-adapting dither of the small-step experiment.
fn solenoid_dither() -> Result<Dither, ParamError> {
    Dither::new(DitherConfig {
        period_s: SOLENOID_PERIOD_S,
        amplitude: 0.2,
        frequency_hz: 50.0,
        adapt: true,
        amplitude_min: 0.05,
        amplitude_max: 3.0,
        frequency_min_hz: 20.0,
        frequency_max_hz: 100.0,
        amplitude_rate_per_s: 4.0,
        frequency_rate_per_s: 1.0,
        error_tolerance_m: 30e-6,
        ripple_moving_m: 0.5e-6,
        ripple_max_m: 10e-6,
        ripple_time_constant_s: 0.05,
    })
}

/// The paper's PIDT1 for the solenoid (eq. 28, `Y` in mm, hence ×1000 for V per m) as the
/// daemon's control law, output 0-24 V.
fn paper_pidt1() -> Result<ControlLaw, BenchError> {
    Ok(ControlLaw::linear(LinearController::Discrete(Box::new(
        DiscreteController::pidt1([2231.0, -4204.0, 2000.0], 0.616, 0.0, 24.0)?,
    ))))
}

/// The paper's small-step experiment on the solenoid plant `plant_text` (TOML, named `name` in
/// errors): steps of [`SMALL_STEP_SIZE_M`] around [`SMALL_STEP_CENTRE_M`], each held
/// [`SMALL_STEP_HOLD_S`], the offset read over the last [`SMALL_STEP_READ_S`] of each dwell,
/// with the paper's PIDT1 (eq. 28) and the chosen compensation.
pub fn solenoid_small_step_on(
    plant_text: &str,
    name: &str,
    mode: SmallStepMode,
) -> Result<SmallStepResult, BenchError> {
    solenoid_small_step_with(plant_text, name, mode, solenoid_adaptive_friction_config()?)
}

/// [`solenoid_small_step_on`] with another adaptive friction compensation.
pub fn solenoid_small_step_with(
    plant_text: &str,
    name: &str,
    mode: SmallStepMode,
    friction_config: AdaptiveFrictionConfig,
) -> Result<SmallStepResult, BenchError> {
    let mut plant = plant_from_str(plant_text, name)?;
    let t0 = SOLENOID_PERIOD_S;
    let mut law = paper_pidt1()?;
    let mut friction = AdaptiveFriction::new(friction_config)?;
    let mut dither = solenoid_dither()?;
    let hold = (SMALL_STEP_HOLD_S / t0).round() as usize;
    let tail = (SMALL_STEP_READ_S / t0).round() as usize;
    let (mut sum, mut n, mut worst) = (0.0, 0usize, 0.0_f64);
    let mut y = plant.measure().position;
    for (i, w) in small_step_setpoints().into_iter().enumerate() {
        let mut step_sum = 0.0;
        for k in 0..hold {
            let e = w - y;
            let comp = match mode {
                SmallStepMode::Linear => 0.0,
                SmallStepMode::AdaptiveFriction => friction.step(w, y).compensation,
                SmallStepMode::AdaptiveDither => dither.step(w, y),
            };
            // The daemon's composition: the compensation (or dither) added to the controller's
            // output within its limits, the controller's own share fed back.
            let u = law.command(e, y, comp, 0.0, 1.0);
            plant.step(u, t0);
            y = plant.measure().position;
            if i >= SMALL_STEP_WARMUP && k >= hold - tail {
                step_sum += (w - y).abs();
            }
        }
        if i >= SMALL_STEP_WARMUP {
            sum += step_sum;
            n += tail;
            worst = worst.max(step_sum / tail as f64);
        }
    }
    let compensation = match mode {
        SmallStepMode::AdaptiveFriction => friction.compensation_values(),
        _ => (0.0, 0.0),
    };
    let dither_state = match mode {
        SmallStepMode::AdaptiveDither => (dither.amplitude(), dither.frequency_hz()),
        _ => (0.0, 0.0),
    };
    Ok(SmallStepResult {
        offset_m: sum / n.max(1) as f64,
        worst_offset_m: worst,
        compensation,
        dither: dither_state,
    })
}

/// [`solenoid_small_step_on`] on the solenoid with the paper's friction
/// ([`SOLENOID_PLANT`]).
pub fn solenoid_small_step(mode: SmallStepMode) -> Result<SmallStepResult, BenchError> {
    solenoid_small_step_on(SOLENOID_PLANT, "config/plants/solenoid.toml", mode)
}

// ---------------------------------------------------------------------------------------------
// Solenoid: direction-dependent identification against the paper's G+(s), G-(s).

/// Third-order model per direction in the paper's form `K ω0² a / ((s + a)(s² + 2 D ω0 s + ω0²))`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ThirdOrder {
    /// Real (current) pole `a` (rad/s).
    pub real_pole: f64,
    /// `2 D ω0` of the quadratic (1/s).
    pub quad_s1: f64,
    /// `ω0²` of the quadratic (1/s²).
    pub quad_s0: f64,
    /// Static gain (mm/V).
    pub gain_mm_per_v: f64,
}

impl ThirdOrder {
    /// The paper's `G+(s) = 382400 / ((s + 116.4)(s² + 40.4 s + 3329.4))` (eq. 26).
    pub const PAPER_POS: ThirdOrder = ThirdOrder {
        real_pole: 116.4,
        quad_s1: 40.4,
        quad_s0: 3329.4,
        gain_mm_per_v: 382_400.0 / (116.4 * 3329.4),
    };
    /// The paper's `G-(s) = 220100 / ((s + 47.9)(s² + 47.9 s + 3444.5))` (eq. 27).
    pub const PAPER_NEG: ThirdOrder = ThirdOrder {
        real_pole: 47.9,
        quad_s1: 47.9,
        quad_s0: 3444.5,
        gain_mm_per_v: 220_100.0 / (47.9 * 3444.5),
    };
}

/// Identified models of both directions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SolenoidIdentification {
    pub positive: ThirdOrder,
    pub negative: ThirdOrder,
    /// Monotone samples used per direction.
    pub samples: (usize, usize),
}

/// Continuous poles `s = ln(z) / T_0` of `1 + a1 z⁻¹ + a2 z⁻² + a3 z⁻³` as a third-order model.
fn third_order_from_arx(a: &[f64], gain_m_per_v: f64, t0: f64) -> Option<ThirdOrder> {
    if a.len() != 3 {
        return None;
    }
    // Companion matrix of z³ + a1 z² + a2 z + a3.
    let m = nalgebra::Matrix3::new(-a[0], -a[1], -a[2], 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let z = m.complex_eigenvalues();
    let s: Vec<nalgebra::Complex<f64>> = z.iter().map(|z| z.ln() / t0).collect();
    // The real pole is the one with the smallest imaginary part; with three real poles the
    // quadratic is the slowest pair.
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&i, &j| s[i].im.abs().total_cmp(&s[j].im.abs()));
    let (real, p1, p2) = if s[idx[1]].im.abs() < 1e-9 {
        // All real: the fastest is the current pole.
        let mut r = [s[0].re, s[1].re, s[2].re];
        r.sort_by(|x, y| x.total_cmp(y));
        (
            r[0],
            nalgebra::Complex::new(r[1], 0.0),
            nalgebra::Complex::new(r[2], 0.0),
        )
    } else {
        (s[idx[0]].re, s[idx[1]], s[idx[2]])
    };
    let sum = p1 + p2;
    let prod = p1 * p2;
    Some(ThirdOrder {
        real_pole: -real,
        quad_s1: -sum.re,
        quad_s0: prod.re,
        gain_mm_per_v: gain_m_per_v * 1e3,
    })
}

/// Identifies the simulated solenoid `plant_text` the way the paper did: open-loop excitation at
/// 400 Hz that moves the armature up and down through the working range (steps of the PWM
/// voltage about the operating point, Fig. 8), then one third-order ARX model per direction from
/// the samples of monotone motion only (least squares, offsets absorbing the Coulomb friction).
pub fn identify_solenoid_on(
    plant_text: &str,
    name: &str,
) -> Result<SolenoidIdentification, BenchError> {
    use crate::ident::{fit_directional, ArxOrder, Direction, DirectionalSelection};
    let mut plant = plant_from_str(plant_text, name)?;
    let t0 = SOLENOID_PERIOD_S;
    let mut rng = crate::physics::rng::SplitMix64::new(7);
    let (mut ys, mut us) = (Vec::new(), Vec::new());
    // Hold each level long enough for the mechanics (1/ω0 = 17 ms) to move, short enough not to
    // settle: 25-100 ms, levels between 14 and 22 V around the 17.5 mm operating point.
    let mut u = 18.0;
    let mut left = 0usize;
    for _ in 0..(40.0 / t0) as usize {
        if left == 0 {
            u = 14.0 + 8.0 * rng.uniform();
            left = 10 + (30.0 * rng.uniform()) as usize;
        }
        left -= 1;
        plant.step(u, t0);
        ys.push(plant.measure().position);
        us.push(u);
    }
    let order = ArxOrder {
        na: 3,
        nb: 3,
        delay: 0,
    };
    let selection = DirectionalSelection {
        order,
        window: 3,
        min_step: 2e-6,
    };
    let fit = fit_directional(&ys, &us, &selection)
        .map_err(|e| BenchError::Failed(format!("identification: {e}")))?;
    let model = |d: Direction| -> Result<ThirdOrder, BenchError> {
        let p = fit
            .parameters(d)
            .map_err(|e| BenchError::Failed(format!("identification: {e}")))?;
        third_order_from_arx(&p.a, p.static_gain(), t0)
            .ok_or_else(|| BenchError::Failed("identification: no third-order model".into()))
    };
    Ok(SolenoidIdentification {
        positive: model(Direction::Positive)?,
        negative: model(Direction::Negative)?,
        samples: (fit.positive_samples.len(), fit.negative_samples.len()),
    })
}

// ---------------------------------------------------------------------------------------------
// Pneumatic: settling time with fixed, scheduled and adaptive gains across supply pressures.

/// Supply pressures of the experiment (Pa, absolute): 400, 600, 800 mbar.
pub const PNEUMATIC_SUPPLIES_PA: [f64; 3] = [40_000.0, 60_000.0, 80_000.0];
/// Effort weight `r` of the quadratic cost `J = Σ (e² + r U²)` (m² per duty²): none. The paper
/// reaches its 15-20 µm "even when using the maximal system dynamics"; `r = 0` is that limit of
/// the cost, `q0 = 1 / (K_I T0)`, the pole `z = 0` for every `K_I`. A fixed `r > 0` puts the pole
/// of the weak drive (800 mbar, `K_I` 0.41 times nominal) at `r / (r + b² P)` with `r / b²` six
/// times the nominal: a nominal pole 0.3 becomes 0.6, and the P loop stops `1 / (1 - z)` times
/// further from the set-point against the membrane's friction (29 µm instead of 8 µm).
const PNEUMATIC_EFFORT_WEIGHT_M2: f64 = 0.0;
/// Set-point step (m) and settling band (fraction of the step).
const PNEUMATIC_STEP_M: f64 = 0.0005;
const PNEUMATIC_BAND: f64 = 0.2;

/// How the pneumatic P gains are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PneumaticStrategy {
    /// One gain pair for the worst case (largest `K_I`, lowest `P_L`), never changed.
    Fixed,
    /// Gains scheduled on the measured supply pressure.
    Scheduled,
    /// Gains from the online estimates of `K_I1`, `K_I2`, starting from the nominal-pressure
    /// values, without a pressure measurement.
    Adaptive,
}

/// `K_I` of the plant file at supply `p` (its `supply_gain` law): the knowledge a calibration
/// run would put into the schedule table.
fn pneumatic_gains_at(p_pa: f64) -> (f64, f64) {
    let (k_down, k_up, p_nom, p_atm, kappa) = (0.030, 0.022, 60_000.0, 101_325.0, 1.35);
    let f = ((p_atm - p_pa) / (p_atm - p_nom)).max(0.0).powf(kappa);
    (k_down * f, k_up * f)
}

/// Mean settling time (s) into ±20 % of a 0.5 mm step and mean steady `|e|` (m) over steps up and
/// down at supply `p`.
pub fn pneumatic_settling(
    strategy: PneumaticStrategy,
    supply_pa: f64,
) -> Result<(f64, f64), BenchError> {
    let mut plant = plant_from_str(PNEUMATIC_PLANT, "config/plants/pneumatic.toml")?;
    plant.set_supply(supply_pa);
    let t0 = PNEUMATIC_PERIOD_S;
    let point = |p: f64| {
        let (d, u) = pneumatic_gains_at(p);
        SchedulePoint {
            supply: p,
            params: vec![d, u],
        }
    };
    let r = PNEUMATIC_EFFORT_WEIGHT_M2;
    let schedule = match strategy {
        PneumaticStrategy::Fixed => vec![point(40_000.0)],
        PneumaticStrategy::Scheduled => PNEUMATIC_SUPPLIES_PA.iter().map(|&p| point(p)).collect(),
        PneumaticStrategy::Adaptive => vec![point(60_000.0)],
    };
    // The daemon's law for a pneumatic axis with scheduled drive gains: the direction P
    // controller makes the duty; the linear controller of `config/pneumatic.toml`'s
    // `[axis.controller]` comes with it, unused while the table schedules the gains.
    let mut law = ControlLaw::linear(LinearController::Discrete(Box::new(
        DiscreteController::new(&[], &[1000.0], -1.0, 1.0)?,
    )))
    .with_direction_p(PneumaticAdaptive::new(
        &PneumaticAdaptiveConfig::membrane_drive(
            t0,
            schedule,
            r,
            strategy == PneumaticStrategy::Adaptive,
        ),
    )?);
    let hold = (1.5 / t0).round() as usize;
    let base = 0.008;
    let mut setpoints = vec![base];
    for i in 0..8 {
        setpoints.push(if i % 2 == 0 {
            base + PNEUMATIC_STEP_M
        } else {
            base
        });
    }
    let mut y = plant.measure().position;
    let (mut settle_sum, mut acc_sum, mut n) = (0.0, 0.0, 0usize);
    for (i, w) in setpoints.into_iter().enumerate() {
        let mut last_out = 0usize;
        let mut acc = 0.0;
        let tail = (0.3 / t0).round() as usize;
        for k in 0..hold {
            // The daemon's stages: estimation with this cycle's position, then the duty.
            law.estimate(y, false);
            let duty = law
                .direction_p(w, y, plant.measure().supply_pressure_pa)
                .ok_or_else(|| BenchError::Failed("pneumatic: no direction P controller".into()))?;
            plant.step(duty, t0);
            y = plant.measure().position;
            let e = (w - y).abs();
            if e > PNEUMATIC_BAND * PNEUMATIC_STEP_M {
                last_out = k + 1;
            }
            if k >= hold - tail {
                acc += e / tail as f64;
            }
        }
        // The first two steps let the adaptive estimator start; all strategies are judged alike.
        if i >= 3 {
            settle_sum += last_out as f64 * t0;
            acc_sum += acc;
            n += 1;
        }
    }
    Ok((settle_sum / n as f64, acc_sum / n as f64))
}

/// The fixed worst-case controller as a plain [`DirectionalP`] (for comparison in tests).
pub fn pneumatic_fixed_controller() -> Result<DirectionalP, BenchError> {
    let (k_down, k_up) = pneumatic_gains_at(40_000.0);
    let t0 = PNEUMATIC_PERIOD_S;
    let q = |k: f64| {
        integrator_lq_gain(k, t0, PNEUMATIC_EFFORT_WEIGHT_M2)
            .ok_or_else(|| BenchError::Failed(format!("no quadratic-cost gain for K_I {k} m/s")))
    };
    Ok(DirectionalP::new(DirectionalPConfig {
        gain_neg_per_m: q(k_down)?,
        gain_pos_per_m: q(k_up)?,
        deadband_m: 1e-6,
        output_min: -1.0,
        output_max: 1.0,
    })?)
}

// ---------------------------------------------------------------------------------------------
// Solenoid: F1..F4 diagnosed from parameter-estimation symptoms.

/// The four faults of the paper as plant faults (F1 pretension ×1.5, F2 spring 1650 → 1200 N/m
/// (×0.73), F3 friction ×3, F4 current gain ×0.6).
pub fn paper_faults() -> [(DiagnosedFault, FaultKind); 4] {
    [
        (
            DiagnosedFault::SpringPretension,
            FaultKind::SpringPretension(1.5),
        ),
        (DiagnosedFault::SpringStiffness, FaultKind::Spring(0.73)),
        (DiagnosedFault::FrictionIncrease, FaultKind::Friction(3.0)),
        (DiagnosedFault::CurrentGain, FaultKind::CurrentGain(0.6)),
    ]
}

/// One paper fault diagnosed window by window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FaultDiagnosisResult {
    pub expected: DiagnosedFault,
    /// Diagnosis of the mean estimate over the run's windows.
    pub mean: Diagnosis,
    /// Windows diagnosed as `expected`, out of `windows`.
    pub correct_windows: usize,
    pub windows: usize,
}

/// The paper's faults diagnosed as the daemon does, with the shipped fault-symptom table:
/// nominal values from the healthy windows of the table's setup (plant seed of the plant file),
/// then each fault with another seed (independent noise), every window judged on its own.
pub fn diagnose_paper_faults() -> Result<Vec<FaultDiagnosisResult>, BenchError> {
    let table = FaultSymptomTable::shipped().map_err(|e| BenchError::Failed(e.to_string()))?;
    let options = FaultTableOptions::default();
    let sim = Simulation::new(&options)?;
    let seed =
        crate::physics::PlantSpec::from_toml(SOLENOID_PLANT, "config/plants/solenoid.toml")?.seed;
    let nominal = sim
        .run(None, seed)?
        .nominal()
        .ok_or_else(|| BenchError::Failed("no healthy estimation window".into()))?;
    let judge = |e: &PhysicalEstimate| {
        let s = symptoms(e, &nominal, &sim.thresholds());
        diagnose(&table, &s, sim.max_distance())
    };
    paper_faults()
        .into_iter()
        .map(|(expected, kind)| {
            let run = sim.run(Some(kind), seed + 1)?;
            let mean = run
                .mean()
                .ok_or_else(|| BenchError::Failed(format!("{kind}: no estimation window")))?;
            Ok(FaultDiagnosisResult {
                expected,
                mean: judge(&mean),
                correct_windows: run
                    .windows
                    .iter()
                    .filter(|w| judge(w).fault == Some(expected))
                    .count(),
                windows: run.windows.len(),
            })
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Solenoid: the observer catches a slow friction rise before the position error shows it.

/// Result of the friction-rise race.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrictionRace {
    /// Time after the start of the rise when the observer's `x4` left both bands (s).
    pub observer_s: Option<f64>,
    /// Time after the start of the rise when the largest `|e|` over one set-point period
    /// exceeded 1.5 × its healthy value (s).
    pub position_error_s: Option<f64>,
    /// Friction factor at the observer's detection.
    pub friction_factor_at_observer: Option<f64>,
    /// Healthy largest `|e|` over one period (m).
    pub healthy_error_m: f64,
}

/// Observer configuration from the solenoid plant file (nominal physics).
pub fn solenoid_observer_config() -> ObserverConfig {
    ObserverConfig {
        period_s: SOLENOID_PERIOD_S,
        params: crate::supervise::ObserverSection {
            mass_kg: 0.4956,
            damping_n_s_per_m: 21.85,
            spring_n_per_m: 1650.0,
            force_constant_n_per_a: 16.3,
            current_gain_a_per_v: 0.1,
            current_time_constant_s: 0.00859,
            poles: [0.6, 0.65, 0.7, 0.75],
            residual_max_m: 20e-6,
            moving_speed_m_per_s: 1.5e-3,
            warmup_s: 4.0,
            learn_samples: 1500,
            band_sigmas: 5.0,
            band_min_halfwidth_m: 15e-6,
            smoothing_time_constant_s: 0.05,
            persistence_samples: 40,
        },
    }
}

/// Closed loop with the paper's PIDT1 on a triangle set-point (5 ± 2 mm, 2 s period); after
/// 12 s of healthy running (the observer learns its bands), friction rises linearly to ×4 over
/// 60 s.
pub fn observer_friction_rise() -> Result<FrictionRace, BenchError> {
    let mut plant = plant_from_str(SOLENOID_PLANT, "config/plants/solenoid.toml")?;
    let t0 = SOLENOID_PERIOD_S;
    let mut law = paper_pidt1()?;
    let mut obs = DisturbanceObserver::new(solenoid_observer_config())?;
    let (period, t_rise, ramp, factor, t_end) = (2.0, 12.0, 60.0, 4.0, 72.0);
    let per = (period / t0).round() as usize;
    let n = (t_end / t0).round() as usize;
    let mut y = plant.measure().position;
    let mut window_max = 0.0_f64;
    let mut healthy_max = 0.0_f64;
    let mut race = FrictionRace {
        observer_s: None,
        position_error_s: None,
        friction_factor_at_observer: None,
        healthy_error_m: 0.0,
    };
    let mut injected = false;
    for k in 0..n {
        let t = k as f64 * t0;
        if !injected && t >= t_rise {
            plant.inject(Fault {
                kind: FaultKind::Friction(factor),
                ramp_s: ramp,
            });
            injected = true;
        }
        let phase = (t / period).fract();
        let tri = if phase < 0.5 {
            4.0 * phase - 1.0
        } else {
            3.0 - 4.0 * phase
        };
        let w = 0.005 + 0.002 * tri;
        let e = w - y;
        // The daemon's composition with nothing added: the PIDT1's output within its limits.
        let u = law.command(e, y, 0.0, 0.0, 1.0);
        plant.step(u, t0);
        y = plant.measure().position;
        let out = obs.step(y, u);
        if t > 4.0 {
            window_max = window_max.max((w - y).abs());
        }
        if (k + 1) % per == 0 && t > 4.0 {
            if t < t_rise {
                healthy_max = healthy_max.max(window_max);
            } else if race.position_error_s.is_none() && window_max > 1.5 * healthy_max {
                race.position_error_s = Some(t - t_rise);
            }
            window_max = 0.0;
        }
        if injected && race.observer_s.is_none() && out.friction_rise {
            race.observer_s = Some(t - t_rise);
            race.friction_factor_at_observer = Some(1.0 + (factor - 1.0) * (t - t_rise) / ramp);
        }
    }
    race.healthy_error_m = healthy_max;
    Ok(race)
}

// ---------------------------------------------------------------------------------------------

fn row(
    experiment: &str,
    paper: &str,
    band: Option<Band>,
    ours: f64,
    unit: &str,
    text: String,
) -> PaperRow {
    PaperRow {
        experiment: experiment.to_string(),
        paper: paper.to_string(),
        ours,
        unit: unit.to_string(),
        ours_text: text,
        paper_min: band.map(|b| b.min),
        paper_max: band.map(|b| b.max),
        verdict: match band {
            Some(b) => b.verdict(ours).to_string(),
            None if ours.is_finite() => "no band".to_string(),
            None => "failed".to_string(),
        },
    }
}

fn failed(experiment: &str, paper: &str, band: Option<Band>, e: BenchError) -> PaperRow {
    row(
        experiment,
        paper,
        band,
        f64::NAN,
        "",
        format!("failed: {e}"),
    )
}

/// Band of ±10 % around one of the paper's identified model figures.
fn model_band(paper: f64) -> Band {
    Band::new(0.9 * paper, 1.1 * paper, Better::Match)
}

/// The identification rows: each direction's poles and gain against eq. (26), (27).
fn identification_rows(rows: &mut Vec<PaperRow>) {
    let name = "solenoid identified";
    match identify_solenoid_on(SOLENOID_PLANT, "config/plants/solenoid.toml") {
        Ok(id) => {
            for (dir, ours, paper, n) in [
                ("G+", id.positive, ThirdOrder::PAPER_POS, id.samples.0),
                ("G-", id.negative, ThirdOrder::PAPER_NEG, id.samples.1),
            ] {
                for (what, unit, o, p) in [
                    ("current pole", "rad/s", ours.real_pole, paper.real_pole),
                    ("2 D w0", "1/s", ours.quad_s1, paper.quad_s1),
                    ("w0^2", "1/s2", ours.quad_s0, paper.quad_s0),
                    (
                        "static gain",
                        "mm/V",
                        ours.gain_mm_per_v,
                        paper.gain_mm_per_v,
                    ),
                ] {
                    rows.push(row(
                        &format!("{name} {dir}: {what}"),
                        &format!("{p:.4} (eq. 26/27, +-10 %)"),
                        Some(model_band(p)),
                        o,
                        unit,
                        format!("directional LS, 3rd order, {n} monotone samples"),
                    ));
                }
            }
        }
        Err(e) => rows.push(failed(name, "G+(s), G-(s)", None, e)),
    }
}

/// All experiments, one row each (plus one per supply pressure and strategy).
pub fn run_paper_bench() -> Vec<PaperRow> {
    let mut rows = Vec::new();
    identification_rows(&mut rows);
    let paper_lin = "110-140 um";
    let band_lin = Band::new(110.0, 140.0, Better::Match);
    let paper_ad = "25-50 um";
    let band_ad = Band::new(25.0, 50.0, Better::Lower);
    let protocol = format!(
        "steps of {:.1} mm at {:.1} mm, {:.1} s dwell, mean |e| over the last {:.1} s",
        SMALL_STEP_SIZE_M * 1e3,
        SMALL_STEP_CENTRE_M * 1e3,
        SMALL_STEP_HOLD_S,
        SMALL_STEP_READ_S
    );
    match (
        solenoid_small_step(SmallStepMode::Linear),
        solenoid_small_step(SmallStepMode::AdaptiveFriction),
    ) {
        (Ok(lin), Ok(ad)) => {
            let (cp, cn) = ad.compensation;
            rows.push(row(
                "solenoid small-step offset, linear PIDT1",
                paper_lin,
                Some(band_lin),
                lin.offset_m * 1e6,
                "um",
                format!("{protocol}; worst step {:.0} um", lin.worst_offset_m * 1e6),
            ));
            rows.push(row(
                "solenoid small-step offset, adaptive friction comp.",
                paper_ad,
                Some(band_ad),
                ad.offset_m * 1e6,
                "um",
                format!(
                    "worst step {:.0} um; U_comp+ {cp:.3} V, U_comp- {cn:.3} V",
                    ad.worst_offset_m * 1e6
                ),
            ));
            rows.push(row(
                "solenoid offset ratio linear/adaptive",
                "2.2-5.6 (110-140 / 25-50)",
                Some(Band::new(2.2, 5.6, Better::Higher)),
                lin.offset_m / ad.offset_m,
                "",
                "same steps, same plant".into(),
            ));
        }
        (Err(e), _) | (_, Err(e)) => rows.push(failed(
            "solenoid small-step offset",
            paper_lin,
            Some(band_lin),
            e,
        )),
    }
    let exp = "solenoid small-step offset, adaptive dither";
    let paper = "dither adapts amplitude and frequency (no figure)";
    match solenoid_small_step(SmallStepMode::AdaptiveDither) {
        Ok(d) => rows.push(row(
            exp,
            paper,
            None,
            d.offset_m * 1e6,
            "um",
            format!(
                "worst step {:.0} um; amplitude {:.2} V, frequency {:.0} Hz at the end",
                d.worst_offset_m * 1e6,
                d.dither.0,
                d.dither.1
            ),
        )),
        Err(e) => rows.push(failed(exp, paper, None, e)),
    }
    for (strategy, name) in [
        (PneumaticStrategy::Fixed, "fixed"),
        (PneumaticStrategy::Scheduled, "scheduled"),
        (PneumaticStrategy::Adaptive, "adaptive"),
    ] {
        for p in PNEUMATIC_SUPPLIES_PA {
            let exp = format!(
                "pneumatic settling 0.5 mm, {name}, P_L {:.0} mbar",
                p / 100.0
            );
            let paper = "bandwidth 1-6 Hz fixed, ~6 Hz adaptive; 15-20 um";
            let exp_acc = format!(
                "pneumatic steady accuracy, {name}, P_L {:.0} mbar",
                p / 100.0
            );
            let band_acc = Band::new(15.0, 20.0, Better::Lower);
            match pneumatic_settling(strategy, p) {
                Ok((ts, acc)) => {
                    rows.push(row(
                        &exp,
                        paper,
                        None,
                        ts,
                        "s",
                        format!("into ±20 %, steady |e| {:.0} um", acc * 1e6),
                    ));
                    rows.push(row(
                        &exp_acc,
                        "15-20 um",
                        Some(band_acc),
                        acc * 1e6,
                        "um",
                        "mean |e| over the last 0.3 s of each 1.5 s step".into(),
                    ));
                }
                Err(e) => rows.push(failed(&exp, paper, None, e)),
            }
        }
    }
    match diagnose_paper_faults() {
        Ok(list) => {
            for r in list {
                let d = r.mean;
                let s: String = d.symptoms.iter().map(|s| s.as_char()).collect();
                let got = d.fault.map_or("none", |f| f.label());
                rows.push(row(
                    &format!("diagnosis {} ({})", r.expected.label(), r.expected.name()),
                    "distinct symptom pattern (Table 2)",
                    Some(Band::new(1.0, 1.0, Better::Higher)),
                    r.correct_windows as f64 / r.windows.max(1) as f64,
                    "share",
                    format!(
                        "windows diagnosed correctly {}/{}; mean estimate: symptoms \
                         [T_I D w0 K_P F_C F_0] = {s}, diagnosed {got}, confidence {:.2}",
                        r.correct_windows, r.windows, d.confidence
                    ),
                ));
            }
        }
        Err(e) => rows.push(failed("diagnosis F1-F4", "Table 2", None, e)),
    }
    match observer_friction_rise() {
        Ok(r) => {
            let fmt_t =
                |t: Option<f64>| t.map_or("not within 60 s".to_string(), |t| format!("{t:.1} s"));
            rows.push(row(
                "observer: slow friction rise (x1 -> x4 over 60 s)",
                "x4 leaves its bands while the position still follows",
                None,
                r.observer_s.unwrap_or(f64::NAN),
                "s",
                format!(
                    "observer after {} (friction x{:.2}); position error > 1.5 x healthy ({:.0} um) after {}",
                    fmt_t(r.observer_s),
                    r.friction_factor_at_observer.unwrap_or(f64::NAN),
                    r.healthy_error_m * 1e6,
                    fmt_t(r.position_error_s)
                ),
            ));
        }
        Err(e) => rows.push(failed("observer friction rise", "", None, e)),
    }
    rows
}
