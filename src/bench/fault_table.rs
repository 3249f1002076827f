//! `actuator bench fault-table`: derive the fault-symptom table of the solenoid's parameter
//! diagnosis from the physics, and write it as data (`config/fault_symptoms.toml`).
//!
//! The daemon of `config/solenoid.toml` and the plant of `config/plants/solenoid.toml` run in
//! lock-step ([`LockStep`]) on a setpoint tour, healthy and with each fault of
//! [`crate::physics::FaultKind`] the solenoid can have. Beside the daemon, the same
//! [`ParameterEstimator`] as the daemon's (its `[axis.parameter_estimation]` settings) estimates
//! `p` over windows from what the daemon saw and sent. The healthy windows give the nominal values
//! and their spread ([`NominalLearner`]); each fault's mean estimate against them, with the
//! daemon's symptom test ([`symptoms`], its `symptom_sigmas` and `relative_floor`), gives the
//! fault's pattern; a sign counts only with a margin ([`TABLE_MARGIN`]) over its bound. (The daemon's own estimation is off in these runs, so its reactions to a
//! diagnosis cannot change the data; limit violations only warn for the same reason.)
//!
//! Every fault the table names must have a distinct pattern: two of the paper's faults F1-F4
//! with one pattern are an error. Any other fault whose pattern is a row's is merged into that
//! row with a note; one without symptoms, or without any estimate, is listed as not diagnosed
//! with the reason.

use std::path::Path;

use super::paper::{paper_faults, BenchError, SOLENOID_PLANT};
use crate::daemon::config::{AxisConfig, FaultReactionsSection, ReactionName, SetpointStep};
use crate::daemon::Config;
use crate::lockstep::LockStep;
use crate::physics::{Fault, FaultKind, ScheduledFault};
use crate::supervise::fault_table::{
    pattern_text, FaultRowFile, FaultTableFile, NotDiagnosedFile, SamePatternFile,
};
use crate::supervise::{
    diagnose, symptom_bound, symptoms, DiagnosedFault, Nominal, NominalLearner, ParameterEstimator,
    PhysicalEstimate, Symptom, SymptomThresholds, PHYSICAL_NAMES, PHYSICAL_PARAMS,
};

/// The shipped daemon configuration of the solenoid axis, whose estimator the table is for.
pub const SOLENOID_CONFIG: &str = include_str!("../../config/solenoid.toml");

/// The command that regenerates the shipped table, for its header.
pub const REGENERATE: &str = "actuator bench fault-table --out config/fault_symptoms.toml";

/// How long to simulate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultTableOptions {
    /// Estimation windows per run (healthy and each fault).
    pub windows: usize,
    /// Simulated seconds before the estimation starts (the axis leaves its rest stop).
    pub warmup_s: f64,
    /// A run that has not filled its windows by then gives up (a seized armature never does).
    pub max_run_s: f64,
}

impl Default for FaultTableOptions {
    fn default() -> Self {
        FaultTableOptions {
            windows: 8,
            warmup_s: 2.0,
            max_run_s: 400.0,
        }
    }
}

/// A fault of the catalogue: what is injected, and which diagnosis it stands for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CatalogueEntry {
    pub fault: FaultKind,
    /// The fault the table names for it; `None`: the table has no fault of its own for it.
    pub diagnosis: Option<DiagnosedFault>,
    /// One of the paper's faults, which must have a pattern of their own.
    pub required: bool,
}

/// The solenoid's faults: the paper's F1-F4 (sizes of [`paper_faults`]), then the others of
/// [`FaultKind`] (sensor offset in both directions, since it acts on the pretension term).
pub fn catalogue() -> Vec<CatalogueEntry> {
    let mut c: Vec<CatalogueEntry> = paper_faults()
        .into_iter()
        .map(|(d, fault)| CatalogueEntry {
            fault,
            diagnosis: Some(d),
            required: true,
        })
        .collect();
    let other = |fault, diagnosis| CatalogueEntry {
        fault,
        diagnosis,
        required: false,
    };
    c.extend([
        other(FaultKind::Supply(0.7), None),
        other(FaultKind::Backlash(2.0), None),
        other(FaultKind::Jamming, None),
        other(
            FaultKind::SensorOffset(0.5e-3),
            Some(DiagnosedFault::SensorOffset),
        ),
        other(
            FaultKind::SensorOffset(-0.5e-3),
            Some(DiagnosedFault::SensorOffset),
        ),
        other(FaultKind::SensorStuck, None),
        other(FaultKind::SensorNoise(10.0), None),
    ]);
    c
}

