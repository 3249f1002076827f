//! The fixed frame layout of the protocol: every frame, its COB-ID, its signals.
//!
//! `dbc/actuatord.dbc` is rendered from these tables (`actuator dbc`), and a test decodes codec
//! output with that file, so code and DBC cannot drift apart.

use crate::canopen::emcy::EMCY_FUNCTION_CODE;
use crate::canopen::nmt::{HEARTBEAT_FUNCTION_CODE, NMT_COB_ID, SYNC_COB_ID};
use crate::canopen::Signal;

/// Whose node id is added to the function code to give the COB-ID.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IdBase {
    /// The control daemon's (`actuatord`) node id: its TPDOs and RPDOs, EMCY, heartbeat.
    Controller,
    /// The actuator node's id (real, or `actuator sim`).
    Actuator,
    /// Broadcast frames with a fixed id (NMT, SYNC).
    Fixed,
}

/// DBC node names of the transmitters.
pub const NODE_CONTROLLER: &str = "actuatord";
pub const NODE_ACTUATOR: &str = "actuator_node";
/// Whoever commands the axes: a PLC, a vehicle ECU, or `cansend`.
pub const NODE_AUTOMATION: &str = "automation";

/// One frame of the protocol.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Message {
    pub name: &'static str,
    /// CANopen function code; the COB-ID is `function_code + node_id` unless the sender is Fixed.
    pub function_code: u32,
    pub id_base: IdBase,
    /// DBC node that transmits it.
    pub transmitter: &'static str,
    pub dlc: usize,
    pub signals: &'static [Signal],
    pub comment: &'static str,
}

impl Message {
    pub fn cob_id(&self, node_id: u8) -> u32 {
        match self.id_base {
            IdBase::Fixed => self.function_code,
            _ => self.function_code + u32::from(node_id),
        }
    }

    pub fn signal(&self, name: &str) -> Option<&'static Signal> {
        self.signals.iter().find(|s| s.name == name)
    }
}

/// Signal names of the fault flags, bit 0 first: `fault_` and the name of `supervise::FaultKind`.
pub const FAULT_FLAG_NAMES: [&str; 8] = [
    "fault_following_error",
    "fault_end_of_range",
    "fault_overcurrent",
    "fault_supply_voltage",
    "fault_supply_pressure",
    "fault_sensor_timeout",
    "fault_heartbeat_lost",
    "fault_node_state",
];

/// Signal names of the supervised-fault flags, bit 0 first: `fault_` and the name of
/// `supervise::SupervisedFault` (without `limit_violation`, which the fault flags above detail).
pub const SUPERVISED_FLAG_NAMES: [&str; 7] = [
    "fault_spring_pretension",
    "fault_spring_stiffness",
    "fault_friction_increase",
    "fault_current_gain",
    "fault_observer_friction",
    "fault_estimator_implausible",
    "fault_sensor_offset",
];

/// Signal names of the symptoms, in the order of `supervise::PHYSICAL_NAMES`.
pub const SYMPTOM_NAMES: [&str; 6] = [
    "symptom_current_time_constant",
    "symptom_damping_ratio",
    "symptom_natural_frequency",
    "symptom_static_gain",
    "symptom_coulomb_friction",
    "symptom_pretension",
];

const fn flag(bit: u16, name: &'static str, comment: &'static str) -> Signal {
    Signal::raw(name, bit, 1, comment)
}

const fn scaled(
    name: &'static str,
    start_bit: u16,
    bits: u8,
    signed: bool,
    factor: f64,
    unit: &'static str,
    comment: &'static str,
) -> Signal {
    Signal {
        name,
        start_bit,
        bits,
        signed,
        factor,
        offset: 0.0,
        unit,
        comment,
    }
}

/// Fault flag signals starting at `base`, in [`FAULT_FLAG_NAMES`] order.
macro_rules! fault_flags {
    ($base:expr) => {
        [
            flag(
                $base,
                "fault_following_error",
                "|setpoint - position| above its limit for longer than allowed",
            ),
            flag(
                $base + 1,
                "fault_end_of_range",
                "position outside the configured travel",
            ),
            flag(
                $base + 2,
                "fault_overcurrent",
                "current above its limit for longer than allowed",
            ),
            flag(
                $base + 3,
                "fault_supply_voltage",
                "supply voltage outside its band",
            ),
            flag(
                $base + 4,
                "fault_supply_pressure",
                "supply pressure outside its band",
            ),
            flag(
                $base + 5,
                "fault_sensor_timeout",
                "sensor frames missing for too many cycles",
            ),
            flag(
                $base + 6,
                "fault_heartbeat_lost",
                "actuator node heartbeat missing",
            ),
            flag(
                $base + 7,
                "fault_node_state",
                "actuator node left the operational state",
            ),
        ]
    };
}

