//! The CANopen-style protocol stack, sans-I/O, knowing no actuator: frames, NMT, SYNC and
//! heartbeat, EMCY framing and the pre-defined error field, SDO client and server, the object
//! dictionary machinery and the EDS writer.
//!
//! What an actuatord node says with it (its PDOs, message table, EMCY codes and the objects of
//! an axis) is the device profile, [`crate::device`], one layer up.

pub mod eds;
pub mod emcy;
mod error;
pub mod error_field;
mod frame;
pub mod heartbeat;
pub mod nmt;
pub mod od;
pub mod sdo;
mod signal;

pub use eds::{render_eds, EdsInfo};
pub use emcy::EmcyFrame;
pub use error::DecodeError;
pub use error_field::{ErrorEntry, ErrorField, ERROR_FIELD_LEN};
pub use frame::{Frame, FrameError};
pub use nmt::{
    decode_heartbeat, decode_sync, encode_heartbeat, is_heartbeat, NmtCommand, NmtState,
    SyncCounter,
};
pub use od::{DataType, ObjectDictionary, ObjectId, Value};
pub use sdo::{AbortCode, SdoClient, SdoServer};
pub use signal::Signal;
