//! The recording format: what the cycle reports (one record per axis and cycle, and events),
//! the MCAP topics they are written on, and the reader that brings cycle records back.
//!
//! Shared by the daemon, which writes recordings, and the lab and benches, which read them; the
//! writer thread itself is the daemon's ([`crate::daemon::recorder`]).

pub mod record;

pub use record::{CycleRecord, Event, Record, RejoinFailure, RejoinStage, Stage, STAGES};

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

/// The magic bytes an MCAP file begins and ends with; a writer killed before its footer leaves
/// a file that does not end with them.
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// Where a recording stops short: its writer was killed (a crash, `kill -9`, power lost) before
/// the footer, in the middle of a record.
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// Messages read before the cut.
    pub messages: usize,
    /// Size of the file, bytes.
    pub bytes: usize,
    /// What the reader met at the cut.
    pub reason: String,
}

impl std::fmt::Display for Cut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the file ends without its footer after {} bytes (its writer was stopped mid-record: \
             {}); read up to its last complete record, message {}",
            self.bytes, self.reason, self.messages
        )
    }
}

/// The cycle records of a recording, and where it was cut if its writer did not finish it.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    pub cycles: Vec<CycleRecord>,
    pub cut: Option<Cut>,
}

/// Read the cycle records of an MCAP recording back, in file order. A recording whose writer
/// was killed (no footer: the file does not end with the MCAP magic) is read up to its last
/// complete record and says where it was cut; a broken record in a finished file is an error.
pub fn read_recording(path: &Path) -> Result<Recording, RecorderError> {
    let err = |message: String| RecorderError::File {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let finished = bytes.ends_with(MCAP_MAGIC) && bytes.len() > MCAP_MAGIC.len();
    let stream = mcap::MessageStream::new(&bytes).map_err(|e| err(e.to_string()))?;
    let mut cycles = Vec::new();
    let mut cut = None;
    for (i, message) in stream.enumerate() {
        let message = match message {
            Ok(m) => m,
            Err(e) if !finished => {
                cut = Some(Cut {
                    messages: i,
                    bytes: bytes.len(),
                    reason: e.to_string(),
                });
                break;
            }
            Err(e) => return Err(err(format!("message {i}: {e}"))),
        };
        if message.channel.topic == CYCLE_TOPIC {
            let record = serde_json::from_slice(&message.data)
                .map_err(|e| err(format!("message {i} on {CYCLE_TOPIC}: {e}")))?;
            cycles.push(record);
        }
    }
    Ok(Recording { cycles, cut })
}

/// Read the cycle records of a finished MCAP recording back, in file order; a cut one is an
/// error that says where it was cut ([`read_recording`] reads what it holds).
pub fn read_cycles(path: &Path) -> Result<Vec<CycleRecord>, RecorderError> {
    let r = read_recording(path)?;
    match r.cut {
        None => Ok(r.cycles),
        Some(cut) => Err(RecorderError::File {
            path: path.to_path_buf(),
            message: cut.to_string(),
        }),
    }
}
