//! A simulated standard node in front of a plant: a CiA 402 drive (cyclic synchronous torque,
//! velocity or position, and homing) or a CiA 401 analog I/O module. Its object dictionary is served over SDO, its PDO
//! communication and mapping parameters follow CiA 301 (written by SDO, checked with the
//! standard's abort codes), and its PDOs carry whatever is mapped. Sans-I/O.

use crate::bus::Frame;
use crate::canopen::heartbeat::{HeartbeatConsumer, CONSUMER_HEARTBEAT_TIME};
use crate::canopen::od::{EntrySpec, ObjectDictionary, ObjectId};
use crate::canopen::sdo::{self, AbortCode, SdoServer};
use crate::canopen::{DataType, EmcyFrame, NmtState, Value};
use crate::device::profile::cia401::{self, Scaling};
use crate::device::profile::cia402::{self, DriveStateMachine, Mode, State};
use crate::device::profile::mapping::{
    abort, Direction, MappedObject, Pdo, COB_ID_INVALID, TRANSMISSION_EVENT_PROFILE,
};
use crate::physics::Plant;
use std::str::FromStr;

pub mod homing;
use homing::{Homing, HomingParameters, HomingStatus};
pub mod stop;
use stop::{StopRamp, QUICK_STOP_OPTIONS, STANDSTILL_M_PER_S};
mod watchdog;

/// Which standard the node speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Profile {
    /// A servo drive after CiA 402.
    Cia402,
    /// An analog I/O module after CiA 401.
    Cia401,
}

impl std::fmt::Display for Profile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Profile::Cia402 => "cia402",
            Profile::Cia401 => "cia401",
        })
    }
}

impl FromStr for Profile {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "cia402" => Ok(Profile::Cia402),
            "cia401" => Ok(Profile::Cia401),
            other => Err(format!(
                "unknown profile {other:?}, expected cia402 or cia401"
            )),
        }
    }
}

/// The simulated drive's units: position actual value in µm (µrad on a rotary axis).
pub const DRIVE_POSITION_UNIT: f64 = 1e-6;
/// Velocity actual value and target velocity in µm/s (µrad/s).
pub const DRIVE_VELOCITY_UNIT: f64 = 1e-6;
/// 6076h of the simulated drive: 100 N·m (100 N on a linear axis), in mN·m.
pub const DRIVE_RATED_TORQUE_MNM: u32 = 100_000;
/// The simulated I/O module's wiring: analog input 1 is the position, 1 µm per count.
pub const IO_POSITION: Scaling = Scaling {
    scale: 1e-6,
    offset: 0.0,
};
/// Analog input 2: the coil current, 1 mA per count.
pub const IO_CURRENT: Scaling = Scaling {
    scale: 1e-3,
    offset: 0.0,
};
/// Analog input 3: the supply voltage, 1 mV per count (100 Pa per count on a pneumatic plant).
pub const IO_SUPPLY_VOLTAGE: Scaling = Scaling {
    scale: 1e-3,
    offset: 0.0,
};
pub const IO_SUPPLY_PRESSURE: Scaling = Scaling {
    scale: 100.0,
    offset: 0.0,
};
/// Analog output 1: the command, 1 mV per count (1e-4 duty per count on a pneumatic plant).
pub const IO_COMMAND_VOLTAGE: Scaling = Scaling {
    scale: 1e-3,
    offset: 0.0,
};
pub const IO_COMMAND_DUTY: Scaling = Scaling {
    scale: 1e-4,
    offset: 0.0,
};

/// Velocity loop of the simulated drive in CSV (force per velocity error, per its integral).
const VELOCITY_KP: f64 = 200.0;
const VELOCITY_KI: f64 = 2000.0;
/// Position loop of the simulated drive in CSP and homing, around the velocity loop
/// (velocity per position error; the velocity loop's integral holds the load).
const POSITION_KP: f64 = 80.0;
/// The load the drive's stop is tuned for, kg (kg·m² on a rotary axis): the built-in plant's
/// carriage.
const DRIVE_LOAD_MASS_KG: f64 = 1.0;
/// The drive's acceleration units (609Ah): µm/s² (µrad/s²).
pub const DRIVE_ACCELERATION_UNIT: f64 = 1e-6;

/// A drive fault to raise at a plant time, e.g. `0x4310@2s` (over-temperature at 2 s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveFault {
    pub error_code: u16,
    pub at_s: f64,
}

impl FromStr for DriveFault {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (code, at) = s
            .split_once('@')
            .ok_or_else(|| format!("drive fault {s:?}: expected CODE@TIME, e.g. 0x4310@2s"))?;
        let code = code.trim();
        let error_code = code
            .strip_prefix("0x")
            .or_else(|| code.strip_prefix("0X"))
            .and_then(|h| u16::from_str_radix(h, 16).ok())
            .filter(|c| *c != 0)
            .ok_or_else(|| format!("drive fault {s:?}: code must be hex, non-zero, e.g. 0x4310"))?;
        let at = at.trim();
        let at_s = if let Some(ms) = at.strip_suffix("ms") {
            ms.parse::<f64>().map(|v| v * 1e-3)
        } else {
            at.trim_end_matches('s').parse::<f64>()
        }
        .ok()
        .filter(|t| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| format!("drive fault {s:?}: time must be like 2s or 500ms"))?;
        Ok(Self { error_code, at_s })
    }
}

const MAPPING_NAMES: [&str; 8] = [
    "mapped_object_1",
    "mapped_object_2",
    "mapped_object_3",
    "mapped_object_4",
    "mapped_object_5",
    "mapped_object_6",
    "mapped_object_7",
    "mapped_object_8",
];

/// The PDO parameter objects (1400h.., 1600h.., 1800h.., 1A00h..) with their factory values.
fn pdo_objects(
    mut b: crate::canopen::od::ObjectDictionaryBuilder,
    pdos: &[Pdo],
) -> crate::canopen::od::ObjectDictionaryBuilder {
    for pdo in pdos {
        let (comm_name, map_name) = match pdo.direction {
            Direction::Receive => ("rpdo_communication", "rpdo_mapping"),
            Direction::Transmit => ("tpdo_communication", "tpdo_mapping"),
        };
        b = b.record(
            pdo.communication_index(),
            format!("{comm_name}_{}", pdo.number),
            None,
            vec![
                EntrySpec::rw("cob_id", pdo.cob_id_entry())
                    .doc("COB-ID; bit 31 set: the PDO is not valid"),
                EntrySpec::rw("transmission_type", pdo.transmission_type)
                    .doc("0..240 synchronous, 254/255 event-driven"),
            ],
        );
        let mut entries = Vec::new();
        for (i, name) in MAPPING_NAMES.iter().enumerate() {
            let v = pdo.objects.get(i).map_or(0, |o| o.to_u32());
            entries
                .push(EntrySpec::rw(name, v).doc("index (31..16), subindex (15..8), bits (7..0)"));
        }
        b = b.record_counted(
            pdo.mapping_index(),
            format!("{map_name}_{}", pdo.number),
            EntrySpec::rw("number_of_mapped_objects", pdo.objects.len() as u8)
                .range(Some(Value::Unsigned8(0)), Some(Value::Unsigned8(8)))
                .doc("written 0 before changing the entries, then their number"),
            entries,
        );
    }
    b
}

fn identity(
    b: crate::canopen::od::ObjectDictionaryBuilder,
    device_type: u32,
    product: u32,
) -> crate::canopen::od::ObjectDictionaryBuilder {
    b.var(0x1000, EntrySpec::ro("device_type", device_type))
        .var(0x1001, EntrySpec::ro("error_register", 0u8).pdo())
        .record(
            0x1018,
            "identity",
            None,
            vec![
                EntrySpec::ro("vendor_id", 0u32),
                EntrySpec::ro("product_code", product),
                EntrySpec::ro("revision_number", 1u32),
                EntrySpec::ro("serial_number", 1u32),
            ],
        )
}

/// The consumer heartbeat time 1016h with one entry, unused at power-on (CiA 301 §7.5.2.4).
fn heartbeat_consumer(
    b: crate::canopen::od::ObjectDictionaryBuilder,
) -> crate::canopen::od::ObjectDictionaryBuilder {
    b.array(
        CONSUMER_HEARTBEAT_TIME,
        "consumer_heartbeat_time",
        None,
        vec![EntrySpec::rw("consumer_heartbeat_time_1", 0u32)
            .doc("producer node-ID (23..16), time in ms (15..0); 0: not watched")],
    )
}

