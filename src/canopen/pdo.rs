//! The process data objects with their fixed mapping, typed.

use super::codec::{pack, unpack, DecodeError};
use super::messages::{
    Message, COMMAND, FAULT_RESET, FAULT_STATE, LOOP_STATUS, SENSOR, SETPOINT, SUPPLY_PRESSURE,
    TUNED_PARAMETERS,
};
use crate::bus::Frame;
use crate::supervise::{FaultFlags, FaultKind, FaultState};

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
                self.following_error,
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let v: [f64; 11] = unpack(&FAULT_STATE, frame)?;
        let state = FaultState::from_code(v[1] as u8)
            .ok_or_else(|| bad_value(&FAULT_STATE, frame, "fault_state", v[1]))?;
        Ok(Self {
            axis_node_id: v[0] as u8,
            state,
            flags: flags_from(&v[2..10]),
            following_error: v[10],
        })
    }
}

/// Parameters an axis is running with (TPDO2 of the controller).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TunedParametersPdo {
    pub axis_node_id: u8,
    pub friction_compensation_v: f64,
    pub gain_schedule_factor: f64,
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
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [axis, friction_compensation_v, gain_schedule_factor] =
            unpack(&TUNED_PARAMETERS, frame)?;
        Ok(Self {
            axis_node_id: axis as u8,
            friction_compensation_v,
            gain_schedule_factor,
        })
    }
}

/// Cycle timing counters (TPDO3 of the controller). Counters wrap at 65535.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoopStatusPdo {
    pub overruns: u16,
    pub sensor_missed: u16,
    pub frames_malformed: u16,
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
                self.cycle_latency_max_s,
            ],
        )
        .0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let [overruns, sensor_missed, frames_malformed, cycle_latency_max_s] =
            unpack(&LOOP_STATUS, frame)?;
        Ok(Self {
            overruns: overruns as u16,
            sensor_missed: sensor_missed as u16,
            frames_malformed: frames_malformed as u16,
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
                following_error: -0.0021,
            };
            let d = FaultStatePdo::decode(&p.encode(1)).expect("decodes");
            assert_eq!(d.flags, flags);
            assert_eq!(d.state, FaultState::Fault);
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
