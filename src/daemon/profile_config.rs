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
        /// A CiA 402 servo drive in cyclic synchronous torque (`command = "torque"`), velocity
        /// (`command = "velocity"`) or position (`command = "position"`, with homing) mode.
        Cia402 = cia402,
        /// A CiA 401 I/O module: analog inputs for position, current and supply, an analog
        /// output for the command.
        Cia401 = cia401,
    }
}

crate::declare_choice! {
    /// What a CiA 402 drive does when it loses the daemon's heartbeat: its abort connection
    /// option code 6007h (CiA 402 §6.3.1).
    pub enum AbortConnectionOption {
        /// 0: nothing; the drive runs on with its last target.
        NoAction = no_action,
        /// 1: a fault of the drive (fault reaction, then "fault"; a fault reset brings it back).
        Fault = fault,
        /// 2: the command "disable voltage": the power stage off at once, the axis coasts.
        DisableVoltage = disable_voltage,
        /// 3: the command "quick stop": the drive stops on its quick stop ramp, then as its
        /// quick stop option code 605Ah says.
        QuickStop = quick_stop,
    }
}

impl AbortConnectionOption {
    /// The value of 6007h.
    pub fn code(self) -> i16 {
        use crate::device::profile::cia402::abort_connection as c;
        match self {
            AbortConnectionOption::NoAction => c::NO_ACTION,
            AbortConnectionOption::Fault => c::FAULT,
            AbortConnectionOption::DisableVoltage => c::DISABLE_VOLTAGE,
            AbortConnectionOption::QuickStop => c::QUICK_STOP,
        }
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
        /// Acceleration unit of 609Ah, 6084h and 6085h: m/s² (rad/s²) per unit; absent: the
        /// velocity unit per second, as CiA 402 drives commonly count it.
        acceleration_m_per_s2_per_unit: Option<f64> = {
            unit: "m/s²", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "acceleration 609Ah, 6084h, 6085h per unit", words: "> 0",
        },
        /// What the drive does when the daemon's heartbeat stops (6007h, written at start-up).
        abort_connection_option: AbortConnectionOption = {
            unit: "", access: Restart, doc: "abort connection option code 6007h",
            default: AbortConnectionOption::QuickStop,
        },
        /// Quick stop option code 605Ah, written at start-up: how the drive stops on the
        /// command "quick stop" (a `quick_stop` fault reaction, or 6007h = quick_stop). 1/5 on
        /// the profile deceleration 6084h, 2/6 on the quick stop deceleration 6085h; 1/2 then
        /// switch the power stage off, 5/6 hold in "quick stop active"; 0 switches off at once,
        /// 3/4/7/8 stop on the current or voltage limit. Absent: the drive's own value.
        quick_stop_option_code: Option<i32> = {
            unit: "", min: 0.0, max: 8.0, access: Restart,
            doc: "quick stop option code 605Ah", words: "a CiA 402 option code in 0..=8",
        },
        /// Quick stop deceleration 6085h, written at start-up; absent: the drive's own value.
        quick_stop_deceleration_m_per_s2: Option<f64> = {
            unit: "m/s²", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "quick stop deceleration 6085h", words: "> 0",
        },
        /// Profile deceleration 6084h, written at start-up: the ramp of a `halt` (and of quick
        /// stop option codes 1 and 5); absent: the drive's own value.
        profile_deceleration_m_per_s2: Option<f64> = {
            unit: "m/s²", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "profile deceleration 6084h", words: "> 0",
        },
        /// Homing at start-up (`command = "position"`).
        homing: Option<HomingSection> = { unit: "", access: Restart, doc: "" },
    }
}

