//! The configuration of an axis whose actuator node is a standard device (`profile = "cia402"`
//! or `"cia401"`): scaling, which channel carries what, and the PDO layout the daemon gives
//! the node at start-up.

use super::config::{AxisConfig, CommandKind};
use crate::device::profile::cia401::{self, Scaling};
use crate::device::profile::cia402::{self, Mode};
use crate::device::profile::mapping::{Direction, MappedObject, Pdo};
use crate::param::{Declared, ParamError, COMMAND_UNIT};

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

crate::declare_section! {
    /// `[axis.cia402]`: the drive's units in SI.
    pub struct Cia402Section {
        /// Position actual value 6064h: m (rad on a rotary axis) per increment.
        position_m_per_inc: f64 = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "position actual value 6064h per increment", words: "finite and non-zero",
            nonzero: true,
        },
        /// Velocity actual value 606Ch and target velocity 60FFh: m/s (rad/s) per unit.
        velocity_m_per_s_per_unit: f64 = {
            unit: "m/s", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "velocity 606Ch and 60FFh per unit", words: "finite and non-zero",
            nonzero: true,
        },
        /// DC link circuit voltage 6079h: V per unit (CiA 402 gives mV).
        dc_link_v_per_unit: f64 = {
            unit: "V", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "DC link circuit voltage 6079h per unit", words: "finite and non-zero",
            nonzero: true, default: 1e-3,
        },
        /// Motor rated torque 6076h in N·m (N on a linear motor); absent: read from the drive at
        /// start-up.
        rated_torque_nm: Option<f64> = {
            unit: "N·m", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "motor rated torque 6076h", words: "> 0",
        },
        /// Seconds to wait for the drive's SDO server at start-up.
        startup_timeout_s: f64 = {
            unit: "s", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "wait for the drive's SDO server at start-up", words: "> 0", default: 5.0,
        },
    }
}

crate::declare_section! {
    /// `[axis.cia401]`: which channel is what, and its scaling (SI value = offset + scale ·
    /// count). A channel's scale is checked where the channel is given.
    pub struct Cia401Section {
        /// Analog input (6401h subindex, 1-based) of the position sensor.
        position_input: u8 = {
            unit: "", min: 1.0, max: 254.0, access: Restart,
            doc: "analog input of the position sensor", words: "a channel (subindex) in 1..=254",
        },
        position_m_per_count: f64 = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "position per count", words: "finite and non-zero", nonzero: true,
        },
        position_offset_m: f64 = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "position at count 0", default: 0.0,
        },
        /// Analog input of the coil current, if wired.
        current_input: Option<u8> = {
            unit: "", min: 1.0, max: 254.0, access: Restart,
            doc: "analog input of the coil current", words: "a channel (subindex) in 1..=254",
        },
        current_a_per_count: f64 = {
            unit: "A", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "current per count", default: 0.0,
        },
        /// Analog input of the supply (voltage for `command = "voltage"`, pressure for `"duty"`).
        supply_input: Option<u8> = {
            unit: "", min: 1.0, max: 254.0, access: Restart,
            doc: "analog input of the supply", words: "a channel (subindex) in 1..=254",
        },
        /// V (or Pa) per count.
        supply_per_count: f64 = {
            unit: "V", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "supply per count", default: 0.0,
        },
        /// Analog output (6411h subindex) carrying the command.
        command_output: u8 = {
            unit: "", min: 1.0, max: 254.0, access: Restart,
            doc: "analog output carrying the command", words: "a channel (subindex) in 1..=254",
        },
        /// V (or duty) per count.
        command_per_count: f64 = {
            unit: COMMAND_UNIT, min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "command per count", words: "finite and non-zero", nonzero: true,
        },
        command_offset: f64 = {
            unit: COMMAND_UNIT, min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "command at count 0", default: 0.0,
        },
        /// Seconds to wait for the module's SDO server at start-up.
        startup_timeout_s: f64 = {
            unit: "s", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "wait for the module's SDO server at start-up", words: "> 0", default: 5.0,
        },
    }
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

/// The rules of the profile keys: a section's own ranges from its declaration, and the rules
/// between keys; `Err((key, rule))`.
pub fn check(axis: &AxisConfig) -> Result<(), (String, String)> {
    let err = |k: &str, r: String| Err((k.to_string(), r));
    // The axis' keys these rules name, from the declaration.
    const COMMAND: &str = crate::param_key!(AxisConfig, command);
    const CIA402: &str = crate::param_key!(AxisConfig, cia402);
    const CIA401: &str = crate::param_key!(AxisConfig, cia401);
    const EDS: &str = crate::param_key!(AxisConfig, eds);
    let within = |section: &str| {
        let section = section.to_string();
        move |e: ParamError| (format!("{section}.{}", e.name), e.reason)
    };
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
            d.check().map_err(within(CIA402))?;
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
            io.check().map_err(within(CIA401))?;
            // A wired channel needs its scale, and each input carries one quantity.
            let mut used = vec![io.position_input];
            for (key, ch, scale_key, scale) in [
                (
                    crate::param_key!(Cia401Section, current_input),
                    io.current_input,
                    crate::param_key!(Cia401Section, current_a_per_count),
                    io.current_a_per_count,
                ),
                (
                    crate::param_key!(Cia401Section, supply_input),
                    io.supply_input,
                    crate::param_key!(Cia401Section, supply_per_count),
                    io.supply_per_count,
                ),
            ] {
                if let Some(ch) = ch {
                    if scale == 0.0 {
                        return err(
                            &format!("{CIA401}.{scale_key}"),
                            format!("must be finite and non-zero, got {scale}"),
                        );
                    }
                    if used.contains(&ch) {
                        return err(
                            &format!("{CIA401}.{key}"),
                            format!("analog input {ch} is already used"),
                        );
                    }
                    used.push(ch);
                }
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
