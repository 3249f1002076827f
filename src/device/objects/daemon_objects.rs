//! The objects of `actuatord` itself: the CiA 301 communication objects it serves and one
//! manufacturer block per axis. Entry names are the config keys and DBC signal names.
//!
//! Layout (see [`index`]):
//!
//! | index | object |
//! |---|---|
//! | 1000h, 1001h, 1003h, 1008h, 100Ah, 1016h, 1017h, 1018h, 1200h | CiA 301 communication objects |
//! | 2000h + 100h·axis + 00h | axis: name, actuator node id, command kind, safe command |
//! | … + 01h | controller: q0..q5, p1..p6, output limits |
//! | … + 02h | friction compensation |
//! | … + 03h | limits (supervision) |
//! | … + 04h | setpoint |
//! | … + 05h | fault state, counters, reset |
//! | … + 06h..09h | intelligent sections (see [`super::axis_intelligence`]) |
//! | … + 10h | learned parameters (results of identification and adaptation, read-only) |
//! | … + 11h | diagnosis: estimates, nominal values, symptoms, observer bands (read-only) |
//! | 2F00h | loop statistics of the cycle (node-wide: one cycle serves every axis) |
//! | 2F01h | the time of each entry of 1003h |
//!
//! The protocol layer does not read the daemon's configuration: the runtime fills
//! [`DeviceParameters`] and [`AxisParameters`] from it, and a tool that only needs the types
//! uses their defaults.

use super::axis_intelligence::{declared_entries, intelligence_objects, IntelligenceParameters};
use super::axis_keys::{AxisKeys, SetpointKeys};
use crate::canopen::od::{
    BuildError, EntrySpec, ObjectDictionary, ObjectDictionaryBuilder, ObjectId, Value,
};
use crate::canopen::ERROR_FIELD_LEN;
use crate::control::{ControllerSection, FrictionCompensationSection};
use crate::supervise::LimitsSection;

/// Manufacturer blocks are 100h apart from 2000h; 2F00h is node-wide, so 15 axes fit.
pub const MAX_AXES: usize = 15;

/// Object indexes of the daemon's dictionary.
pub mod index {
    pub const DEVICE_TYPE: u16 = 0x1000;
    pub const ERROR_REGISTER: u16 = 0x1001;
    pub const PRE_DEFINED_ERROR_FIELD: u16 = 0x1003;
    pub const DEVICE_NAME: u16 = 0x1008;
    pub const SOFTWARE_VERSION: u16 = 0x100A;
    pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
    pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
    pub const IDENTITY: u16 = 0x1018;
    pub const SDO_SERVER_PARAMETER: u16 = 0x1200;

    pub const AXIS_BASE: u16 = 0x2000;
    pub const AXIS_STRIDE: u16 = 0x100;
    /// Offsets inside an axis block.
    pub const AXIS: u16 = 0x00;
    pub const CONTROLLER: u16 = 0x01;
    pub const FRICTION_COMPENSATION: u16 = 0x02;
    pub const LIMITS: u16 = 0x03;
    pub const SETPOINT: u16 = 0x04;
    pub const FAULT: u16 = 0x05;
    pub const LEARNED: u16 = 0x10;

    pub const LOOP_STATISTICS: u16 = 0x2F00;
    pub const ERROR_FIELD_TIME: u16 = 0x2F01;

    /// Index of `offset` in the block of `axis` (0-based).
    pub const fn axis(axis: usize, offset: u16) -> u16 {
        AXIS_BASE + AXIS_STRIDE * axis as u16 + offset
    }

    /// The axis and offset of a manufacturer index, if it is in an axis block.
    pub const fn split(index: u16) -> Option<(usize, u16)> {
        if index < AXIS_BASE || index >= LOOP_STATISTICS {
            return None;
        }
        let rel = index - AXIS_BASE;
        Some(((rel / AXIS_STRIDE) as usize, rel % AXIS_STRIDE))
    }
}

/// Node-wide facts for the communication objects.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceParameters {
    /// The daemon's own node id (SDO COB-IDs are made from it).
    pub node_id: u8,
    pub device_name: String,
    pub software_version: String,
    pub vendor_id: u32,
    pub product_code: u32,
    pub revision_number: u32,
    pub serial_number: u32,
    pub heartbeat_period_s: f64,
}

impl Default for DeviceParameters {
    fn default() -> Self {
        Self {
            node_id: 1,
            device_name: "actuatord".into(),
            software_version: env!("CARGO_PKG_VERSION").into(),
            // No vendor id is registered with CiA for this project: 0 = not assigned.
            vendor_id: 0,
            product_code: 0,
            revision_number: version_number(),
            serial_number: 0,
            heartbeat_period_s: 0.1,
        }
    }
}

