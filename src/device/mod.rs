//! The device profile of an actuatord node on the CANopen-style stack ([`crate::canopen`]):
//! the message table, the PDOs and EMCY codes made from it, the objects of an axis in the
//! dictionary, and the standard profiles (CiA 401/402) the simulated nodes speak.
//!
//! The layout lives in one table ([`messages`]); the codec and `dbc/actuatord.dbc` are both made
//! from it.

mod codec;
pub mod dbc;
mod decode;
mod emcy;
pub mod messages;
pub mod objects;
mod pdo;
pub mod profile;

pub use codec::{check_length, pack, unpack, DecodeError};
pub use decode::{decode_frame, DecodedSignal};
pub use emcy::{
    error_code, error_code_meaning, error_field_entry, error_register, supervised_error_code,
    supply_band_code, Emcy, ERROR_RESET,
};
pub use messages::{Message, FAULT_FLAG_NAMES, SUPERVISED_FLAG_NAMES, SYMPTOM_NAMES};
pub use pdo::{
    diagnosed_fault_code, diagnosed_fault_from_code, CommandPdo, FaultDiagnosisPdo, FaultResetPdo,
    FaultStatePdo, LoopStatusPdo, SensorPdo, SetpointPdo, SupplyPressurePdo, TunedGainsPdo,
    TunedParametersPdo, SUPERVISED_FLAGGED,
};
