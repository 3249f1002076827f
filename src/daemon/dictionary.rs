//! The daemon's object dictionary: built from the configuration, fed with live values, and
//! the way SDO writes reach the configuration at a cycle boundary.

use super::axis::AxisStep;
use super::config::{AxisConfig, Config, FrictionCompensationSection};
use super::learned::AxisLearned;
use super::record::CycleRecord;
use crate::canopen::od::{BuildError, Handle, PendingWrite};
use crate::canopen::{ErrorField, ObjectDictionary, ObjectId, Value, ERROR_FIELD_LEN};
use crate::device::objects::axis_intelligence::{
    self, symptom_bits, IntelligenceParameters, BAND_NAMES, ESTIMATE_NAMES, NOMINAL_NAMES,
};
use crate::device::objects::{
    daemon_dictionary, index, AxisKeys, AxisParameters, DeviceParameters, SetpointKeys,
};
use crate::param::Declared;

/// One entry per configuration value the dictionary carries.
pub fn axis_parameters(a: &AxisConfig) -> AxisParameters {
    AxisParameters {
        name: a.name.clone(),
        actuator_node_id: a.actuator_node_id,
        command: a.command,
        keys: AxisKeys {
            safe_command: a.safe_command,
        },
        initial_setpoint_m: a.initial_setpoint_m,
        setpoint: SetpointKeys {
            setpoint_rate_max_m_per_s: a.setpoint_rate_max_m_per_s,
        },
        controller: a.controller.clone(),
        friction_compensation: a.friction_compensation.clone(),
        limits: a.limits.clone(),
        intelligence: intelligence_parameters(a),
    }
}

/// The intelligent sections as the dictionary shows them.
fn intelligence_parameters(a: &AxisConfig) -> IntelligenceParameters {
    IntelligenceParameters {
        adaptive_friction: a.adaptive_friction.clone(),
        observer: a.observer.clone(),
        estimation: a.parameter_estimation.clone(),
        schedule: a.schedule.clone(),
    }
}

pub fn device_parameters(c: &Config) -> DeviceParameters {
    DeviceParameters {
        node_id: c.node.node_id,
        heartbeat_period_s: c.node.heartbeat_period_s,
        ..DeviceParameters::default()
    }
}

/// The dictionary of a configuration.
pub fn build(config: &Config) -> Result<ObjectDictionary, BuildError> {
    let axes: Vec<_> = config.axis.iter().map(axis_parameters).collect();
    daemon_dictionary(&device_parameters(config), &axes)
}

/// The axis' friction compensation, created (neutral) by the first write to one of its keys.
fn friction(a: &mut AxisConfig) -> &mut FrictionCompensationSection {
    a.friction_compensation
        .get_or_insert_with(FrictionCompensationSection::neutral)
}

/// What a write asks the node to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum WriteEffect {
    /// A new setpoint for an axis, now.
    Setpoint { axis: usize, position: f64 },
    /// Clear an axis' latched faults.
    FaultReset { axis: usize },
    /// The configuration changed: rebuild this axis from it (only writable in pre-operational).
    Rebuild { axis: usize },
    /// The node-wide configuration changed (heartbeat period).
    Node,
    /// Forget the errors of the pre-defined error field (0 written to 1003h sub 0).
    ClearErrorField,
}

/// The effect of a write that leaves the configuration alone (a setpoint, a fault reset): what
/// an operational node receives, applied in place without copying the configuration.
pub fn live_effect(w: &PendingWrite) -> Option<WriteEffect> {
    // Sub 0 is its only writable entry, and 0 the only value it takes.
    if w.id.index == index::PRE_DEFINED_ERROR_FIELD {
        return Some(WriteEffect::ClearErrorField);
    }
    let axis = w.axis?;
    match w.name {
        "setpoint_position" => Some(WriteEffect::Setpoint {
            axis,
            position: number(w),
        }),
        "fault_reset" => Some(WriteEffect::FaultReset { axis }),
        _ => None,
    }
}

fn number(w: &PendingWrite) -> f64 {
    match w.value {
        Value::Real64(v) => v,
        Value::Real32(v) => f64::from(v),
        Value::Unsigned8(v) => f64::from(v),
        Value::Unsigned16(v) => f64::from(v),
        Value::Unsigned32(v) => f64::from(v),
        Value::Boolean(b) => f64::from(u8::from(b)),
        _ => f64::NAN,
    }
}