/// Supervised-fault flag signals starting at `base`, in [`SUPERVISED_FLAG_NAMES`] order; the
/// seventh (added later) at `seventh`, where the frame had room for it.
macro_rules! supervised_flags {
    ($base:expr, $seventh:expr) => {
        [
            flag(
                $base,
                "fault_spring_pretension",
                "F1 diagnosed and latched: spring pretension too high",
            ),
            flag(
                $base + 1,
                "fault_spring_stiffness",
                "F2 diagnosed and latched: spring constant dropped",
            ),
            flag(
                $base + 2,
                "fault_friction_increase",
                "F3 diagnosed and latched: friction increased",
            ),
            flag(
                $base + 3,
                "fault_current_gain",
                "F4 diagnosed and latched: current circuit gain dropped",
            ),
            flag(
                $base + 4,
                "fault_observer_friction",
                "observer x4+ below and x4- above their learned bands: friction rise",
            ),
            flag(
                $base + 5,
                "fault_estimator_implausible",
                "drive-gain estimate implausible, scheduled gains in use",
            ),
            flag(
                $seventh,
                "fault_sensor_offset",
                "F5 diagnosed and latched: the position sensor reads with an offset",
            ),
        ]
    };
}

const STATE_COMMENT: &str =
    "0 ok, 1 warning (limit exceeded not yet latched, or a warning latched), \
2 fail_safe (latched, axis in safe state), 3 maintenance_requested (latched, axis keeps working)";

const DIAGNOSED_COMMENT: &str =
    "latest latched supervised fault: 0 none, 1 spring_pretension (F1), \
2 spring_stiffness (F2), 3 friction_increase (F3), 4 current_gain (F4), 5 observer_friction, \
6 estimator_implausible, 7 limit_violation, 8 sensor_offset (F5)";

const fn symptom(name: &'static str, start_bit: u16, comment: &'static str) -> Signal {
    Signal {
        name,
        start_bit,
        bits: 2,
        signed: true,
        factor: 1.0,
        offset: 0.0,
        unit: "",
        comment,
    }
}

const SYNC_SIGNALS: [Signal; 1] = [Signal::raw(
    "sync_counter",
    0,
    8,
    "CiA 301 SYNC counter, 1..=240, wraps to 1",
)];

const NMT_SIGNALS: [Signal; 2] = [
    Signal::raw(
        "nmt_command",
        0,
        8,
        "1 start, 2 stop, 128 pre-operational, 129 reset node, 130 reset communication",
    ),
    Signal::raw("nmt_node_id", 8, 8, "addressed node, 0 = all"),
];

const HEARTBEAT_SIGNALS: [Signal; 1] = [Signal::raw(
    "nmt_state",
    0,
    7,
    "0 boot-up, 4 stopped, 5 operational, 127 pre-operational",
)];

const SENSOR_SIGNALS: [Signal; 3] = [
    scaled("position", 0, 32, true, 1e-7, "m", "measured position"),
    scaled(
        "current",
        32,
        16,
        true,
        1e-3,
        "A",
        "measured coil or armature current",
    ),
    scaled(
        "supply_voltage",
        48,
        16,
        false,
        1e-3,
        "V",
        "measured supply voltage",
    ),
];

const SUPPLY_PRESSURE_SIGNALS: [Signal; 1] = [scaled(
    "supply_pressure",
    0,
    32,
    false,
    1.0,
    "Pa",
    "measured absolute supply pressure",
)];

const COMMAND_SIGNALS: [Signal; 3] = [
    scaled(
        "command_voltage",
        0,
        16,
        true,
        1e-3,
        "V",
        "terminal voltage to apply (solenoid, motor)",
    ),
    scaled(
        "command_duty",
        16,
        16,
        true,
        1e-4,
        "",
        "signed valve duty -1..1 (pneumatic: < 0 valve to low pressure, > 0 valve to atmosphere)",
    ),
    Signal::raw(
        "command_sync_counter",
        32,
        8,
        "SYNC counter this command answers",
    ),
];

