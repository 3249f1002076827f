//! Emergency (EMCY) frames: one when a fault is raised, one with error code 0 when faults are reset.

use super::codec::{pack, unpack, DecodeError};
use super::messages::EMCY;
use crate::bus::Frame;
use crate::supervise::{FaultFlags, FaultKind};

/// CiA 301 "error reset or no error".
pub const ERROR_RESET: u16 = 0x0000;

/// The error code announced for a fault (CiA 301 / CiA 402 code ranges).
pub fn error_code(kind: FaultKind) -> u16 {
    match kind {
        FaultKind::FollowingError => 0x8611,
        FaultKind::EndOfRange => 0x8612,
        FaultKind::Overcurrent => 0x2310,
        FaultKind::SupplyVoltage => 0x3100,
        // No standard code for a pneumatic supply: manufacturer-specific range.
        FaultKind::SupplyPressure => 0xFF01,
        FaultKind::SensorTimeout => 0x8100,
        FaultKind::HeartbeatLost => 0x8130,
        FaultKind::NodeState => 0x8140,
    }
}

/// CiA 301 error register (object 1001h) bits for a set of faults.
pub fn error_register(flags: FaultFlags) -> u8 {
    if flags.is_empty() {
        return 0;
    }
    let mut reg = 0x01; // generic error
    for kind in flags.iter() {
        reg |= match kind {
            FaultKind::Overcurrent => 0x02,
            FaultKind::SupplyVoltage => 0x04,
            FaultKind::HeartbeatLost | FaultKind::SensorTimeout | FaultKind::NodeState => 0x10,
            FaultKind::FollowingError | FaultKind::EndOfRange | FaultKind::SupplyPressure => 0x80,
        };
    }
    reg
}

/// One EMCY frame of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Emcy {
    pub error_code: u16,
    pub error_register: u8,
    pub axis_node_id: u8,
    /// Every fault active on the axis when the frame was sent.
    pub flags: FaultFlags,
}

impl Emcy {
    /// The EMCY for a newly raised fault `kind` while `flags` are active.
    pub fn raised(axis_node_id: u8, kind: FaultKind, flags: FaultFlags) -> Self {
        Self {
            error_code: error_code(kind),
            error_register: error_register(flags),
            axis_node_id,
            flags,
        }
    }

    /// The EMCY announcing that an axis' faults were reset.
    pub fn reset(axis_node_id: u8) -> Self {
        Self {
            error_code: ERROR_RESET,
            error_register: 0,
            axis_node_id,
            flags: FaultFlags::default(),
        }
    }

    pub fn encode(&self, controller_node: u8) -> Frame {
        let mut values = [0.0; 11];
        values[0] = f64::from(self.error_code);
        values[1] = f64::from(self.error_register);
        values[2] = f64::from(self.axis_node_id);
        for (slot, kind) in values[3..].iter_mut().zip(FaultKind::ALL) {
            *slot = if self.flags.contains(kind) { 1.0 } else { 0.0 };
        }
        pack(&EMCY, controller_node, &values).0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let v: [f64; 11] = unpack(&EMCY, frame)?;
        let mut flags = FaultFlags::default();
        for (value, kind) in v[3..].iter().zip(FaultKind::ALL) {
            if *value != 0.0 {
                flags.insert(kind);
            }
        }
        Ok(Self {
            error_code: v[0] as u16,
            error_register: v[1] as u8,
            axis_node_id: v[2] as u8,
            flags,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raised_emcy_names_the_fault_and_round_trips() {
        let mut flags = FaultFlags::default();
        flags.insert(FaultKind::SupplyVoltage);
        let e = Emcy::raised(0x10, FaultKind::SupplyVoltage, flags);
        let f = e.encode(1);
        assert_eq!(f.id(), 0x81);
        assert_eq!(&f.data()[..2], &[0x00, 0x31]);
        assert_eq!(e.error_register, 0x05);
        assert_eq!(Emcy::decode(&f), Ok(e));
        assert_eq!(
            Emcy::decode(&Emcy::reset(0x10).encode(1)).map(|e| e.error_code),
            Ok(0)
        );
    }

    #[test]
    fn every_fault_has_its_own_code() {
        let mut codes: Vec<_> = FaultKind::ALL.iter().map(|k| error_code(*k)).collect();
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), FaultKind::ALL.len());
    }
}
