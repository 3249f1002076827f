//! The configuration of an axis whose actuator node is a standard device (`profile = "cia402"`
//! or `"cia401"`): scaling, which channel carries what, and the PDO layout the daemon gives
//! the node at start-up.

use super::config::{AxisConfig, CommandKind};
use crate::device::profile::cia401::{self, Scaling};
use crate::device::profile::cia402::{self, Mode};
use crate::device::profile::mapping::{Direction, MappedObject, Pdo};
use serde::Deserialize;

crate::declare_choice! {
    /// What the axis' actuator node speaks.
    pub enum ProfileKind {
        /// Our own frames (`actuator sim`, or firmware written to `dbc/actuatord.dbc`).
        Actuatord = actuatord,
        /// A CiA 402 servo drive in cyclic synchronous torque (`command = "torque"`) or velocity
        /// (`command = "velocity"`) mode.
        Cia402 = cia402,
        /// A CiA 401 I/O module: analog inputs for position, current and supply, an analog
        /// output for the command.
        Cia401 = cia401,
    }
}

/// `[axis.cia402]`: the drive's units in SI.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Cia402Section {
    /// Position actual value 6064h: m (rad on a rotary axis) per increment.
    pub position_m_per_inc: f64,
    /// Velocity actual value 606Ch and target velocity 60FFh: m/s (rad/s) per unit.
    pub velocity_m_per_s_per_unit: f64,
    /// DC link circuit voltage 6079h: V per unit (CiA 402 gives mV).
    #[serde(default = "millivolt")]
    pub dc_link_v_per_unit: f64,
    /// Motor rated torque 6076h in N·m (N on a linear motor); absent: read from the drive at
    /// start-up.
    pub rated_torque_nm: Option<f64>,
    /// Seconds to wait for the drive's SDO server at start-up.
    #[serde(default = "startup_timeout")]
    pub startup_timeout_s: f64,
}

fn millivolt() -> f64 {
    1e-3
}

fn startup_timeout() -> f64 {
    5.0
}

/// `[axis.cia401]`: which channel is what, and its scaling (SI value = offset + scale · count).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Cia401Section {
    /// Analog input (6401h subindex, 1-based) of the position sensor.
    pub position_input: u8,
    pub position_m_per_count: f64,
    #[serde(default)]
    pub position_offset_m: f64,
    /// Analog input of the coil current, if wired.
    pub current_input: Option<u8>,
    #[serde(default)]
    pub current_a_per_count: f64,
    /// Analog input of the supply (voltage for `command = "voltage"`, pressure for `"duty"`).
    pub supply_input: Option<u8>,
    /// V (or Pa) per count.
    #[serde(default)]
    pub supply_per_count: f64,
    /// Analog output (6411h subindex) carrying the command.
    pub command_output: u8,
    /// V (or duty) per count.
    pub command_per_count: f64,
    #[serde(default)]
    pub command_offset: f64,
    /// Seconds to wait for the module's SDO server at start-up.
    #[serde(default = "startup_timeout")]
    pub startup_timeout_s: f64,
}

impl Cia401Section {
    pub fn position(&self) -> Scaling {
        Scaling {
            scale: self.position_m_per_count,
            offset: self.position_offset_m,
        }
    }

    pub fn current(&self) -> Scaling {
        Scaling {
            scale: self.current_a_per_count,
            offset: 0.0,
        }
    }

    pub fn supply(&self) -> Scaling {
        Scaling {
            scale: self.supply_per_count,
            offset: 0.0,
        }
    }

    pub fn command(&self) -> Scaling {
        Scaling {
            scale: self.command_per_count,
            offset: self.command_offset,
        }
    }
}

/// The mode of operation a CiA 402 axis runs in, from its command.
pub fn drive_mode(command: CommandKind) -> Option<Mode> {
    match command {
        CommandKind::Torque => Some(Mode::CyclicSynchronousTorque),
        CommandKind::Velocity => Some(Mode::CyclicSynchronousVelocity),
        _ => None,
    }
}

/// The PDOs the daemon gives a node at start-up: one command RPDO and the feedback TPDOs, all
/// synchronous on every SYNC, on the pre-defined connection set's COB-IDs; the node's other
/// PDO of each kind is switched off so nothing else is sent.
pub fn desired_pdos(axis: &AxisConfig) -> Vec<Pdo> {
    let n = u32::from(axis.actuator_node_id);
    match axis.profile {
        ProfileKind::Actuatord => Vec::new(),
        ProfileKind::Cia402 => {
            let target = match drive_mode(axis.command) {
                Some(Mode::CyclicSynchronousVelocity) => {
                    MappedObject::new(cia402::TARGET_VELOCITY, 0, 32)
                }
                _ => MappedObject::new(cia402::TARGET_TORQUE, 0, 16),
            };
            vec![
                Pdo::sync(
                    Direction::Receive,
                    1,
                    0x200 + n,
                    &[MappedObject::new(cia402::CONTROLWORD, 0, 16), target],
                ),
                Pdo::disabled(Direction::Receive, 2, 0x300 + n),
                Pdo::sync(
                    Direction::Transmit,
                    1,
                    0x180 + n,
                    &[
                        MappedObject::new(cia402::STATUSWORD, 0, 16),
                        MappedObject::new(cia402::POSITION_ACTUAL, 0, 32),
                        MappedObject::new(cia402::TORQUE_ACTUAL, 0, 16),
                    ],
                ),
                Pdo::sync(
                    Direction::Transmit,
                    2,
                    0x280 + n,
                    &[
                        MappedObject::new(cia402::VELOCITY_ACTUAL, 0, 32),
                        MappedObject::new(cia402::DC_LINK_VOLTAGE, 0, 32),
                    ],
                ),
            ]
        }
        ProfileKind::Cia401 => {
            let Some(io) = &axis.cia401 else {
                return Vec::new();
            };
            let mut inputs = vec![MappedObject::new(
                cia401::ANALOG_INPUTS_16,
                io.position_input,
                16,
            )];
            for ch in [io.current_input, io.supply_input].into_iter().flatten() {
                inputs.push(MappedObject::new(cia401::ANALOG_INPUTS_16, ch, 16));
            }
            // CiA 401 puts the analog channels in PDO 2; PDO 1 (digital I/O) is not used.
            vec![
                Pdo::disabled(Direction::Receive, 1, 0x200 + n),
                Pdo::sync(
                    Direction::Receive,
                    2,
                    0x300 + n,
                    &[MappedObject::new(
                        cia401::ANALOG_OUTPUTS_16,
                        io.command_output,
                        16,
                    )],
                ),
                Pdo::disabled(Direction::Transmit, 1, 0x180 + n),
                Pdo::sync(Direction::Transmit, 2, 0x280 + n, &inputs),
            ]
        }
    }
}