/// The drive's factory mapping: RPDO1 the controlword, TPDO1 the statusword (CiA 402
/// §12.1.1's first PDOs), both event-driven; PDO 2 not used.
fn drive_factory_pdos(node: u8) -> Vec<Pdo> {
    let n = u32::from(node);
    let mut r1 = Pdo::sync(
        Direction::Receive,
        1,
        0x200 + n,
        &[MappedObject::new(cia402::CONTROLWORD, 0, 16)],
    );
    r1.transmission_type = TRANSMISSION_EVENT_PROFILE;
    let mut t1 = Pdo::sync(
        Direction::Transmit,
        1,
        0x180 + n,
        &[MappedObject::new(cia402::STATUSWORD, 0, 16)],
    );
    t1.transmission_type = TRANSMISSION_EVENT_PROFILE;
    vec![
        r1,
        Pdo::disabled(Direction::Receive, 2, 0x300 + n),
        t1,
        Pdo::disabled(Direction::Transmit, 2, 0x280 + n),
    ]
}

/// The I/O module's factory mapping (CiA 401 §7): digital I/O in PDO 1, the first analog
/// inputs and outputs in PDO 2, all event-driven.
fn io_factory_pdos(node: u8) -> Vec<Pdo> {
    let n = u32::from(node);
    let ev = |mut p: Pdo| {
        p.transmission_type = TRANSMISSION_EVENT_PROFILE;
        p
    };
    vec![
        ev(Pdo::sync(
            Direction::Receive,
            1,
            0x200 + n,
            &[MappedObject::new(cia401::DIGITAL_OUTPUTS_8, 1, 8)],
        )),
        ev(Pdo::sync(
            Direction::Receive,
            2,
            0x300 + n,
            &[
                MappedObject::new(cia401::ANALOG_OUTPUTS_16, 1, 16),
                MappedObject::new(cia401::ANALOG_OUTPUTS_16, 2, 16),
            ],
        )),
        ev(Pdo::sync(
            Direction::Transmit,
            1,
            0x180 + n,
            &[MappedObject::new(cia401::DIGITAL_INPUTS_8, 1, 8)],
        )),
        ev(Pdo::sync(
            Direction::Transmit,
            2,
            0x280 + n,
            &[
                MappedObject::new(cia401::ANALOG_INPUTS_16, 1, 16),
                MappedObject::new(cia401::ANALOG_INPUTS_16, 2, 16),
                MappedObject::new(cia401::ANALOG_INPUTS_16, 3, 16),
                MappedObject::new(cia401::ANALOG_INPUTS_16, 4, 16),
            ],
        )),
    ]
}

/// The simulated node's object dictionary at power-on, for the node and for its EDS.
pub fn dictionary(profile: Profile, node_id: u8) -> ObjectDictionary {
    let b = ObjectDictionary::builder();
    let b = match profile {
        Profile::Cia402 => {
            let b = heartbeat_consumer(identity(b, cia402::DEVICE_TYPE, 402));
            let b = pdo_objects(b, &drive_factory_pdos(node_id));
            b.var(cia402::ERROR_CODE, EntrySpec::ro("error_code", 0u16).pdo())
                .var(
                    cia402::CONTROLWORD,
                    EntrySpec::rw("controlword", 0u16).pdo(),
                )
                .var(cia402::STATUSWORD, EntrySpec::ro("statusword", 0u16).pdo())
                .var(
                    cia402::QUICK_STOP_OPTION,
                    EntrySpec::rw("quick_stop_option_code", 2i16)
                        .range(Some(Value::Integer16(0)), Some(Value::Integer16(8)))
                        .doc("1, 2 stop on 6084h, 6085h then switch on disabled; 5, 6 hold in quick stop active"),
                )
                .var(
                    cia402::PROFILE_DECELERATION,
                    EntrySpec::rw("profile_deceleration", 1_000_000u32).unit("um/s2"),
                )
                .var(
                    cia402::QUICK_STOP_DECELERATION,
                    EntrySpec::rw("quick_stop_deceleration", 10_000_000u32).unit("um/s2"),
                )
                .var(
                    cia402::ABORT_CONNECTION_OPTION,
                    EntrySpec::rw("abort_connection_option_code", 1i16)
                        .range(Some(Value::Integer16(0)), Some(Value::Integer16(3)))
                        .doc("0 no action, 1 fault, 2 disable voltage, 3 quick stop"),
                )
                .var(
                    cia402::MODES_OF_OPERATION,
                    EntrySpec::rw("modes_of_operation", 0i8).pdo(),
                )
                .var(
                    cia402::MODES_OF_OPERATION_DISPLAY,
                    EntrySpec::ro("modes_of_operation_display", 0i8).pdo(),
                )
                .var(
                    cia402::POSITION_ACTUAL,
                    EntrySpec::ro("position_actual_value", 0i32)
                        .pdo()
                        .unit("um"),
                )
                .var(
                    cia402::VELOCITY_ACTUAL,
                    EntrySpec::ro("velocity_actual_value", 0i32)
                        .pdo()
                        .unit("um/s"),
                )
                .var(
                    cia402::TARGET_TORQUE,
                    EntrySpec::rw("target_torque", 0i16).pdo().unit("per mille"),
                )
                .var(
                    cia402::MAX_TORQUE,
                    EntrySpec::rw("max_torque", 1000u16).unit("per mille"),
                )
                .var(
                    cia402::RATED_TORQUE,
                    EntrySpec::ro("motor_rated_torque", DRIVE_RATED_TORQUE_MNM).unit("mN m"),
                )
                .var(
                    cia402::TORQUE_ACTUAL,
                    EntrySpec::ro("torque_actual_value", 0i16)
                        .pdo()
                        .unit("per mille"),
                )
                .var(
                    cia402::DC_LINK_VOLTAGE,
                    EntrySpec::ro("dc_link_circuit_voltage", 0u32)
                        .pdo()
                        .unit("mV"),
                )
                .var(
                    cia402::TARGET_VELOCITY,
                    EntrySpec::rw("target_velocity", 0i32).pdo().unit("um/s"),
                )
                .var(
                    cia402::TARGET_POSITION,
                    EntrySpec::rw("target_position", 0i32).pdo().unit("um"),
                )
                .var(
                    cia402::HOME_OFFSET,
                    EntrySpec::rw("home_offset", 0i32).unit("um"),
                )
                .var(
                    cia402::HOMING_METHOD,
                    EntrySpec::rw("homing_method", 37i8).doc("1, 2, 17, 18, 33, 34, 35, 37"),
                )
                .record(
                    cia402::HOMING_SPEEDS,
                    "homing_speeds",
                    None,
                    vec![
                        EntrySpec::rw("speed_during_search_for_switch", 20_000u32).unit("um/s"),
                        EntrySpec::rw("speed_during_search_for_zero", 2_000u32).unit("um/s"),
                    ],
                )
                .var(
                    cia402::HOMING_ACCELERATION,
                    EntrySpec::rw("homing_acceleration", 500_000u32).unit("um/s2"),
                )
                .var(
                    cia402::SUPPORTED_DRIVE_MODES,
                    EntrySpec::ro(
                        "supported_drive_modes",
                        [
                            Mode::Homing,
                            Mode::CyclicSynchronousPosition,
                            Mode::CyclicSynchronousVelocity,
                            Mode::CyclicSynchronousTorque,
                        ]
                        .iter()
                        .fold(0u32, |bits, m| bits | (1u32 << (m.code() - 1))),
                    ),
                )
        }
        Profile::Cia401 => {
            let b = heartbeat_consumer(identity(b, cia401::DEVICE_TYPE, 401));
            let b = pdo_objects(b, &io_factory_pdos(node_id));
            let ai = [
                "analog_input_1",
                "analog_input_2",
                "analog_input_3",
                "analog_input_4",
            ];
            b.array(
                cia401::DIGITAL_INPUTS_8,
                "read_input_8_bit",
                None,
                vec![EntrySpec::ro("digital_inputs_1", 0u8).pdo()],
            )
            .array(
                cia401::DIGITAL_OUTPUTS_8,
                "write_output_8_bit",
                None,
                vec![EntrySpec::rw("digital_outputs_1", 0u8).pdo()],
            )
            .array(
                cia401::ANALOG_INPUTS_16,
                "read_analog_input_16_bit",
                None,
                ai.iter().map(|n| EntrySpec::ro(n, 0i16).pdo()).collect(),
            )
            .array(
                cia401::ANALOG_OUTPUTS_16,
                "write_analog_output_16_bit",
                None,
                vec![
                    EntrySpec::rw("analog_output_1", 0i16).pdo(),
                    EntrySpec::rw("analog_output_2", 0i16).pdo(),
                ],
            )
            .var(
                cia401::ANALOG_INPUT_INTERRUPT_ENABLE,
                EntrySpec::rw("analog_input_global_interrupt_enable", false),
            )
        }
    };
    b.build()
        .unwrap_or_else(|e| unreachable!("the simulated node's dictionary is constant: {e}"))
}

