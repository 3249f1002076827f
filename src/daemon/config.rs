//! The daemon's TOML configuration: parsing, defaults and validation with errors that name
//! the file, the key and the rule broken.

use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        #[source]
        source: std::io::Error,
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
    pub axis: Vec<AxisConfig>,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BusConfig {
    /// SocketCAN interface, e.g. "can0" or "vcan0".
    pub iface: String,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct NodeConfig {
    /// The daemon's own CANopen node id, 1..=127.
    pub node_id: u8,
    pub heartbeat_period_s: f64,
    /// Period of the fault_state, tuned_parameters and loop_status frames.
    pub status_period_s: f64,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            node_id: 1,
            heartbeat_period_s: 0.1,
            status_period_s: 0.05,
        }
    }
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct CycleConfig {
    /// Control period; 2.5 ms (400 Hz) is the paper's solenoid.
    pub period_s: f64,
    /// How long after SYNC the cycle waits for the sensor frames before it runs without them.
    pub sensor_deadline_s: f64,
    /// SCHED_FIFO priority to ask for (1..=99); 0 runs with the normal scheduler.
    pub realtime_priority: i32,
    /// Lock all memory (mlockall) so a page fault cannot stall the cycle.
    pub lock_memory: bool,
}

impl Default for CycleConfig {
    fn default() -> Self {
        Self {
            period_s: 0.0025,
            sensor_deadline_s: 0.0015,
            realtime_priority: 80,
            lock_memory: true,
        }
    }
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Records the cycle can queue for the writer before it drops (and counts) them.
    pub queue_depth: usize,
    /// Record every CAN frame sent and received too (MCAP topic /actuatord/can).
    pub can_frames: bool,
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            queue_depth: 8192,
            can_frames: true,
        }
    }
}

/// What the actuator command means.
#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CommandKind {
    /// Terminal voltage, V (solenoid, motor).
    Voltage,
    /// Signed valve duty, -1..1 (pneumatic).
    Duty,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    pub name: String,
    /// Node id of the axis' actuator node (real or simulated), 1..=127.
    pub actuator_node_id: u8,
    pub command: CommandKind,
    /// Send NMT start to the actuator node at start-up.
    #[serde(default = "yes")]
    pub start_node: bool,
    /// Setpoint before any arrives, m.
    pub initial_setpoint_m: f64,
    /// Rate limit of the reference the loop tracks (m/s, rad/s on a rotary axis); absent: steps.
    pub setpoint_rate_max_m_per_s: Option<f64>,
    /// Command sent while a fault is latched (V or duty, as `command`); the spring-return rest for a solenoid.
    #[serde(default)]
    pub safe_command: f64,
    pub controller: ControllerConfig,
    pub friction_compensation: Option<FrictionCompensationConfig>,
    pub limits: LimitsConfig,
    /// A setpoint schedule; setpoint frames on the bus override it until its next entry.
    #[serde(default)]
    pub setpoints: Vec<SetpointStep>,
}

fn yes() -> bool {
    true
}

/// The general discrete controller `u(k) = -Σ p_i u(k-i) + Σ q_j e(k-j)`, e in m, u in the command unit.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ControllerConfig {
    /// Numerator coefficients q_0..q_m, command unit per m of error.
    pub q_per_m: Vec<f64>,
    /// Denominator coefficients p_1..p_n (without the leading 1).
    #[serde(default)]
    pub p: Vec<f64>,
    /// Output limits in the command unit.
    pub output_min: f64,
    pub output_max: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FrictionCompensationConfig {
    /// Safety factor α, 0 < α ≤ 1.
    pub alpha: f64,
    pub coulomb_pos_n: f64,
    pub coulomb_neg_n: f64,
    /// Actuator force per command unit, N/V or N per unit duty.
    pub force_gain_n_per_command: f64,
    /// Errors below this count as zero for the sign, m.
    #[serde(default)]
    pub deadband_m: f64,
}