const SETPOINT_SIGNALS: [Signal; 2] = [
    scaled(
        "setpoint_position",
        0,
        32,
        true,
        1e-7,
        "m",
        "position setpoint",
    ),
    Signal::raw("axis_node_id", 32, 8, "node id of the axis' actuator node"),
];

const FAULT_RESET_SIGNALS: [Signal; 1] = [Signal::raw(
    "axis_node_id",
    0,
    8,
    "node id of the axis to reset, 0 = all axes",
)];

const FAULT_STATE_SIGNALS: [Signal; 12] = {
    let f = fault_flags!(16);
    [
        Signal::raw("axis_node_id", 0, 8, "node id of the axis' actuator node"),
        Signal::raw("fault_state", 8, 8, STATE_COMMENT),
        f[0],
        f[1],
        f[2],
        f[3],
        f[4],
        f[5],
        f[6],
        f[7],
        Signal::raw("diagnosed_fault", 24, 8, DIAGNOSED_COMMENT),
        scaled(
            "following_error",
            32,
            32,
            true,
            1e-7,
            "m",
            "setpoint - position",
        ),
    ]
};

const FAULT_DIAGNOSIS_SIGNALS: [Signal; 19] = {
    let f = supervised_flags!(16, 23);
    [
        Signal::raw("axis_node_id", 0, 8, "node id of the axis' actuator node"),
        scaled(
            "diagnosis_confidence",
            8,
            7,
            false,
            0.01,
            "",
            "confidence of diagnosed_fault: 1 - differing symptoms / 6 for F1-F4, 1 otherwise",
        ),
        Signal::raw(
            "nominal_learned",
            15,
            1,
            "nominal physical parameters known (configured or learned)",
        ),
        f[0],
        f[1],
        f[2],
        f[3],
        f[4],
        f[5],
        f[6],
        Signal::raw(
            "observer_learned",
            22,
            1,
            "observer x4 bands of both directions learned",
        ),
        symptom(
            "symptom_current_time_constant",
            24,
            "T_I vs nominal: -1 below, 0 within, +1 above its threshold",
        ),
        symptom("symptom_damping_ratio", 26, "D vs nominal: -1, 0, +1"),
        symptom(
            "symptom_natural_frequency",
            28,
            "omega0 vs nominal: -1, 0, +1",
        ),
        symptom("symptom_static_gain", 30, "K_P vs nominal: -1, 0, +1"),
        symptom("symptom_coulomb_friction", 32, "F_C vs nominal: -1, 0, +1"),
        symptom("symptom_pretension", 34, "F_0 vs nominal: -1, 0, +1"),
        scaled(
            "observer_x4_pos",
            40,
            12,
            true,
            5e-6,
            "m",
            "observer disturbance state x4, smoothed, moving in +",
        ),
        scaled(
            "observer_x4_neg",
            52,
            12,
            true,
            5e-6,
            "m",
            "observer disturbance state x4, smoothed, moving in -",
        ),
    ]
};

const EMCY_SIGNALS: [Signal; 20] = {
    let f = fault_flags!(32);
    let g = supervised_flags!(56, 62);
    [
        Signal::raw(
            "emcy_error_code",
            0,
            16,
            "CiA 301/402 error code, 0 = error reset",
        ),
        Signal::raw(
            "emcy_error_register",
            16,
            8,
            "CiA 301 error register (object 1001h)",
        ),
        Signal::raw("axis_node_id", 24, 8, "node id of the axis' actuator node"),
        f[0],
        f[1],
        f[2],
        f[3],
        f[4],
        f[5],
        f[6],
        f[7],
        Signal::raw("fault_state", 40, 8, STATE_COMMENT),
        Signal::raw("diagnosed_fault", 48, 8, DIAGNOSED_COMMENT),
        g[0],
        g[1],
        g[2],
        g[3],
        g[4],
        g[5],
        g[6],
    ]
};

const TUNED_PARAMETER_SIGNALS: [Signal; 5] = [
    Signal::raw("axis_node_id", 0, 8, "node id of the axis' actuator node"),
    scaled(
        "friction_compensation",
        8,
        16,
        true,
        1e-3,
        "V",
        "friction compensation voltage in use",
    ),
    scaled(
        "gain_schedule_factor",
        24,
        16,
        false,
        1e-3,
        "",
        "controller gain factor from the supply schedule",
    ),
    scaled(
        "friction_compensation_pos",
        40,
        12,
        false,
        1e-3,
        "V",
        "friction compensation for motion in + (U_comp+), learned or feed-forward",
    ),
    scaled(
        "friction_compensation_neg",
        52,
        12,
        false,
        1e-3,
        "V",
        "friction compensation for motion in - (U_comp-), learned or feed-forward",
    ),
];