/// The estimation windows of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    pub windows: Vec<PhysicalEstimate>,
    /// Simulated seconds.
    pub seconds: f64,
}

impl Run {
    /// Mean `p` over the windows, with the typical single window's deviation (root mean
    /// square): what the daemon's test sees of one window, on average.
    pub fn mean(&self) -> Option<PhysicalEstimate> {
        if self.windows.is_empty() {
            return None;
        }
        let n = self.windows.len() as f64;
        let mut out = PhysicalEstimate::default();
        for w in &self.windows {
            for j in 0..PHYSICAL_PARAMS {
                out.p.values[j] += w.p.values[j] / n;
                out.deviation[j] += w.deviation[j] * w.deviation[j] / n;
            }
        }
        out.deviation = out.deviation.map(f64::sqrt);
        Some(out)
    }

    /// The nominal these windows give as healthy ones, as the daemon learns it.
    pub fn nominal(&self) -> Option<Nominal> {
        let mut learner = NominalLearner::default();
        for w in &self.windows {
            learner.add(w);
        }
        learner.nominal()
    }
}

/// The daemon configuration of the runs, its estimator's settings and the plant.
pub struct Simulation {
    options: FaultTableOptions,
    plant: crate::physics::PlantSpec,
    config: Config,
    estimator: crate::supervise::ParameterEstimatorConfig,
    window_updates: u64,
    thresholds: SymptomThresholds,
    max_distance: usize,
}

impl Simulation {
    /// The daemon of `config/solenoid.toml` set up for the runs.
    pub fn new(options: &FaultTableOptions) -> Result<Self, BenchError> {
        let plant =
            crate::physics::PlantSpec::from_toml(SOLENOID_PLANT, "config/plants/solenoid.toml")?;
        let config = Config::from_toml(SOLENOID_CONFIG, Path::new("config/solenoid.toml"))
            .map_err(|e| BenchError::Failed(e.to_string()))?;
        Self::with(options, config, plant)
    }

    /// Another solenoid axis' configuration against another solenoid plant (a tuned
    /// configuration and the model it was tuned for).
    pub fn with(
        options: &FaultTableOptions,
        mut config: Config,
        plant: crate::physics::PlantSpec,
    ) -> Result<Self, BenchError> {
        let failed = |e: &dyn std::fmt::Display| BenchError::Failed(e.to_string());
        let period_s = config.cycle.period_s;
        let axis = config
            .axis
            .first_mut()
            .ok_or_else(|| failed(&"config/solenoid.toml has no axis"))?;
        let section = axis.parameter_estimation.take().ok_or_else(|| {
            failed(&format!(
                "config/solenoid.toml has no [{}.{}]",
                crate::param_key!(Config, axis),
                crate::param_key!(AxisConfig, parameter_estimation)
            ))
        })?;
        axis.fault_reactions = Some(FaultReactionsSection {
            limit_violation: Some(ReactionName::Warning),
            ..FaultReactionsSection::default()
        });
        // The tour of the daemon's tests: 0.25 s steps between 4 and 12 mm.
        let tour = [
            0.004, 0.009, 0.006, 0.011, 0.005, 0.010, 0.007, 0.012, 0.0045, 0.0085,
        ];
        let steps = (options.max_run_s / 0.25).ceil() as usize + 1;
        axis.initial_setpoint_m = tour[0];
        axis.setpoints = (0..steps)
            .map(|i| SetpointStep {
                at_s: 0.25 * i as f64,
                position_m: tour[i % tour.len()],
            })
            .collect();
        Ok(Simulation {
            options: *options,
            plant,
            config,
            estimator: section.estimator_config(period_s),
            window_updates: section.window_updates,
            thresholds: section.symptom_thresholds(),
            max_distance: usize::from(section.max_distance),
        })
    }