/// Apply one staged write to `config`. Infinite bounds mean "not watched", as in the dictionary.
pub fn apply_write(config: &mut Config, w: &PendingWrite) -> Result<WriteEffect, String> {
    if let Some(effect) = live_effect(w) {
        return Ok(effect);
    }
    let number = number(w);
    let Some(axis) = w.axis else {
        return match w.name {
            "producer_heartbeat_time" => {
                config.node.heartbeat_period_s = number * 1e-3;
                Ok(WriteEffect::Node)
            }
            other => Err(format!("{}: {other} is not writable here", w.id)),
        };
    };
    let a = config
        .axis
        .get_mut(axis)
        .ok_or_else(|| format!("{}: no axis {axis}", w.id))?;
    match w.name {
        "enabled" => {
            if number == 0.0 {
                a.friction_compensation = None;
            } else {
                friction(a);
            }
        }
        other => {
            return apply_intelligence_write(a, w, other).map(|()| WriteEffect::Rebuild { axis })
        }
    }
    Ok(WriteEffect::Rebuild { axis })
}

/// A write to one of the declared sections (the intelligent ones are in the dictionary only
/// when configured; a write to the friction compensation creates it): the object says which
/// section, the entry's name is the declaration's, and so are the range
/// checks.
fn apply_intelligence_write(
    a: &mut AxisConfig,
    w: &PendingWrite,
    name: &str,
) -> Result<(), String> {
    let missing = || format!("{}: {name}: the section is not configured", w.id);
    let value = w.value.as_f64().unwrap_or(f64::NAN);
    let written = match index::split(w.id.index).map(|(_, offset)| offset) {
        // The axis' own keys, declared with the objects they are entries of.
        Some(index::AXIS) if AxisKeys::spec(name).is_some() => a.set(name, value),
        Some(index::SETPOINT) if SetpointKeys::spec(name).is_some() => a.set(name, value),
        Some(index::CONTROLLER) => a.controller.set(name, value),
        Some(index::FRICTION_COMPENSATION) => friction(a).set(name, value),
        Some(index::LIMITS) => a.limits.set(name, value),
        Some(axis_intelligence::ADAPTIVE_FRICTION) => a
            .adaptive_friction
            .as_mut()
            .ok_or_else(missing)?
            .set(name, value),
        Some(axis_intelligence::OBSERVER) => {
            a.observer.as_mut().ok_or_else(missing)?.set(name, value)
        }
        Some(axis_intelligence::PARAMETER_ESTIMATION) => a
            .parameter_estimation
            .as_mut()
            .ok_or_else(missing)?
            .set(name, value),
        _ => return Err(format!("{}: {name} is not writable here", w.id)),
    };
    written.map_err(|e| format!("{}: {e}", w.id))
}

/// Handles of the values the node publishes, looked up once so publishing is a store.
pub struct LiveObjects {
    error_register: Option<Handle>,
    cycles: Option<Handle>,
    overruns: Option<Handle>,
    frames_malformed: Option<Handle>,
    frames_unknown: Option<Handle>,
    bus_errors: Option<Handle>,
    bus_faults: Option<Handle>,
    bus_lost_cycles: Option<Handle>,
    cycle_latency_max_us: Option<Handle>,
    cycle_latency_p99_us: Option<Handle>,
    wake_latency_max_us: Option<Handle>,
    /// 1003h: sub 0, then one handle per entry.
    error_field: [Option<Handle>; ERROR_FIELD_LEN + 1],
    /// 2F01h: the entries' times, sub 1 first.
    error_times: [Option<Handle>; ERROR_FIELD_LEN],
    axes: Vec<AxisObjects>,
}

struct AxisObjects {
    fault_state: Option<Handle>,
    fault_flags: Option<Handle>,
    faults_raised: Option<Handle>,
    sensor_missed: Option<Handle>,
    setpoint_position: Option<Handle>,
    friction_compensation: Option<Handle>,
    friction_compensation_pos: Option<Handle>,
    friction_compensation_neg: Option<Handle>,
    gain_schedule_factor: Option<Handle>,
    drive_gain_down: Option<Handle>,
    drive_gain_up: Option<Handle>,
    observer_x4_pos: Option<Handle>,
    observer_x4_neg: Option<Handle>,
    estimates: [Option<Handle>; 6],
    nominal: [Option<Handle>; 6],
    symptoms: Option<Handle>,
    diagnosed_fault: Option<Handle>,
    diagnosis_confidence: Option<Handle>,
    nominal_learned: Option<Handle>,
    bands: [Option<Handle>; 4],
    learned_table_cells: Option<Handle>,
}

