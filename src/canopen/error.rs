//! Why a received frame could not be decoded, for every decoder of the stack and the profiles.

use super::Frame;

/// Why a received frame could not be decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("frame {name} (0x{id:03X}) has {got} data bytes, expected {expected}")]
    WrongLength {
        name: &'static str,
        id: u32,
        got: usize,
        expected: usize,
    },
    #[error("frame {name} (0x{id:03X}): signal {signal} has invalid value {value}")]
    BadValue {
        name: &'static str,
        id: u32,
        signal: &'static str,
        value: i64,
    },
}

impl DecodeError {
    /// `frame` must carry exactly `expected` data bytes; `name` is the frame's name in the error.
    pub fn check_length(name: &'static str, frame: &Frame, expected: usize) -> Result<(), Self> {
        if frame.len() != expected {
            return Err(Self::WrongLength {
                name,
                id: frame.id(),
                got: frame.len(),
                expected,
            });
        }
        Ok(())
    }
}
