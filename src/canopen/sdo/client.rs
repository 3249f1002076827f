//! The SDO client of CiA 301 §7.2.4, sans-I/O, for the `actuator sdo` tool: start a read or a
//! write, feed it the server's frames, send what it returns, until it has an outcome.
//!
//! ```text
//! let first = client.start_upload(id, now);      // send `first`
//! loop { frame = recv(); if let Some(next) = client.handle(&frame, now) { send(next) }
//!        if let Some(abort) = client.poll(now) { send(abort) }
//!        if let Some(outcome) = client.outcome() { break } }
//! ```

use super::{
    abort_frame, ccs, header, multiplexer, request_cob_id, response_cob_id, scs, sdo_frame,
    AbortCode, DEFAULT_TIMEOUT_S, TOGGLE,
};
use crate::canopen::od::{format_hex, parse_hex, DataType, ObjectId, Value, ValueError};
use crate::canopen::Frame;

/// How a transfer ended badly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SdoError {
    #[error("{id}: the server aborted: {code}")]
    ServerAbort { id: ObjectId, code: AbortCode },
    /// The client aborted (and told the server): no answer in time, or an answer that breaks
    /// the protocol.
    #[error("{id}: aborted: {code}")]
    ClientAbort { id: ObjectId, code: AbortCode },
}

impl SdoError {
    pub fn code(&self) -> AbortCode {
        match self {
            SdoError::ServerAbort { code, .. } | SdoError::ClientAbort { code, .. } => *code,
        }
    }
}

/// A finished transfer: the bytes read (empty after a write), or why it failed.
pub type SdoOutcome = Result<Vec<u8>, SdoError>;

#[derive(Debug, Clone, PartialEq)]
enum State {
    Idle,
    /// Waiting for the initiate response, then for segments.
    Upload {
        id: ObjectId,
        initiated: bool,
        toggle: bool,
        size: Option<usize>,
        last_s: f64,
    },
    /// `sent` bytes of `data` are out; waiting for the response to the last request.
    Download {
        id: ObjectId,
        initiated: bool,
        toggle: bool,
        sent: usize,
        last_s: f64,
    },
    Done,
}

/// One SDO client talking to the server of one node. Not for the real-time thread: it keeps
/// the transferred bytes in a `Vec`.
#[derive(Debug, Clone)]
pub struct SdoClient {
    node_id: u8,
    timeout_s: f64,
    state: State,
    data: Vec<u8>,
    outcome: Option<SdoOutcome>,
}

impl SdoClient {
    /// A client of the server of node `node_id`.
    pub fn new(node_id: u8) -> Self {
        Self {
            node_id,
            timeout_s: DEFAULT_TIMEOUT_S,
            state: State::Idle,
            data: Vec::new(),
            outcome: None,
        }
    }

    /// Give up on a server that is silent for `timeout_s`.
    pub fn with_timeout(mut self, timeout_s: f64) -> Self {
        self.timeout_s = timeout_s;
        self
    }

    /// Read `id`: returns the initiate upload request to send.
    pub fn start_upload(&mut self, id: ObjectId, now_s: f64) -> Frame {
        self.data.clear();
        self.outcome = None;
        self.state = State::Upload {
            id,
            initiated: false,
            toggle: false,
            size: None,
            last_s: now_s,
        };
        self.request(header(ccs::INITIATE_UPLOAD << 5, id))
    }

    /// Write `bytes` to `id`: expedited for 1 to 4 bytes, segmented otherwise. Returns the
    /// initiate download request to send.
    pub fn start_download(&mut self, id: ObjectId, bytes: &[u8], now_s: f64) -> Frame {
        self.data.clear();
        self.data.extend_from_slice(bytes);
        self.outcome = None;
        let mut d = header(ccs::INITIATE_DOWNLOAD << 5, id);
        let len = bytes.len();
        if (1..=4).contains(&len) {
            d[0] |= (((4 - len) as u8) << 2) | 0x03;
            d[4..4 + len].copy_from_slice(bytes);
        } else {
            d[0] |= 0x01;
            d[4..8].copy_from_slice(&(len as u32).to_le_bytes());
        }
        self.state = State::Download {
            id,
            initiated: false,
            toggle: false,
            sent: if (1..=4).contains(&len) { len } else { 0 },
            last_s: now_s,
        };
        self.request(d)
    }