/// Node-wide figures published each status period.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LoopFigures {
    pub error_register: u8,
    pub cycles: u64,
    pub overruns: u64,
    pub frames_malformed: u64,
    pub frames_unknown: u64,
    pub bus_errors: u64,
    pub bus_faults: u64,
    pub bus_lost_cycles: u64,
    pub cycle_latency_max_s: f64,
    pub cycle_latency_p99_s: f64,
    pub wake_latency_max_s: f64,
}

fn us(s: f64) -> u32 {
    (s * 1e6).round().clamp(0.0, f64::from(u32::MAX)) as u32
}

fn saturate(n: u64) -> u32 {
    n.min(u64::from(u32::MAX)) as u32
}

impl LiveObjects {
    pub fn new(od: &ObjectDictionary, axes: usize) -> Self {
        let n = |name: &str| od.handle_by_name(None, name);
        let a = |i: usize, name: &str| od.handle_by_name(Some(i), name);
        Self {
            error_register: n("error_register"),
            cycles: n("cycles"),
            overruns: n("overruns"),
            frames_malformed: n("frames_malformed"),
            frames_unknown: n("frames_unknown"),
            bus_errors: n("bus_errors"),
            bus_faults: n("bus_faults"),
            bus_lost_cycles: n("bus_lost_cycles"),
            cycle_latency_max_us: n("cycle_latency_max_us"),
            cycle_latency_p99_us: n("cycle_latency_p99_us"),
            wake_latency_max_us: n("wake_latency_max_us"),
            error_field: std::array::from_fn(|sub| {
                od.handle(ObjectId::new(index::PRE_DEFINED_ERROR_FIELD, sub as u8))
            }),
            error_times: std::array::from_fn(|i| {
                od.handle(ObjectId::new(index::ERROR_FIELD_TIME, i as u8 + 1))
            }),
            axes: (0..axes)
                .map(|i| AxisObjects {
                    fault_state: a(i, "fault_state"),
                    fault_flags: a(i, "fault_flags"),
                    faults_raised: a(i, "faults_raised"),
                    sensor_missed: a(i, "sensor_missed"),
                    setpoint_position: a(i, "setpoint_position"),
                    friction_compensation: a(i, "friction_compensation"),
                    friction_compensation_pos: a(i, "friction_compensation_pos"),
                    friction_compensation_neg: a(i, "friction_compensation_neg"),
                    gain_schedule_factor: a(i, "gain_schedule_factor"),
                    drive_gain_down: a(i, "drive_gain_down"),
                    drive_gain_up: a(i, "drive_gain_up"),
                    observer_x4_pos: a(i, "observer_x4_pos"),
                    observer_x4_neg: a(i, "observer_x4_neg"),
                    estimates: ESTIMATE_NAMES.map(|n| a(i, n)),
                    nominal: NOMINAL_NAMES.map(|n| a(i, n)),
                    symptoms: a(i, "symptoms"),
                    diagnosed_fault: a(i, "diagnosed_fault"),
                    diagnosis_confidence: a(i, "diagnosis_confidence"),
                    nominal_learned: a(i, "nominal_learned"),
                    bands: BAND_NAMES.map(|n| a(i, n)),
                    learned_table_cells: a(i, "learned_table_cells"),
                })
                .collect(),
        }
    }

    /// Publish the node-wide figures.
    pub fn publish_loop(&self, od: &mut ObjectDictionary, f: &LoopFigures) {
        let mut put = |h: Option<Handle>, v: Value| {
            if let Some(h) = h {
                // The types are fixed by the table above; a mismatch would be a build-time bug.
                let _ = od.publish(h, v);
            }
        };
        put(self.error_register, Value::Unsigned8(f.error_register));
        put(self.cycles, Value::Unsigned32(saturate(f.cycles)));
        put(self.overruns, Value::Unsigned32(saturate(f.overruns)));
        put(
            self.frames_malformed,
            Value::Unsigned32(saturate(f.frames_malformed)),
        );
        put(
            self.frames_unknown,
            Value::Unsigned32(saturate(f.frames_unknown)),
        );
        put(self.bus_errors, Value::Unsigned32(saturate(f.bus_errors)));
        put(self.bus_faults, Value::Unsigned32(saturate(f.bus_faults)));
        put(
            self.bus_lost_cycles,
            Value::Unsigned32(saturate(f.bus_lost_cycles)),
        );
        put(
            self.cycle_latency_max_us,
            Value::Unsigned32(us(f.cycle_latency_max_s)),
        );
        put(
            self.cycle_latency_p99_us,
            Value::Unsigned32(us(f.cycle_latency_p99_s)),
        );
        put(
            self.wake_latency_max_us,
            Value::Unsigned32(us(f.wake_latency_max_s)),
        );
    }