#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LimitsConfig {
    pub following_error_m: Option<f64>,
    #[serde(default = "default_following_error_time")]
    pub following_error_time_s: f64,
    pub position_min_m: Option<f64>,
    pub position_max_m: Option<f64>,
    pub current_max_a: Option<f64>,
    #[serde(default = "default_short_time")]
    pub current_time_s: f64,
    pub supply_voltage_min_v: Option<f64>,
    pub supply_voltage_max_v: Option<f64>,
    pub supply_pressure_min_pa: Option<f64>,
    pub supply_pressure_max_pa: Option<f64>,
    #[serde(default = "default_short_time")]
    pub supply_time_s: f64,
    /// Time without sensor frames before `sensor_timeout` latches.
    #[serde(default = "default_sensor_timeout")]
    pub sensor_timeout_s: f64,
    /// Time without the actuator node's heartbeat before `heartbeat_lost` latches; absent = not watched.
    pub heartbeat_timeout_s: Option<f64>,
}

fn default_following_error_time() -> f64 {
    0.25
}
fn default_short_time() -> f64 {
    0.01
}
fn default_sensor_timeout() -> f64 {
    0.02
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SetpointStep {
    /// Seconds after the start of the cycle.
    pub at_s: f64,
    pub position_m: f64,
}

impl Config {
    /// Read, parse and validate a configuration file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            file: path.to_path_buf(),
            source,
        })?;
        Self::from_toml(&text, path)
    }

    /// Parse and validate TOML text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, ConfigError> {
        let config: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })?;
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
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(key, format!("must be > 0, got {v}")))
            }
        };
        let node_id = |key: &str, v: u8| {
            if (1..=127).contains(&v) {
                Ok(())
            } else {
                Err(bad(key, format!("must be a node id in 1..=127, got {v}")))
            }
        };
        if self.bus.iface.is_empty() {
            return Err(bad("[bus] iface", "must name a CAN interface".into()));
        }
        node_id("[node] node_id", self.node.node_id)?;
        positive("[node] heartbeat_period_s", self.node.heartbeat_period_s)?;
        positive("[node] status_period_s", self.node.status_period_s)?;
        positive("[cycle] period_s", self.cycle.period_s)?;
        positive("[cycle] sensor_deadline_s", self.cycle.sensor_deadline_s)?;
        if self.cycle.sensor_deadline_s >= self.cycle.period_s {
            return Err(bad(
                "[cycle] sensor_deadline_s",
                format!(
                    "must be shorter than period_s ({}), got {}",
                    self.cycle.period_s, self.cycle.sensor_deadline_s
                ),
            ));
        }
        if !(0..=99).contains(&self.cycle.realtime_priority) {
            return Err(bad(
                "[cycle] realtime_priority",
                format!("must be 0..=99, got {}", self.cycle.realtime_priority),
            ));
        }
        if self.record.queue_depth == 0 {
            return Err(bad("[record] queue_depth", "must be > 0".into()));
        }
        if self.axis.is_empty() {
            return Err(bad("[[axis]]", "needs at least one axis".into()));
        }
        let mut seen = vec![self.node.node_id];
        for (i, axis) in self.axis.iter().enumerate() {
            let at = |key: &str| format!("[[axis]] #{} ({}) {key}", i + 1, axis.name);
            node_id(&at("actuator_node_id"), axis.actuator_node_id)?;
            if seen.contains(&axis.actuator_node_id) {
                return Err(bad(
                    &at("actuator_node_id"),
                    format!("{} is already used by another node", axis.actuator_node_id),
                ));
            }
            seen.push(axis.actuator_node_id);
            let c = &axis.controller;
            if c.q_per_m.is_empty() || c.q_per_m.len() > crate::control::MAX_ORDER {
                return Err(bad(
                    &at("controller.q_per_m"),
                    format!(
                        "needs 1 to {} coefficients, got {}",
                        crate::control::MAX_ORDER,
                        c.q_per_m.len()
                    ),
                ));
            }
            if c.p.len() > crate::control::MAX_ORDER {
                return Err(bad(
                    &at("controller.p"),
                    format!("takes at most {} coefficients", crate::control::MAX_ORDER),
                ));
            }
            if c.q_per_m.iter().chain(&c.p).any(|x| !x.is_finite()) {
                return Err(bad(&at("controller"), "coefficients must be finite".into()));
            }
            if c.output_min >= c.output_max {
                return Err(bad(
                    &at("controller.output_max"),
                    format!(
                        "must be > output_min ({}), got {}",
                        c.output_min, c.output_max
                    ),
                ));
            }
            if !(c.output_min..=c.output_max).contains(&axis.safe_command) {
                return Err(bad(
                    &at("safe_command"),
                    format!(
                        "must lie within the controller output limits [{}, {}], got {}",
                        c.output_min, c.output_max, axis.safe_command
                    ),
                ));
            }
            if axis.command == CommandKind::Duty && (c.output_min < -1.0 || c.output_max > 1.0) {
                return Err(bad(
                    &at("controller.output_min/output_max"),
                    "must lie within [-1, 1] for command = \"duty\"".into(),
                ));
            }
            if let Some(f) = &axis.friction_compensation {
                if !(f.alpha > 0.0 && f.alpha <= 1.0) {
                    return Err(bad(
                        &at("friction_compensation.alpha"),
                        format!("must be in (0, 1], got {}", f.alpha),
                    ));
                }
                for (k, v) in [
                    ("coulomb_pos_n", f.coulomb_pos_n),
                    ("coulomb_neg_n", f.coulomb_neg_n),
                ] {
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(bad(
                            &at(&format!("friction_compensation.{k}")),
                            format!("must be >= 0, got {v}"),
                        ));
                    }
                }
                positive(
                    &at("friction_compensation.force_gain_n_per_command"),
                    f.force_gain_n_per_command,
                )?;
                if !(f.deadband_m.is_finite() && f.deadband_m >= 0.0) {
                    return Err(bad(
                        &at("friction_compensation.deadband_m"),
                        format!("must be >= 0, got {}", f.deadband_m),
                    ));
                }
            }
            if let Some(v) = axis.setpoint_rate_max_m_per_s {
                positive(&at("setpoint_rate_max_m_per_s"), v)?;
            }
            let l = &axis.limits;
            if let Some(v) = l.following_error_m {
                positive(&at("limits.following_error_m"), v)?;
            }
            positive(
                &at("limits.following_error_time_s"),
                l.following_error_time_s,
            )?;
            positive(&at("limits.current_time_s"), l.current_time_s)?;
            positive(&at("limits.supply_time_s"), l.supply_time_s)?;
            positive(&at("limits.sensor_timeout_s"), l.sensor_timeout_s)?;
            if let Some(v) = l.heartbeat_timeout_s {
                positive(&at("limits.heartbeat_timeout_s"), v)?;
            }
            if let Some(v) = l.current_max_a {
                positive(&at("limits.current_max_a"), v)?;
            }
            for (lo_key, lo, hi_key, hi) in [
                (
                    "limits.position_min_m",
                    l.position_min_m,
                    "limits.position_max_m",
                    l.position_max_m,
                ),
                (
                    "limits.supply_voltage_min_v",
                    l.supply_voltage_min_v,
                    "limits.supply_voltage_max_v",
                    l.supply_voltage_max_v,
                ),
                (
                    "limits.supply_pressure_min_pa",
                    l.supply_pressure_min_pa,
                    "limits.supply_pressure_max_pa",
                    l.supply_pressure_max_pa,
                ),
            ] {
                if let (Some(lo), Some(hi)) = (lo, hi) {
                    if lo >= hi {
                        return Err(bad(
                            &at(hi_key),
                            format!(
                                "must be > {} ({lo}), got {hi}",
                                lo_key.trim_start_matches("limits.")
                            ),
                        ));
                    }
                }
            }
            let in_travel = |v: f64| {
                l.position_min_m.is_none_or(|lo| v >= lo)
                    && l.position_max_m.is_none_or(|hi| v <= hi)
            };
            if !in_travel(axis.initial_setpoint_m) {
                return Err(bad(
                    &at("initial_setpoint_m"),
                    format!(
                        "{} lies outside the position limits",
                        axis.initial_setpoint_m
                    ),
                ));
            }
            let mut last = f64::NEG_INFINITY;
            for (j, s) in axis.setpoints.iter().enumerate() {
                let key = at(&format!("setpoints #{}", j + 1));
                if !(s.at_s.is_finite() && s.at_s >= 0.0 && s.at_s >= last) {
                    return Err(bad(
                        &key,
                        format!(
                            "at_s must be >= 0 and not earlier than the one before, got {}",
                            s.at_s
                        ),
                    ));
                }
                if !s.position_m.is_finite() || !in_travel(s.position_m) {
                    return Err(bad(
                        &key,
                        format!(
                            "position_m {} lies outside the position limits",
                            s.position_m
                        ),
                    ));
                }
                last = s.at_s;
            }
        }
        Ok(())
    }
}

/// Persistence in cycles for a time, at least one cycle.
pub fn cycles(time_s: f64, period_s: f64) -> u32 {
    ((time_s / period_s).round() as u32).max(1)
}

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
}