const TUNED_GAIN_SIGNALS: [Signal; 7] = [
    Signal::raw("axis_node_id", 0, 8, "node id of the axis' actuator node"),
    scaled(
        "gain_down",
        8,
        14,
        false,
        0.5,
        "1/m",
        "direction P gain q01 in use (duty per m of error, error < 0)",
    ),
    scaled(
        "gain_up",
        22,
        14,
        false,
        0.5,
        "1/m",
        "direction P gain q02 in use (duty per m of error, error > 0)",
    ),
    scaled(
        "drive_gain_down",
        36,
        12,
        false,
        1e-4,
        "m/s",
        "estimated drive gain K_I1 (valve to low pressure, moving down)",
    ),
    scaled(
        "drive_gain_up",
        48,
        12,
        false,
        1e-4,
        "m/s",
        "estimated drive gain K_I2 (valve to atmosphere, moving up)",
    ),
    Signal::raw(
        "gain_source_down",
        60,
        1,
        "0 scheduled, 1 adapted (estimate valid and plausible)",
    ),
    Signal::raw("gain_source_up", 61, 1, "0 scheduled, 1 adapted"),
];

const LOOP_STATUS_SIGNALS: [Signal; 5] = [
    Signal::raw(
        "overruns",
        0,
        16,
        "cycles that missed their deadline, total (wraps)",
    ),
    Signal::raw(
        "sensor_missed",
        16,
        16,
        "cycles without a sensor frame in time, total (wraps)",
    ),
    Signal::raw(
        "frames_malformed",
        32,
        8,
        "frames with a known id but a wrong length, total (wraps)",
    ),
    Signal::raw(
        "bus_faults",
        40,
        8,
        "bus faults (interface down or gone, bus-off, error passive, ...), total (wraps)",
    ),
    scaled(
        "cycle_latency_max",
        48,
        16,
        false,
        1e-6,
        "s",
        "largest delay from cycle start to command sent since the last report",
    ),
];

pub const NMT: Message = Message {
    name: "nmt",
    function_code: NMT_COB_ID,
    id_base: IdBase::Fixed,
    transmitter: NODE_CONTROLLER,
    dlc: 2,
    signals: &NMT_SIGNALS,
    comment: "NMT node control, sent by the controller",
};

pub const SYNC: Message = Message {
    name: "sync",
    function_code: SYNC_COB_ID,
    id_base: IdBase::Fixed,
    transmitter: NODE_CONTROLLER,
    dlc: 1,
    signals: &SYNC_SIGNALS,
    comment: "SYNC from the controller, starts every control cycle",
};

pub const EMCY: Message = Message {
    name: "emcy",
    function_code: EMCY_FUNCTION_CODE,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &EMCY_SIGNALS,
    comment: "emergency: a fault was raised (or reset, error code 0)",
};

pub const SENSOR: Message = Message {
    name: "sensor",
    function_code: 0x180,
    id_base: IdBase::Actuator,
    transmitter: NODE_ACTUATOR,
    dlc: 8,
    signals: &SENSOR_SIGNALS,
    comment: "TPDO1 of the actuator node, answers every SYNC",
};

pub const SUPPLY_PRESSURE: Message = Message {
    name: "sensor_supply_pressure",
    function_code: 0x280,
    id_base: IdBase::Actuator,
    transmitter: NODE_ACTUATOR,
    dlc: 4,
    signals: &SUPPLY_PRESSURE_SIGNALS,
    comment: "TPDO2 of a pneumatic actuator node, after every sensor frame",
};

pub const COMMAND: Message = Message {
    name: "command",
    function_code: 0x200,
    id_base: IdBase::Actuator,
    transmitter: NODE_CONTROLLER,
    dlc: 5,
    signals: &COMMAND_SIGNALS,
    comment: "RPDO1 of the actuator node: the actuator command, once per cycle",
};

