//! The SDO server of CiA 301 §7.2.4, sans-I/O: one request frame in, at most one response out.
//!
//! Reads copy the value out of the dictionary's snapshot at the first frame; writes are checked
//! and staged in the dictionary only once the whole value has arrived (see [`crate::canopen::od`]),
//! so the node applies them at its next cycle boundary. A segmented transfer holds its bytes in
//! a fixed buffer of [`SEGMENT_BUFFER`] bytes: nothing allocates per frame.

use super::{
    abort_frame, ccs, header, multiplexer, response_cob_id, scs, sdo_frame, AbortCode,
    DEFAULT_TIMEOUT_S, SEGMENT_BUFFER, TOGGLE,
};
use crate::canopen::nmt::NmtState;
use crate::canopen::od::{ObjectDictionary, ObjectId};
use crate::canopen::Frame;

/// A segmented transfer in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Transfer {
    Idle,
    /// Download (client writes): bytes collected so far in the buffer.
    Download {
        id: ObjectId,
        toggle: bool,
        len: usize,
        /// Size the client announced at initiate, if it did.
        size: Option<usize>,
        last_s: f64,
    },
    /// Upload (client reads): the whole value is in the buffer, `pos` bytes already sent.
    Upload {
        id: ObjectId,
        toggle: bool,
        len: usize,
        pos: usize,
        last_s: f64,
    },
}

/// One SDO server channel (the default server, 1200h).
#[derive(Debug, Clone)]
pub struct SdoServer {
    node_id: u8,
    timeout_s: f64,
    transfer: Transfer,
    buf: [u8; SEGMENT_BUFFER],
}

impl SdoServer {
    /// The server of node `node_id`: requests on 600h + id, responses on 580h + id.
    pub fn new(node_id: u8) -> Self {
        Self {
            node_id,
            timeout_s: DEFAULT_TIMEOUT_S,
            transfer: Transfer::Idle,
            buf: [0; SEGMENT_BUFFER],
        }
    }

    /// Abort a segmented transfer after `timeout_s` without a request frame.
    pub fn with_timeout(mut self, timeout_s: f64) -> Self {
        self.timeout_s = timeout_s;
        self
    }

    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    pub fn timeout_s(&self) -> f64 {
        self.timeout_s
    }

    /// True while a segmented transfer waits for its next request.
    pub fn is_busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Drop any transfer without answering (e.g. on an NMT reset).
    pub fn reset(&mut self) {
        self.transfer = Transfer::Idle;
    }

    /// Take one frame. Frames for other COB-IDs are ignored; SDO is served in pre-operational
    /// and operational only (CiA 301 §7.3.2.2.1: not in stopped). Returns the response, if any:
    /// every request gets exactly one, except a client's abort, which gets none.
    pub fn handle(
        &mut self,
        frame: &Frame,
        now_s: f64,
        od: &mut ObjectDictionary,
        state: NmtState,
    ) -> Option<Frame> {
        if frame.is_extended() || frame.id() != super::request_cob_id(self.node_id) {
            return None;
        }
        if !matches!(state, NmtState::PreOperational | NmtState::Operational) {
            return None;
        }
        let d = frame.data();
        let command = d.first().copied().unwrap_or(0xFF);
        let ccs = command >> 5;
        if ccs == ccs::ABORT {
            // CiA 301 §7.2.4.3.17: an abort is not confirmed.
            self.transfer = Transfer::Idle;
            return None;
        }
        // A transfer that outlived its timeout is over, whether or not poll() said so yet.
        let expired = self.expired(now_s);
        if let Some(id) = expired {
            self.transfer = Transfer::Idle;
            if matches!(ccs, ccs::DOWNLOAD_SEGMENT | ccs::UPLOAD_SEGMENT) {
                return Some(self.abort(id, AbortCode::TIMEOUT));
            }
        }
        if d.len() != 8 {
            let id = self.current_id().unwrap_or_else(|| multiplexer(d));
            self.transfer = Transfer::Idle;
            return Some(self.abort(id, AbortCode::GENERAL_ERROR));
        }
        let mut data = [0u8; 8];
        data.copy_from_slice(d);
        let response = match ccs {
            ccs::INITIATE_DOWNLOAD => self.initiate_download(&data, now_s, od, state),
            ccs::DOWNLOAD_SEGMENT => self.download_segment(&data, now_s, od, state),
            ccs::INITIATE_UPLOAD => self.initiate_upload(&data, now_s, od),
            ccs::UPLOAD_SEGMENT => self.upload_segment(&data, now_s),
            // Block upload (5), block download (6) and 7 are not served.
            _ => Err((
                self.current_id().unwrap_or_else(|| multiplexer(&data)),
                AbortCode::COMMAND_SPECIFIER_INVALID,
            )),
        };
        Some(match response {
            Ok(frame) => frame,
            Err((id, code)) => {
                self.transfer = Transfer::Idle;
                self.abort(id, code)
            }
        })
    }

