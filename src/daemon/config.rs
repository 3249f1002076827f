//! The daemon's TOML configuration: parsing, defaults and validation with errors that name
//! the file, the key and the rule broken.

use crate::control::{
    AdaptiveFriction, AdaptiveFrictionConfig, Dither, GainSchedule, LearnedTable,
    LearnedTableConfig, NonlinearCorrection, NonlinearCorrectionConfig, ParamError,
    PneumaticAdaptive, PneumaticAdaptiveConfig, SchedulePoint,
};
use crate::param::Declared;
use crate::supervise::{
    DisturbanceObserver, EstimatorSupervisorConfig, FaultMachineConfig, ObserverConfig,
    ParameterEstimator,
};
use crate::{declare_section, param_key};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// An axis key as errors name it, `section.key` or `section`, each name checked against the
/// configuration's fields ([`param_key!`]).
macro_rules! axis_key {
    ($section:ident) => {
        param_key!(AxisConfig, $section)
    };
    ($section:ident : $ty:ty, $key:ident) => {
        format!(
            "{}.{}",
            param_key!(AxisConfig, $section),
            param_key!($ty, $key)
        )
    };
}

/// A node-wide key as errors name it, `[section] key`, both names checked against the
/// configuration's fields.
macro_rules! node_key {
    ($section:ident : $ty:ty, $key:ident) => {
        format!(
            "[{}] {}",
            param_key!(Config, $section),
            param_key!($ty, $key)
        )
    };
}

/// A section of the axis as a rule names it, `[axis.section]`, checked as `axis_key!` is.
macro_rules! axis_table {
    ($section:ident) => {
        format!(
            "[{}.{}]",
            param_key!(Config, axis),
            param_key!(AxisConfig, $section)
        )
    };
}

/// What a rule needs of the axis' command, as the file writes it: `command = "duty"`,
/// `command = "voltage" or "torque"`.
fn command_of(kinds: &[CommandKind]) -> String {
    let names: Vec<String> = kinds.iter().map(|k| format!("\"{}\"", k.name())).collect();
    format!(
        "{} = {}",
        param_key!(AxisConfig, command),
        names.join(" or ")
    )
}

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The I/O error is part of the message, not a separate cause (printed once by `{:#}`).
    #[error("{file}: cannot read: {error}")]
    Read {
        file: PathBuf,
        error: std::io::Error,
    },
    #[error("{file}: {message}")]
    Parse { file: PathBuf, message: String },
    #[error("{file}: {key} {rule}")]
    Invalid {
        file: PathBuf,
        key: String,
        rule: String,
    },
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub bus: BusConfig,
    #[serde(default)]
    pub node: NodeConfig,
    #[serde(default)]
    pub cycle: CycleConfig,
    #[serde(default)]
    pub record: RecordConfig,
    #[serde(default)]
    pub state: StateConfig,
    pub axis: Vec<AxisConfig>,
}

/// `[bus]`, `[node]`, `[cycle]`, `[record]` and `[state]`, declared with their ranges and
/// defaults.
pub use super::node_sections::{
    BusConfig, BusLossPolicy, CycleConfig, NodeConfig, RecordConfig, StateConfig,
};

/// `[[axis]]`'s own keys, declared with their ranges and defaults, and what the command means.
pub use super::axis_section::{AxisConfig, CommandKind};

/// `[axis.controller]`, declared where the discrete controller lives; its rules between keys
/// are checked in [`Config::validate`].
pub use crate::control::ControllerSection;

/// `[axis.friction_compensation]`, declared with its ranges and access where the feed-forward
/// lives.
pub use crate::control::FrictionCompensationSection;

/// `[axis.learned_table]`, declared where the table lives.
pub use crate::control::LearnedTableSection;

/// `[axis.adaptive_friction]`, declared with its ranges and access where the algorithm lives.
pub use crate::control::AdaptiveFrictionSection;

/// `[axis.dither]`, declared with its ranges where the dither lives.
pub use crate::control::DitherSection;

/// `[axis.correction]`, declared where the correction lives.
pub use crate::control::CorrectionSection;

/// `[axis.schedule]`, declared where the scheduling lives.
pub use crate::control::{ScheduleSection, ScheduleVariable};

/// `[axis.pneumatic_adaptive]`, declared where the drive-gain adaptation lives.
pub use crate::control::PneumaticAdaptiveSection;

/// `[axis.observer]`, declared with its ranges and access where the observer lives.
pub use crate::supervise::ObserverSection;

/// `[axis.parameter_estimation]`, declared with its ranges and access where the diagnosis
/// lives, and its nominal parameters.
pub use crate::supervise::{NominalParameters, ParameterEstimationSection};

