//! The process data objects with their fixed mapping, typed.

use super::codec::{pack, unpack, DecodeError};
use super::messages::{
    Message, COMMAND, FAULT_DIAGNOSIS, FAULT_RESET, FAULT_STATE, LOOP_STATUS, SENSOR, SETPOINT,
    SUPPLY_PRESSURE, TUNED_GAINS, TUNED_PARAMETERS,
};
use crate::canopen::Frame;
use crate::supervise::{
    FaultFlags, FaultKind, FaultState, SupervisedFault, SupervisedFaults, Symptom, PHYSICAL_PARAMS,
};

/// `diagnosed_fault` on the bus: 0 none, else the position in `SupervisedFault::ALL` plus one.
pub fn diagnosed_fault_code(fault: Option<SupervisedFault>) -> u8 {
    fault.map_or(0, |f| f as u8 + 1)
}

/// The inverse of [`diagnosed_fault_code`]; `None` inside `Some` is "no fault", outer `None` an
/// unknown code.
pub fn diagnosed_fault_from_code(code: u8) -> Option<Option<SupervisedFault>> {
    match code {
        0 => Some(None),
        c => SupervisedFault::ALL
            .get(usize::from(c) - 1)
            .map(|f| Some(*f)),
    }
}

/// The supervised faults with a flag of their own on the bus (limit violations are detailed by
/// the limit fault flags).
pub const SUPERVISED_FLAGGED: [SupervisedFault; 7] = [
    SupervisedFault::SpringPretension,
    SupervisedFault::SpringStiffness,
    SupervisedFault::FrictionIncrease,
    SupervisedFault::CurrentGain,
    SupervisedFault::ObserverFriction,
    SupervisedFault::EstimatorImplausible,
    SupervisedFault::SensorOffset,
];

pub(crate) fn supervised_values(faults: SupervisedFaults) -> [f64; 7] {
    SUPERVISED_FLAGGED.map(|f| if faults.contains(f) { 1.0 } else { 0.0 })
}

pub(crate) fn supervised_from(values: &[f64]) -> SupervisedFaults {
    let mut faults = SupervisedFaults::default();
    for (f, v) in SUPERVISED_FLAGGED.iter().zip(values) {
        if *v != 0.0 {
            faults.insert(*f);
        }
    }
    faults
}

fn symptom_value(s: Symptom) -> f64 {
    match s {
        Symptom::Minus => -1.0,
        Symptom::Zero => 0.0,
        Symptom::Plus => 1.0,
    }
}

fn symptom_from(v: f64) -> Symptom {
    if v < 0.0 {
        Symptom::Minus
    } else if v > 0.0 {
        Symptom::Plus
    } else {
        Symptom::Zero
    }
}

/// Sensor data from the actuator node (TPDO1 of the actuator).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorPdo {
    /// m
    pub position: f64,
    pub current_a: f64,
    pub supply_voltage_v: f64,
}

impl SensorPdo {
    pub fn encode(&self, actuator_node: u8) -> Frame {
        pack(
            &SENSOR,
            actuator_node,
            &[self.position, self.current_a, self.supply_voltage_v],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [position, current_a, supply_voltage_v] = unpack(&SENSOR, frame)?;
        Ok(Self {
            position,
            current_a,
            supply_voltage_v,
        })
    }
}

/// Supply pressure from a pneumatic actuator node (TPDO2 of the actuator).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SupplyPressurePdo {
    pub supply_pressure_pa: f64,
}

impl SupplyPressurePdo {
    pub fn encode(&self, actuator_node: u8) -> Frame {
        pack(&SUPPLY_PRESSURE, actuator_node, &[self.supply_pressure_pa]).0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [supply_pressure_pa] = unpack(&SUPPLY_PRESSURE, frame)?;
        Ok(Self { supply_pressure_pa })
    }
}

/// The actuator command (RPDO1 of the actuator).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CommandPdo {
    pub voltage_v: f64,
    /// Signed valve duty, -1..1.
    pub duty: f64,
    /// The SYNC counter this command answers, so the node can tell a late command.
    pub sync_counter: u8,
}

impl CommandPdo {
    pub fn encode(&self, actuator_node: u8) -> Frame {
        pack(
            &COMMAND,
            actuator_node,
            &[self.voltage_v, self.duty, f64::from(self.sync_counter)],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [voltage_v, duty, counter] = unpack(&COMMAND, frame)?;
        Ok(Self {
            voltage_v,
            duty,
            sync_counter: counter as u8,
        })
    }
}

/// A position setpoint for one axis (RPDO1 of the controller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SetpointPdo {
    /// m
    pub position: f64,
    pub axis_node_id: u8,
}