/// The rules of the profile keys; `Err((key, rule))`.
pub fn check(axis: &AxisConfig) -> Result<(), (String, String)> {
    let err = |k: &str, r: String| Err((k.to_string(), r));
    let positive = |k: &str, v: f64| {
        if v.is_finite() && v != 0.0 {
            Ok(())
        } else {
            err(k, format!("must be finite and non-zero, got {v}"))
        }
    };
    let channel = |k: &str, v: u8| {
        if (1..=254).contains(&v) {
            Ok(())
        } else {
            err(
                k,
                format!("must be a channel (subindex) in 1..=254, got {v}"),
            )
        }
    };
    // The axis' keys these rules name, from the declaration.
    const COMMAND: &str = crate::param_key!(AxisConfig, command);
    const CIA402: &str = crate::param_key!(AxisConfig, cia402);
    const CIA401: &str = crate::param_key!(AxisConfig, cia401);
    const EDS: &str = crate::param_key!(AxisConfig, eds);
    let drive_command = matches!(axis.command, CommandKind::Torque | CommandKind::Velocity);
    match axis.profile {
        ProfileKind::Actuatord => {
            if drive_command {
                return err(
                    COMMAND,
                    "\"torque\" and \"velocity\" are CiA 402 drive commands: set profile = \"cia402\""
                        .into(),
                );
            }
            for (key, given) in [
                (CIA402, axis.cia402.is_some()),
                (CIA401, axis.cia401.is_some()),
                (EDS, axis.eds.is_some()),
            ] {
                if given {
                    return err(key, "belongs to profile = \"cia402\" or \"cia401\"".into());
                }
            }
        }
        ProfileKind::Cia402 => {
            if !drive_command {
                return err(
                    COMMAND,
                    "a CiA 402 drive is commanded with \"torque\" (CST) or \"velocity\" (CSV)"
                        .into(),
                );
            }
            let Some(d) = &axis.cia402 else {
                return err(CIA402, "is needed with profile = \"cia402\"".into());
            };
            if axis.cia401.is_some() {
                return err(CIA401, "belongs to profile = \"cia401\"".into());
            }
            positive("cia402.position_m_per_inc", d.position_m_per_inc)?;
            positive(
                "cia402.velocity_m_per_s_per_unit",
                d.velocity_m_per_s_per_unit,
            )?;
            positive("cia402.dc_link_v_per_unit", d.dc_link_v_per_unit)?;
            if let Some(t) = d.rated_torque_nm {
                if !(t.is_finite() && t > 0.0) {
                    return err("cia402.rated_torque_nm", format!("must be > 0, got {t}"));
                }
            }
            if !(d.startup_timeout_s.is_finite() && d.startup_timeout_s > 0.0) {
                return err("cia402.startup_timeout_s", "must be > 0".into());
            }
        }
        ProfileKind::Cia401 => {
            if drive_command {
                return err(
                    COMMAND,
                    "a CiA 401 module outputs \"voltage\" or \"duty\"".into(),
                );
            }
            let Some(io) = &axis.cia401 else {
                return err(CIA401, "is needed with profile = \"cia401\"".into());
            };
            if axis.cia402.is_some() {
                return err(CIA402, "belongs to profile = \"cia402\"".into());
            }
            channel("cia401.position_input", io.position_input)?;
            positive("cia401.position_m_per_count", io.position_m_per_count)?;
            channel("cia401.command_output", io.command_output)?;
            positive("cia401.command_per_count", io.command_per_count)?;
            let mut used = vec![io.position_input];
            for (key, ch, scale_key, scale) in [
                (
                    "cia401.current_input",
                    io.current_input,
                    "cia401.current_a_per_count",
                    io.current_a_per_count,
                ),
                (
                    "cia401.supply_input",
                    io.supply_input,
                    "cia401.supply_per_count",
                    io.supply_per_count,
                ),
            ] {
                if let Some(ch) = ch {
                    channel(key, ch)?;
                    positive(scale_key, scale)?;
                    if used.contains(&ch) {
                        return err(key, format!("analog input {ch} is already used"));
                    }
                    used.push(ch);
                }
            }
            if !(io.startup_timeout_s.is_finite() && io.startup_timeout_s > 0.0) {
                return err("cia401.startup_timeout_s", "must be > 0".into());
            }
        }
    }
    Ok(())
}

/// Relative EDS paths are taken from the configuration file's folder.
pub fn resolve_eds(axis: &mut AxisConfig, folder: &std::path::Path) {
    if let Some(f) = axis.eds.as_mut() {
        if f.is_relative() {
            *f = folder.join(&*f);
        }
    }
}