/// `[axis.fault_reactions]`, declared where the fault machine lives, with its values.
pub use crate::supervise::{FaultReactionsSection, ReactionName};

/// `[axis.limits]`, declared with its ranges and access where the supervision lives.
pub use crate::supervise::LimitsSection;

declare_section! {
    /// `[[axis.setpoints]]`: one step of an axis' setpoint schedule. Each step comes after the
    /// one before and lies within the travel (checked with the axis' limits).
    #[derive(Copy)]
    pub struct SetpointStep {
        /// Seconds after the start of the cycle.
        at_s: f64 = {
            unit: "s", min: 0.0, max: f64::MAX, access: Restart,
            doc: "when the step is taken, after the start of the cycle",
            words: ">= 0 and not earlier than the one before",
        },
        position_m: f64 = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "the setpoint from then on",
        },
    }
}

impl Config {
    /// Read, parse and validate a configuration file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
            file: path.to_path_buf(),
            error,
        })?;
        Self::from_toml(&text, path)
    }

    /// Parse and validate TOML text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, ConfigError> {
        let mut config: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })?;
        let folder = file.parent().unwrap_or(Path::new("."));
        // Relative paths are relative to the configuration file, not to where the daemon runs.
        if let Some(f) = config.state.file.as_mut() {
            if f.is_relative() {
                *f = folder.join(&*f);
            }
        }
        for axis in config.axis.iter_mut() {
            if let Some(f) = axis.controller.state_space_file.as_mut() {
                if f.is_relative() {
                    *f = folder.join(&*f);
                }
            }
            super::profile_config::resolve_eds(axis, folder);
            let table = axis.parameter_estimation.as_mut();
            if let Some(f) = table.and_then(|p| p.fault_table.as_mut()) {
                if f.is_relative() {
                    *f = folder.join(&*f);
                }
            }
        }
        config.validate(file)?;
        Ok(config)
    }

    /// Check every rule a working configuration must follow.
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        let bad = |key: &str, rule: String| ConfigError::Invalid {
            file: file.to_path_buf(),
            key: key.to_string(),
            rule,
        };
        if self.bus.iface.is_empty() {
            return Err(bad(
                &node_key!(bus: BusConfig, iface),
                "must name a CAN interface".into(),
            ));
        }
        // The node-wide sections: the ranges declared with them.
        let section = |name: &'static str| {
            move |e: ParamError| bad(&format!("[{name}] {}", e.name), e.reason)
        };
        self.bus.check().map_err(section(param_key!(Config, bus)))?;
        self.node
            .check()
            .map_err(section(param_key!(Config, node)))?;
        self.cycle
            .check()
            .map_err(section(param_key!(Config, cycle)))?;
        self.state
            .check()
            .map_err(section(param_key!(Config, state)))?;
        if self.cycle.sensor_deadline_s >= self.cycle.period_s {
            return Err(bad(
                &node_key!(cycle: CycleConfig, sensor_deadline_s),
                format!(
                    "must be shorter than {} ({}), got {}",
                    param_key!(CycleConfig, period_s),
                    self.cycle.period_s,
                    self.cycle.sensor_deadline_s
                ),
            ));
        }
        self.record
            .check()
            .map_err(section(param_key!(Config, record)))?;
        if self.axis.is_empty() {
            return Err(bad(
                &format!("[[{}]]", param_key!(Config, axis)),
                "needs at least one axis".into(),
            ));
        }
        let mut seen = vec![self.node.node_id];
        for (i, axis) in self.axis.iter().enumerate() {
            let at = |key: &str| {
                let axis_table = param_key!(Config, axis);
                format!("[[{axis_table}]] #{} ({}) {key}", i + 1, axis.name)
            };
            // The axis' own keys: the ranges declared with them.
            axis.check().map_err(|e| bad(&at(e.name), e.reason))?;
            if seen.contains(&axis.actuator_node_id) {
                return Err(bad(
                    &at(param_key!(AxisConfig, actuator_node_id)),
                    format!("{} is already used by another node", axis.actuator_node_id),
                ));
            }
            seen.push(axis.actuator_node_id);
            super::profile_config::check(axis).map_err(|(key, rule)| bad(&at(&key), rule))?;
            let c = &axis.controller;
            if let Some(f) = &c.state_space_file {
                if !c.q_per_m.is_empty() || !c.p.is_empty() {
                    return Err(bad(
                        &at(&axis_key!(controller: ControllerSection, state_space_file)),
                        format!(
                            "replaces {} and {}: give one or the other",
                            param_key!(ControllerSection, q_per_m),
                            param_key!(ControllerSection, p)
                        ),
                    ));
                }
                let ss = crate::control::robust::StateSpaceController::load(f).map_err(|e| {
                    bad(
                        &at(&axis_key!(controller: ControllerSection, state_space_file)),
                        format!("cannot be used: {e}"),
                    )
                })?;
                if (ss.period_s() - self.cycle.period_s).abs() > 1e-9 {
                    return Err(bad(
                        &at(&axis_key!(controller: ControllerSection, state_space_file)),
                        format!(
                            "{} was designed for a {} s period, the cycle runs at {} s",
                            f.display(),
                            ss.period_s(),
                            self.cycle.period_s
                        ),
                    ));
                }
            } else if c.q_per_m.is_empty() || c.q_per_m.len() > crate::control::MAX_ORDER {
                return Err(bad(
                    &at(&axis_key!(controller: ControllerSection, q_per_m)),
                    format!(
                        "needs 1 to {} coefficients, got {}",
                        crate::control::MAX_ORDER,
                        c.q_per_m.len()
                    ),
                ));
            }
            if c.p.len() > crate::control::MAX_ORDER {
                return Err(bad(
                    &at(&axis_key!(controller: ControllerSection, p)),
                    format!("takes at most {} coefficients", crate::control::MAX_ORDER),
                ));
            }
            if c.q_per_m.iter().chain(&c.p).any(|x| !x.is_finite()) {
                return Err(bad(
                    &at(axis_key!(controller)),
                    "coefficients must be finite".into(),
                ));
            }
            // Whatever the rules above leave: the ranges declared with the section.
            c.check().map_err(|e| {
                bad(
                    &at(&format!("{}.{}", axis_key!(controller), e.name)),
                    e.reason,
                )
            })?;
            if c.output_min >= c.output_max {
                return Err(bad(
                    &at(&axis_key!(controller: ControllerSection, output_max)),
                    format!(
                        "must be > {} ({}), got {}",
                        param_key!(ControllerSection, output_min),
                        c.output_min,
                        c.output_max
                    ),
                ));
            }
            if !(c.output_min..=c.output_max).contains(&axis.safe_command) {
                return Err(bad(
                    &at(param_key!(AxisConfig, safe_command)),
                    format!(
                        "must lie within the controller output limits [{}, {}], got {}",
                        c.output_min, c.output_max, axis.safe_command
                    ),
                ));
            }
            if axis.command == CommandKind::Duty && (c.output_min < -1.0 || c.output_max > 1.0) {
                return Err(bad(
                    &at(&format!(
                        "{}/{}",
                        axis_key!(controller: ControllerSection, output_min),
                        param_key!(ControllerSection, output_max)
                    )),
                    format!(
                        "must lie within [-1, 1] for {}",
                        command_of(&[CommandKind::Duty])
                    ),
                ));
            }
            if let Some(f) = &axis.friction_compensation {
                f.check().map_err(|e| {
                    bad(
                        &at(&format!("{}.{}", axis_key!(friction_compensation), e.name)),
                        e.reason,
                    )
                })?;
            }
            axis.check_intelligence(self.cycle.period_s)
                .map_err(|(key, rule)| bad(&at(&key), rule))?;
            let l = &axis.limits;
            l.check()
                .map_err(|e| bad(&at(&format!("{}.{}", axis_key!(limits), e.name)), e.reason))?;
            if let Some(t) = &axis.setpoint_timeout {
                let key = |name: &str| at(&format!("{}.{name}", axis_key!(setpoint_timeout)));
                t.check().map_err(|e| bad(&key(e.name), e.reason))?;
                t.check_reaction(
                    l.position_min_m.unwrap_or(f64::NEG_INFINITY),
                    l.position_max_m.unwrap_or(f64::INFINITY),
                )
                .map_err(|(name, rule)| bad(&key(name), rule))?;
            }
            for (lo_key, lo, hi_key, hi) in [
                (
                    param_key!(LimitsSection, position_min_m),
                    l.position_min_m,
                    param_key!(LimitsSection, position_max_m),
                    l.position_max_m,
                ),
                (
                    param_key!(LimitsSection, supply_voltage_min_v),
                    l.supply_voltage_min_v,
                    param_key!(LimitsSection, supply_voltage_max_v),
                    l.supply_voltage_max_v,
                ),
                (
                    param_key!(LimitsSection, supply_pressure_min_pa),
                    l.supply_pressure_min_pa,
                    param_key!(LimitsSection, supply_pressure_max_pa),
                    l.supply_pressure_max_pa,
                ),
                (
                    param_key!(LimitsSection, supply_voltage_scheduled_min_v),
                    l.supply_voltage_scheduled_min_v,
                    param_key!(LimitsSection, supply_voltage_scheduled_max_v),
                    l.supply_voltage_scheduled_max_v,
                ),
                (
                    param_key!(LimitsSection, supply_pressure_scheduled_min_pa),
                    l.supply_pressure_scheduled_min_pa,
                    param_key!(LimitsSection, supply_pressure_scheduled_max_pa),
                    l.supply_pressure_scheduled_max_pa,
                ),
            ] {
                if let (Some(lo), Some(hi)) = (lo, hi) {
                    if lo >= hi {
                        return Err(bad(
                            &at(&format!("{}.{hi_key}", axis_key!(limits))),
                            format!("must be > {lo_key} ({lo}), got {hi}"),
                        ));
                    }
                }
            }
            // The scheduled band lies inside the hard band: past the hard band the axis is in
            // its safe state, and a warning band reaching beyond it would never be seen.
            for (key, v, lo, hi) in [
                (
                    param_key!(LimitsSection, supply_voltage_scheduled_min_v),
                    l.supply_voltage_scheduled_min_v,
                    l.supply_voltage_min_v,
                    l.supply_voltage_max_v,
                ),
                (
                    param_key!(LimitsSection, supply_voltage_scheduled_max_v),
                    l.supply_voltage_scheduled_max_v,
                    l.supply_voltage_min_v,
                    l.supply_voltage_max_v,
                ),
                (
                    param_key!(LimitsSection, supply_pressure_scheduled_min_pa),
                    l.supply_pressure_scheduled_min_pa,
                    l.supply_pressure_min_pa,
                    l.supply_pressure_max_pa,
                ),
                (
                    param_key!(LimitsSection, supply_pressure_scheduled_max_pa),
                    l.supply_pressure_scheduled_max_pa,
                    l.supply_pressure_min_pa,
                    l.supply_pressure_max_pa,
                ),
            ] {
                let Some(v) = v else { continue };
                if !v.is_finite() {
                    return Err(bad(
                        &at(&format!("{}.{key}", axis_key!(limits))),
                        format!("must be finite, got {v}"),
                    ));
                }
                if lo.is_some_and(|lo| v < lo) || hi.is_some_and(|hi| v > hi) {
                    return Err(bad(
                        &at(&format!("{}.{key}", axis_key!(limits))),
                        format!(
                            "must lie inside the hard band [{}, {}], got {v}",
                            lo.unwrap_or(f64::NEG_INFINITY),
                            hi.unwrap_or(f64::INFINITY)
                        ),
                    ));
                }
            }
            let in_travel = |v: f64| {
                l.position_min_m.is_none_or(|lo| v >= lo)
                    && l.position_max_m.is_none_or(|hi| v <= hi)
            };
            if !in_travel(axis.initial_setpoint_m) {
                return Err(bad(
                    &at(param_key!(AxisConfig, initial_setpoint_m)),
                    format!(
                        "{} lies outside the position limits",
                        axis.initial_setpoint_m
                    ),
                ));
            }
            let mut last = f64::NEG_INFINITY;
            for (j, s) in axis.setpoints.iter().enumerate() {
                let key = at(&format!("{} #{}", param_key!(AxisConfig, setpoints), j + 1));
                let rule = |e: ParamError| bad(&key, format!("{} {}", e.name, e.reason));
                s.check().map_err(rule)?;
                if s.at_s < last {
                    let at_s = SetpointStep::spec(param_key!(SetpointStep, at_s));
                    return Err(rule(ParamError::new(
                        param_key!(SetpointStep, at_s),
                        format!("must be {}, got {}", at_s.map_or("", |p| p.words), s.at_s),
                    )));
                }
                if !in_travel(s.position_m) {
                    return Err(bad(
                        &key,
                        format!(
                            "{} {} lies outside the position limits",
                            param_key!(SetpointStep, position_m),
                            s.position_m
                        ),
                    ));
                }
                last = s.at_s;
            }
        }
        let load = super::bus_load::bus_load(self);
        if load.load > self.bus.max_load {
            return Err(bad(
                &node_key!(bus: BusConfig, max_load),
                format!(
                    "is {:.0} %, but the configured traffic needs {:.0} kbit/s = {:.0} % of {} kbit/s: lower the rates or raise {}",
                    self.bus.max_load * 100.0,
                    load.bits_per_s / 1000.0,
                    load.load * 100.0,
                    self.bus.bitrate_bps / 1000,
                    param_key!(BusConfig, bitrate_bps)
                ),
            ));
        }
        Ok(())
    }
}