/// `major << 16 | minor` of the crate version, for 1018h sub 3.
fn version_number() -> u32 {
    let major: u32 = env!("CARGO_PKG_VERSION_MAJOR").parse().unwrap_or(0);
    let minor: u32 = env!("CARGO_PKG_VERSION_MINOR").parse().unwrap_or(0);
    (major << 16) | (minor & 0xFFFF)
}

crate::declare_choice! {
    /// What the actuator command means (an axis' `command` key); it gives the units of the
    /// entries that carry a command.
    pub enum CommandKind {
        /// Terminal voltage, V (solenoid, motor).
        Voltage = voltage,
        /// Signed valve duty, -1..1, no unit (pneumatic).
        Duty = duty,
        /// Torque in N m, force in N on a linear axis: a CiA 402 drive's target torque (CST).
        Torque = torque,
        /// Velocity in m/s (rad/s on a rotary axis): a CiA 402 drive's target velocity (CSV).
        Velocity = velocity,
        /// Position in m (rad on a rotary axis): a CiA 402 drive's target position (CSP); the
        /// drive closes the position loop, the controller's output is added as a correction.
        Position = position,
    }
}

impl CommandKind {
    /// The `command_kind` entry's code.
    pub fn code(self) -> u8 {
        match self {
            CommandKind::Voltage => 0,
            CommandKind::Duty => 1,
            CommandKind::Torque => 2,
            CommandKind::Velocity => 3,
            CommandKind::Position => 4,
        }
    }

    /// The largest magnitude of a command value: 1 for a duty, 1000 (V, N m, m/s) otherwise.
    pub fn bound(self) -> f64 {
        if self == CommandKind::Duty {
            1.0
        } else {
            1000.0
        }
    }

    /// The unit of a command value.
    pub fn unit(self) -> &'static str {
        match self {
            CommandKind::Voltage => "V",
            CommandKind::Duty => "",
            CommandKind::Torque => "N m",
            CommandKind::Velocity => "m/s",
            CommandKind::Position => "m",
        }
    }

    /// The unit of a controller coefficient: command per m of error.
    pub fn per_m(self) -> &'static str {
        match self {
            CommandKind::Voltage => "V/m",
            CommandKind::Duty => "1/m",
            CommandKind::Torque => "N m/m",
            CommandKind::Velocity => "1/s",
            CommandKind::Position => "m/m",
        }
    }

    /// The unit of the drive's force per command.
    pub fn force_per_command(self) -> &'static str {
        match self {
            CommandKind::Voltage => "N/V",
            CommandKind::Duty => "N",
            CommandKind::Torque => "N/(N m)",
            CommandKind::Velocity => "N s/m",
            CommandKind::Position => "N/m",
        }
    }
}

/// One axis' configured parameters, as the dictionary shows them. A limit that is not
/// configured is infinite (a minimum -inf, a maximum or time +inf): "not watched".
#[derive(Debug, Clone, PartialEq)]
pub struct AxisParameters {
    pub name: String,
    pub actuator_node_id: u8,
    /// What the axis commands: the unit of its command entries.
    pub command: CommandKind,
    /// The writable entries of the axis object, as declared.
    pub keys: AxisKeys,
    pub initial_setpoint_m: f64,
    /// The writable entries of the setpoint object, as declared.
    pub setpoint: SetpointKeys,
    /// `[axis.controller]`: its coefficients and output limits, as declared.
    pub controller: ControllerSection,
    /// `[axis.friction_compensation]`, if configured: its entries, as declared.
    pub friction_compensation: Option<FrictionCompensationSection>,
    /// `[axis.limits]`: its entries, as declared.
    pub limits: LimitsSection,
    pub intelligence: IntelligenceParameters,
}

impl Default for AxisParameters {
    fn default() -> Self {
        Self {
            name: "axis".into(),
            actuator_node_id: 16,
            command: CommandKind::Voltage,
            keys: AxisKeys::defaults()
                .expect("every key of the axis object has a default or may be left out"),
            initial_setpoint_m: 0.0,
            setpoint: SetpointKeys::defaults()
                .expect("every key of the setpoint object has a default or may be left out"),
            controller: ControllerSection::unconfigured(-1.0, 1.0),
            friction_compensation: None,
            limits: LimitsSection::defaults()
                .expect("every key of [axis.limits] has a default or may be left out"),
            intelligence: IntelligenceParameters::default(),
        }
    }
}

