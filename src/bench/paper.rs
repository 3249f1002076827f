//! `actuator bench paper`: the seed experiments of Isermann & Raab (1993) on the simulated plants,
//! beside the paper's figures. Every experiment is a small lock-step loop
//! (`plant.step(command, T_0)`, `plant.measure()`, the algorithms), deterministic for the plant
//! files' seeds.

use std::fmt;

use serde::Serialize;

use super::fault_table::{FaultTableOptions, Simulation};
use crate::control::{
    effort_weight_for_pole, AdaptiveFriction, AdaptiveFrictionConfig, DirectionalP,
    DirectionalPConfig, DiscreteController, ParamError, PneumaticAdaptive, PneumaticAdaptiveConfig,
    SchedulePoint,
};
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

/// One row of the bench: the experiment, the paper's figure, ours.
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
            "{:<w0$}  {:<w1$}  {:>10} {:<4}  result",
            "experiment", "paper", "ours", ""
        )?;
        for r in self.0 {
            writeln!(
                f,
                "{:<w0$}  {:<w1$}  {:>10.4} {:<4}  {}",
                r.experiment, r.paper, r.ours, r.unit, r.ours_text
            )?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Solenoid: small-step steady offset, linear control vs adaptive friction compensation.

/// Set-points of the small-step experiment (m): a warm-up tour, then small steps around 5 mm.
fn small_step_setpoints() -> Vec<f64> {
    let mut w = vec![0.005, 0.0053, 0.005, 0.0047, 0.005, 0.0052, 0.0049];
    for i in 0..16 {
        let s = if i % 2 == 0 { 1.0 } else { -1.0 };
        let size = [0.1e-3, 0.2e-3, 0.3e-3, 0.15e-3][i % 4];
        w.push(0.005 + s * size);
    }
    w
}

/// Hold time of each small step (s).
const SMALL_STEP_HOLD_S: f64 = 0.3;
/// Steps of the warm-up (not measured).
const SMALL_STEP_WARMUP: usize = 7;

/// Mean `|e|` over the last 0.1 s of each measured step (m), and the compensation values at the
/// end (V), with the paper's PIDT1 and, optionally, adaptive friction compensation.
pub fn solenoid_small_step_offset(adaptive: bool) -> Result<(f64, (f64, f64)), BenchError> {
    let mut plant = plant_from_str(SOLENOID_PLANT, "config/plants/solenoid.toml")?;
    let t0 = SOLENOID_PERIOD_S;
    // Paper PIDT1, Y in mm → ×1000 for V per m.
    let mut pid = DiscreteController::pidt1([2231.0, -4204.0, 2000.0], 0.616, 0.0, 24.0)?;
    let mut friction = AdaptiveFriction::new(AdaptiveFrictionConfig {
        period_s: t0,
        model_time_constant_s: 0.03,
        adaptation_gain_per_m_s: 2000.0,
        max_compensation: 0.4,
        initial_pos: 0.0,
        initial_neg: 0.0,
        error_deadband_m: 3e-6,
        model_deadband_m: 10e-6,
        settled_band_m: 20e-6,
    })?;
    let hold = (SMALL_STEP_HOLD_S / t0).round() as usize;
    let tail = (0.05 / t0).round() as usize;
    let mut sum = 0.0;
    let mut n = 0usize;
    let mut y = plant.measure().position;
    for (i, w) in small_step_setpoints().into_iter().enumerate() {
        for k in 0..hold {
            let e = w - y;
            let comp = if adaptive {
                friction.step(w, y).compensation
            } else {
                0.0
            };
            let u_pid = pid.propose(e);
            let u = (u_pid + comp).clamp(0.0, 24.0);
            pid.commit(e, u - comp);
            plant.step(u, t0);
            y = plant.measure().position;
            if i >= SMALL_STEP_WARMUP && k >= hold - tail {
                sum += (w - y).abs();
                n += 1;
            }
        }
    }
    Ok((sum / n.max(1) as f64, friction.compensation_values()))
}

// ---------------------------------------------------------------------------------------------
// Pneumatic: settling time with fixed, scheduled and adaptive gains across supply pressures.

/// Supply pressures of the experiment (Pa, absolute): 400, 600, 800 mbar.
pub const PNEUMATIC_SUPPLIES_PA: [f64; 3] = [40_000.0, 60_000.0, 80_000.0];
/// Wanted closed-loop pole of the quadratic-cost design.
const PNEUMATIC_POLE: f64 = 0.3;
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
    let (k_nom, _) = pneumatic_gains_at(60_000.0);
    let r = effort_weight_for_pole(k_nom, t0, PNEUMATIC_POLE)
        .ok_or_else(|| BenchError::Failed("no effort weight".into()))?;
    let schedule = match strategy {
        PneumaticStrategy::Fixed => vec![point(40_000.0)],
        PneumaticStrategy::Scheduled => PNEUMATIC_SUPPLIES_PA.iter().map(|&p| point(p)).collect(),
        PneumaticStrategy::Adaptive => vec![point(60_000.0)],
    };
    let mut ctl = PneumaticAdaptive::new(&PneumaticAdaptiveConfig::membrane_drive(
        t0,
        schedule,
        r,
        strategy == PneumaticStrategy::Adaptive,
    ))?;
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
            let out = ctl.step(w, y, plant.measure().supply_pressure_pa);
            plant.step(out.duty, t0);
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
    let q = |k: f64| (1.0 - PNEUMATIC_POLE) / (k * t0);
    Ok(DirectionalP::new(DirectionalPConfig {
        gain_neg_per_m: q(k_down),
        gain_pos_per_m: q(k_up),
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
        mass_kg: 0.4956,
        damping_n_s_per_m: 21.85,
        spring_n_per_m: 1650.0,
        force_constant_n_per_a: 16.3,
        current_gain_a_per_v: 0.1,
        current_time_constant_s: 0.00859,
        poles: [0.6, 0.65, 0.7, 0.75],
        residual_max_m: 20e-6,
        moving_speed_m_per_s: 1.5e-3,
        warmup_samples: 1600,
        learn_samples: 1500,
        band_sigmas: 5.0,
        band_min_halfwidth_m: 15e-6,
        smoothing_time_constant_s: 0.05,
        persistence_samples: 40,
    }
}

/// Closed loop with the paper's PIDT1 on a triangle set-point (5 ± 2 mm, 2 s period); after
/// 12 s of healthy running (the observer learns its bands), friction rises linearly to ×4 over
/// 60 s.
pub fn observer_friction_rise() -> Result<FrictionRace, BenchError> {
    let mut plant = plant_from_str(SOLENOID_PLANT, "config/plants/solenoid.toml")?;
    let t0 = SOLENOID_PERIOD_S;
    let mut pid = DiscreteController::pidt1([2231.0, -4204.0, 2000.0], 0.616, 0.0, 24.0)?;
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
        let u = pid.step(e);
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

fn row(experiment: &str, paper: &str, ours: f64, unit: &str, text: String) -> PaperRow {
    PaperRow {
        experiment: experiment.to_string(),
        paper: paper.to_string(),
        ours,
        unit: unit.to_string(),
        ours_text: text,
    }
}

fn failed(experiment: &str, paper: &str, e: BenchError) -> PaperRow {
    row(experiment, paper, f64::NAN, "", format!("failed: {e}"))
}

/// All experiments, one row each (plus one per supply pressure and strategy).
pub fn run_paper_bench() -> Vec<PaperRow> {
    let mut rows = Vec::new();
    let paper_lin = "110-140 um";
    let paper_ad = "25-50 um";
    match (
        solenoid_small_step_offset(false),
        solenoid_small_step_offset(true),
    ) {
        (Ok((lin, _)), Ok((ad, (cp, cn)))) => {
            rows.push(row(
                "solenoid small-step offset, linear PIDT1",
                paper_lin,
                lin * 1e6,
                "um",
                "mean |e| at the end of small steps".into(),
            ));
            rows.push(row(
                "solenoid small-step offset, adaptive friction comp.",
                paper_ad,
                ad * 1e6,
                "um",
                format!(
                    "ratio linear/adaptive {:.1} (paper 2.2-5.6); U_comp+ {cp:.3} V, U_comp- {cn:.3} V",
                    lin / ad
                ),
            ));
        }
        (Err(e), _) | (_, Err(e)) => rows.push(failed("solenoid small-step offset", paper_lin, e)),
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
            match pneumatic_settling(strategy, p) {
                Ok((ts, acc)) => rows.push(row(
                    &exp,
                    paper,
                    ts,
                    "s",
                    format!("into ±20 %, steady |e| {:.0} um", acc * 1e6),
                )),
                Err(e) => rows.push(failed(&exp, paper, e)),
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
        Err(e) => rows.push(failed("diagnosis F1-F4", "Table 2", e)),
    }
    match observer_friction_rise() {
        Ok(r) => {
            let fmt_t =
                |t: Option<f64>| t.map_or("not within 60 s".to_string(), |t| format!("{t:.1} s"));
            rows.push(row(
                "observer: slow friction rise (x1 -> x4 over 60 s)",
                "x4 leaves its bands while the position still follows",
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
        Err(e) => rows.push(failed("observer friction rise", "", e)),
    }
    rows
}