    /// The result, once the transfer is over.
    pub fn outcome(&self) -> Option<&SdoOutcome> {
        self.outcome.as_ref()
    }

    pub fn is_done(&self) -> bool {
        self.outcome.is_some()
    }

    /// Take one received frame; returns the next request to send, or an abort if the server
    /// broke the protocol. Frames not from the server are ignored.
    pub fn handle(&mut self, frame: &Frame, now_s: f64) -> Option<Frame> {
        if frame.is_extended() || frame.id() != response_cob_id(self.node_id) {
            return None;
        }
        let id = match &self.state {
            State::Upload { id, .. } | State::Download { id, .. } => *id,
            State::Idle | State::Done => return None,
        };
        let d = frame.data();
        if d.len() != 8 {
            return Some(self.fail(id, AbortCode::GENERAL_ERROR));
        }
        let mut b = [0u8; 8];
        b.copy_from_slice(d);
        if b[0] >> 5 == scs::ABORT {
            let code = AbortCode(u32::from_le_bytes([b[4], b[5], b[6], b[7]]));
            self.finish(Err(SdoError::ServerAbort { id, code }));
            return None;
        }
        match self.state.clone() {
            State::Upload {
                initiated: false, ..
            } => self.upload_initiated(id, &b, now_s),
            State::Upload { toggle, size, .. } => self.upload_segment(id, &b, toggle, size, now_s),
            State::Download {
                initiated,
                toggle,
                sent,
                ..
            } => self.download_acked(id, &b, initiated, toggle, sent, now_s),
            State::Idle | State::Done => None,
        }
    }

    /// Call regularly: after `timeout_s` without an answer, ends the transfer and returns the
    /// abort (0504 0000h) to send.
    pub fn poll(&mut self, now_s: f64) -> Option<Frame> {
        let (id, last_s) = match self.state {
            State::Upload { id, last_s, .. } | State::Download { id, last_s, .. } => (id, last_s),
            State::Idle | State::Done => return None,
        };
        let waited = now_s - last_s;
        if waited.is_nan() || waited > self.timeout_s {
            return Some(self.fail(id, AbortCode::TIMEOUT));
        }
        None
    }

    fn upload_initiated(&mut self, id: ObjectId, b: &[u8; 8], now_s: f64) -> Option<Frame> {
        if b[0] >> 5 != scs::INITIATE_UPLOAD || multiplexer(b) != id {
            return Some(self.fail(id, AbortCode::COMMAND_SPECIFIER_INVALID));
        }
        let expedited = b[0] & 0x02 != 0;
        let size_indicated = b[0] & 0x01 != 0;
        if expedited {
            let len = if size_indicated {
                4 - usize::from((b[0] >> 2) & 0x03)
            } else {
                4
            };
            self.data.extend_from_slice(&b[4..4 + len]);
            let data = std::mem::take(&mut self.data);
            self.finish(Ok(data));
            return None;
        }
        let size = size_indicated.then(|| u32::from_le_bytes([b[4], b[5], b[6], b[7]]) as usize);
        self.state = State::Upload {
            id,
            initiated: true,
            toggle: false,
            size,
            last_s: now_s,
        };
        Some(self.request([ccs::UPLOAD_SEGMENT << 5, 0, 0, 0, 0, 0, 0, 0]))
    }