const AXIS_NAMES: [&str; MAX_AXES] = [
    "axis0", "axis1", "axis2", "axis3", "axis4", "axis5", "axis6", "axis7", "axis8", "axis9",
    "axis10", "axis11", "axis12", "axis13", "axis14",
];

/// The entries of 1003h after sub 0, newest first.
const ERROR_FIELD_NAMES: [&str; ERROR_FIELD_LEN] = [
    "error_1", "error_2", "error_3", "error_4", "error_5", "error_6", "error_7", "error_8",
    "error_9", "error_10", "error_11", "error_12", "error_13", "error_14", "error_15", "error_16",
];

/// The entries of 2F01h, one per entry of 1003h.
const ERROR_TIME_NAMES: [&str; ERROR_FIELD_LEN] = [
    "time_1", "time_2", "time_3", "time_4", "time_5", "time_6", "time_7", "time_8", "time_9",
    "time_10", "time_11", "time_12", "time_13", "time_14", "time_15", "time_16",
];

/// The pre-defined error field, 1003h, and the time of each of its entries, 2F01h (CiA 301
/// has no place for it): empty at build; the node publishes what it holds.
fn error_field(b: ObjectDictionaryBuilder) -> ObjectDictionaryBuilder {
    let times = ERROR_TIME_NAMES
        .into_iter()
        .map(|name| {
            EntrySpec::ro(name, 0.0f64).unit("s").doc(
                "when the EMCY at the same subindex of 1003h went out: Unix time by the \
                 daemon's wall clock; 0 past the errors held",
            )
        })
        .collect();
    let entries = ERROR_FIELD_NAMES
        .into_iter()
        .map(|name| {
            EntrySpec::ro(name, 0u32).doc(
                "an EMCY the daemon sent, newest at sub 1: error code in bits 0..15, error \
                 register in bits 16..23, axis node id in bits 24..31 (0: the daemon or the bus)",
            )
        })
        .collect();
    b.array_counted(
        index::PRE_DEFINED_ERROR_FIELD,
        "pre_defined_error_field",
        EntrySpec::rw("number_of_errors", 0u8)
            .range(Some(Value::Unsigned8(0)), Some(Value::Unsigned8(0)))
            .doc("errors held (kept across restarts with a state file); write 0 to clear them"),
        entries,
    )
    .array(index::ERROR_FIELD_TIME, "error_history_time", None, times)
}

/// 1016h entry: actuator node id in bits 16..23, time in ms in bits 0..15 (0 = not watched).
pub fn consumer_heartbeat_entry(node_id: u8, timeout_s: f64) -> u32 {
    let ms = if timeout_s.is_finite() && timeout_s > 0.0 {
        (timeout_s * 1000.0).round().clamp(1.0, 65535.0) as u32
    } else {
        0
    };
    (u32::from(node_id) << 16) | ms
}