impl SetpointPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        pack(
            &SETPOINT,
            controller_node,
            &[self.position, f64::from(self.axis_node_id)],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [position, axis] = unpack(&SETPOINT, frame)?;
        Ok(Self {
            position,
            axis_node_id: axis as u8,
        })
    }
}

/// Clear latched faults (RPDO2 of the controller); axis 0 means every axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FaultResetPdo {
    pub axis_node_id: u8,
}

impl FaultResetPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        pack(
            &FAULT_RESET,
            controller_node,
            &[f64::from(self.axis_node_id)],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [axis] = unpack(&FAULT_RESET, frame)?;
        Ok(Self {
            axis_node_id: axis as u8,
        })
    }
}

/// Fault state of one axis (TPDO1 of the controller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FaultStatePdo {
    pub axis_node_id: u8,
    pub state: FaultState,
    pub flags: FaultFlags,
    /// The latest latched supervised fault, `None` when nothing is latched.
    pub diagnosed_fault: Option<SupervisedFault>,
    /// setpoint - position, m
    pub following_error: f64,
}

fn flag_values(flags: FaultFlags) -> [f64; 8] {
    FaultKind::ALL.map(|k| if flags.contains(k) { 1.0 } else { 0.0 })
}

fn flags_from(values: &[f64]) -> FaultFlags {
    let mut flags = FaultFlags::default();
    for (k, v) in FaultKind::ALL.iter().zip(values) {
        if *v != 0.0 {
            flags.insert(*k);
        }
    }
    flags
}

fn bad_value(message: &Message, frame: &Frame, signal: &'static str, value: f64) -> DecodeError {
    DecodeError::BadValue {
        name: message.name,
        id: frame.id(),
        signal,
        value: value as i64,
    }
}

impl FaultStatePdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        let f = flag_values(self.flags);
        pack(
            &FAULT_STATE,
            controller_node,
            &[
                f64::from(self.axis_node_id),
                f64::from(self.state.code()),
                f[0],
                f[1],
                f[2],
                f[3],
                f[4],
                f[5],
                f[6],
                f[7],
                f64::from(diagnosed_fault_code(self.diagnosed_fault)),
                self.following_error,
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let v: [f64; 12] = unpack(&FAULT_STATE, frame)?;
        let state = FaultState::from_code(v[1] as u8)
            .ok_or_else(|| bad_value(&FAULT_STATE, frame, "fault_state", v[1]))?;
        let diagnosed_fault = diagnosed_fault_from_code(v[10] as u8)
            .ok_or_else(|| bad_value(&FAULT_STATE, frame, "diagnosed_fault", v[10]))?;
        Ok(Self {
            axis_node_id: v[0] as u8,
            state,
            flags: flags_from(&v[2..10]),
            diagnosed_fault,
            following_error: v[11],
        })
    }
}

/// Parameters an axis is running with (TPDO2 of the controller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TunedParametersPdo {
    pub axis_node_id: u8,
    /// Compensation applied this cycle, V.
    pub friction_compensation_v: f64,
    pub gain_schedule_factor: f64,
    /// `U_comp+`, `U_comp-` (learned, or the feed-forward values), V.
    pub friction_compensation_pos_v: f64,
    pub friction_compensation_neg_v: f64,
}

impl TunedParametersPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        pack(
            &TUNED_PARAMETERS,
            controller_node,
            &[
                f64::from(self.axis_node_id),
                self.friction_compensation_v,
                self.gain_schedule_factor,
                self.friction_compensation_pos_v,
                self.friction_compensation_neg_v,
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [axis, friction_compensation_v, gain_schedule_factor, pos, neg] =
            unpack(&TUNED_PARAMETERS, frame)?;
        Ok(Self {
            axis_node_id: axis as u8,
            friction_compensation_v,
            gain_schedule_factor,
            friction_compensation_pos_v: pos,
            friction_compensation_neg_v: neg,
        })
    }
}

/// Direction P gains and drive-gain estimates of a duty axis (TPDO4 of the controller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TunedGainsPdo {
    pub axis_node_id: u8,
    /// `q01`, `q02` in use, duty per m.
    pub gain_down_per_m: f64,
    pub gain_up_per_m: f64,
    /// Estimated `K_I1`, `K_I2`, m/s.
    pub drive_gain_down_m_per_s: f64,
    pub drive_gain_up_m_per_s: f64,
    /// The gain in use comes from the estimate (true) or the schedule (false).
    pub adapted_down: bool,
    pub adapted_up: bool,
}