/// A value of `data_type` from a PDO's raw bits.
fn value_from_raw(data_type: DataType, raw: u64) -> Value {
    match data_type {
        DataType::Boolean => Value::Boolean(raw & 1 != 0),
        DataType::Integer8 => Value::Integer8(raw as u8 as i8),
        DataType::Integer16 => Value::Integer16(raw as u16 as i16),
        DataType::Integer32 => Value::Integer32(raw as u32 as i32),
        DataType::Unsigned8 => Value::Unsigned8(raw as u8),
        DataType::Unsigned16 => Value::Unsigned16(raw as u16),
        DataType::Unsigned32 => Value::Unsigned32(raw as u32),
        DataType::Real32 => Value::Real32(f32::from_bits(raw as u32)),
        DataType::Real64 => Value::Real64(f64::from_bits(raw)),
        DataType::VisibleString => Value::zero(DataType::VisibleString),
    }
}

/// The raw bits of a value, little endian as on the bus.
fn raw_from_value(v: Value) -> u64 {
    let mut b = [0u8; 8];
    let mut out = [0u8; 32];
    let n = v.encode(&mut out).min(8);
    b[..n].copy_from_slice(&out[..n]);
    u64::from_le_bytes(b)
}

/// A standard node: its dictionary, its PDOs as configured, and the device behind them.
pub struct ProfileNode {
    profile: Profile,
    node_id: u8,
    od: ObjectDictionary,
    sdo: SdoServer,
    pdos: Vec<Pdo>,
    /// Synchronous RPDO data received since the last SYNC, applied at the next (CiA 301).
    rpdo_buffer: Vec<Option<Frame>>,
    /// What each event-driven TPDO last sent.
    tpdo_last: Vec<Option<Frame>>,
    drive: DriveStateMachine,
    drive_faults: Vec<DriveFault>,
    next_drive_fault: usize,
    velocity_integral: f64,
    homing: Homing,
    /// The plant position where 6064h reads 0: moved by homing.
    position_origin_m: f64,
    /// The plant's position as last measured.
    position_m: f64,
    /// CSP's target position of the last period (plant m), for the velocity feed-forward.
    last_target_m: Option<f64>,
    syncs: u64,
    /// EMCY frames the device wants to send (drive faults and their reset).
    pending_emcy: Option<Frame>,
    /// The master's heartbeat as 1016h sub 1 asks for it watched.
    consumer: Option<HeartbeatConsumer>,
    /// A quick stop or halt under way (or ended and holding).
    stop_ramp: Option<StopRamp>,
    /// The plant's velocity as last measured, and the period before.
    velocity_m_per_s: f64,
    velocity_before_m_per_s: f64,
    /// Where a stop came to rest: held there while the stop lasts.
    stop_hold_m: Option<f64>,
    /// The force beyond the load's inertia in the last period and the one before, N.
    beyond_inertia_n: (f64, f64),
    /// The force or torque applied in the last period.
    force_n: f64,
}

impl ProfileNode {
    pub fn new(profile: Profile, node_id: u8, mut drive_faults: Vec<DriveFault>) -> Self {
        drive_faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let od = dictionary(profile, node_id);
        let mut node = Self {
            profile,
            node_id,
            od,
            sdo: SdoServer::new(node_id),
            pdos: Vec::new(),
            rpdo_buffer: Vec::new(),
            tpdo_last: Vec::new(),
            drive: DriveStateMachine::new(),
            drive_faults,
            next_drive_fault: 0,
            velocity_integral: 0.0,
            homing: Homing::new(),
            position_origin_m: 0.0,
            position_m: 0.0,
            last_target_m: None,
            syncs: 0,
            pending_emcy: None,
            consumer: None,
            stop_ramp: None,
            velocity_m_per_s: 0.0,
            velocity_before_m_per_s: 0.0,
            stop_hold_m: None,
            beyond_inertia_n: (0.0, 0.0),
            force_n: 0.0,
        };
        node.reset();
        node
    }

    pub fn profile(&self) -> Profile {
        self.profile
    }

    pub fn dictionary(&self) -> &ObjectDictionary {
        &self.od
    }

    /// The drive's state (CiA 402 nodes).
    pub fn drive_state(&self) -> State {
        self.drive.state()
    }

    /// What the statusword shows of homing (bits 10, 12, 13 in homing mode).
    pub fn homing_status(&self) -> HomingStatus {
        self.homing.status()
    }

    /// The plant position where the position actual value reads 0.
    pub fn position_origin_m(&self) -> f64 {
        self.position_origin_m
    }

    /// The PDOs as configured now.
    pub fn pdos(&self) -> &[Pdo] {
        &self.pdos
    }

    /// Power-on or NMT reset: factory values, the drive initialised (transitions 0 and 1).
    pub fn reset(&mut self) {
        self.od.reset_to_defaults();
        self.sdo.reset();
        self.drive = DriveStateMachine::new();
        self.drive.initialised();
        self.velocity_integral = 0.0;
        self.homing = Homing::new();
        self.position_origin_m = 0.0;
        self.last_target_m = None;
        self.consumer = None;
        self.stop_ramp = None;
        self.stop_hold_m = None;
        self.force_n = 0.0;
        self.refresh_pdos();
        self.publish_status();
    }

    fn value(&self, id: ObjectId) -> Option<Value> {
        self.od.handle(id).map(|h| self.od.value(h))
    }

    fn u32_at(&self, index: u16, sub: u8) -> u32 {
        self.value(ObjectId::new(index, sub))
            .and_then(|v| v.as_f64())
            .map_or(0, |v| v as u32)
    }

    fn f64_at(&self, index: u16, sub: u8) -> f64 {
        self.value(ObjectId::new(index, sub))
            .and_then(|v| v.as_f64())
            .unwrap_or(0.0)
    }

    fn set(&mut self, id: ObjectId, value: Value) {
        if let Some(h) = self.od.handle(id) {
            let _ = self.od.publish(h, value);
        }
    }

    fn set_f64(&mut self, index: u16, sub: u8, v: f64) {
        let id = ObjectId::new(index, sub);
        if let Some(h) = self.od.handle(id) {
            let t = self.od.entry(h).data_type;
            let raw = match t {
                DataType::Integer8 | DataType::Integer16 | DataType::Integer32 => {
                    let bits = (t.size().unwrap_or(4) * 8) as u8;
                    crate::device::profile::mapping::to_raw_signed(v, bits)
                }
                _ => v.max(0.0).round() as u64,
            };
            let _ = self.od.publish(h, value_from_raw(t, raw));
        }
    }

    /// Mirror the PDO parameters of the dictionary.
    fn refresh_pdos(&mut self) {
        let mut pdos = Vec::new();
        for (direction, comm, map) in [
            (Direction::Receive, 0x1400u16, 0x1600u16),
            (Direction::Transmit, 0x1800, 0x1A00),
        ] {
            for n in 0..512u16 {
                if self.od.object(comm + n).is_none() {
                    break;
                }
                let cob = self.u32_at(comm + n, 1);
                let count = self.u32_at(map + n, 0) as u8;
                pdos.push(Pdo {
                    direction,
                    number: n + 1,
                    cob_id: cob & 0x7FF,
                    enabled: cob & COB_ID_INVALID == 0,
                    transmission_type: self.u32_at(comm + n, 2) as u8,
                    objects: (1..=count)
                        .map(|s| MappedObject::from_u32(self.u32_at(map + n, s)))
                        .collect(),
                });
            }
        }
        self.rpdo_buffer = vec![None; pdos.len()];
        self.tpdo_last = vec![None; pdos.len()];
        self.pdos = pdos;
    }