/// A section key and the rule it breaks.
type KeyRule = (String, String);

fn param(section: &str) -> impl Fn(ParamError) -> KeyRule + '_ {
    move |e| (format!("{section}.{}", e.name), e.reason)
}

fn column<'a>(
    section: &str,
    key: &str,
    v: &'a Option<Vec<f64>>,
    n: usize,
) -> Result<&'a [f64], KeyRule> {
    let v = v
        .as_deref()
        .ok_or_else(|| (format!("{section}.{key}"), "is missing".to_string()))?;
    if v.len() != n {
        return Err((
            format!("{section}.{key}"),
            format!("needs one value per point ({n}), got {}", v.len()),
        ));
    }
    Ok(v)
}

/// The schedule as points of the algorithm, with the reference to the key of a bad column.
fn schedule_points(
    s: &ScheduleSection,
    columns: &[(&str, &Option<Vec<f64>>)],
) -> Result<Vec<SchedulePoint>, KeyRule> {
    let (_, supply) = s.variable();
    let n = supply.len();
    let mut cols = Vec::with_capacity(columns.len());
    for (key, v) in columns {
        cols.push(column(axis_key!(schedule), key, v, n)?);
    }
    Ok((0..n)
        .map(|i| SchedulePoint {
            supply: supply[i],
            params: cols.iter().map(|c| c[i]).collect(),
        })
        .collect())
}