pub const FAULT_STATE: Message = Message {
    name: "fault_state",
    function_code: 0x180,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &FAULT_STATE_SIGNALS,
    comment: "TPDO1 of the controller: fault state of one axis, every status period and on change",
};

pub const TUNED_PARAMETERS: Message = Message {
    name: "tuned_parameters",
    function_code: 0x280,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &TUNED_PARAMETER_SIGNALS,
    comment: "TPDO2 of the controller: parameters the axis is running with, every status period",
};

pub const FAULT_DIAGNOSIS: Message = Message {
    name: "fault_diagnosis",
    function_code: 0x400,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &FAULT_DIAGNOSIS_SIGNALS,
    comment: "controller: confidence, latched supervised faults, symptoms and observer x4 of one axis, with every fault_state frame",
};

pub const TUNED_GAINS: Message = Message {
    name: "tuned_gains",
    function_code: 0x480,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &TUNED_GAIN_SIGNALS,
    comment: "TPDO4 of the controller: direction P gains and estimated drive gains of a duty axis, every status period",
};

pub const LOOP_STATUS: Message = Message {
    name: "loop_status",
    function_code: 0x380,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 8,
    signals: &LOOP_STATUS_SIGNALS,
    comment: "TPDO3 of the controller: cycle timing counters, every status period",
};

pub const SETPOINT: Message = Message {
    name: "setpoint",
    function_code: 0x200,
    id_base: IdBase::Controller,
    transmitter: NODE_AUTOMATION,
    dlc: 5,
    signals: &SETPOINT_SIGNALS,
    comment: "RPDO1 of the controller: position setpoint for one axis",
};

pub const FAULT_RESET: Message = Message {
    name: "fault_reset",
    function_code: 0x300,
    id_base: IdBase::Controller,
    transmitter: NODE_AUTOMATION,
    dlc: 1,
    signals: &FAULT_RESET_SIGNALS,
    comment: "RPDO2 of the controller: clear latched faults",
};

pub const HEARTBEAT_CONTROLLER: Message = Message {
    name: "heartbeat_controller",
    function_code: HEARTBEAT_FUNCTION_CODE,
    id_base: IdBase::Controller,
    transmitter: NODE_CONTROLLER,
    dlc: 1,
    signals: &HEARTBEAT_SIGNALS,
    comment: "heartbeat of the controller: its NMT state",
};

pub const HEARTBEAT_ACTUATOR: Message = Message {
    name: "heartbeat_actuator",
    function_code: HEARTBEAT_FUNCTION_CODE,
    id_base: IdBase::Actuator,
    transmitter: NODE_ACTUATOR,
    dlc: 1,
    signals: &HEARTBEAT_SIGNALS,
    comment: "heartbeat of the actuator node: its NMT state",
};

/// Every frame, for the DBC and for tests.
pub const ALL: [&Message; 15] = [
    &NMT,
    &SYNC,
    &EMCY,
    &SENSOR,
    &SUPPLY_PRESSURE,
    &COMMAND,
    &FAULT_STATE,
    &TUNED_PARAMETERS,
    &FAULT_DIAGNOSIS,
    &TUNED_GAINS,
    &LOOP_STATUS,
    &SETPOINT,
    &FAULT_RESET,
    &HEARTBEAT_CONTROLLER,
    &HEARTBEAT_ACTUATOR,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signal_names_are_unique_within_a_frame() {
        for m in ALL {
            for (i, s) in m.signals.iter().enumerate() {
                assert!(
                    m.signals[..i].iter().all(|o| o.name != s.name),
                    "{}.{} twice",
                    m.name,
                    s.name
                );
            }
        }
    }

    #[test]
    fn every_signal_fits_its_frame_and_no_two_overlap() {
        for m in ALL {
            let mut used = 0u64;
            for s in m.signals {
                assert!(s.end_byte() <= m.dlc, "{}.{} runs past dlc", m.name, s.name);
                let mask = ((1u128 << s.bits) - 1) as u64;
                assert_eq!(
                    used & (mask << s.start_bit),
                    0,
                    "{}.{} overlaps",
                    m.name,
                    s.name
                );
                used |= mask << s.start_bit;
            }
        }
    }

    #[test]
    fn bus_names_match_the_protocol_table() {
        let names: Vec<_> = crate::supervise::FaultKind::ALL
            .iter()
            .map(|k| format!("fault_{}", k.name()))
            .collect();
        assert_eq!(names, FAULT_FLAG_NAMES);
    }
}