    /// CiA 301's rules for a write to a PDO parameter; `Ok` means it may be stored.
    fn check_pdo_write(&self, id: ObjectId, value: u32) -> Result<(), AbortCode> {
        let (direction, number, is_mapping) = match id.index {
            0x1400..=0x15FF => (Direction::Receive, id.index - 0x1400 + 1, false),
            0x1600..=0x17FF => (Direction::Receive, id.index - 0x1600 + 1, true),
            0x1800..=0x19FF => (Direction::Transmit, id.index - 0x1800 + 1, false),
            _ => (Direction::Transmit, id.index - 0x1A00 + 1, true),
        };
        let pdo = self
            .pdos
            .iter()
            .find(|p| p.direction == direction && p.number == number)
            .ok_or(AbortCode::OBJECT_DOES_NOT_EXIST)?;
        if self.od.handle(id).is_none() {
            return Err(AbortCode::SUBINDEX_DOES_NOT_EXIST);
        }
        match (is_mapping, id.sub) {
            // COB-ID: only bit 31 may change while the PDO is valid.
            (false, 1) => {
                let was_valid = pdo.enabled;
                let new_cob = value & 0x1FFF_FFFF;
                if was_valid && value & COB_ID_INVALID == 0 && new_cob & 0x7FF != pdo.cob_id {
                    return Err(abort::INVALID_VALUE);
                }
                if value & (1 << 29) != 0 {
                    // 29-bit ids: not supported by this node.
                    return Err(abort::INVALID_VALUE);
                }
                Ok(())
            }
            (false, 2) => {
                if (241..=251).contains(&value) {
                    return Err(abort::INVALID_VALUE);
                }
                Ok(())
            }
            (false, _) => Err(AbortCode::SUBINDEX_DOES_NOT_EXIST),
            (true, 0) => {
                if pdo.enabled {
                    return Err(abort::UNSUPPORTED_ACCESS);
                }
                if value > 8 {
                    return Err(AbortCode::VALUE_TOO_HIGH);
                }
                let mut bits = 0u32;
                for sub in 1..=value as u8 {
                    let entry = MappedObject::from_u32(self.u32_at(id.index, sub));
                    self.check_mappable(entry, direction)?;
                    bits += u32::from(entry.bits);
                }
                if bits > 64 {
                    return Err(abort::EXCEEDS_PDO_LENGTH);
                }
                Ok(())
            }
            (true, _) => {
                if pdo.enabled || !pdo.objects.is_empty() {
                    return Err(abort::UNSUPPORTED_ACCESS);
                }
                self.check_mappable(MappedObject::from_u32(value), direction)
            }
        }
    }

    /// The object exists, may be mapped in this direction, and is mapped whole.
    fn check_mappable(&self, o: MappedObject, direction: Direction) -> Result<(), AbortCode> {
        let h = self.od.handle(o.id).ok_or(abort::CANNOT_BE_MAPPED)?;
        let e = self.od.entry(h);
        let direction_ok = match direction {
            Direction::Receive => e.access.writable(),
            Direction::Transmit => e.access.readable(),
        };
        let size_ok = e.data_type.size().map(|s| s * 8) == Some(usize::from(o.bits));
        if !e.pdo_mappable || !direction_ok || !size_ok {
            return Err(abort::CANNOT_BE_MAPPED);
        }
        Ok(())
    }

    /// Serve an SDO request addressed to this node; writes to PDO parameters pass CiA 301's
    /// checks first, writes to the device's objects take effect at once.
    fn on_sdo(&mut self, frame: &Frame, state: NmtState, send: &mut dyn FnMut(&Frame)) {
        let d = frame.data();
        let ccs = d.first().map_or(0xFF, |c| c >> 5);
        let expedited = d.first().is_some_and(|c| c & 0x02 != 0);
        let id = if d.len() >= 4 {
            ObjectId::new(u16::from_le_bytes([d[1], d[2]]), d[3])
        } else {
            ObjectId::new(0, 0)
        };
        let now_s = self.syncs as f64 * 1e-3;
        if ccs == 1 && d.len() == 8 && (0x1400..=0x1BFF).contains(&id.index) {
            if !matches!(state, NmtState::PreOperational | NmtState::Operational) {
                return;
            }
            let response = sdo::response_cob_id(self.node_id);
            let code = if !expedited {
                Err(AbortCode::GENERAL_ERROR)
            } else {
                let len = if d[0] & 0x01 != 0 {
                    4 - usize::from((d[0] >> 2) & 0x03)
                } else {
                    4
                };
                let mut b = [0u8; 4];
                b[..len].copy_from_slice(&d[4..4 + len]);
                let value = u32::from_le_bytes(b);
                self.check_pdo_write(id, value).and_then(|()| {
                    let h = self
                        .od
                        .handle(id)
                        .ok_or(AbortCode::SUBINDEX_DOES_NOT_EXIST)?;
                    let t = self.od.entry(h).data_type;
                    let max = match t.size() {
                        Some(1) => 0xFF,
                        Some(2) => 0xFFFF,
                        _ => u32::MAX,
                    };
                    if value > max {
                        return Err(AbortCode::VALUE_TOO_HIGH);
                    }
                    self.set(id, value_from_raw(t, u64::from(value)));
                    Ok(())
                })
            };
            match code {
                Ok(()) => {
                    self.refresh_pdos();
                    send(&sdo::sdo_frame(
                        response,
                        sdo::header(sdo::scs::INITIATE_DOWNLOAD << 5, id),
                    ));
                }
                Err(code) => send(&sdo::abort_frame(response, id, code)),
            }
            return;
        }
        if ccs == 1 && id.index == cia402::MODES_OF_OPERATION && d.len() == 8 {
            let mode = d[4] as i8;
            if mode != 0 && Mode::from_code(mode).is_none() {
                send(&sdo::abort_frame(
                    sdo::response_cob_id(self.node_id),
                    id,
                    AbortCode::VALUE_RANGE_EXCEEDED,
                ));
                return;
            }
        }
        if ccs == 1 && id.index == cia402::QUICK_STOP_OPTION && d.len() == 8 {
            // An INTEGER16, or one byte where the client sent one.
            let one_byte = d[0] & 0x01 != 0 && (d[0] >> 2) & 0x03 == 3;
            let option = if one_byte {
                i16::from(d[4] as i8)
            } else {
                i16::from_le_bytes([d[4], d[5]])
            };
            if !QUICK_STOP_OPTIONS.contains(&option) {
                send(&sdo::abort_frame(
                    sdo::response_cob_id(self.node_id),
                    id,
                    AbortCode::VALUE_RANGE_EXCEEDED,
                ));
                return;
            }
        }
        if ccs == 1
            && id.index == cia402::HOMING_METHOD
            && d.len() == 8
            && !homing::METHODS.contains(&(d[4] as i8))
        {
            send(&sdo::abort_frame(
                sdo::response_cob_id(self.node_id),
                id,
                AbortCode::VALUE_RANGE_EXCEEDED,
            ));
            return;
        }
        if let Some(answer) = self.sdo.handle(frame, now_s, &mut self.od, state) {
            send(&answer);
        }
        let writes: Vec<_> = self.od.take_pending_writes().collect();
        for w in writes {
            self.on_written(w.id);
        }
    }

    /// An object of the device changed (SDO or RPDO).
    fn on_written(&mut self, id: ObjectId) {
        match (self.profile, id.index) {
            (Profile::Cia402, cia402::CONTROLWORD) => {
                let cw = self.u32_at(cia402::CONTROLWORD, 0) as u16;
                self.on_controlword(cw);
            }
            (Profile::Cia402, cia402::MODES_OF_OPERATION) => {
                let mode = self.f64_at(cia402::MODES_OF_OPERATION, 0);
                self.set_f64(cia402::MODES_OF_OPERATION_DISPLAY, 0, mode);
            }
            (_, CONSUMER_HEARTBEAT_TIME) => self.on_consumer_time_written(),
            (Profile::Cia402, cia402::QUICK_STOP_OPTION) => {
                let option = self.f64_at(cia402::QUICK_STOP_OPTION, 0) as i16;
                self.drive.set_quick_stop_option(option);
            }
            _ => {}
        }
    }

    fn on_controlword(&mut self, cw: u16) {
        let start = cia402::control::HOMING_START;
        let was = self.drive.last_controlword() & start != 0;
        let transition = self.drive.on_controlword(cw);
        let homing_mode = self.mode() == Some(Mode::Homing);
        let enabled = self.drive.state().is_enabled();
        if homing_mode && enabled && cw & start != 0 && !was {
            self.start_homing();
        } else if self.homing.is_moving() && (cw & start == 0 || !enabled || !homing_mode) {
            self.homing.interrupt();
        }
        if transition == Some(15) {
            // The fault is gone: EMCY "error reset" (CiA 301 §7.2.7.1).
            self.pending_emcy = Some(self.emcy(0, 0));
        }
        if matches!(transition, Some(2 | 7 | 9 | 10 | 12 | 15)) {
            self.velocity_integral = 0.0;
            self.last_target_m = None;
        }
        self.publish_status();
    }

    /// The mode of operation 6060h asks for.
    fn mode(&self) -> Option<Mode> {
        Mode::from_code(self.f64_at(cia402::MODES_OF_OPERATION, 0) as i8)
    }