crate::declare_section! {
    /// `[axis.cia402.homing]`: how the drive finds its home point at start-up, before the
    /// axis is enabled for motion.
    pub struct HomingSection {
        /// Homing method 6098h (CiA 402: 1/2 limit switch and index pulse, 17/18 limit switch,
        /// 33/34 index pulse, 35/37 current position, ...); the drive checks that it has it.
        method: i32 = {
            unit: "", min: -128.0, max: 127.0, access: Restart,
            doc: "homing method 6098h", words: "a method number in -128..=127",
        },
        /// 6099h sub 1: speed during the search for the switch.
        speed_switch_m_per_s: f64 = {
            unit: "m/s", min: 0.0, max: f64::MAX, access: Restart,
            doc: "homing speed 6099h sub 1, search for the switch", words: ">= 0",
            default: 0.01,
        },
        /// 6099h sub 2: speed during the search for zero (the switch edge, the index pulse).
        speed_zero_m_per_s: f64 = {
            unit: "m/s", min: 0.0, max: f64::MAX, access: Restart,
            doc: "homing speed 6099h sub 2, search for zero", words: ">= 0", default: 0.002,
        },
        /// 609Ah.
        acceleration_m_per_s2: f64 = {
            unit: "m/s²", min: 0.0, max: f64::MAX, access: Restart,
            doc: "homing acceleration 609Ah", words: ">= 0", default: 0.5,
        },
        /// Home offset 607Ch: the application's zero lies this far beyond the home point, so
        /// the home point reads minus this once homed.
        offset_m: f64 = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "home offset 607Ch", default: 0.0,
        },
        /// Homing not attained in this time is a fault of the axis.
        timeout_s: f64 = {
            unit: "s", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "homing must be attained within", words: "> 0", default: 30.0,
        },
        /// The axis is not enabled for motion before it is homed, and a failed homing is its
        /// fault; `false`: a failed homing is reported and the axis runs unhomed.
        require_homing: bool = {
            unit: "", access: Restart, doc: "no motion before homing is attained",
            default: true,
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
        CommandKind::Position => Some(Mode::CyclicSynchronousPosition),
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
        ProfileKind::Cia402
            if drive_mode(axis.command) == Some(Mode::CyclicSynchronousPosition) =>
        {
            // The mode travels with the target, so homing and CSP follow each other in the
            // cycle; the torque actual value is left out (the daemon does not read it).
            vec![
                Pdo::sync(
                    Direction::Receive,
                    1,
                    0x200 + n,
                    &[
                        MappedObject::new(cia402::CONTROLWORD, 0, 16),
                        MappedObject::new(cia402::TARGET_POSITION, 0, 32),
                        MappedObject::new(cia402::MODES_OF_OPERATION, 0, 8),
                    ],
                ),
                Pdo::disabled(Direction::Receive, 2, 0x300 + n),
                Pdo::sync(
                    Direction::Transmit,
                    1,
                    0x180 + n,
                    &[
                        MappedObject::new(cia402::STATUSWORD, 0, 16),
                        MappedObject::new(cia402::POSITION_ACTUAL, 0, 32),
                        MappedObject::new(cia402::MODES_OF_OPERATION_DISPLAY, 0, 8),
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
    // A drive stop fits a CiA 402 drive only; the first such reaction is named.
    if axis.profile != ProfileKind::Cia402 {
        if let Some((fault, reaction)) = axis.fault_reactions.as_ref().and_then(|r| r.drive_stop())
        {
            return err(
                &format!(
                    "{}.{}",
                    crate::param_key!(AxisConfig, fault_reactions),
                    fault.name()
                ),
                format!(
                    "= \"{}\" is a stop a CiA 402 drive makes (controlword 6040h): this axis' node is profile = \"{}\"",
                    reaction.name(),
                    axis.profile.name()
                ),
            );
        }
    }
    let drive_command = matches!(
        axis.command,
        CommandKind::Torque | CommandKind::Velocity | CommandKind::Position
    );
    match axis.profile {
        ProfileKind::Actuatord => {
            if drive_command {
                return err(
                    COMMAND,
                    "\"torque\", \"velocity\" and \"position\" are CiA 402 drive commands: set profile = \"cia402\""
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
                    "a CiA 402 drive is commanded with \"torque\" (CST), \"velocity\" (CSV) or \"position\" (CSP)"
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
            const HOMING: &str = crate::param_key!(Cia402Section, homing);
            if let Some(h) = &d.homing {
                if axis.command != CommandKind::Position {
                    return err(
                        &format!("{CIA402}.{HOMING}"),
                        "homes a drive in position mode: set command = \"position\"".into(),
                    );
                }
                h.check().map_err(within(&format!("{CIA402}.{HOMING}")))?;
            }
            if axis.command == CommandKind::Position {
                check_position_axis(axis)?;
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

/// A position axis' drive closes the loop: the sections that model or shape a force command do
/// not fit it.
fn check_position_axis(axis: &AxisConfig) -> Result<(), (String, String)> {
    for (key, given) in [
        (
            crate::param_key!(AxisConfig, friction_compensation),
            axis.friction_compensation.is_some(),
        ),
        (
            crate::param_key!(AxisConfig, adaptive_friction),
            axis.adaptive_friction.is_some(),
        ),
        (crate::param_key!(AxisConfig, dither), axis.dither.is_some()),
        (
            crate::param_key!(AxisConfig, correction),
            axis.correction.is_some(),
        ),
        (
            crate::param_key!(AxisConfig, pneumatic_adaptive),
            axis.pneumatic_adaptive.is_some(),
        ),
        (
            crate::param_key!(AxisConfig, observer),
            axis.observer.is_some(),
        ),
        (
            crate::param_key!(AxisConfig, parameter_estimation),
            axis.parameter_estimation.is_some(),
        ),
        (
            crate::param_key!(AxisConfig, learned_table),
            axis.learned_table.is_some(),
        ),
    ] {
        if given {
            return Err((
                key.to_string(),
                "models or shapes a force command; with command = \"position\" the drive closes the loop: leave it out".into(),
            ));
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