/// Build the dictionary of the daemon for `device` and `axes` (at most [`MAX_AXES`]).
///
/// Errors only if a configured value lies outside the bounds of its object or there are too
/// many axes, i.e. the configuration and the table disagree.
pub fn daemon_dictionary(
    device: &DeviceParameters,
    axes: &[AxisParameters],
) -> Result<ObjectDictionary, BuildError> {
    if axes.len() > MAX_AXES {
        return Err(BuildError::BadEntry {
            id: ObjectId::new(index::axis(MAX_AXES, 0), 0),
            name: "axis",
            problem: format!("at most {MAX_AXES} axes, got {}", axes.len()),
        });
    }
    let text = |name: &'static str, s: &str| {
        Value::string(s).ok_or_else(|| BuildError::BadEntry {
            id: ObjectId::new(0, 0),
            name,
            problem: format!("{s:?} is not printable ASCII of at most 64 bytes"),
        })
    };
    let heartbeat_ms = (device.heartbeat_period_s * 1000.0)
        .round()
        .clamp(1.0, 65535.0) as u16;
    let sdo_rx = 0x600 + u32::from(device.node_id);
    let sdo_tx = 0x580 + u32::from(device.node_id);
    let mut b = ObjectDictionary::builder()
        .var(
            index::DEVICE_TYPE,
            EntrySpec::ro("device_type", 0u32)
                .doc("CiA 301 1000h; 0: no standard device profile"),
        )
        .var(
            index::ERROR_REGISTER,
            EntrySpec::ro("error_register", 0u8)
                .pdo()
                .doc("CiA 301 1001h; bit 0 generic, 1 current, 2 voltage, 4 communication, 7 manufacturer"),
        )
        .var(
            index::DEVICE_NAME,
            EntrySpec::ro(
                "manufacturer_device_name",
                text("manufacturer_device_name", &device.device_name)?,
            ),
        )
        .var(
            index::SOFTWARE_VERSION,
            EntrySpec::ro(
                "manufacturer_software_version",
                text("manufacturer_software_version", &device.software_version)?,
            ),
        )
        .var(
            index::PRODUCER_HEARTBEAT_TIME,
            EntrySpec::rw("producer_heartbeat_time", heartbeat_ms)
                .unit("ms")
                .range(Some(Value::Unsigned16(1)), None)
                .doc("period of the daemon's heartbeat (heartbeat_period_s)"),
        )
        .record(
            index::IDENTITY,
            "identity",
            None,
            vec![
                EntrySpec::ro("vendor_id", device.vendor_id),
                EntrySpec::ro("product_code", device.product_code),
                EntrySpec::ro("revision_number", device.revision_number)
                    .doc("major << 16 | minor of the software version"),
                EntrySpec::ro("serial_number", device.serial_number),
            ],
        )
        .record(
            index::SDO_SERVER_PARAMETER,
            "sdo_server_parameter",
            None,
            vec![
                EntrySpec::ro("cob_id_client_to_server", sdo_rx),
                EntrySpec::ro("cob_id_server_to_client", sdo_tx),
            ],
        );
    b = error_field(b);
    if !axes.is_empty() {
        let entries = axes
            .iter()
            .enumerate()
            .map(|(i, a)| {
                EntrySpec::ro(
                    AXIS_NAMES[i],
                    consumer_heartbeat_entry(
                        a.actuator_node_id,
                        a.limits.heartbeat_timeout_s.unwrap_or(f64::INFINITY),
                    ),
                )
                .doc("actuator node id << 16 | heartbeat timeout in ms (0 = not watched); mirrors limits.heartbeat_timeout_s, write that one")
            })
            .collect();
        b = b.array(
            index::CONSUMER_HEARTBEAT_TIME,
            "consumer_heartbeat_time",
            None,
            entries,
        );
    }
    for (i, a) in axes.iter().enumerate() {
        b = axis_objects(b, i, a)?;
    }
    b = b.record(
        index::LOOP_STATISTICS,
        "loop_statistics",
        None,
        vec![
            EntrySpec::ro("cycles", 0u32).doc("cycles run since start (wraps)"),
            EntrySpec::ro("overruns", 0u32).doc("cycles that missed their deadline (wraps)"),
            EntrySpec::ro("frames_malformed", 0u32)
                .doc("frames with a known id but a wrong length or value (wraps)"),
            EntrySpec::ro("frames_unknown", 0u32).doc("frames with an id nobody here uses (wraps)"),
            EntrySpec::ro("bus_errors", 0u32).doc("CAN error frames (wraps)"),
            EntrySpec::ro("cycle_latency_max_us", 0u32)
                .unit("us")
                .doc("largest delay from cycle start to command sent, since start"),
            EntrySpec::ro("cycle_latency_p99_us", 0u32)
                .unit("us")
                .doc("99th percentile of that delay over the last statistics window"),
            EntrySpec::ro("wake_latency_max_us", 0u32)
                .unit("us")
                .doc("largest delay from release time to wake-up, since start"),
            EntrySpec::ro("bus_faults", 0u32).doc(
                "bus faults since start: interface down or gone, bus-off, error passive, ... (wraps)",
            ),
            EntrySpec::ro("bus_lost_cycles", 0u32)
                .doc("cycles run while the bus could not carry frames (wraps)"),
        ],
    );
    b.build()
}