    /// The daemon's symptom test settings.
    pub fn thresholds(&self) -> SymptomThresholds {
        self.thresholds
    }

    /// The daemon's largest distance to a table row.
    pub fn max_distance(&self) -> usize {
        self.max_distance
    }

    /// Run the daemon and the plant (with `fault` from the start, and plant seed `seed`)
    /// until `options.windows` windows are estimated or `max_run_s` has passed.
    pub fn run(&self, fault: Option<FaultKind>, seed: u64) -> Result<Run, BenchError> {
        let options = &self.options;
        let mut spec = self.plant.clone();
        spec.seed = seed;
        let plant = spec.build()?;
        let schedule = fault
            .map(|kind| ScheduledFault {
                at_s: 0.0,
                fault: Fault { kind, ramp_s: 0.0 },
            })
            .into_iter()
            .collect();
        let mut rig = LockStep::new(&self.config, plant, schedule)
            .map_err(|e| BenchError::Failed(e.to_string()))?;
        let mut est = ParameterEstimator::new(self.estimator)?;
        let period_s = self.config.cycle.period_s;
        let cycles = (options.max_run_s / period_s).round() as u64;
        let warmup = (options.warmup_s / period_s).round() as u64;
        let mut out = Run {
            windows: Vec::with_capacity(options.windows),
            seconds: 0.0,
        };
        // The command applied during the period that led to this cycle's position, as the daemon
        // pairs them.
        let mut last_command = None;
        // An arrival relief went into the command since the set-point last changed: as in the
        // daemon, the samples it disturbs stay out until the set-point changes.
        let mut relief_hold = false;
        let mut last_setpoint = None;
        for k in 0..cycles {
            let Some(sample) = rig.cycle() else { continue };
            let r = sample.record;
            if last_setpoint != Some(r.setpoint_position) {
                relief_hold = false;
            }
            last_setpoint = Some(r.setpoint_position);
            if let (Some(u), true) = (last_command, k >= warmup) {
                if relief_hold {
                    est.exclude_disturbed();
                }
                est.step(r.position, u);
                if est.updates() >= self.window_updates {
                    if let Some(e) = est.physical_with_deviation() {
                        out.windows.push(e);
                    }
                    est.reset();
                }
            }
            relief_hold |= r.arrival_relief != 0.0;
            last_command = Some(r.command_voltage);
            out.seconds = (k + 1) as f64 * period_s;
            if out.windows.len() >= options.windows {
                break;
            }
        }
        Ok(out)
    }
}

/// One simulated fault's outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultOutcome {
    pub entry: CatalogueEntry,
    pub run: Run,
    /// Pattern of the mean estimate; `None` without any window.
    pub symptoms: Option<[Symptom; PHYSICAL_PARAMS]>,
    pub relative_change: Option<[f64; PHYSICAL_PARAMS]>,
    pub relative_bound: Option<[f64; PHYSICAL_PARAMS]>,
    /// Windows whose own diagnosis with the derived table names what the table says for this
    /// fault (its row, the row it was merged into, or none), out of all windows.
    pub windows_as_table: usize,
}

/// The derived table and everything behind it.
#[derive(Debug, Clone, PartialEq)]
pub struct Derived {
    pub file: FaultTableFile,
    pub nominal: Nominal,
    pub healthy: Run,
    pub outcomes: Vec<FaultOutcome>,
    /// Groups of simulated faults that share a pattern (indistinguishable), as text.
    pub indistinguishable: Vec<String>,
}

