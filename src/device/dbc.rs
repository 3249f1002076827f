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

/// A message of another kind of node on the bus (a standard node's PDOs as mapped, its EMCY,
/// SDO and heartbeat), rendered beside the protocol's own by [`render_bus`].
#[derive(Debug, Clone, PartialEq)]
pub struct BusMessage {
    pub id: u32,
    /// Unique on the bus, snake_case.
    pub name: String,
    pub dlc: usize,
    pub transmitter: String,
    pub receiver: String,
    pub comment: String,
    pub signals: Vec<BusSignal>,
}

/// One signal of a [`BusMessage`], little endian.
#[derive(Debug, Clone, PartialEq)]
pub struct BusSignal {
    pub name: String,
    pub start_bit: u16,
    pub bits: u8,
    pub signed: bool,
    pub factor: f64,
    pub offset: f64,
    pub unit: String,
    pub comment: String,
}

impl BusSignal {
    /// The physical values the raw range covers, low first.
    fn physical_range(&self) -> (f64, f64) {
        let bits = u32::from(self.bits.clamp(1, 64));
        let (lo, hi) = if self.signed {
            (
                -(2f64.powi(bits as i32 - 1)),
                2f64.powi(bits as i32 - 1) - 1.0,
            )
        } else {
            (0.0, 2f64.powi(bits as i32) - 1.0)
        };
        let (a, b) = (
            lo * self.factor + self.offset,
            hi * self.factor + self.offset,
        );
        (a.min(b), a.max(b))
    }
}

/// The protocol's message `m` for one node, as a [`BusMessage`].
fn own(m: &Message, id: u32, suffix: &str) -> (BusMessage, Vec<(f64, f64)>) {
    let signals: Vec<BusSignal> = m
        .signals
        .iter()
        .map(|s| BusSignal {
            name: s.name.to_string(),
            start_bit: s.start_bit,
            bits: s.bits,
            signed: s.signed,
            factor: s.factor,
            offset: s.offset,
            unit: s.unit.to_string(),
            comment: s.comment.to_string(),
        })
        .collect();
    let ranges = m.signals.iter().map(|s| s.physical_range()).collect();
    (
        BusMessage {
            id,
            name: format!("{}{suffix}", m.name),
            dlc: m.dlc,
            transmitter: m.transmitter.to_string(),
            receiver: receivers(m).to_string(),
            comment: m.comment.to_string(),
            signals,
        },
        ranges,
    )
}

/// The DBC text for a controller with node id `controller_node` and one actuator node.
pub fn render(controller_node: u8, actuator_node: u8) -> String {
    render_bus(controller_node, &[actuator_node], &[], &[])
}

/// The DBC text of a whole bus: the controller's messages, ours of each actuator node in
/// `actuator_nodes` (the first with the plain names, the others suffixed `_n<id>`), and the
/// messages of other nodes (`nodes`, their `extra` messages).
pub fn render_bus(
    controller_node: u8,
    actuator_nodes: &[u8],
    nodes: &[String],
    extra: &[BusMessage],
) -> String {
    let mut messages: Vec<(BusMessage, Vec<(f64, f64)>)> = Vec::new();
    for m in ALL {
        if m.id_base == super::messages::IdBase::Actuator {
            for (i, node) in actuator_nodes.iter().enumerate() {
                let suffix = if i == 0 {
                    String::new()
                } else {
                    format!("_n{node}")
                };
                messages.push(own(m, cob_id(m, controller_node, *node), &suffix));
            }
        } else {
            messages.push(own(m, cob_id(m, controller_node, 0), ""));
        }
    }
    for m in extra {
        let ranges = m.signals.iter().map(BusSignal::physical_range).collect();
        messages.push((m.clone(), ranges));
    }
    let mut out = String::new();
    out.push_str("VERSION \"actuatord 1\"\n\nNS_ :\n\tCM_\n\tBA_DEF_\n\tBA_\n\tVAL_\n\nBS_:\n\n");
    let mut bu = format!("BU_: {NODE_CONTROLLER} {NODE_ACTUATOR} {NODE_AUTOMATION}");
    for n in nodes {
        bu.push(' ');
        bu.push_str(n);
    }
    let _ = writeln!(out, "{bu}\n");
    for (m, ranges) in &messages {
        let _ = writeln!(out, "BO_ {} {}: {} {}", m.id, m.name, m.dlc, m.transmitter);
        for (s, (lo, hi)) in m.signals.iter().zip(ranges) {
            let _ = writeln!(
                out,
                " SG_ {} : {}|{}@1{} ({},{}) [{}|{}] \"{}\" {}",
                s.name,
                s.start_bit,
                s.bits,
                if s.signed { '-' } else { '+' },
                num(s.factor),
                num(s.offset),
                num(*lo),
                num(*hi),
                s.unit,
                m.receiver,
            );
        }
        out.push('\n');
    }
    let first = actuator_nodes.first().copied().unwrap_or(0);
    let _ = writeln!(
        out,
        "CM_ \"actuatord protocol, controller node {controller_node}, actuator node {first}. Rendered by: actuator dbc\";"
    );
    for (m, _) in &messages {
        let _ = writeln!(out, "CM_ BO_ {} \"{}\";", m.id, m.comment);
        for s in &m.signals {
            let _ = writeln!(out, "CM_ SG_ {} {} \"{}\";", m.id, s.name, s.comment);
        }
    }
    for (m, _) in &messages {
        for s in &m.signals {
            if let Some((_, table)) = VALUE_TABLES.iter().find(|(n, _)| *n == s.name) {
                let _ = write!(out, "VAL_ {} {}", m.id, s.name);
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
