//! The CANopen-style protocol, sans-I/O: frames in, typed values out, and back.
//!
//! NMT, SYNC, heartbeat, EMCY and PDOs with a fixed mapping. The layout lives in one table
//! ([`messages`]); the codec and `dbc/actuatord.dbc` are both made from it. Parameters and
//! results are reached over SDO ([`sdo`]) in the object dictionary ([`od`]), which also renders
//! the EDS ([`eds`]).

mod codec;
pub mod dbc;
mod decode;
pub mod eds;
mod emcy;
pub mod messages;
mod nmt;
pub mod od;
mod pdo;
pub mod profile;
pub mod sdo;
mod signal;

pub use codec::{check_length, pack, unpack, DecodeError};
pub use decode::{decode_frame, DecodedSignal};
pub use eds::{render_eds, EdsInfo};
pub use emcy::{
    error_code, error_register, supervised_error_code, supply_band_code, Emcy, ERROR_RESET,
};
pub use messages::{Message, FAULT_FLAG_NAMES, SUPERVISED_FLAG_NAMES, SYMPTOM_NAMES};
pub use nmt::{
    decode_heartbeat, decode_sync, encode_heartbeat, is_heartbeat, NmtCommand, NmtState,
    SyncCounter,
};
pub use od::{DataType, ObjectDictionary, ObjectId, Value};
pub use pdo::{
    diagnosed_fault_code, diagnosed_fault_from_code, CommandPdo, FaultDiagnosisPdo, FaultResetPdo,
    FaultStatePdo, LoopStatusPdo, SensorPdo, SetpointPdo, SupplyPressurePdo, TunedGainsPdo,
    TunedParametersPdo, SUPERVISED_FLAGGED,
};
pub use sdo::{AbortCode, SdoClient, SdoServer};
pub use signal::Signal;