fn relative(estimate: &PhysicalEstimate, nominal: &Nominal) -> [f64; PHYSICAL_PARAMS] {
    let mut r = [0.0; PHYSICAL_PARAMS];
    for (j, v) in r.iter_mut().enumerate() {
        let n = nominal.p.values[j];
        *v = (estimate.p.values[j] - n) / n.abs().max(f64::MIN_POSITIVE);
    }
    r
}

fn signs(s: &[Symptom; PHYSICAL_PARAMS]) -> Vec<String> {
    s.iter().map(|c| c.as_char().to_string()).collect()
}

/// Simulate, derive and check the table.
/// A table entry is `+` or `-` only when the mean change exceeds its bound by this factor.
pub const TABLE_MARGIN: f64 = 1.5;

pub fn derive(options: &FaultTableOptions) -> Result<Derived, BenchError> {
    derive_with(&Simulation::new(options)?)
}

/// [`derive`] for the configuration and plant of `sim`.
pub fn derive_with(sim: &Simulation) -> Result<Derived, BenchError> {
    let seed = sim.plant.seed;
    let healthy = sim.run(None, seed)?;
    if healthy.windows.len() < 2 {
        return Err(BenchError::Failed(format!(
            "the healthy run gave {} estimation windows in {:.0} s; need at least 2",
            healthy.windows.len(),
            healthy.seconds
        )));
    }
    let nominal = healthy
        .nominal()
        .ok_or_else(|| BenchError::Failed("no nominal".into()))?;
    let mut file = FaultTableFile {
        parameters: PHYSICAL_NAMES.iter().map(|s| s.to_string()).collect(),
        fault: Vec::new(),
        not_diagnosed: Vec::new(),
    };
    let mut patterns: Vec<[Symptom; PHYSICAL_PARAMS]> = Vec::new();
    let mut outcomes = Vec::new();
    let mut entries = catalogue();
    // The paper's faults claim their rows first.
    entries.sort_by_key(|e| !e.required);
    for entry in entries {
        let r = sim.run(Some(entry.fault), seed)?;
        let name = entry.fault.to_string();
        let Some(mean) = r.mean() else {
            if entry.required {
                return Err(BenchError::Failed(format!(
                    "{name}: no estimation window in {:.0} s",
                    r.seconds
                )));
            }
            file.not_diagnosed.push(NotDiagnosedFile {
                simulated: name,
                reason: format!(
                    "no estimation window in {:.0} s: the position readings do not move as \
                     the regression needs (samples of non-zero velocity)",
                    r.seconds
                ),
                relative_change: None,
            });
            outcomes.push(FaultOutcome {
                entry,
                run: r,
                symptoms: None,
                relative_change: None,
                relative_bound: None,
                windows_as_table: 0,
            });
            continue;
        };
        let mut s = symptoms(&mean, &nominal, &sim.thresholds);
        let change = relative(&mean, &nominal);
        let mut bound = [0.0; PHYSICAL_PARAMS];
        for (j, b) in bound.iter_mut().enumerate() {
            *b = symptom_bound(&mean, &nominal, &sim.thresholds, j)
                / nominal.p.values[j].abs().max(f64::MIN_POSITIVE);
        }
        // A sign enters the table only with a margin over its bound: a mean change just past it
        // is one that single windows show half of the time, and a row built on it would not
        // match what the daemon sees.
        for (j, sym) in s.iter_mut().enumerate() {
            if change[j].abs() < TABLE_MARGIN * bound[j] {
                *sym = Symptom::Zero;
            }
        }
        let row_of_pattern = patterns.iter().position(|p| *p == s);
        let own_row = entry
            .diagnosis
            .and_then(|d| file.fault.iter().position(|f| f.name == d.name()));
        if s.iter().all(|c| *c == Symptom::Zero) {
            if entry.required {
                return Err(BenchError::Failed(format!(
                    "{name}: no symptom (relative changes {change:.3?}, bounds {bound:.3?})"
                )));
            }
            let reason = if r.windows == healthy.windows {
                "no symptom: the estimates equal the healthy run's, the fault has nothing to \
                 act on in this plant"
            } else {
                "no symptom: every parameter stays within its bound"
            };
            file.not_diagnosed.push(NotDiagnosedFile {
                simulated: name,
                reason: reason.into(),
                relative_change: Some(change.to_vec()),
            });
        } else if let Some(i) = row_of_pattern {
            if entry.required {
                return Err(BenchError::Failed(format!(
                    "{name} and {} give the same pattern {}: the paper's faults must be told apart",
                    file.fault[i].simulated,
                    pattern_text(&s)
                )));
            }
            let note = format!(
                "same pattern as {} ({}): parameter estimation cannot tell them apart; \
                 the diagnosis names {}",
                file.fault[i].simulated,
                pattern_text(&s),
                file.fault[i].name
            );
            file.fault[i].same_pattern.push(SamePatternFile {
                simulated: name,
                relative_change: change.to_vec(),
                note,
            });
        } else if let Some(i) = own_row {
            return Err(BenchError::Failed(format!(
                "{name} gives {} but {} ({}) already has {}",
                pattern_text(&s),
                file.fault[i].name,
                file.fault[i].simulated,
                file.fault[i].symptoms.concat()
            )));
        } else if let Some(d) = entry.diagnosis {
            patterns.push(s);
            file.fault.push(FaultRowFile {
                code: d.label().into(),
                name: d.name().into(),
                symptoms: signs(&s),
                simulated: name,
                relative_change: change.to_vec(),
                relative_bound: bound.to_vec(),
                same_pattern: Vec::new(),
            });
        } else {
            // A pattern no fault of the diagnosis stands for: listed, never hidden; on the bus
            // it shows as its symptoms, and the diagnosis names a fault only if a row is near.
            file.not_diagnosed.push(NotDiagnosedFile {
                simulated: name,
                reason: format!(
                    "a pattern of its own ({}) that no fault of the diagnosis stands for: \
                     published as symptoms only",
                    pattern_text(&s)
                ),
                relative_change: Some(change.to_vec()),
            });
        }
        outcomes.push(FaultOutcome {
            entry,
            run: r,
            symptoms: Some(s),
            relative_change: Some(change),
            relative_bound: Some(bound),
            windows_as_table: 0,
        });
    }
    // The whole file through the same checks as the daemon's loading.
    let table = file
        .table("derived table")
        .map_err(|e| BenchError::Failed(e.to_string()))?;
    // How single windows fare with the derived table.
    for o in &mut outcomes {
        let name = o.entry.fault.to_string();
        let expected = file
            .fault
            .iter()
            .find(|f| f.simulated == name || f.same_pattern.iter().any(|m| m.simulated == name))
            .and_then(|f| DiagnosedFault::from_name(&f.name));
        o.windows_as_table = o
            .run
            .windows
            .iter()
            .filter(|w| {
                let s = symptoms(w, &nominal, &sim.thresholds);
                diagnose(&table, &s, sim.max_distance).fault == expected
            })
            .count();
    }
    let indistinguishable = file
        .fault
        .iter()
        .filter(|f| !f.same_pattern.is_empty())
        .map(|f| {
            let others: Vec<&str> = f
                .same_pattern
                .iter()
                .map(|m| m.simulated.as_str())
                .collect();
            format!(
                "{} ({}) = {}: {}",
                f.code,
                f.symptoms.concat(),
                f.simulated,
                others.join(", ")
            )
        })
        .collect();
    Ok(Derived {
        file,
        nominal,
        healthy,
        outcomes,
        indistinguishable,
    })
}