fn axis_objects(
    b: ObjectDictionaryBuilder,
    i: usize,
    a: &AxisParameters,
) -> Result<ObjectDictionaryBuilder, BuildError> {
    let at = |offset| index::axis(i, offset);
    let axis = Some(i);
    let cu = a.command.unit();
    let name = Value::string(&a.name).ok_or_else(|| BuildError::BadEntry {
        id: ObjectId::new(at(index::AXIS), 1),
        name: "axis_name",
        problem: format!("{:?} is not printable ASCII of at most 64 bytes", a.name),
    })?;
    // The entries of the axis itself that are not its keys: read-only, and named apart from
    // the keys they show (`name`, `command`) or live (the setpoint).
    let mut own = vec![
        EntrySpec::ro("axis_name", name),
        EntrySpec::ro("actuator_node_id", a.actuator_node_id),
        EntrySpec::ro("command_kind", a.command.code())
            .doc("0 voltage (V), 1 signed valve duty (-1..1), 2 torque (N m), 3 velocity (m/s)"),
    ];
    own.extend(declared_entries(&a.keys, a.command));
    let mut setpoint = vec![EntrySpec::rw("setpoint_position", a.initial_setpoint_m)
        .unit("m")
        .between(
            a.limits.position_min_m.unwrap_or(f64::NEG_INFINITY),
            a.limits.position_max_m.unwrap_or(f64::INFINITY),
        )
        .pdo()
        .doc("position setpoint, a setpoint frame overrides it")];
    setpoint.extend(declared_entries(&a.setpoint, a.command));
    let controller = declared_entries(&a.controller, a.command);
    let limits = declared_entries(&a.limits, a.command);
    let learned = vec![
        EntrySpec::ro("friction_compensation", 0.0f64)
            .unit(cu)
            .doc("friction compensation command in use"),
        EntrySpec::ro("gain_schedule_factor", 1.0f64)
            .doc("controller gain factor from the supply schedule"),
        EntrySpec::ro("friction_compensation_pos", 0.0f64)
            .unit(cu)
            .doc("adapted friction compensation for motion in + direction"),
        EntrySpec::ro("friction_compensation_neg", 0.0f64)
            .unit(cu)
            .doc("adapted friction compensation for motion in - direction"),
        EntrySpec::ro("drive_gain_down", 0.0f64)
            .unit("m/s")
            .doc("drive gain K_I1 in use (estimated when adapting, scheduled otherwise)"),
        EntrySpec::ro("drive_gain_up", 0.0f64)
            .unit("m/s")
            .doc("drive gain K_I2 in use (estimated when adapting, scheduled otherwise)"),
        EntrySpec::ro("observer_x4_pos", 0.0f64)
            .unit("m")
            .doc("observer disturbance state x4 learned for motion in + direction"),
        EntrySpec::ro("observer_x4_neg", 0.0f64)
            .unit("m")
            .doc("observer disturbance state x4 learned for motion in - direction"),
    ];
    let mut friction = vec![EntrySpec::rw_preop(
        "enabled",
        a.friction_compensation.is_some(),
    )];
    let neutral = FrictionCompensationSection::neutral();
    friction.extend(declared_entries(
        a.friction_compensation.as_ref().unwrap_or(&neutral),
        a.command,
    ));
    let b = intelligence_objects(b, i, at, &a.intelligence, a.command);
    Ok(b
        .record(at(index::AXIS), format!("axis{i}"), axis, own)
        .record(
            at(index::CONTROLLER),
            format!("axis{i}_controller"),
            axis,
            controller,
        )
        .ordered(
            ObjectId::new(at(index::CONTROLLER), 13),
            ObjectId::new(at(index::CONTROLLER), 14),
        )
        .record(
            at(index::FRICTION_COMPENSATION),
            format!("axis{i}_friction_compensation"),
            axis,
            friction,
        )
        .record(
            at(index::LIMITS),
            format!("axis{i}_limits"),
            axis,
            limits,
        )
        .ordered(
            ObjectId::new(at(index::LIMITS), 3),
            ObjectId::new(at(index::LIMITS), 4),
        )
        .ordered(
            ObjectId::new(at(index::LIMITS), 7),
            ObjectId::new(at(index::LIMITS), 8),
        )
        .ordered(
            ObjectId::new(at(index::LIMITS), 9),
            ObjectId::new(at(index::LIMITS), 10),
        )
        .record(
            at(index::SETPOINT),
            format!("axis{i}_setpoint"),
            axis,
            setpoint,
        )
        .record(
            at(index::FAULT),
            format!("axis{i}_fault"),
            axis,
            vec![
                EntrySpec::ro("fault_state", 0u8)
                    .pdo()
                    .doc("0 ok, 1 warning, 2 fault (latched, axis in safe state)"),
                EntrySpec::ro("fault_flags", 0u16)
                    .pdo()
                    .doc("latched faults, bit 0 first: following_error, end_of_range, overcurrent, supply_voltage, supply_pressure, sensor_timeout, heartbeat_lost, node_state"),
                EntrySpec::ro("faults_raised", 0u32).doc("faults raised since start (wraps)"),
                EntrySpec::ro("sensor_missed", 0u32)
                    .doc("cycles without a sensor frame in time (wraps)"),
                EntrySpec::wo("fault_reset", false)
                    .doc("write true to reset the latched faults of this axis"),
            ],
        )
        .record(
            at(index::LEARNED),
            format!("axis{i}_learned"),
            axis,
            learned,
        ))
}