    /// Call regularly: aborts a segmented transfer whose client went silent for the timeout
    /// (abort code 0504 0000h) and returns that abort frame.
    pub fn poll(&mut self, now_s: f64) -> Option<Frame> {
        let id = self.expired(now_s)?;
        self.transfer = Transfer::Idle;
        Some(self.abort(id, AbortCode::TIMEOUT))
    }

    fn expired(&self, now_s: f64) -> Option<ObjectId> {
        match self.transfer {
            Transfer::Idle => None,
            Transfer::Download { id, last_s, .. } | Transfer::Upload { id, last_s, .. } => {
                // A clock that jumped back, or a NaN, must not keep a transfer alive forever.
                let waited = now_s - last_s;
                (waited.is_nan() || !(0.0..=self.timeout_s).contains(&waited)).then_some(id)
            }
        }
    }

    fn current_id(&self) -> Option<ObjectId> {
        match self.transfer {
            Transfer::Idle => None,
            Transfer::Download { id, .. } | Transfer::Upload { id, .. } => Some(id),
        }
    }

    fn abort(&self, id: ObjectId, code: AbortCode) -> Frame {
        abort_frame(response_cob_id(self.node_id), id, code)
    }

    fn respond(&self, data: [u8; 8]) -> Frame {
        sdo_frame(response_cob_id(self.node_id), data)
    }

    /// Initiate download (ccs 1, CiA 301 §7.2.4.3.3): bit 1 e (expedited), bit 0 s (size
    /// indicated), bits 3..2 n (bytes of 4..7 without data, when e and s).
    fn initiate_download(
        &mut self,
        d: &[u8; 8],
        now_s: f64,
        od: &mut ObjectDictionary,
        state: NmtState,
    ) -> Result<Frame, (ObjectId, AbortCode)> {
        let id = multiplexer(d);
        let fail = |code: AbortCode| (id, code);
        // Any new initiate ends a transfer in progress.
        self.transfer = Transfer::Idle;
        let handle = od.check_writable(id, state).map_err(|e| fail(e.into()))?;
        let expedited = d[0] & 0x02 != 0;
        let size_indicated = d[0] & 0x01 != 0;
        let data_type = od.entry(handle).data_type;
        if expedited {
            let len = if size_indicated {
                4 - usize::from((d[0] >> 2) & 0x03)
            } else {
                // "Unspecified number of bytes": take what the type needs.
                data_type.size().unwrap_or(4).min(4)
            };
            od.stage_write(id, &d[4..4 + len], state)
                .map_err(|e| fail(e.into()))?;
        } else {
            let size = if size_indicated {
                let s = u32::from_le_bytes([d[4], d[5], d[6], d[7]]) as usize;
                let wrong_for_type = data_type.size().is_some_and(|t| t != s);
                if s > SEGMENT_BUFFER || wrong_for_type {
                    return Err(fail(AbortCode::LENGTH_MISMATCH));
                }
                Some(s)
            } else {
                None
            };
            self.transfer = Transfer::Download {
                id,
                toggle: false,
                len: 0,
                size,
                last_s: now_s,
            };
        }
        Ok(self.respond(header(scs::INITIATE_DOWNLOAD << 5, id)))
    }