    /// Publish the pre-defined error field: the number of errors, the entries newest first,
    /// and 0 in the subindexes past them; and the entries' times.
    pub fn publish_error_field(&self, od: &mut ObjectDictionary, field: &ErrorField) {
        let [count, entries @ ..] = &self.error_field;
        if let Some(h) = count {
            let _ = od.publish(*h, Value::Unsigned8(field.len() as u8));
        }
        for (i, h) in entries.iter().enumerate() {
            if let Some(h) = h {
                let value = field.get(i).map_or(0, |e| e.field());
                let _ = od.publish(*h, Value::Unsigned32(value));
            }
        }
        for (i, h) in self.error_times.iter().enumerate() {
            if let Some(h) = h {
                let time_s = field.get(i).map_or(0.0, |e| e.time_s);
                let _ = od.publish(*h, Value::Real64(time_s));
            }
        }
    }

    /// Publish one axis' values from its cycle record.
    pub fn publish_axis(
        &self,
        od: &mut ObjectDictionary,
        axis: usize,
        r: &CycleRecord,
        faults_raised: u64,
        sensor_missed: u64,
    ) {
        let Some(h) = self.axes.get(axis) else { return };
        let mut put = |h: Option<Handle>, v: Value| {
            if let Some(h) = h {
                let _ = od.publish(h, v);
            }
        };
        put(h.fault_state, Value::Unsigned8(r.fault_state));
        put(h.fault_flags, Value::Unsigned16(r.fault_flags));
        put(h.faults_raised, Value::Unsigned32(saturate(faults_raised)));
        put(h.sensor_missed, Value::Unsigned32(saturate(sensor_missed)));
        put(h.setpoint_position, Value::Real64(r.setpoint_position));
        put(
            h.friction_compensation,
            Value::Real64(r.friction_compensation),
        );
        put(
            h.friction_compensation_pos,
            Value::Real64(r.friction_compensation_pos),
        );
        put(
            h.friction_compensation_neg,
            Value::Real64(r.friction_compensation_neg),
        );
        put(
            h.gain_schedule_factor,
            Value::Real64(r.gain_schedule_factor),
        );
        put(h.drive_gain_down, Value::Real64(r.drive_gain_down));
        put(h.drive_gain_up, Value::Real64(r.drive_gain_up));
        put(h.observer_x4_pos, Value::Real64(r.observer_x4_pos));
        put(h.observer_x4_neg, Value::Real64(r.observer_x4_neg));
    }

    /// Publish what one axis' supervision estimated and learned.
    pub fn publish_diagnosis(
        &self,
        od: &mut ObjectDictionary,
        axis: usize,
        r: &CycleRecord,
        step: &AxisStep,
        learned: &AxisLearned,
        learned_table_cells: usize,
    ) {
        let Some(h) = self.axes.get(axis) else { return };
        let mut put = |h: Option<Handle>, v: Value| {
            if let Some(h) = h {
                let _ = od.publish(h, v);
            }
        };
        let estimate = step.model.estimate.map_or([f64::NAN; 6], |p| p.values);
        for (h, v) in h.estimates.iter().zip(estimate) {
            put(*h, Value::Real64(v));
        }
        for (h, v) in h
            .nominal
            .iter()
            .zip(learned.nominal.map_or([f64::NAN; 6], |n| n.p.values))
        {
            put(*h, Value::Real64(v));
        }
        put(h.symptoms, Value::Unsigned16(symptom_bits(&r.symptoms)));
        put(h.diagnosed_fault, Value::Unsigned8(r.diagnosed_fault));
        put(
            h.diagnosis_confidence,
            Value::Real64(r.diagnosis_confidence),
        );
        put(h.nominal_learned, Value::Boolean(learned.nominal.is_some()));
        let bands = learned
            .observer_bands
            .map_or([f64::NAN; 4], |[p, n]| [p.0, p.1, n.0, n.1]);
        for (h, v) in h.bands.iter().zip(bands) {
            put(*h, Value::Real64(v));
        }
        put(
            h.learned_table_cells,
            Value::Unsigned32(saturate(learned_table_cells as u64)),
        );
    }
}