impl AxisConfig {
    /// `[axis.learned_table]` as the table's grid and the learning period in cycles.
    pub fn learned_table_config(&self, period_s: f64) -> Option<(LearnedTableConfig, u32)> {
        let t = self.learned_table.as_ref()?;
        let supply = t
            .supply_voltage_edges_v
            .clone()
            .or_else(|| t.supply_pressure_edges_pa.clone())
            .unwrap_or_default();
        Some((
            LearnedTableConfig {
                position_edges_m: t.position_edges_m.clone(),
                // No load on the frames: one band that every operating point falls into.
                load_edges_n: vec![0.0, 1.0],
                supply_edges: supply,
                param_names: crate::daemon::learned::FRICTION_TABLE_PARAMS
                    .map(String::from)
                    .to_vec(),
                averaging_count: t.averaging_count,
                min_count: t.min_count,
            },
            cycles(t.learn_interval_s, period_s),
        ))
    }

    /// `[axis.adaptive_friction]` as the algorithm's configuration; starts from the feed-forward
    /// values `α F_C± / K` of `[axis.friction_compensation]` when given (clamped to the maximum).
    pub fn adaptive_friction_config(&self, period_s: f64) -> Option<AdaptiveFrictionConfig> {
        let a = self.adaptive_friction.as_ref()?;
        let (pos, neg) = self.friction_compensation.as_ref().map_or((0.0, 0.0), |f| {
            let k = f.force_gain_n_per_command;
            (f.alpha * f.coulomb_pos_n / k, f.alpha * f.coulomb_neg_n / k)
        });
        let clamp = |v: f64| {
            if v.is_finite() {
                v.clamp(0.0, a.compensation_max.max(0.0))
            } else {
                0.0
            }
        };
        Some(AdaptiveFrictionConfig {
            period_s,
            params: a.clone(),
            initial_pos: clamp(pos),
            initial_neg: clamp(neg),
        })
    }

