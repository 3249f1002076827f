//! Generic pack/unpack of a [`Message`] from physical values, allocation-free.

pub use crate::canopen::DecodeError;

use super::messages::Message;
use crate::canopen::Frame;

/// Pack physical values, one per signal in table order, into a frame with the message's length.
///
/// Values outside a signal's range saturate; the count of such values is returned beside the frame.
pub fn pack(message: &Message, node_id: u8, values: &[f64]) -> (Frame, usize) {
    debug_assert_eq!(values.len(), message.signals.len(), "{}", message.name);
    let mut data = [0u8; 8];
    let mut clipped = 0;
    for (signal, value) in message.signals.iter().zip(values) {
        if !signal.encode(*value, &mut data) {
            clipped += 1;
        }
    }
    // The tables are fixed and tested to fit in 8 bytes with an 11-bit id.
    let frame = Frame::new(message.cob_id(node_id), &data[..message.dlc])
        .unwrap_or_else(|e| unreachable!("message table {}: {e}", message.name));
    (frame, clipped)
}

/// Check a frame's length against its message.
pub fn check_length(message: &Message, frame: &Frame) -> Result<(), DecodeError> {
    DecodeError::check_length(message.name, frame, message.dlc)
}

/// Unpack every signal into physical values, in table order.
pub fn unpack<const N: usize>(message: &Message, frame: &Frame) -> Result<[f64; N], DecodeError> {
    check_length(message, frame)?;
    debug_assert_eq!(N, message.signals.len(), "{}", message.name);
    let mut out = [0.0; N];
    for (slot, signal) in out.iter_mut().zip(message.signals) {
        *slot = signal.decode(frame.data());
    }
    Ok(out)
}