impl TunedGainsPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        let bit = |b: bool| if b { 1.0 } else { 0.0 };
        pack(
            &TUNED_GAINS,
            controller_node,
            &[
                f64::from(self.axis_node_id),
                self.gain_down_per_m,
                self.gain_up_per_m,
                self.drive_gain_down_m_per_s,
                self.drive_gain_up_m_per_s,
                bit(self.adapted_down),
                bit(self.adapted_up),
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [axis, gd, gu, kd, ku, ad, au] = unpack(&TUNED_GAINS, frame)?;
        Ok(Self {
            axis_node_id: axis as u8,
            gain_down_per_m: gd,
            gain_up_per_m: gu,
            drive_gain_down_m_per_s: kd,
            drive_gain_up_m_per_s: ku,
            adapted_down: ad != 0.0,
            adapted_up: au != 0.0,
        })
    }
}

/// What the model-based supervision of one axis sees (sent with every fault_state frame).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FaultDiagnosisPdo {
    pub axis_node_id: u8,
    /// Confidence of the diagnosed fault of the fault_state frame, 0..1.
    pub confidence: f64,
    pub nominal_learned: bool,
    /// Latched supervised faults (limit violations are in the fault_state flags).
    pub latched: SupervisedFaults,
    pub observer_learned: bool,
    /// Symptoms over `[T_I, D, ω0, K_P, F_C, F_0]` of the last estimation window.
    pub symptoms: [Symptom; PHYSICAL_PARAMS],
    /// Smoothed observer `x4` per direction, m.
    pub observer_x4_pos: f64,
    pub observer_x4_neg: f64,
}

impl FaultDiagnosisPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        let bit = |b: bool| if b { 1.0 } else { 0.0 };
        let g = supervised_values(self.latched);
        let y = self.symptoms.map(symptom_value);
        pack(
            &FAULT_DIAGNOSIS,
            controller_node,
            &[
                f64::from(self.axis_node_id),
                self.confidence,
                bit(self.nominal_learned),
                g[0],
                g[1],
                g[2],
                g[3],
                g[4],
                g[5],
                g[6],
                bit(self.observer_learned),
                y[0],
                y[1],
                y[2],
                y[3],
                y[4],
                y[5],
                // Not learned yet (NaN) goes out as 0, which the learned bit qualifies.
                if self.observer_x4_pos.is_finite() {
                    self.observer_x4_pos
                } else {
                    0.0
                },
                if self.observer_x4_neg.is_finite() {
                    self.observer_x4_neg
                } else {
                    0.0
                },
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let v: [f64; 19] = unpack(&FAULT_DIAGNOSIS, frame)?;
        let mut symptoms = [Symptom::Zero; PHYSICAL_PARAMS];
        for (s, x) in symptoms.iter_mut().zip(&v[11..17]) {
            *s = symptom_from(*x);
        }
        Ok(Self {
            axis_node_id: v[0] as u8,
            confidence: v[1],
            nominal_learned: v[2] != 0.0,
            latched: supervised_from(&v[3..10]),
            observer_learned: v[10] != 0.0,
            symptoms,
            observer_x4_pos: v[17],
            observer_x4_neg: v[18],
        })
    }
}

/// Cycle timing counters (TPDO3 of the controller). Counters wrap at their width (65535, 255).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoopStatusPdo {
    pub overruns: u16,
    pub sensor_missed: u16,
    pub frames_malformed: u8,
    pub bus_faults: u8,
    pub cycle_latency_max_s: f64,
}