    pub fn correction_config(&self) -> Option<NonlinearCorrectionConfig> {
        let c = self.correction.as_ref()?;
        Some(NonlinearCorrectionConfig {
            pole_m: c.pole_m,
            c0: c.c0,
            c1_per_m: c.c1_per_m,
            c2_per_m2: c.c2_per_m2,
            reference_position_m: c.reference_position_m,
            min_gain_ratio: c.min_gain_ratio,
            output_min: self.controller.output_min,
            output_max: self.controller.output_max,
        })
    }

    /// The gain-factor schedule (`gain_factor` column), if the axis has one.
    pub fn gain_factor_points(&self) -> Result<Option<Vec<SchedulePoint>>, KeyRule> {
        match &self.schedule {
            Some(s) if !s.schedules_drive_gains() => match &s.command_limit_factor {
                None => schedule_points(
                    s,
                    &[(param_key!(ScheduleSection, gain_factor), &s.gain_factor)],
                )
                .map(Some),
                Some(_) => schedule_points(
                    s,
                    &[
                        (param_key!(ScheduleSection, gain_factor), &s.gain_factor),
                        (
                            param_key!(ScheduleSection, command_limit_factor),
                            &s.command_limit_factor,
                        ),
                    ],
                )
                .map(Some),
            },
            _ => Ok(None),
        }
    }

