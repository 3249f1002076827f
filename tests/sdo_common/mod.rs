//! Shared by the `sdo_*` tests: the daemon's dictionary from the shipped configuration.
#![allow(dead_code)]

use actuatord::canopen::od::{daemon_dictionary, AxisParameters, DeviceParameters};
use actuatord::canopen::ObjectDictionary;
use actuatord::daemon::config::{AxisConfig, CommandKind, Config};
use std::path::Path;

/// The configuration → dictionary mapping the runtime needs (one field per object entry).
pub fn axis_parameters(a: &AxisConfig) -> AxisParameters {
    let mut q = [0.0; 6];
    for (slot, v) in q.iter_mut().zip(&a.controller.q_per_m) {
        *slot = *v;
    }
    let mut p = [0.0; 6];
    for (slot, v) in p.iter_mut().zip(&a.controller.p) {
        *slot = *v;
    }
    let f = a.friction_compensation.as_ref();
    let l = &a.limits;
    let inf = f64::INFINITY;
    AxisParameters {
        name: a.name.clone(),
        actuator_node_id: a.actuator_node_id,
        command_duty: a.command == CommandKind::Duty,
        safe_command: a.safe_command,
        initial_setpoint_m: a.initial_setpoint_m,
        // Configured as `setpoint_rate_max_m_per_s` where the config has that key; absent: steps.
        setpoint_rate_max_m_per_s: inf,
        q_per_m: q,
        p,
        output_min: a.controller.output_min,
        output_max: a.controller.output_max,
        friction_compensation_enabled: f.is_some(),
        alpha: f.map_or(1.0, |f| f.alpha),
        coulomb_pos_n: f.map_or(0.0, |f| f.coulomb_pos_n),
        coulomb_neg_n: f.map_or(0.0, |f| f.coulomb_neg_n),
        force_gain_n_per_command: f.map_or(1.0, |f| f.force_gain_n_per_command),
        deadband_m: f.map_or(0.0, |f| f.deadband_m),
        following_error_m: l.following_error_m.unwrap_or(inf),
        following_error_time_s: l.following_error_time_s,
        position_min_m: l.position_min_m.unwrap_or(-inf),
        position_max_m: l.position_max_m.unwrap_or(inf),
        current_max_a: l.current_max_a.unwrap_or(inf),
        current_time_s: l.current_time_s,
        supply_voltage_min_v: l.supply_voltage_min_v.unwrap_or(-inf),
        supply_voltage_max_v: l.supply_voltage_max_v.unwrap_or(inf),
        supply_pressure_min_pa: l.supply_pressure_min_pa.unwrap_or(-inf),
        supply_pressure_max_pa: l.supply_pressure_max_pa.unwrap_or(inf),
        supply_time_s: l.supply_time_s,
        sensor_timeout_s: l.sensor_timeout_s,
        heartbeat_timeout_s: l.heartbeat_timeout_s.unwrap_or(inf),
    }
}

pub fn device_parameters(c: &Config) -> DeviceParameters {
    DeviceParameters {
        node_id: c.node.node_id,
        heartbeat_period_s: c.node.heartbeat_period_s,
        ..DeviceParameters::default()
    }
}

/// `config/solenoid.toml` as a dictionary.
pub fn solenoid_dictionary() -> (Config, ObjectDictionary) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let config = Config::load(&path).expect("shipped config is valid");
    let axes: Vec<_> = config.axis.iter().map(axis_parameters).collect();
    let od = daemon_dictionary(&device_parameters(&config), &axes).expect("config fits the table");
    (config, od)
}