    /// Homing starts from the objects as they are now; a current-position method moves the
    /// origin at once.
    fn start_homing(&mut self) {
        let speed = |sub| self.f64_at(cia402::HOMING_SPEEDS, sub) * DRIVE_VELOCITY_UNIT;
        let parameters = HomingParameters {
            method: self.f64_at(cia402::HOMING_METHOD, 0) as i8,
            speed_switch_m_per_s: speed(1),
            speed_zero_m_per_s: speed(2),
            acceleration_m_per_s2: self.f64_at(cia402::HOMING_ACCELERATION, 0)
                * DRIVE_ACCELERATION_UNIT,
            timeout_s: homing::HOMING_TIMEOUT_S,
        };
        if let Some(home) = self.homing.start(parameters, self.position_m) {
            self.set_home(home);
        }
    }

    /// The home point found: it reads minus the home offset from now on (CiA 402: the zero
    /// position lies the home offset beyond the home point).
    fn set_home(&mut self, home_m: f64) {
        let offset_m = self.f64_at(cia402::HOME_OFFSET, 0) * DRIVE_POSITION_UNIT;
        // The origin: the home point plus the offset.
        self.position_origin_m = home_m + offset_m;
        self.publish_position();
    }

    fn publish_position(&mut self) {
        let raw = (self.position_m - self.position_origin_m) / DRIVE_POSITION_UNIT;
        self.set_f64(cia402::POSITION_ACTUAL, 0, raw);
    }

    fn emcy(&self, code: u16, register: u8) -> Frame {
        EmcyFrame {
            node_id: self.node_id,
            error_code: code,
            error_register: register,
            manufacturer: [0; 5],
        }
        .encode()
    }

    fn publish_status(&mut self) {
        if self.profile == Profile::Cia402 {
            let mut sw = self.drive.statusword();
            match self.mode() {
                Some(Mode::Homing) => sw |= self.homing.status().statusword_bits(),
                Some(Mode::CyclicSynchronousPosition) if self.drive.state().is_enabled() => {
                    sw |= cia402::status::HOMING_ATTAINED
                }
                _ => {}
            }
            if self.halted_at_standstill() {
                sw |= cia402::status::TARGET_REACHED;
            }
            let code = self.drive.error_code();
            self.set(ObjectId::new(cia402::STATUSWORD, 0), Value::Unsigned16(sw));
            self.set(
                ObjectId::new(cia402::ERROR_CODE, 0),
                Value::Unsigned16(code),
            );
            let register = u8::from(self.drive.state().is_fault());
            self.set(ObjectId::new(0x1001, 0), Value::Unsigned8(register));
        }
    }

    /// Write a received PDO's objects into the dictionary.
    fn apply_rpdo(&mut self, index: usize, frame: &Frame) {
        let Some(values) = self.pdos[index]
            .unpack(frame.data())
            .map(|it| it.collect::<Vec<_>>())
        else {
            return;
        };
        for (o, raw) in values {
            if let Some(h) = self.od.handle(o.id) {
                let t = self.od.entry(h).data_type;
                let _ = self.od.publish(h, value_from_raw(t, raw));
                self.on_written(o.id);
            }
        }
    }

    /// A frame other than NMT and SYNC; true when it was for this node's profile.
    pub fn handle(&mut self, frame: &Frame, state: NmtState, send: &mut dyn FnMut(&Frame)) -> bool {
        let id = frame.id();
        if id == sdo::request_cob_id(self.node_id) {
            self.on_sdo(frame, state, send);
            return true;
        }
        let Some(index) = self
            .pdos
            .iter()
            .position(|p| p.direction == Direction::Receive && p.enabled && p.cob_id == id)
        else {
            return false;
        };
        // PDOs count only in operational (CiA 301 §7.3.2.2.1).
        if state != NmtState::Operational {
            return true;
        }
        if self.pdos[index].transmission_type <= 240 {
            self.rpdo_buffer[index] = Some(*frame);
        } else {
            self.apply_rpdo(index, frame);
        }
        if let Some(e) = self.pending_emcy.take() {
            send(&e);
        }
        true
    }

    /// One SYNC: buffered RPDOs take effect, the device runs one period with the plant, and the
    /// TPDOs due go out.
    pub fn on_sync(
        &mut self,
        plant: &mut dyn Plant,
        period_s: f64,
        state: NmtState,
        send: &mut dyn FnMut(&Frame),
    ) {
        self.syncs += 1;
        for i in 0..self.pdos.len() {
            if let Some(f) = self.rpdo_buffer[i].take() {
                self.apply_rpdo(i, &f);
            }
        }
        let command = match self.profile {
            Profile::Cia402 => self.drive_step(plant, period_s),
            Profile::Cia401 => {
                let raw = self.f64_at(cia401::ANALOG_OUTPUTS_16, 1) as i16;
                let scaling = match plant.family() {
                    crate::physics::Family::Pneumatic => IO_COMMAND_DUTY,
                    _ => IO_COMMAND_VOLTAGE,
                };
                scaling.to_si(raw)
            }
        };
        plant.step(command, period_s);
        let m = plant.measure();
        match self.profile {
            Profile::Cia402 => {
                self.position_m = m.position;
                self.velocity_before_m_per_s = self.velocity_m_per_s;
                self.velocity_m_per_s = m.velocity;
                self.publish_position();
                self.set_f64(cia402::VELOCITY_ACTUAL, 0, m.velocity / DRIVE_VELOCITY_UNIT);
                let rated_n = f64::from(DRIVE_RATED_TORQUE_MNM) * 1e-3;
                self.set_f64(cia402::TORQUE_ACTUAL, 0, command / rated_n * 1000.0);
                self.set_f64(cia402::DC_LINK_VOLTAGE, 0, m.supply_voltage_v * 1e3);
                self.publish_status();
            }
            Profile::Cia401 => {
                let pneumatic = plant.family() == crate::physics::Family::Pneumatic;
                let supply = if pneumatic {
                    IO_SUPPLY_PRESSURE.to_raw(m.supply_pressure_pa)
                } else {
                    IO_SUPPLY_VOLTAGE.to_raw(m.supply_voltage_v)
                };
                let ai = [
                    IO_POSITION.to_raw(m.position),
                    IO_CURRENT.to_raw(m.current_a),
                    supply,
                    0,
                ];
                for (i, v) in ai.iter().enumerate() {
                    self.set(
                        ObjectId::new(cia401::ANALOG_INPUTS_16, i as u8 + 1),
                        Value::Integer16(*v),
                    );
                }
            }
        }
        if let Some(e) = self.pending_emcy.take() {
            send(&e);
        }
        if state != NmtState::Operational {
            return;
        }
        let analog_events = self
            .value(ObjectId::new(cia401::ANALOG_INPUT_INTERRUPT_ENABLE, 0))
            .is_some_and(|v| v == Value::Boolean(true));
        for i in 0..self.pdos.len() {
            let p = &self.pdos[i];
            if p.direction != Direction::Transmit || !p.enabled {
                continue;
            }
            let frame = p.pack(|id| {
                self.od
                    .handle(id)
                    .map_or(0, |h| raw_from_value(self.od.value(h)))
            });
            let due = match p.transmission_type {
                // Acyclic synchronous (0) is sent on SYNC after a change, like the events.
                0 => self.tpdo_last[i] != Some(frame),
                n @ 1..=240 => self.syncs % u64::from(n) == 0,
                254 | 255 => {
                    let analog = p
                        .objects
                        .iter()
                        .any(|o| o.id.index == cia401::ANALOG_INPUTS_16);
                    self.tpdo_last[i] != Some(frame) && (!analog || analog_events)
                }
                _ => false,
            };
            if due {
                send(&frame);
                self.tpdo_last[i] = Some(frame);
            }
        }
    }

    /// The drive's cycle, remembering the force it applies (a stop starts from it).
    fn drive_step(&mut self, plant: &mut dyn Plant, dt: f64) -> f64 {
        // The force beyond the load's inertia in the last period: F_d = F - m (v(k) - v(k-1)) / T.
        let beyond = self.force_n
            - DRIVE_LOAD_MASS_KG * (self.velocity_m_per_s - self.velocity_before_m_per_s) / dt;
        self.beyond_inertia_n = (beyond, self.beyond_inertia_n.0);
        let force = self.drive_force(plant, dt);
        self.force_n = force;
        force
    }

    /// The halt bit is set while the drive is enabled.
    fn halted(&self) -> bool {
        self.drive.state().is_enabled()
            && self.drive.last_controlword() & cia402::control::HALT != 0
    }