    /// The direction-P axis (scheduled drive gains, optionally adapted online), if configured.
    pub fn pneumatic_config(
        &self,
        period_s: f64,
    ) -> Result<Option<PneumaticAdaptiveConfig>, KeyRule> {
        let Some(s) = self.schedule.as_ref().filter(|s| s.schedules_drive_gains()) else {
            return Ok(None);
        };
        let schedule = schedule_points(
            s,
            &[
                (
                    param_key!(ScheduleSection, drive_gain_down_m_per_s),
                    &s.drive_gain_down_m_per_s,
                ),
                (
                    param_key!(ScheduleSection, drive_gain_up_m_per_s),
                    &s.drive_gain_up_m_per_s,
                ),
            ],
        )?;
        let effort_weight_m2 = s.effort_weight_m2.ok_or_else(|| {
            (
                axis_key!(schedule: ScheduleSection, effort_weight_m2),
                "is needed with drive gains".to_string(),
            )
        })?;
        let a = self.pneumatic_adaptive.as_ref();
        Ok(Some(PneumaticAdaptiveConfig {
            period_s,
            schedule,
            effort_weight_m2,
            nominal_supply_pa: s.nominal_supply_pa,
            adapt: a.is_some(),
            forgetting: a.map_or(0.975, |a| a.forgetting),
            supervision: EstimatorSupervisorConfig {
                min_input: a.map_or(0.0, |a| a.min_duty),
                min_output_step: a.map_or(0.0, |a| a.min_position_step_m),
                min_updates: a.map_or(1, |a| a.min_updates),
                eigenvalue_valid: a.map_or(0.5, |a| a.eigenvalue_valid),
                plausible: a.map_or(vec![], |a| {
                    vec![(a.drive_gain_min_m_per_s, a.drive_gain_max_m_per_s)]
                }),
            },
            deadband_m: s.deadband_m,
            output_min: self.controller.output_min,
            output_max: self.controller.output_max,
        }))
    }

    pub fn observer_config(&self, period_s: f64) -> Option<ObserverConfig> {
        let o = self.observer.as_ref()?;
        Some(ObserverConfig {
            period_s,
            params: o.clone(),
        })
    }

    /// The fault machine's policies: the defaults with the configured reactions.
    pub fn fault_machine_config(&self) -> FaultMachineConfig {
        self.fault_reactions
            .as_ref()
            .map_or_else(FaultMachineConfig::default, |r| r.machine_config())
    }

