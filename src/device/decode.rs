//! Frames to named signals with the message table (what `actuator decode` prints for a
//! candump log), the same table `dbc/actuatord.dbc` is rendered from.

use super::messages::{IdBase, Message, ALL};
use crate::canopen::Frame;

/// One decoded signal: name, physical value, unit.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedSignal {
    pub name: &'static str,
    pub value: f64,
    pub unit: &'static str,
    /// Resolution of the signal on the bus.
    pub factor: f64,
}

impl std::fmt::Display for DecodedSignal {
    /// `name=value unit`, the value with as many decimals as the signal's resolution has.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let decimals = (-self.factor.log10()).ceil().clamp(0.0, 12.0) as usize;
        let mut text = format!("{:.*}", decimals, self.value);
        if text.contains('.') {
            text = text.trim_end_matches('0').trim_end_matches('.').to_string();
        }
        write!(f, "{}={text}", self.name)?;
        if !self.unit.is_empty() {
            write!(f, " {}", self.unit)?;
        }
        Ok(())
    }
}

/// The message a frame is, for the given node ids, and its signals; `None` for ids the
/// protocol does not use. A frame of the wrong length is named but not decoded.
pub fn decode_frame(
    frame: &Frame,
    controller_node: u8,
    actuator_node: u8,
) -> Option<(&'static Message, Result<Vec<DecodedSignal>, usize>)> {
    if frame.is_extended() {
        return None;
    }
    let message: &'static Message = ALL.iter().copied().find(|m| {
        let node = match m.id_base {
            IdBase::Actuator => actuator_node,
            _ => controller_node,
        };
        m.cob_id(node) == frame.id()
    })?;
    if frame.len() != message.dlc {
        return Some((message, Err(frame.len())));
    }
    let signals = message
        .signals
        .iter()
        .map(|s| DecodedSignal {
            name: s.name,
            value: s.decode(frame.data()),
            unit: s.unit,
            factor: s.factor,
        })
        .collect();
    Some((message, Ok(signals)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::SensorPdo;

    #[test]
    fn a_sensor_frame_decodes_to_its_signals_and_a_short_one_is_named() {
        let f = SensorPdo {
            position: 0.0125,
            current_a: 1.5,
            supply_voltage_v: 24.0,
        }
        .encode(16);
        let (m, signals) = decode_frame(&f, 1, 16).expect("known id");
        assert_eq!(m.name, "sensor");
        let signals = signals.expect("right length");
        assert_eq!(signals[0].name, "position");
        assert!((signals[0].value - 0.0125).abs() < 1e-9);
        assert_eq!(signals[0].unit, "m");
        let short = Frame::new(0x190, &[1, 2]).expect("frame");
        assert_eq!(
            decode_frame(&short, 1, 16).map(|(m, r)| (m.name, r.err())),
            Some(("sensor", Some(2)))
        );
        let unknown = Frame::new(0x5FF, &[]).expect("frame");
        assert!(decode_frame(&unknown, 1, 16).is_none());
    }
}
