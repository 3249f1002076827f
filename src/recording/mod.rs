//! The recording format: what the cycle reports (one record per axis and cycle, and events),
//! the MCAP topics they are written on, and the reader that brings cycle records back.
//!
//! Shared by the daemon, which writes recordings, and the lab and benches, which read them; the
//! writer thread itself is the daemon's ([`crate::daemon::recorder`]).

pub mod record;

pub use record::{CycleRecord, Event, Record, Stage, STAGES};

use std::path::{Path, PathBuf};

/// MCAP topic of the per-cycle records.
pub const CYCLE_TOPIC: &str = "/actuatord/cycle";
/// MCAP topic of the events.
pub const EVENT_TOPIC: &str = "/actuatord/events";

/// MCAP topic of the raw CAN frames.
pub const CAN_TOPIC: &str = "/actuatord/can";

/// A recording could not be written or read back.
#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    #[error("recording {path}: {message}")]
    File { path: PathBuf, message: String },
    #[error("recorder thread panicked")]
    Panicked,
}

/// Read the cycle records of an MCAP recording back, in file order.
pub fn read_cycles(path: &Path) -> Result<Vec<CycleRecord>, RecorderError> {
    let err = |message: String| RecorderError::File {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let stream = mcap::MessageStream::new(&bytes).map_err(|e| err(e.to_string()))?;
    let mut cycles = Vec::new();
    for (i, message) in stream.enumerate() {
        let message = message.map_err(|e| err(format!("message {i}: {e}")))?;
        if message.channel.topic == CYCLE_TOPIC {
            let record = serde_json::from_slice(&message.data)
                .map_err(|e| err(format!("message {i} on {CYCLE_TOPIC}: {e}")))?;
            cycles.push(record);
        }
    }
    Ok(cycles)
}
