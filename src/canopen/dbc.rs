//! Render the message tables as a DBC file, for candump/cantools/SavvyCAN users.

use super::messages::{Message, ALL, NODE_ACTUATOR, NODE_AUTOMATION, NODE_CONTROLLER};
use std::fmt::Write;

/// Value tables for signals whose raw values are states.
const VALUE_TABLES: [(&str, &[(u32, &str)]); 4] = [
    (
        "nmt_command",
        &[
            (1, "start"),
            (2, "stop"),
            (128, "enter_pre_operational"),
            (129, "reset_node"),
            (130, "reset_communication"),
        ],
    ),
    (
        "nmt_state",
        &[
            (0, "boot_up"),
            (4, "stopped"),
            (5, "operational"),
            (127, "pre_operational"),
        ],
    ),
    (
        "fault_state",
        &[
            (0, "ok"),
            (1, "warning"),
            (2, "fail_safe"),
            (3, "maintenance_requested"),
        ],
    ),
    (
        "diagnosed_fault",
        &[
            (0, "none"),
            (1, "spring_pretension"),
            (2, "spring_stiffness"),
            (3, "friction_increase"),
            (4, "current_gain"),
            (5, "observer_friction"),
            (6, "estimator_implausible"),
            (7, "limit_violation"),
            (8, "sensor_offset"),
        ],
    ),
];

/// The DBC text for a controller with node id `controller_node` and one actuator node.
pub fn render(controller_node: u8, actuator_node: u8) -> String {
    let mut out = String::new();
    out.push_str("VERSION \"actuatord 1\"\n\nNS_ :\n\tCM_\n\tBA_DEF_\n\tBA_\n\tVAL_\n\nBS_:\n\n");
    let _ = writeln!(
        out,
        "BU_: {NODE_CONTROLLER} {NODE_ACTUATOR} {NODE_AUTOMATION}\n"
    );
    for m in ALL {
        let id = cob_id(m, controller_node, actuator_node);
        let _ = writeln!(out, "BO_ {id} {}: {} {}", m.name, m.dlc, m.transmitter);
        for s in m.signals {
            let (lo, hi) = s.physical_range();
            let _ = writeln!(
                out,
                " SG_ {} : {}|{}@1{} ({},{}) [{}|{}] \"{}\" {}",
                s.name,
                s.start_bit,
                s.bits,
                if s.signed { '-' } else { '+' },
                num(s.factor),
                num(s.offset),
                num(lo),
                num(hi),
                s.unit,
                receivers(m),
            );
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "CM_ \"actuatord protocol, controller node {controller_node}, actuator node {actuator_node}. Rendered by: actuator dbc\";"
    );
    for m in ALL {
        let id = cob_id(m, controller_node, actuator_node);
        let _ = writeln!(out, "CM_ BO_ {id} \"{}\";", m.comment);
        for s in m.signals {
            let _ = writeln!(out, "CM_ SG_ {id} {} \"{}\";", s.name, s.comment);
        }
    }
    for m in ALL {
        let id = cob_id(m, controller_node, actuator_node);
        for s in m.signals {
            if let Some((_, table)) = VALUE_TABLES.iter().find(|(n, _)| *n == s.name) {
                let _ = write!(out, "VAL_ {id} {}", s.name);
                for (v, label) in *table {
                    let _ = write!(out, " {v} \"{label}\"");
                }
                out.push_str(" ;\n");
            }
        }
    }
    out
}

fn cob_id(m: &Message, controller_node: u8, actuator_node: u8) -> u32 {
    match m.id_base {
        super::messages::IdBase::Actuator => m.cob_id(actuator_node),
        _ => m.cob_id(controller_node),
    }
}

fn receivers(m: &Message) -> &'static str {
    if m.transmitter == NODE_ACTUATOR || m.transmitter == NODE_AUTOMATION {
        NODE_CONTROLLER
    } else {
        NODE_ACTUATOR
    }
}

/// Shortest decimal that reads back exactly; DBC parsers take plain or exponent notation.
fn num(x: f64) -> String {
    let s = format!("{x}");
    if s.contains('e') || s.len() <= 12 {
        s
    } else {
        format!("{x:e}")
    }
}