    /// A stop has brought the axis to rest.
    fn at_standstill(&self) -> bool {
        self.stop_hold_m.is_some()
    }

    /// Statusword bit 10 of a halt: the axis has come to rest.
    fn halted_at_standstill(&self) -> bool {
        self.halted() && self.at_standstill()
    }

    /// A quick stop or halt: the deceleration its objects give, held to by a force that adds
    /// the load's inertia to what the last period needed beyond it; at rest, the position loop
    /// holds the axis where it stopped.
    fn stop_force(&mut self, dt: f64, max_n: f64) -> f64 {
        let quick_stop_ramp = self.drive.state() == State::QuickStopActive
            && stop::on_quick_stop_deceleration(self.drive.quick_stop_option());
        let object = if quick_stop_ramp {
            cia402::QUICK_STOP_DECELERATION
        } else {
            cia402::PROFILE_DECELERATION
        };
        let deceleration = self.f64_at(object, 0) * DRIVE_ACCELERATION_UNIT;
        if self.homing.is_moving() {
            self.homing.interrupt();
        }
        self.last_target_m = None;
        let v = self.velocity_m_per_s;
        let mut ramp = self
            .stop_ramp
            .unwrap_or_else(|| StopRamp::new(self.position_m, v));
        if self.stop_hold_m.is_none() && ramp.stopped() && v.abs() < STANDSTILL_M_PER_S {
            // Bumpless: the velocity loop's integral carries the force applied so far.
            self.velocity_integral = self.force_n / VELOCITY_KI;
            self.stop_hold_m = Some(self.position_m);
        }
        if let Some(hold) = self.stop_hold_m {
            self.stop_ramp = Some(ramp);
            return self.position_loop(hold, 0.0, dt, max_n);
        }
        ramp.step(deceleration, dt);
        self.stop_ramp = Some(ramp);
        // The force beyond the load's inertia in the coming period, continued along its last
        // change (the spring's force grows with the travel): F_d(k+1) = 2 F_d(k) - F_d(k-1).
        let (now, before) = self.beyond_inertia_n;
        let beyond_inertia_n = 2.0 * now - before;
        // a = (v_ramp(k+1) - v(k)) / T, held within the deceleration.
        let a = ((ramp.velocity_m_per_s - v) / dt).clamp(-deceleration, deceleration);
        // F = F_d + m a.
        (beyond_inertia_n + DRIVE_LOAD_MASS_KG * a).clamp(-max_n, max_n)
    }

    /// The drive's cycle: scheduled faults, automatic transitions, and the force or torque it
    /// applies in the mode of operation, or on a stop's ramp (none while the power stage is
    /// off).
    fn drive_force(&mut self, plant: &mut dyn Plant, dt: f64) -> f64 {
        while let Some(f) = self.drive_faults.get(self.next_drive_fault) {
            if f.at_s > plant.time_s() + 1e-9 {
                break;
            }
            let code = f.error_code;
            self.next_drive_fault += 1;
            self.drive.fault(code);
            // Error register 1001h bit 0 (generic) with the code, as a drive announces it.
            self.pending_emcy = Some(self.emcy(code, 0x01));
        }
        self.drive.step(self.at_standstill());
        let rated_n = f64::from(DRIVE_RATED_TORQUE_MNM) * 1e-3;
        let max_n = self.f64_at(cia402::MAX_TORQUE, 0) * 1e-3 * rated_n;
        if self.drive.state() == State::QuickStopActive || self.halted() {
            return self.stop_force(dt, max_n).clamp(-max_n, max_n);
        }
        self.stop_ramp = None;
        self.stop_hold_m = None;
        if !self.drive.state().is_enabled() {
            if self.homing.is_moving() {
                self.homing.interrupt();
            }
            return 0.0;
        }
        let mode = self.mode();
        if mode != Some(Mode::CyclicSynchronousPosition) {
            self.last_target_m = None;
        }
        if mode != Some(Mode::Homing) && self.homing.is_moving() {
            self.homing.interrupt();
        }
        let force = match mode {
            // 6071h in per mille of 6076h.
            Some(Mode::CyclicSynchronousTorque) => {
                self.f64_at(cia402::TARGET_TORQUE, 0) * 1e-3 * rated_n
            }
            Some(Mode::CyclicSynchronousVelocity) => {
                let target = self.f64_at(cia402::TARGET_VELOCITY, 0) * DRIVE_VELOCITY_UNIT;
                self.velocity_loop(target, dt, max_n)
            }
            Some(Mode::CyclicSynchronousPosition) => {
                let target = self.f64_at(cia402::TARGET_POSITION, 0) * DRIVE_POSITION_UNIT
                    + self.position_origin_m;
                // The target's velocity over the last SYNC period feeds the velocity loop
                // forward.
                let feed_forward = self.last_target_m.map_or(0.0, |last| (target - last) / dt);
                self.last_target_m = Some(target);
                self.position_loop(target, feed_forward, dt, max_n)
            }
            Some(Mode::Homing) => {
                let step = self.homing.step(self.position_m, dt);
                if let Some(home) = step.home_m {
                    self.set_home(home);
                }
                self.position_loop(step.reference_m, step.velocity_m_per_s, dt, max_n)
            }
            _ => 0.0,
        };
        force.clamp(-max_n, max_n)
    }

    /// The PI velocity loop toward `target` (m/s): F = K_P e + K_I ∫e dt, the integral held
    /// at the torque limit.
    fn velocity_loop(&mut self, target: f64, dt: f64, max_n: f64) -> f64 {
        // The velocity as the drive measures it: 606Ch's resolution.
        let actual = self.f64_at(cia402::VELOCITY_ACTUAL, 0) * DRIVE_VELOCITY_UNIT;
        let e = target - actual;
        let f = VELOCITY_KP * e + VELOCITY_KI * (self.velocity_integral + e * dt);
        if f.abs() < max_n {
            self.velocity_integral += e * dt;
        }
        f
    }