impl Derived {
    /// The file's header comment.
    pub fn header(&self, options: &FaultTableOptions) -> String {
        format!(
            "Fault-symptom table of the solenoid's parameter diagnosis (Isermann & Raab 1993).\n\
             Generated from the physics; do not edit. Regenerate with\n\
             \x20 {REGENERATE}\n\
             and compare with this file with\n\
             \x20 actuator bench fault-table --check\n\
             \n\
             How: the daemon of config/solenoid.toml and the plant of config/plants/solenoid.toml\n\
             in lock-step on a setpoint tour (0.25 s steps, 4-12 mm), healthy and with each fault\n\
             from the start; p = [T_I, D, w0, K_P, F_C, F_0] estimated as the daemon does over {} windows\n\
             per run (after {} s). Nominal: the healthy windows' mean and spread. A fault's\n\
             symptoms: its mean estimate against the nominal with the daemon's test,\n\
             + / - when |p - p_nom| > max(k sigma, floor |p_nom|), and in the table only when\n\
             the change is more than {TABLE_MARGIN} times that bound (else single windows flip it).\n\
             relative_change = (p - p_nom) / |p_nom|; relative_bound = that bound / |p_nom|.\n\
             A fault whose pattern is a row's is listed under it (same_pattern): the diagnosis\n\
             names the row's fault for both.",
            options.windows, options.warmup_s
        )
    }