    /// Download segment (ccs 0, §7.2.4.3.4): bit 4 t (toggle), bits 3..1 n (bytes of 1..7
    /// without data), bit 0 c (last segment).
    fn download_segment(
        &mut self,
        d: &[u8; 8],
        now_s: f64,
        od: &mut ObjectDictionary,
        state: NmtState,
    ) -> Result<Frame, (ObjectId, AbortCode)> {
        let Transfer::Download {
            id,
            toggle,
            len,
            size,
            ..
        } = self.transfer
        else {
            let id = self.current_id().unwrap_or(ObjectId::new(0, 0));
            return Err((id, AbortCode::COMMAND_SPECIFIER_INVALID));
        };
        let t = d[0] & TOGGLE != 0;
        if t != toggle {
            return Err((id, AbortCode::TOGGLE_NOT_ALTERNATED));
        }
        let count = 7 - usize::from((d[0] >> 1) & 0x07);
        let last = d[0] & 0x01 != 0;
        let new_len = len + count;
        if new_len > SEGMENT_BUFFER || size.is_some_and(|s| new_len > s) {
            return Err((id, AbortCode::LENGTH_MISMATCH));
        }
        self.buf[len..new_len].copy_from_slice(&d[1..1 + count]);
        let ack = self.respond([
            (scs::DOWNLOAD_SEGMENT << 5) | (d[0] & TOGGLE),
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        ]);
        if last {
            self.transfer = Transfer::Idle;
            if size.is_some_and(|s| s != new_len) {
                return Err((id, AbortCode::LENGTH_MISMATCH));
            }
            od.stage_write(id, &self.buf[..new_len], state)
                .map_err(|e| (id, e.into()))?;
        } else {
            self.transfer = Transfer::Download {
                id,
                toggle: !toggle,
                len: new_len,
                size,
                last_s: now_s,
            };
        }
        Ok(ack)
    }

    /// Initiate upload (ccs 2, §7.2.4.3.6); the response is expedited for 1 to 4 bytes.
    fn initiate_upload(
        &mut self,
        d: &[u8; 8],
        now_s: f64,
        od: &ObjectDictionary,
    ) -> Result<Frame, (ObjectId, AbortCode)> {
        let id = multiplexer(d);
        self.transfer = Transfer::Idle;
        let value = od.read(id).map_err(|e| (id, e.into()))?;
        let len = value.encode(&mut self.buf);
        let mut out = header(scs::INITIATE_UPLOAD << 5, id);
        if (1..=4).contains(&len) {
            out[0] |= (((4 - len) as u8) << 2) | 0x03;
            out[4..4 + len].copy_from_slice(&self.buf[..len]);
        } else {
            out[0] |= 0x01;
            out[4..8].copy_from_slice(&(len as u32).to_le_bytes());
            self.transfer = Transfer::Upload {
                id,
                toggle: false,
                len,
                pos: 0,
                last_s: now_s,
            };
        }
        Ok(self.respond(out))
    }

    /// Upload segment (ccs 3, §7.2.4.3.7): the response carries up to 7 bytes, n unused, c last.
    fn upload_segment(&mut self, d: &[u8; 8], now_s: f64) -> Result<Frame, (ObjectId, AbortCode)> {
        let Transfer::Upload {
            id,
            toggle,
            len,
            pos,
            ..
        } = self.transfer
        else {
            let id = self.current_id().unwrap_or(ObjectId::new(0, 0));
            return Err((id, AbortCode::COMMAND_SPECIFIER_INVALID));
        };
        let t = d[0] & TOGGLE != 0;
        if t != toggle {
            return Err((id, AbortCode::TOGGLE_NOT_ALTERNATED));
        }
        let count = (len - pos).min(7);
        let last = pos + count == len;
        let mut out = [0u8; 8];
        out[0] = (scs::UPLOAD_SEGMENT << 5)
            | (d[0] & TOGGLE)
            | (((7 - count) as u8) << 1)
            | u8::from(last);
        out[1..1 + count].copy_from_slice(&self.buf[pos..pos + count]);
        self.transfer = if last {
            Transfer::Idle
        } else {
            Transfer::Upload {
                id,
                toggle: !toggle,
                len,
                pos: pos + count,
                last_s: now_s,
            }
        };
        Ok(self.respond(out))
    }
}
