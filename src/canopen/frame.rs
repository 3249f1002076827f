//! The CAN frame as every layer above the transport sees it: classic CAN 2.0, up to 8 data bytes.

use std::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// A classic CAN data frame. Copy-able and fixed-size, so the real-time cycle never allocates for it.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    id: u32,
    extended: bool,
    len: u8,
    data: [u8; 8],
}

/// Why a frame could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("CAN id 0x{0:X} does not fit in 11 bits")]
    StandardIdTooLarge(u32),
    #[error("CAN id 0x{0:X} does not fit in 29 bits")]
    ExtendedIdTooLarge(u32),
    #[error("{0} data bytes do not fit in a classic CAN frame (at most 8)")]
    TooLong(usize),
}

impl Frame {
    /// A standard-id (11-bit) data frame, the kind the CANopen-style protocol uses.
    pub fn new(id: u32, data: &[u8]) -> Result<Self, FrameError> {
        if id > MAX_STANDARD_ID {
            return Err(FrameError::StandardIdTooLarge(id));
        }
        Self::build(id, false, data)
    }

    /// An extended-id (29-bit) data frame; other nodes on a shared bus may send these.
    pub fn new_extended(id: u32, data: &[u8]) -> Result<Self, FrameError> {
        if id > MAX_EXTENDED_ID {
            return Err(FrameError::ExtendedIdTooLarge(id));
        }
        Self::build(id, true, data)
    }

    fn build(id: u32, extended: bool, data: &[u8]) -> Result<Self, FrameError> {
        if data.len() > 8 {
            return Err(FrameError::TooLong(data.len()));
        }
        let mut buf = [0u8; 8];
        buf[..data.len()].copy_from_slice(data);
        Ok(Self {
            id,
            extended,
            len: data.len() as u8,
            data: buf,
        })
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    pub fn is_extended(&self) -> bool {
        self.extended
    }

    /// The data bytes actually carried (length = DLC).
    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    pub fn len(&self) -> usize {
        self.len as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// candump's compact notation: `123#DEADBEEF`, or `12345678#..` for extended ids.
impl fmt::Display for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended {
            write!(f, "{:08X}#", self.id)?;
        } else {
            write!(f, "{:03X}#", self.id)?;
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

impl fmt::Debug for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Frame({self})")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_ids_and_lengths_that_do_not_fit() {
        assert_eq!(
            Frame::new(0x800, &[]),
            Err(FrameError::StandardIdTooLarge(0x800))
        );
        assert_eq!(Frame::new(0x100, &[0; 9]), Err(FrameError::TooLong(9)));
        assert!(Frame::new_extended(0x1FFF_FFFF, &[1]).is_ok());
        assert!(Frame::new_extended(0x2000_0000, &[1]).is_err());
    }

    #[test]
    fn displays_like_candump() {
        let f = Frame::new(0x18A, &[0xDE, 0xAD, 0x01]).expect("valid frame");
        assert_eq!(f.to_string(), "18A#DEAD01");
        let e = Frame::new_extended(0x1234, &[]).expect("valid frame");
        assert_eq!(e.to_string(), "00001234#");
        assert_eq!(f.data(), &[0xDE, 0xAD, 0x01]);
    }
}