    /// Build every configured algorithm once, so a bad value is reported with its key here and
    /// not found later by the cycle.
    fn check_intelligence(&self, period_s: f64) -> Result<(), KeyRule> {
        if let Some(c) = self.adaptive_friction_config(period_s) {
            AdaptiveFriction::new(c).map_err(param(axis_key!(adaptive_friction)))?;
        }
        if let Some(t) = &self.learned_table {
            if self.adaptive_friction.is_none() {
                return Err((
                    axis_key!(learned_table).to_string(),
                    format!(
                        "stores the adapted friction compensation: it needs {}",
                        axis_table!(adaptive_friction)
                    ),
                ));
            }
            // A drive's supply is its DC link voltage.
            let (key, wanted) = match self.command {
                CommandKind::Duty => (
                    param_key!(LearnedTableSection, supply_pressure_edges_pa),
                    &t.supply_pressure_edges_pa,
                ),
                _ => (
                    param_key!(LearnedTableSection, supply_voltage_edges_v),
                    &t.supply_voltage_edges_v,
                ),
            };
            let other = match self.command {
                CommandKind::Duty => (
                    param_key!(LearnedTableSection, supply_voltage_edges_v),
                    &t.supply_voltage_edges_v,
                ),
                _ => (
                    param_key!(LearnedTableSection, supply_pressure_edges_pa),
                    &t.supply_pressure_edges_pa,
                ),
            };
            if wanted.is_none() || other.1.is_some() {
                return Err((
                    format!("{}.{key}", axis_key!(learned_table)),
                    format!(
                        "is the supply this axis measures: set it, and not {}",
                        other.0
                    ),
                ));
            }
            t.check().map_err(param(axis_key!(learned_table)))?;
            if let Some((c, _)) = self.learned_table_config(period_s) {
                LearnedTable::new(c).map_err(|e| {
                    let key = match e.name {
                        "supply_edges" => key,
                        other => other,
                    };
                    (format!("{}.{key}", axis_key!(learned_table)), e.reason)
                })?;
            }
        }
        if let Some(d) = &self.dither {
            d.check_adaptation().map_err(param(axis_key!(dither)))?;
            Dither::new(d.config(period_s)).map_err(param(axis_key!(dither)))?;
            // Whatever the generator leaves: the ranges declared with the section.
            d.check().map_err(param(axis_key!(dither)))?;
        }
        if let Some(c) = self.correction_config() {
            NonlinearCorrection::new(c).map_err(param(axis_key!(correction)))?;
        }
        if let Some(s) = &self.schedule {
            match (&s.supply_voltage_v, &s.supply_pressure_pa) {
                (Some(_), Some(_)) | (None, None) => {
                    return Err((
                        axis_key!(schedule).to_string(),
                        format!(
                            "needs exactly one of {} and {}",
                            param_key!(ScheduleSection, supply_voltage_v),
                            param_key!(ScheduleSection, supply_pressure_pa)
                        ),
                    ))
                }
                _ => {}
            }
            if s.schedules_drive_gains() == s.gain_factor.is_some() {
                return Err((
                    axis_key!(schedule).to_string(),
                    format!(
                        "needs either {} or {} and {}",
                        param_key!(ScheduleSection, gain_factor),
                        param_key!(ScheduleSection, drive_gain_down_m_per_s),
                        param_key!(ScheduleSection, drive_gain_up_m_per_s)
                    ),
                ));
            }
            if s.schedules_drive_gains() {
                if self.command != CommandKind::Duty {
                    return Err((
                        axis_key!(schedule: ScheduleSection, drive_gain_down_m_per_s),
                        format!(
                            "schedules direction P gains, which need {}",
                            command_of(&[CommandKind::Duty])
                        ),
                    ));
                }
                if s.variable().0 != ScheduleVariable::SupplyPressure {
                    return Err((
                        axis_key!(schedule: ScheduleSection, supply_voltage_v),
                        format!(
                            "drive gains are scheduled on {}",
                            param_key!(ScheduleSection, supply_pressure_pa)
                        ),
                    ));
                }
            }
            if s.command_limit_factor.is_some() && s.schedules_drive_gains() {
                return Err((
                    axis_key!(schedule: ScheduleSection, command_limit_factor),
                    format!(
                        "goes with {}, not with drive gains",
                        param_key!(ScheduleSection, gain_factor)
                    ),
                ));
            }
            let points = self.gain_factor_points()?;
            // The gain and limit factors, the deadband: the ranges declared with the section.
            s.check().map_err(param(axis_key!(schedule)))?;
            if let Some(points) = points {
                GainSchedule::new(&points).map_err(param(axis_key!(schedule)))?;
            }
        }
        if self.pneumatic_adaptive.is_some()
            && !self
                .schedule
                .as_ref()
                .is_some_and(|s| s.schedules_drive_gains())
        {
            return Err((
                axis_key!(pneumatic_adaptive).to_string(),
                format!(
                    "needs {} with {} and {} (its start and fallback)",
                    axis_table!(schedule),
                    param_key!(ScheduleSection, drive_gain_down_m_per_s),
                    param_key!(ScheduleSection, drive_gain_up_m_per_s)
                ),
            ));
        }
        if let Some(c) = self.pneumatic_config(period_s)? {
            let section = if self.pneumatic_adaptive.is_some() {
                axis_key!(pneumatic_adaptive)
            } else {
                axis_key!(schedule)
            };
            PneumaticAdaptive::new(&c).map_err(param(section))?;
        }
        if let Some(o) = &self.observer {
            if !(o.warmup_s.is_finite() && o.warmup_s >= 0.0) {
                return Err((
                    axis_key!(observer: ObserverSection, warmup_s),
                    format!("must be >= 0, got {}", o.warmup_s),
                ));
            }
            for (key, v) in [
                (param_key!(ObserverSection, band_sigmas), o.band_sigmas),
                (
                    param_key!(ObserverSection, band_min_halfwidth_m),
                    o.band_min_halfwidth_m,
                ),
                (
                    param_key!(ObserverSection, moving_speed_m_per_s),
                    o.moving_speed_m_per_s,
                ),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err((
                        format!("{}.{key}", axis_key!(observer)),
                        format!("must be >= 0, got {v}"),
                    ));
                }
            }
            if o.learn_samples < 2 {
                return Err((
                    axis_key!(observer: ObserverSection, learn_samples),
                    format!("must be >= 2, got {}", o.learn_samples),
                ));
            }
        }
        if let Some(c) = self.observer_config(period_s) {
            DisturbanceObserver::new(c).map_err(param(axis_key!(observer)))?;
        }
        if let Some(o) = &self.observer {
            // Whatever the rules above leave: the ranges declared with the section.
            o.check().map_err(param(axis_key!(observer)))?;
        }
        if let Some(p) = &self.parameter_estimation {
            p.check().map_err(param(axis_key!(parameter_estimation)))?;
            if let Err(e) = p.load_fault_table() {
                return Err((
                    axis_key!(parameter_estimation: ParameterEstimationSection, fault_table),
                    e.to_string(),
                ));
            }
            if self.command != CommandKind::Voltage {
                return Err((
                    axis_key!(parameter_estimation).to_string(),
                    format!(
                        "models the solenoid drive, which needs {}",
                        command_of(&[CommandKind::Voltage])
                    ),
                ));
            }
        }
        if let Some(p) = &self.parameter_estimation {
            ParameterEstimator::new(p.estimator_config(period_s))
                .map_err(param(axis_key!(parameter_estimation)))?;
        }
        // A force (torque) command is the observer's model with a unit force gain.
        if self.observer.is_some()
            && !matches!(self.command, CommandKind::Voltage | CommandKind::Torque)
        {
            return Err((
                axis_key!(observer).to_string(),
                format!(
                    "models the drive force, which needs {}",
                    command_of(&[CommandKind::Voltage, CommandKind::Torque])
                ),
            ));
        }
        Ok(())
    }
}

