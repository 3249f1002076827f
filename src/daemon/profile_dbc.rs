//! The DBC of a configuration's bus: the protocol's own messages for our actuator nodes, and for
//! each standard node its PDOs as mapped (the daemon's layout, or the one of its EDS), with the
//! axis' scaling, its EMCY, SDO and heartbeat; so `candump` + `cantools` read the whole bus.

use super::config::{AxisConfig, Config};
use super::profile_config::ProfileKind;
use super::profile_setup::planned_layout;
use crate::canopen::od::ObjectId;
use crate::device::dbc::{render_bus, BusMessage, BusSignal};
use crate::device::messages::NODE_CONTROLLER;
use crate::device::profile::cia401;
use crate::device::profile::cia402;
use crate::device::profile::mapping::Direction;

fn signal(name: &str, start_bit: u16, bits: u8, signed: bool, comment: &str) -> BusSignal {
    BusSignal {
        name: name.to_string(),
        start_bit,
        bits,
        signed,
        factor: 1.0,
        offset: 0.0,
        unit: String::new(),
        comment: comment.to_string(),
    }
}

/// A mapped object as a signal: its name, sign, and the axis' scaling to SI where it has one.
fn mapped_signal(axis: &AxisConfig, id: ObjectId, start_bit: u16, bits: u8) -> BusSignal {
    let scaled =
        |name: &str, signed: bool, factor: f64, offset: f64, unit: &str, c: &str| BusSignal {
            factor,
            offset,
            unit: unit.to_string(),
            ..signal(name, start_bit, bits, signed, c)
        };
    let d = axis.cia402.as_ref();
    let rated = d.and_then(|d| d.rated_torque_nm);
    let torque = |name: &str, c: &str| match rated {
        Some(r) => scaled(name, true, r * 1e-3, 0.0, "N m", c),
        None => scaled(name, true, 1.0, 0.0, "permille", c),
    };
    match (id.index, id.sub) {
        (cia402::CONTROLWORD, 0) => signal("controlword", start_bit, bits, false, "6040h"),
        (cia402::STATUSWORD, 0) => signal("statusword", start_bit, bits, false, "6041h"),
        (cia402::ERROR_CODE, 0) => signal("error_code", start_bit, bits, false, "603Fh"),
        (cia402::MODES_OF_OPERATION, 0) => {
            signal("modes_of_operation", start_bit, bits, true, "6060h")
        }
        (cia402::MODES_OF_OPERATION_DISPLAY, 0) => {
            signal("modes_of_operation_display", start_bit, bits, true, "6061h")
        }
        (cia402::POSITION_ACTUAL, 0) => scaled(
            "position_actual_value",
            true,
            d.map_or(1.0, |d| d.position_m_per_inc),
            0.0,
            "m",
            "6064h",
        ),
        (cia402::VELOCITY_ACTUAL, 0) => scaled(
            "velocity_actual_value",
            true,
            d.map_or(1.0, |d| d.velocity_m_per_s_per_unit),
            0.0,
            "m/s",
            "606Ch",
        ),
        (cia402::TARGET_VELOCITY, 0) => scaled(
            "target_velocity",
            true,
            d.map_or(1.0, |d| d.velocity_m_per_s_per_unit),
            0.0,
            "m/s",
            "60FFh",
        ),
        (cia402::TARGET_TORQUE, 0) => torque("target_torque", "6071h"),
        (cia402::TORQUE_ACTUAL, 0) => torque("torque_actual_value", "6077h"),
        (cia402::DC_LINK_VOLTAGE, 0) => scaled(
            "dc_link_circuit_voltage",
            false,
            d.map_or(1e-3, |d| d.dc_link_v_per_unit),
            0.0,
            "V",
            "6079h",
        ),
        (cia401::ANALOG_INPUTS_16, ch) | (cia401::ANALOG_OUTPUTS_16, ch) => {
            let input = id.index == cia401::ANALOG_INPUTS_16;
            let name = if input {
                format!("analog_input_{ch}")
            } else {
                format!("analog_output_{ch}")
            };
            let io = axis.cia401.as_ref();
            let duty = axis.command == super::config::CommandKind::Duty;
            let meaning = io.and_then(|io| {
                if input && ch == io.position_input {
                    Some((io.position(), "m", "position"))
                } else if input && Some(ch) == io.current_input {
                    Some((io.current(), "A", "current"))
                } else if input && Some(ch) == io.supply_input {
                    Some((io.supply(), if duty { "Pa" } else { "V" }, "supply"))
                } else if !input && ch == io.command_output {
                    Some((io.command(), if duty { "" } else { "V" }, "command"))
                } else {
                    None
                }
            });
            match meaning {
                Some((s, unit, what)) => scaled(
                    &name,
                    true,
                    s.scale,
                    s.offset,
                    unit,
                    &format!("{:04X}h sub {ch}: {what}", id.index),
                ),
                None => signal(
                    &name,
                    start_bit,
                    bits,
                    true,
                    &format!("{:04X}h sub {ch}", id.index),
                ),
            }
        }
        (index, sub) => signal(
            &format!("object_{index:04x}_{sub:02x}"),
            start_bit,
            bits,
            false,
            "mapped object",
        ),
    }
}