impl LoopStatusPdo {
    pub fn encode(&self, controller_node: u8) -> Frame {
        pack(
            &LOOP_STATUS,
            controller_node,
            &[
                f64::from(self.overruns),
                f64::from(self.sensor_missed),
                f64::from(self.frames_malformed),
                f64::from(self.bus_faults),
                self.cycle_latency_max_s,
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [overruns, sensor_missed, frames_malformed, bus_faults, cycle_latency_max_s] =
            unpack(&LOOP_STATUS, frame)?;
        Ok(Self {
            overruns: overruns as u16,
            sensor_missed: sensor_missed as u16,
            frames_malformed: frames_malformed as u8,
            bus_faults: bus_faults as u8,
            cycle_latency_max_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_round_trips_within_resolution() {
        let s = SensorPdo {
            position: 0.012_345_6,
            current_a: -1.234,
            supply_voltage_v: 24.0,
        };
        let f = s.encode(0x10);
        assert_eq!(f.id(), 0x190);
        let d = SensorPdo::decode(&f).expect("decodes");
        assert!((d.position - s.position).abs() <= 0.5e-7);
        assert!((d.current_a - s.current_a).abs() <= 0.5e-3);
        assert!((d.supply_voltage_v - s.supply_voltage_v).abs() <= 0.5e-3);
    }

    #[test]
    fn wrong_length_is_reported_with_the_frame_name() {
        let f = Frame::new(0x190, &[0; 6]).expect("frame");
        let err = SensorPdo::decode(&f).expect_err("too short");
        assert_eq!(
            err.to_string(),
            "frame sensor (0x190) has 6 data bytes, expected 8"
        );
    }

    #[test]
    fn fault_state_carries_every_flag() {
        for kind in FaultKind::ALL {
            let mut flags = FaultFlags::default();
            flags.insert(kind);
            let p = FaultStatePdo {
                axis_node_id: 0x10,
                state: FaultState::Fault,
                flags,
                diagnosed_fault: Some(SupervisedFault::SpringStiffness),
                following_error: -0.0021,
            };
            let d = FaultStatePdo::decode(&p.encode(1)).expect("decodes");
            assert_eq!(d.flags, flags);
            assert_eq!(d.state, FaultState::Fault);
            assert_eq!(d.diagnosed_fault, Some(SupervisedFault::SpringStiffness));
            assert!((d.following_error + 0.0021).abs() < 1e-7);
        }
        let mut bad = FaultStatePdo::default().encode(1).data().to_vec();
        bad[1] = 9;
        let f = Frame::new(0x181, &bad).expect("frame");
        assert!(matches!(
            FaultStatePdo::decode(&f),
            Err(DecodeError::BadValue {
                signal: "fault_state",
                ..
            })
        ));
    }

    #[test]
    fn diagnosis_and_tuned_frames_round_trip_within_resolution() {
        let mut latched = SupervisedFaults::default();
        latched.insert(SupervisedFault::ObserverFriction);
        latched.insert(SupervisedFault::SpringStiffness);
        let d = FaultDiagnosisPdo {
            axis_node_id: 16,
            confidence: 5.0 / 6.0,
            nominal_learned: true,
            latched,
            observer_learned: true,
            symptoms: [
                Symptom::Zero,
                Symptom::Plus,
                Symptom::Minus,
                Symptom::Plus,
                Symptom::Zero,
                Symptom::Minus,
            ],
            observer_x4_pos: -1.94e-3,
            observer_x4_neg: -1.70e-3,
        };
        let back = FaultDiagnosisPdo::decode(&d.encode(1)).expect("decodes");
        assert_eq!(back.symptoms, d.symptoms);
        assert_eq!(back.latched, latched);
        assert!(back.nominal_learned && back.observer_learned);
        assert!((back.confidence - d.confidence).abs() <= 0.005);
        assert!((back.observer_x4_pos - d.observer_x4_pos).abs() <= 2.5e-6);
        assert!((back.observer_x4_neg - d.observer_x4_neg).abs() <= 2.5e-6);
        let g = TunedGainsPdo {
            axis_node_id: 16,
            gain_down_per_m: 1166.7,
            gain_up_per_m: 1590.9,
            drive_gain_down_m_per_s: 0.0301,
            drive_gain_up_m_per_s: 0.0219,
            adapted_down: true,
            adapted_up: false,
        };
        let back = TunedGainsPdo::decode(&g.encode(1)).expect("decodes");
        assert!((back.gain_down_per_m - g.gain_down_per_m).abs() <= 0.25);
        assert!((back.drive_gain_up_m_per_s - g.drive_gain_up_m_per_s).abs() <= 0.5e-4);
        assert!(back.adapted_down && !back.adapted_up);
        assert_eq!(
            diagnosed_fault_from_code(diagnosed_fault_code(Some(SupervisedFault::LimitViolation))),
            Some(Some(SupervisedFault::LimitViolation))
        );
        assert_eq!(
            diagnosed_fault_from_code(8),
            Some(Some(SupervisedFault::SensorOffset))
        );
        assert_eq!(diagnosed_fault_from_code(9), None);
    }

    #[test]
    fn command_and_setpoint_round_trip() {
        let c = CommandPdo {
            voltage_v: 12.5,
            duty: -0.25,
            sync_counter: 240,
        };
        assert_eq!(CommandPdo::decode(&c.encode(0x10)), Ok(c));
        let s = SetpointPdo {
            position: 0.0125,
            axis_node_id: 0x10,
        };
        let d = SetpointPdo::decode(&s.encode(1)).expect("decodes");
        assert!((d.position - 0.0125).abs() < 1e-9);
    }
}