/// Persistence in cycles for a time, at least one cycle.
pub use crate::param::cycles;

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = include_str!("../../config/solenoid.toml");

    fn err(text: &str) -> String {
        Config::from_toml(text, Path::new("x.toml"))
            .expect_err("invalid config")
            .to_string()
    }

    #[test]
    fn shipped_config_is_valid() {
        let c = Config::from_toml(GOOD, Path::new("config/solenoid.toml")).expect("valid");
        assert_eq!(c.bus.iface, "vcan0");
        assert_eq!(c.axis.len(), 1);
        assert_eq!(c.cycle.period_s, 0.0025);
    }

    #[test]
    fn errors_name_file_key_and_rule() {
        let t = GOOD.replace("output_max = 24.0", "output_max = -3.0");
        let e = err(&t);
        assert!(
            e.starts_with(
                "x.toml: [[axis]] #1 (solenoid) controller.output_max must be > output_min"
            ),
            "{e}"
        );
        let t = GOOD.replace("period_s = 0.0025", "period_s = -1.0");
        assert_eq!(err(&t), "x.toml: [cycle] period_s must be > 0, got -1");
    }

    #[test]
    fn unknown_keys_and_wrong_types_are_named() {
        let t = GOOD.replace("[bus]", "[bus]\nspeed = 3");
        let e = err(&t);
        assert!(e.contains("x.toml") && e.contains("speed"), "{e}");
        let t = GOOD.replace("actuator_node_id = 16", "actuator_node_id = \"sixteen\"");
        let e = err(&t);
        assert!(e.contains("actuator_node_id"), "{e}");
    }

    #[test]
    fn node_id_collisions_are_refused() {
        let t = GOOD.replace("actuator_node_id = 16", "actuator_node_id = 1");
        let e = err(&t);
        assert!(e.contains("already used"), "{e}");
    }

    #[test]
    fn a_learned_table_needs_adaptive_friction_and_the_axis_own_supply() {
        let table = "\n[axis.learned_table]\nposition_edges_m = [0.0, 0.01]\n";
        let (a, b) = (
            GOOD.find("[axis.adaptive_friction]").expect("section"),
            GOOD.find("[axis.observer]").expect("section"),
        );
        let plain = format!("{}{}", &GOOD[..a], &GOOD[b..]);
        let e = err(&format!(
            "{plain}{table}supply_voltage_edges_v = [20.0, 30.0]\n"
        ));
        assert!(
            e.ends_with("learned_table stores the adapted friction compensation: it needs [axis.adaptive_friction]"),
            "{e}"
        );
        let e = err(&format!(
            "{GOOD}{table}supply_pressure_edges_pa = [2e5, 6e5]\n"
        ));
        assert!(
            e.contains("learned_table.supply_voltage_edges_v is the supply this axis measures"),
            "{e}"
        );
        let e = err(&format!(
            "{GOOD}{table}supply_voltage_edges_v = [30.0, 20.0]\n"
        ));
        assert!(e.contains("learned_table.supply_voltage_edges_v"), "{e}");
        let good = format!("{GOOD}{table}supply_voltage_edges_v = [20.0, 30.0]\n");
        let c = Config::from_toml(&good, Path::new("x.toml")).expect("valid");
        assert!(c.axis[0].learned_table_config(0.0025).is_some());
    }
}