/// The messages of one standard node.
fn node_messages(axis: &AxisConfig) -> Result<Vec<BusMessage>, String> {
    let n = u32::from(axis.actuator_node_id);
    let node_name = format!("{}_node", axis.name);
    let pdos = planned_layout(axis).map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    for p in pdos.iter().filter(|p| p.enabled && !p.objects.is_empty()) {
        let mut bit = 0u16;
        let mut signals = Vec::new();
        for o in &p.objects {
            signals.push(mapped_signal(axis, o.id, bit, o.bits));
            bit += u16::from(o.bits);
        }
        let (tx, rx) = match p.direction {
            Direction::Transmit => (node_name.clone(), NODE_CONTROLLER.to_string()),
            Direction::Receive => (NODE_CONTROLLER.to_string(), node_name.clone()),
        };
        out.push(BusMessage {
            id: p.cob_id,
            name: format!(
                "{}_{}{}",
                axis.name,
                p.direction.name().to_lowercase(),
                p.number
            ),
            dlc: p.len_bytes(),
            transmitter: tx,
            receiver: rx,
            comment: format!(
                "{} of {} node {} ({}), transmission type {}",
                p.label(),
                axis.profile.name(),
                n,
                axis.name,
                p.transmission_type
            ),
            signals,
        });
    }
    let sdo = |dir: &str, id: u32, tx: &str, rx: &str| BusMessage {
        id,
        name: format!("{}_sdo_{dir}", axis.name),
        dlc: 8,
        transmitter: tx.to_string(),
        receiver: rx.to_string(),
        comment: format!("SDO {dir} of node {n}: the daemon's start-up configuration"),
        signals: vec![
            signal("sdo_command", 0, 8, false, "command specifier"),
            signal("sdo_index", 8, 16, false, "object index"),
            signal("sdo_subindex", 24, 8, false, "subindex"),
            signal("sdo_data", 32, 32, false, "data or abort code"),
        ],
    };
    out.push(sdo("request", 0x600 + n, NODE_CONTROLLER, &node_name));
    out.push(sdo("response", 0x580 + n, &node_name, NODE_CONTROLLER));
    out.push(BusMessage {
        id: 0x80 + n,
        name: format!("{}_emcy", axis.name),
        dlc: 8,
        transmitter: node_name.clone(),
        receiver: NODE_CONTROLLER.to_string(),
        comment: format!("EMCY of node {n}"),
        signals: vec![
            signal("emcy_error_code", 0, 16, false, "CiA 301/402 error code"),
            signal("emcy_error_register", 16, 8, false, "1001h"),
            signal("emcy_manufacturer", 24, 40, false, "manufacturer-specific"),
        ],
    });
    out.push(BusMessage {
        id: 0x700 + n,
        name: format!("{}_heartbeat", axis.name),
        dlc: 1,
        transmitter: node_name,
        receiver: NODE_CONTROLLER.to_string(),
        comment: format!("heartbeat of node {n}"),
        signals: vec![signal("nmt_state", 0, 8, false, "NMT state")],
    });
    Ok(out)
}

/// The DBC of the bus `config` describes (its first actuatord axis keeps the plain names).
pub fn render_config_dbc(config: &Config) -> Result<String, String> {
    let ours: Vec<u8> = config
        .axis
        .iter()
        .filter(|a| a.profile == ProfileKind::Actuatord)
        .map(|a| a.actuator_node_id)
        .collect();
    let mut nodes = Vec::new();
    let mut extra = Vec::new();
    for a in config
        .axis
        .iter()
        .filter(|a| a.profile != ProfileKind::Actuatord)
    {
        nodes.push(format!("{}_node", a.name));
        extra.extend(node_messages(a)?);
    }
    Ok(render_bus(config.node.node_id, &ours, &nodes, &extra))
}
