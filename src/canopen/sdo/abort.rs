//! SDO abort codes (CiA 301 §7.2.4.3.17, Table 22).

use crate::canopen::od::OdError;
use std::fmt;

/// A 32-bit SDO abort code. Any value can arrive from the bus; the named constants are the ones
/// this server sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AbortCode(pub u32);

impl AbortCode {
    pub const TOGGLE_NOT_ALTERNATED: Self = Self(0x0503_0000);
    pub const TIMEOUT: Self = Self(0x0504_0000);
    pub const COMMAND_SPECIFIER_INVALID: Self = Self(0x0504_0001);
    pub const READ_WRITE_ONLY: Self = Self(0x0601_0001);
    pub const WRITE_READ_ONLY: Self = Self(0x0601_0002);
    pub const OBJECT_DOES_NOT_EXIST: Self = Self(0x0602_0000);
    pub const LENGTH_MISMATCH: Self = Self(0x0607_0010);
    pub const SUBINDEX_DOES_NOT_EXIST: Self = Self(0x0609_0011);
    pub const VALUE_RANGE_EXCEEDED: Self = Self(0x0609_0030);
    pub const VALUE_TOO_HIGH: Self = Self(0x0609_0031);
    pub const VALUE_TOO_LOW: Self = Self(0x0609_0032);
    pub const GENERAL_ERROR: Self = Self(0x0800_0000);
    pub const DEVICE_STATE: Self = Self(0x0800_0022);

    /// The CiA 301 text of a code, or `None` for one not in Table 22.
    pub fn description(self) -> Option<&'static str> {
        Some(match self.0 {
            0x0503_0000 => "toggle bit not alternated",
            0x0504_0000 => "SDO protocol timed out",
            0x0504_0001 => "client/server command specifier not valid or unknown",
            0x0504_0002 => "invalid block size",
            0x0504_0003 => "invalid sequence number",
            0x0504_0004 => "CRC error",
            0x0504_0005 => "out of memory",
            0x0601_0000 => "unsupported access to an object",
            0x0601_0001 => "attempt to read a write only object",
            0x0601_0002 => "attempt to write a read only object",
            0x0602_0000 => "object does not exist in the object dictionary",
            0x0604_0041 => "object cannot be mapped to the PDO",
            0x0604_0042 => "number and length of objects to be mapped would exceed PDO length",
            0x0604_0043 => "general parameter incompatibility",
            0x0604_0047 => "general internal incompatibility in the device",
            0x0606_0000 => "access failed due to a hardware error",
            0x0607_0010 => "data type does not match, length of service parameter does not match",
            0x0607_0012 => "data type does not match, length of service parameter too high",
            0x0607_0013 => "data type does not match, length of service parameter too low",
            0x0609_0011 => "subindex does not exist",
            0x0609_0030 => "invalid value for parameter (value range exceeded)",
            0x0609_0031 => "value of parameter written too high",
            0x0609_0032 => "value of parameter written too low",
            0x0609_0036 => "maximum value is less than minimum value",
            0x060A_0023 => "resource not available: SDO connection",
            0x0800_0000 => "general error",
            0x0800_0020 => "data cannot be transferred or stored to the application",
            0x0800_0021 => "data cannot be transferred or stored because of local control",
            0x0800_0022 => {
                "data cannot be transferred or stored because of the present device state"
            }
            0x0800_0023 => {
                "object dictionary dynamic generation fails or no object dictionary is present"
            }
            0x0800_0024 => "no data available",
            _ => return None,
        })
    }
}

/// `0x06090031 (value of parameter written too high)`.
impl fmt::Display for AbortCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.description() {
            Some(d) => write!(f, "0x{:08X} ({d})", self.0),
            None => write!(f, "0x{:08X}", self.0),
        }
    }
}

impl From<OdError> for AbortCode {
    fn from(e: OdError) -> Self {
        match e {
            OdError::NoObject => Self::OBJECT_DOES_NOT_EXIST,
            OdError::NoSubIndex => Self::SUBINDEX_DOES_NOT_EXIST,
            OdError::ReadOnly => Self::WRITE_READ_ONLY,
            OdError::WriteOnly => Self::READ_WRITE_ONLY,
            OdError::WrongLength => Self::LENGTH_MISMATCH,
            OdError::OutOfRange => Self::VALUE_RANGE_EXCEEDED,
            OdError::TooHigh => Self::VALUE_TOO_HIGH,
            OdError::TooLow => Self::VALUE_TOO_LOW,
            OdError::RefusedInState => Self::DEVICE_STATE,
            OdError::TypeMismatch { .. } => Self::GENERAL_ERROR,
        }
    }
}