    fn upload_segment(
        &mut self,
        id: ObjectId,
        b: &[u8; 8],
        toggle: bool,
        size: Option<usize>,
        now_s: f64,
    ) -> Option<Frame> {
        if b[0] >> 5 != scs::UPLOAD_SEGMENT {
            return Some(self.fail(id, AbortCode::COMMAND_SPECIFIER_INVALID));
        }
        if (b[0] & TOGGLE != 0) != toggle {
            return Some(self.fail(id, AbortCode::TOGGLE_NOT_ALTERNATED));
        }
        let count = 7 - usize::from((b[0] >> 1) & 0x07);
        self.data.extend_from_slice(&b[1..1 + count]);
        if size.is_some_and(|s| self.data.len() > s) {
            return Some(self.fail(id, AbortCode::LENGTH_MISMATCH));
        }
        if b[0] & 0x01 != 0 {
            if size.is_some_and(|s| self.data.len() != s) {
                return Some(self.fail(id, AbortCode::LENGTH_MISMATCH));
            }
            let data = std::mem::take(&mut self.data);
            self.finish(Ok(data));
            return None;
        }
        self.state = State::Upload {
            id,
            initiated: true,
            toggle: !toggle,
            size,
            last_s: now_s,
        };
        let t = if toggle { 0 } else { TOGGLE };
        Some(self.request([(ccs::UPLOAD_SEGMENT << 5) | t, 0, 0, 0, 0, 0, 0, 0]))
    }

    fn download_acked(
        &mut self,
        id: ObjectId,
        b: &[u8; 8],
        initiated: bool,
        toggle: bool,
        sent: usize,
        now_s: f64,
    ) -> Option<Frame> {
        if !initiated {
            if b[0] >> 5 != scs::INITIATE_DOWNLOAD || multiplexer(b) != id {
                return Some(self.fail(id, AbortCode::COMMAND_SPECIFIER_INVALID));
            }
            if sent == self.data.len() && sent > 0 {
                // Expedited: done with the initiate.
                self.finish(Ok(Vec::new()));
                return None;
            }
        } else {
            if b[0] >> 5 != scs::DOWNLOAD_SEGMENT {
                return Some(self.fail(id, AbortCode::COMMAND_SPECIFIER_INVALID));
            }
            // The ack carries the toggle of the segment it confirms, i.e. the one before `toggle`.
            if (b[0] & TOGGLE != 0) == toggle {
                return Some(self.fail(id, AbortCode::TOGGLE_NOT_ALTERNATED));
            }
            if sent == self.data.len() {
                self.finish(Ok(Vec::new()));
                return None;
            }
        }
        let count = (self.data.len() - sent).min(7);
        let last = sent + count == self.data.len();
        let mut d = [0u8; 8];
        d[0] = (ccs::DOWNLOAD_SEGMENT << 5)
            | if toggle { TOGGLE } else { 0 }
            | (((7 - count) as u8) << 1)
            | u8::from(last);
        d[1..1 + count].copy_from_slice(&self.data[sent..sent + count]);
        self.state = State::Download {
            id,
            initiated: true,
            toggle: !toggle,
            sent: sent + count,
            last_s: now_s,
        };
        Some(self.request(d))
    }

    fn request(&self, data: [u8; 8]) -> Frame {
        sdo_frame(request_cob_id(self.node_id), data)
    }

    fn fail(&mut self, id: ObjectId, code: AbortCode) -> Frame {
        self.finish(Err(SdoError::ClientAbort { id, code }));
        abort_frame(request_cob_id(self.node_id), id, code)
    }

    fn finish(&mut self, outcome: SdoOutcome) {
        self.state = State::Done;
        self.outcome = Some(outcome);
    }
}

/// Text of uploaded bytes: the value if the type is known and the bytes fit it, hex otherwise.
pub fn format_bytes(data_type: Option<DataType>, bytes: &[u8]) -> String {
    match data_type.map(|t| Value::decode(t, bytes)) {
        Some(Ok(v)) => v.to_string(),
        _ => format_hex(bytes),
    }
}

/// Bytes to download for text a user typed: parsed as `data_type` if known, else raw hex.
pub fn encode_text(data_type: Option<DataType>, text: &str) -> Result<Vec<u8>, ValueError> {
    match data_type {
        Some(t) => {
            let v = Value::parse(t, text)?;
            let mut buf = [0u8; crate::canopen::od::STRING_CAPACITY];
            let n = v.encode(&mut buf);
            Ok(buf[..n].to_vec())
        }
        None => parse_hex(text).ok_or_else(|| ValueError::Parse {
            data_type: DataType::VisibleString,
            text: format!("{text} (type unknown: give the bytes in hex)"),
        }),
    }
}