    /// A summary for the terminal: the nominal, each fault's pattern and how single windows fare.
    pub fn summary(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let v = &self.nominal;
        let _ = writeln!(
            out,
            "healthy: {} windows in {:.1} s",
            self.healthy.windows.len(),
            self.healthy.seconds
        );
        for (j, name) in PHYSICAL_NAMES.iter().enumerate() {
            let _ = writeln!(
                out,
                "  {name:<28} {:>12.5e}  window spread {:>9.2e}",
                v.p.values[j], v.window_spread[j]
            );
        }
        let _ = writeln!(
            out,
            "{:<26} {:>7}  {:>8}  {:>9}  relative change [T_I D w0 K_P F_C F_0]",
            "fault", "pattern", "windows", "as table"
        );
        for o in &self.outcomes {
            let pattern = o.symptoms.map_or("-".into(), |s| pattern_text(&s));
            let change = o.relative_change.map_or(String::new(), |c| {
                c.iter()
                    .map(|x| format!("{x:+.3}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            });
            let _ = writeln!(
                out,
                "{:<26} {:>7}  {:>8}  {:>5}/{:<3}  {change}",
                o.entry.fault.to_string(),
                pattern,
                o.run.windows.len(),
                o.windows_as_table,
                o.run.windows.len()
            );
        }
        if self.indistinguishable.is_empty() {
            let _ = writeln!(out, "every simulated fault has a pattern of its own");
        } else {
            for line in &self.indistinguishable {
                let _ = writeln!(out, "indistinguishable: {line}");
            }
        }
        for n in &self.file.not_diagnosed {
            let _ = writeln!(out, "not diagnosed: {}: {}", n.simulated, n.reason);
        }
        out
    }
}

/// `actuator bench fault-table`: derive the table and write it to `out`, or with `check` compare
/// it with `out`. Returns the summary to print; a difference is an error listing it.
pub fn regenerate(out: &Path, check: bool) -> Result<String, BenchError> {
    let options = FaultTableOptions::default();
    let derived = derive(&options)?;
    let mut summary = derived.summary();
    let origin = out.display().to_string();
    if check {
        let text = std::fs::read_to_string(out)
            .map_err(|e| BenchError::Failed(format!("{origin}: {e}")))?;
        let committed = FaultTableFile::from_toml(&text, &origin)
            .map_err(|e| BenchError::Failed(e.to_string()))?;
        let diff = derived.file.differences(&committed, CHECK_TOLERANCE);
        if !diff.is_empty() {
            return Err(BenchError::Failed(format!(
                "{summary}{origin} differs from what the physics gives (regenerate with `{REGENERATE}`):\n  {}",
                diff.join("\n  ")
            )));
        }
        summary.push_str(&format!("{origin} agrees with the physics\n"));
    } else {
        std::fs::write(out, derived.file.to_toml(&derived.header(&options)))
            .map_err(|e| BenchError::Failed(format!("{origin}: {e}")))?;
        summary.push_str(&format!("written to {origin}\n"));
    }
    Ok(summary)
}

/// Relative changes may differ by this much between the committed file and a regeneration (the
/// file keeps four decimals; other platforms' floating point may round elsewhere).
pub const CHECK_TOLERANCE: f64 = 1e-3;