    /// The position loop around the velocity loop: v = v_ff + K_P (x_ref - x).
    fn position_loop(&mut self, reference_m: f64, feed_forward: f64, dt: f64, max_n: f64) -> f64 {
        let v = feed_forward + POSITION_KP * (reference_m - self.position_m);
        self.velocity_loop(v, dt, max_n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::profile::mapping::sign_extend;

    fn sdo_write(n: &mut ProfileNode, index: u16, sub: u8, value: u32, size: usize) -> Frame {
        let (_, req) = crate::canopen::sdo::Expedited::write(
            n.node_id,
            ObjectId::new(index, sub),
            &value.to_le_bytes()[..size],
        );
        let mut out = vec![];
        n.handle(&req, NmtState::PreOperational, &mut |f| out.push(*f));
        out[0]
    }

    fn abort_code(f: &Frame) -> Option<u32> {
        (f.data()[0] == 0x80).then(|| u32::from_le_bytes(f.data()[4..8].try_into().expect("4")))
    }

    #[test]
    fn mapping_writes_follow_the_cia301_protocol() {
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        // The PDO is valid: its mapping cannot change.
        let a = sdo_write(&mut n, 0x1A00, 0, 0, 1);
        assert_eq!(abort_code(&a), Some(0x0601_0000));
        // Nor its COB-ID, except bit 31.
        let a = sdo_write(&mut n, 0x1800, 1, 0x4000_0191, 4);
        assert_eq!(abort_code(&a), Some(0x0609_0030));
        let mut p = n.pdos()[2].clone();
        assert_eq!(p.label(), "TPDO1 (1800h/1A00h)");
        p.objects = vec![
            MappedObject::new(cia402::STATUSWORD, 0, 16),
            MappedObject::new(cia402::POSITION_ACTUAL, 0, 32),
            MappedObject::new(cia402::TORQUE_ACTUAL, 0, 16),
        ];
        p.transmission_type = 1;
        for w in p.configuration_writes() {
            let a = sdo_write(&mut n, w.id.index, w.id.sub, w.value, w.size);
            assert_eq!(abort_code(&a), None, "{}", w.id);
        }
        assert_eq!(n.pdos()[2], p);
        // An object that is not mappable, or not in this direction, or a wrong length.
        sdo_write(&mut n, 0x1800, 1, 0xC000_0190, 4);
        sdo_write(&mut n, 0x1A00, 0, 0, 1);
        for bad in [0x6076_0020u32, 0x6072_0010, 0x6041_0020, 0x1234_0010] {
            let a = sdo_write(&mut n, 0x1A00, 1, bad, 4);
            assert_eq!(abort_code(&a), Some(0x0604_0041), "{bad:#x}");
        }
        // More than 64 bits.
        for sub in 1..=3 {
            sdo_write(&mut n, 0x1A00, sub, 0x6064_0020, 4);
        }
        let a = sdo_write(&mut n, 0x1A00, 0, 3, 1);
        assert_eq!(abort_code(&a), Some(0x0604_0042));
    }

    #[test]
    fn the_drive_applies_target_torque_only_when_enabled_and_faults_on_schedule() {
        let plant = crate::physics::plant_from_str(
            &include_str!("../../../config/plants/linear_axis.toml")
                .replace("command = \"voltage\"", "command = \"force\""),
            "linear_axis.toml",
        )
        .expect("plant");
        let mut plant = plant;
        let fault: DriveFault = "0x4310@50ms".parse().expect("fault");
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![fault]);
        let mut p = n.pdos()[0].clone();
        p.objects = vec![
            MappedObject::new(cia402::CONTROLWORD, 0, 16),
            MappedObject::new(cia402::TARGET_TORQUE, 0, 16),
        ];
        p.transmission_type = 1;
        for w in p.configuration_writes() {
            sdo_write(&mut n, w.id.index, w.id.sub, w.value, w.size);
        }
        sdo_write(&mut n, cia402::MODES_OF_OPERATION, 0, 10, 1);
        let rpdo = |cw: u64, torque: f64| {
            p.pack(|id| match id.index {
                cia402::CONTROLWORD => cw,
                _ => crate::device::profile::mapping::to_raw_signed(torque, 16),
            })
        };
        let mut frames = vec![];
        let op = NmtState::Operational;
        // 200 per mille of 100 N = 20 N, against a 2000 N/m spring: 10 mm.
        for (i, cw) in [0x06u64, 0x07, 0x0F].iter().enumerate() {
            n.handle(&rpdo(*cw, 200.0), op, &mut |f| frames.push(*f));
            n.on_sync(plant.as_mut(), 0.001, op, &mut |f| frames.push(*f));
            if i < 2 {
                assert_eq!(plant.truth().position, 0.0, "no force before enabled ({i})");
            }
        }
        assert_eq!(n.drive_state(), State::OperationEnabled);
        for _ in 0..45 {
            n.handle(&rpdo(0x0F, 200.0), op, &mut |f| frames.push(*f));
            n.on_sync(plant.as_mut(), 0.001, op, &mut |f| frames.push(*f));
        }
        assert!(plant.truth().position > 1e-3, "{}", plant.truth().position);
        for _ in 0..5 {
            n.on_sync(plant.as_mut(), 0.001, op, &mut |f| frames.push(*f));
        }
        assert_eq!(n.drive_state(), State::Fault);
        let emcy: Vec<_> = frames.iter().filter(|f| f.id() == 0x90).collect();
        assert_eq!(emcy.len(), 1);
        assert_eq!(emcy[0].data()[..3], [0x10, 0x43, 0x01]);
        // The statusword TPDO (factory: event-driven) showed each change.
        let sw: Vec<u16> = frames
            .iter()
            .filter(|f| f.id() == 0x190)
            .map(|f| u16::from_le_bytes([f.data()[0], f.data()[1]]))
            .collect();
        assert_eq!(sw.last().map(|s| s & 0x4F), Some(0x08), "{sw:x?}");
        assert_eq!(n.f64_at(cia402::ERROR_CODE, 0), f64::from(0x4310));
        n.handle(&rpdo(0x00, 0.0), op, &mut |_| {});
        n.on_sync(plant.as_mut(), 0.001, op, &mut |_| {});
        let mut out = vec![];
        n.handle(&rpdo(0x80, 0.0), op, &mut |f| out.push(*f));
        n.on_sync(plant.as_mut(), 0.001, op, &mut |f| out.push(*f));
        assert_eq!(n.drive_state(), State::SwitchOnDisabled);
        assert!(out
            .iter()
            .any(|f| f.id() == 0x90 && f.data()[..2] == [0, 0]));
        let _ = sign_extend(0, 16);
    }

    /// The built-in drive plant (1 kg, 2000 N/m spring, ±100 N) behind the drive.
    fn drive_plant() -> Box<dyn Plant> {
        crate::physics::plant_from_str(
            include_str!("../../../config/plants/linear_axis_drive.toml"),
            "linear_axis_drive.toml",
        )
        .expect("plant")
    }

    #[test]
    fn the_drive_homes_on_its_limit_switch_and_then_tracks_csp_targets() {
        let mut plant = drive_plant();
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        // A method the simulated drive does not have is refused.
        let a = sdo_write(&mut n, cia402::HOMING_METHOD, 0, 19, 1);
        assert_eq!(abort_code(&a), Some(0x0609_0030));
        let mut p = n.pdos()[0].clone();
        p.objects = vec![
            MappedObject::new(cia402::CONTROLWORD, 0, 16),
            MappedObject::new(cia402::TARGET_POSITION, 0, 32),
        ];
        p.transmission_type = 1;
        for (index, sub, value, size) in [
            (cia402::MODES_OF_OPERATION, 0, 6, 1),
            (cia402::HOMING_METHOD, 0, 17, 1),
            // The application's zero 1 mm beyond the home point.
            (cia402::HOME_OFFSET, 0, 1000, 4),
        ] {
            let a = sdo_write(&mut n, index, sub, value, size);
            assert_eq!(abort_code(&a), None, "{index:04X}");
        }
        for w in p.configuration_writes() {
            sdo_write(&mut n, w.id.index, w.id.sub, w.value, w.size);
        }
        let op = NmtState::Operational;
        let dt = 0.001;
        let step = |n: &mut ProfileNode, plant: &mut dyn Plant, cw: u64, target: i32| {
            let f = p.pack(|id| match id.index {
                cia402::CONTROLWORD => cw,
                _ => target as u32 as u64,
            });
            n.handle(&f, op, &mut |_| {});
            n.on_sync(plant, dt, op, &mut |_| {});
            n.f64_at(cia402::STATUSWORD, 0) as u16
        };
        for cw in [0x06, 0x07, 0x0F] {
            step(&mut n, plant.as_mut(), cw, 0);
        }
        assert_eq!(n.drive_state(), State::OperationEnabled);
        let sw = step(&mut n, plant.as_mut(), 0x0F, 0);
        assert_eq!(sw & 0x3400, 0x0400, "homing not started: {sw:04x}");
        let mut syncs = 0;
        let sw = loop {
            let sw = step(&mut n, plant.as_mut(), 0x1F, 0);
            syncs += 1;
            if sw & 0x3400 != 0 || syncs > 10_000 {
                break sw;
            }
        };
        assert_eq!(
            sw & 0x3400,
            0x1400,
            "attained after {syncs} SYNCs: {sw:04x}"
        );
        // Home is the switch's edge; the origin lies the offset beyond it.
        let home = n.position_origin_m() - 1e-3;
        eprintln!(
            "sim homing 17: home {:.4} mm after {syncs} SYNCs",
            home * 1e3
        );
        assert!(
            (home - homing::NEGATIVE_LIMIT_SWITCH_M).abs() < 5e-6,
            "{home}"
        );
        // CSP from where it stands: a 5 mm ramp at 10 mm/s, then a hold.
        sdo_write(&mut n, cia402::MODES_OF_OPERATION, 0, 8, 1);
        let start = n.f64_at(cia402::POSITION_ACTUAL, 0) as i32;
        assert!(
            (start + 1000).abs() < 20,
            "the home point reads -offset: {start}"
        );
        let mut worst: i32 = 0;
        for k in 0..1500 {
            let target = start + (k * 10).min(5000);
            let sw = step(&mut n, plant.as_mut(), 0x0F, target);
            assert_eq!(sw & 0x1000, 0x1000, "CSP follows: {sw:04x}");
            // The position answers the target of one SYNC before.
            let previous = start + ((k - 1).max(0) * 10).min(5000);
            worst = worst.max((n.f64_at(cia402::POSITION_ACTUAL, 0) as i32 - previous).abs());
        }
        let end = n.f64_at(cia402::POSITION_ACTUAL, 0) as i32;
        eprintln!(
            "sim CSP: worst tracking error {worst} um, end {} um",
            end - start
        );
        assert!(worst < 150, "{worst} um");
        assert!((end - start - 5000).abs() <= 3, "{}", end - start);
    }

    /// A drive in CSV toward 0.1 m/s behind the built-in plant, with 605Ah = `option`, 6084h =
    /// 1 m/s² and 6085h = 4 m/s²; then the controlword `stop` each SYNC (0x02 quick stop,
    /// 0x10F halt). Returns the true velocity and the statusword of each SYNC after the stop,
    /// and the drive's states.
    fn stop_run(option: i16, stop: u64, syncs: usize) -> (Vec<f64>, Vec<u16>, Vec<State>) {
        let mut plant = drive_plant();
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        let mut p = n.pdos()[0].clone();
        p.objects = vec![
            MappedObject::new(cia402::CONTROLWORD, 0, 16),
            MappedObject::new(cia402::TARGET_VELOCITY, 0, 32),
        ];
        p.transmission_type = 1;
        for w in p.configuration_writes() {
            sdo_write(&mut n, w.id.index, w.id.sub, w.value, w.size);
        }
        for (index, value, size) in [
            (cia402::MODES_OF_OPERATION, 9, 1),
            (cia402::QUICK_STOP_OPTION, option as u16 as u32, 2),
            (cia402::PROFILE_DECELERATION, 1_000_000, 4),
            (cia402::QUICK_STOP_DECELERATION, 4_000_000, 4),
        ] {
            let a = sdo_write(&mut n, index, 0, value, size);
            assert_eq!(abort_code(&a), None, "{index:04X}");
        }
        let op = NmtState::Operational;
        let dt = 0.001;
        let step = |n: &mut ProfileNode, plant: &mut dyn Plant, cw: u64| {
            let f = p.pack(|id| match id.index {
                cia402::CONTROLWORD => cw,
                _ => 100_000,
            });
            n.handle(&f, op, &mut |_| {});
            n.on_sync(plant, dt, op, &mut |_| {});
            n.f64_at(cia402::STATUSWORD, 0) as u16
        };
        for cw in [0x06, 0x07] {
            step(&mut n, plant.as_mut(), cw);
        }
        for _ in 0..300 {
            step(&mut n, plant.as_mut(), 0x0F);
        }
        // The velocity loop's integral lags the spring's growing force: it runs at about half
        // the target.
        let v0 = plant.truth().velocity;
        assert!(v0 > 0.03, "moving at {v0} m/s");
        let (mut v, mut sw, mut states) = (vec![v0], vec![], vec![]);
        for _ in 0..syncs {
            sw.push(step(&mut n, plant.as_mut(), stop));
            v.push(plant.truth().velocity);
            states.push(n.drive_state());
        }
        (v, sw, states)
    }

    /// The largest |dv/dt| of a velocity sampled every millisecond.
    fn largest_deceleration(v: &[f64]) -> f64 {
        v.windows(2)
            .map(|w| ((w[1] - w[0]) / 0.001).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_quick_stop_decelerates_on_the_ramp_its_option_code_names_and_ends_as_it_says() {
        for (option, deceleration, holds) in [
            (1, 1.0, false),
            (2, 4.0, false),
            (5, 1.0, true),
            (6, 4.0, true),
        ] {
            let (v, sw, states) = stop_run(option, 0x02, 400);
            // Quick stop active shows bit 5 cleared, and the state pattern 0x07.
            assert_eq!(states[0], State::QuickStopActive, "option {option}");
            assert_eq!(sw[0] & 0x6F, 0x07, "option {option}: {:04x}", sw[0]);
            // The stop ends where the drive switches off (1, 2: the spring then moves the
            // free axis) or, holding (5, 6), at the last SYNC still moving.
            let off = states.iter().position(|s| *s == State::SwitchOnDisabled);
            let still = match off {
                Some(off) => off,
                None => v
                    .iter()
                    .rposition(|x| x.abs() >= STANDSTILL_M_PER_S)
                    .map_or(0, |i| i + 1),
            };
            let a_max = largest_deceleration(&v[..=still]);
            let expected_ms = v[0] / deceleration * 1e3;
            eprintln!(
                "605Ah = {option}: standstill after {still} ms ({:.4} m/s at {deceleration} m/s²: {expected_ms:.0} ms), largest |a| {a_max:.3} m/s²",
                v[0]
            );
            assert!(a_max <= 1.05 * deceleration, "option {option}: |a| {a_max}");
            assert!(
                (still as f64 - expected_ms).abs() < 0.1 * expected_ms + 3.0,
                "option {option}: {still} ms"
            );
            assert!(
                v[still].abs() < STANDSTILL_M_PER_S,
                "option {option}: {}",
                v[still]
            );
            let last = *states.last().expect("ran");
            if holds {
                assert!(off.is_none(), "option {option}");
                assert_eq!(last, State::QuickStopActive, "option {option}");
                assert!(sw.iter().all(|s| s & 0x6F == 0x07));
                assert!(v[still..].iter().all(|x| x.abs() < STANDSTILL_M_PER_S));
            } else {
                // Switched off only once at rest: every SYNC before was quick stop active.
                let off = off.expect("switched off");
                assert!(states[..off].iter().all(|s| *s == State::QuickStopActive));
                assert_eq!(sw.last().map(|s| s & 0x4F), Some(0x40));
            }
        }
    }

    #[test]
    fn a_halt_decelerates_on_the_profile_deceleration_and_reports_the_target_reached() {
        let (v, sw, states) = stop_run(2, 0x10F, 300);
        let still = v
            .iter()
            .rposition(|x| x.abs() >= STANDSTILL_M_PER_S)
            .map_or(0, |i| i + 1);
        let a_max = largest_deceleration(&v[..still]);
        eprintln!("halt: standstill after {still} ms, largest |a| {a_max:.3} m/s²");
        assert!(a_max <= 1.05, "|a| {a_max}");
        let expected_ms = v[0] / 1.0 * 1e3;
        assert!(
            (still as f64 - expected_ms).abs() < 0.1 * expected_ms + 3.0,
            "{still} ms"
        );
        assert!(states.iter().all(|s| *s == State::OperationEnabled));
        // Bit 10 only once stopped, and from then on.
        let reached = sw
            .iter()
            .position(|s| s & cia402::status::TARGET_REACHED != 0)
            .expect("target reached");
        assert!(
            reached + 1 >= still,
            "bit 10 at {reached}, still at {still}"
        );
        assert!(sw[reached..].iter().all(|s| s & 0x0400 != 0));
        assert!(
            sw.iter().all(|s| s & 0x6F == 0x27),
            "operation enabled throughout"
        );
    }

    #[test]
    fn quick_stop_option_codes_the_drive_does_not_have_are_refused() {
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        for bad in [0u32, 3, 4, 7, 8, 0xFFFF] {
            let a = sdo_write(&mut n, cia402::QUICK_STOP_OPTION, 0, bad, 2);
            assert_eq!(abort_code(&a), Some(0x0609_0030), "{bad}");
        }
        for good in [1u32, 2, 5, 6] {
            let a = sdo_write(&mut n, cia402::QUICK_STOP_OPTION, 0, good, 2);
            assert_eq!(abort_code(&a), None, "{good}");
            assert_eq!(n.drive.quick_stop_option(), good as i16);
        }
    }

    #[test]
    fn the_io_module_reads_its_inputs_and_drives_its_output() {
        let mut plant = crate::physics::plant_from_str(
            include_str!("../../../config/plants/solenoid.toml"),
            "solenoid.toml",
        )
        .expect("plant");
        let mut n = ProfileNode::new(Profile::Cia401, 16, vec![]);
        let mut t2 = n.pdos()[3].clone();
        t2.transmission_type = 1;
        for w in t2.configuration_writes() {
            let a = sdo_write(&mut n, w.id.index, w.id.sub, w.value, w.size);
            assert_eq!(abort_code(&a), None, "{}", w.id);
        }
        let r2 = n.pdos()[1].clone();
        let op = NmtState::Operational;
        let mut last = vec![];
        for _ in 0..400 {
            // 12 V on analog output 1.
            n.handle(
                &r2.pack(|id| if id.sub == 1 { 12000 } else { 0 }),
                op,
                &mut |_| {},
            );
            last.clear();
            n.on_sync(plant.as_mut(), 0.0025, op, &mut |f| last.push(*f));
        }
        assert_eq!(last.len(), 1, "one TPDO per SYNC (type 1)");
        let v: Vec<i64> = t2
            .unpack(last[0].data())
            .expect("full")
            .map(|(o, raw)| sign_extend(raw, o.bits))
            .collect();
        // The solenoid at 12 V rests near 10 mm; the supply reads 24 V in mV.
        let expected = (1.63 * 12.0 - 3.0) / 1650.0;
        assert!((v[0] as f64 * 1e-6 - expected).abs() < 3e-4, "{v:?}");
        assert!(
            (v[2] - 24000).abs() < 100,
            "supply {} mV (noise 20 mV)",
            v[2]
        );
    }
}
