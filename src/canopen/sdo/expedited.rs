//! One expedited SDO transfer (a value of 1 to 4 bytes in one request and one answer), sans-I/O
//! and allocation-free, for the cycle thread: a node that rebooted is configured again between
//! cycles without a thread or a socket of its own. Values longer than 4 bytes need
//! [`super::SdoClient`], which is not for the cycle thread.

use super::{
    abort_frame, ccs, header, multiplexer, request_cob_id, response_cob_id, scs, sdo_frame,
    AbortCode, SdoError,
};
use crate::canopen::od::ObjectId;
use crate::canopen::Frame;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Direction {
    Upload,
    Download,
}

/// A read or a write of one object on the server of one node, waiting for its answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Expedited {
    node_id: u8,
    id: ObjectId,
    direction: Direction,
}

/// What the server's answer was to the transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Answer {
    /// Read: the value, little-endian in the low bytes; write: 0.
    Done(u32),
    /// The transfer failed; for a [`SdoError::ClientAbort`] the abort frame goes to the server.
    Failed(SdoError, Option<Frame>),
}

impl Expedited {
    /// Read `id` of node `node_id`: the transfer and the initiate upload request to send.
    pub fn read(node_id: u8, id: ObjectId) -> (Self, Frame) {
        let t = Self {
            node_id,
            id,
            direction: Direction::Upload,
        };
        (t, t.request(header(ccs::INITIATE_UPLOAD << 5, id)))
    }

    /// Write `bytes` (1 to 4; more are cut to 4) to `id` of node `node_id`: the transfer and
    /// the expedited initiate download request, with its size indicated.
    pub fn write(node_id: u8, id: ObjectId, bytes: &[u8]) -> (Self, Frame) {
        let len = bytes.len().clamp(1, 4);
        let mut d = header(ccs::INITIATE_DOWNLOAD << 5, id);
        // e = 1, s = 1, n = 4 - len bytes of the data field unused (CiA 301 §7.2.4.3.3).
        d[0] |= (((4 - len) as u8) << 2) | 0x03;
        let n = bytes.len().min(4);
        d[4..4 + n].copy_from_slice(&bytes[..n]);
        let t = Self {
            node_id,
            id,
            direction: Direction::Download,
        };
        (t, t.request(d))
    }

    /// The object the transfer reads or writes.
    pub fn object(&self) -> ObjectId {
        self.id
    }

    /// The server's answer in `frame`, or `None` when the frame is not one (another id, or an
    /// answer about another object: a late answer to an earlier transfer is not this one's).
    pub fn answer(&self, frame: &Frame) -> Option<Answer> {
        if frame.is_extended() || frame.id() != response_cob_id(self.node_id) {
            return None;
        }
        let d = frame.data();
        if d.len() != 8 {
            return Some(self.client_abort(AbortCode::GENERAL_ERROR));
        }
        if multiplexer(d) != self.id {
            return None;
        }
        let value = u32::from_le_bytes([d[4], d[5], d[6], d[7]]);
        match (d[0] >> 5, self.direction) {
            (scs::ABORT, _) => Some(Answer::Failed(
                SdoError::ServerAbort {
                    id: self.id,
                    code: AbortCode(value),
                },
                None,
            )),
            (scs::INITIATE_DOWNLOAD, Direction::Download) => Some(Answer::Done(0)),
            (scs::INITIATE_UPLOAD, Direction::Upload) if d[0] & 0x02 != 0 => {
                // Expedited upload: with the size indicated, only the low 4 - n bytes count.
                let len = if d[0] & 0x01 != 0 {
                    4 - u32::from((d[0] >> 2) & 0x03)
                } else {
                    4
                };
                let mask = if len >= 4 {
                    u32::MAX
                } else {
                    (1u32 << (8 * len)) - 1
                };
                Some(Answer::Done(value & mask))
            }
            // A segmented upload of a value longer than 4 bytes: not what was asked for.
            (scs::INITIATE_UPLOAD, Direction::Upload) => {
                Some(self.client_abort(AbortCode::LENGTH_MISMATCH))
            }
            _ => Some(self.client_abort(AbortCode::COMMAND_SPECIFIER_INVALID)),
        }
    }

    /// Give up on the transfer (no answer in time): the abort frame to send, and the error.
    pub fn timeout(&self) -> (SdoError, Frame) {
        let code = AbortCode::TIMEOUT;
        (
            SdoError::ClientAbort { id: self.id, code },
            abort_frame(request_cob_id(self.node_id), self.id, code),
        )
    }

    fn client_abort(&self, code: AbortCode) -> Answer {
        Answer::Failed(
            SdoError::ClientAbort { id: self.id, code },
            Some(abort_frame(request_cob_id(self.node_id), self.id, code)),
        )
    }

    fn request(&self, data: [u8; 8]) -> Frame {
        sdo_frame(request_cob_id(self.node_id), data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::od::{EntrySpec, ObjectDictionary, Value};
    use crate::canopen::{NmtState, SdoServer};

    /// A server with a writable UNSIGNED16 at 2000h sub 0 and a 9-byte string at 1008h.
    fn server() -> (SdoServer, ObjectDictionary) {
        let od = ObjectDictionary::builder()
            .var(0x2000, EntrySpec::rw("value", 0x1234u16))
            .var(
                0x1008,
                EntrySpec::ro(
                    "manufacturer_device_name",
                    Value::string("actuatord").expect("ascii"),
                ),
            )
            .build()
            .expect("dictionary");
        (SdoServer::new(5), od)
    }

    #[test]
    fn a_read_and_a_write_against_the_projects_server() {
        let (mut s, mut od) = server();
        let (t, request) = Expedited::read(5, ObjectId::new(0x2000, 0));
        let answer = s
            .handle(&request, 0.0, &mut od, NmtState::PreOperational)
            .expect("answer");
        assert_eq!(t.answer(&answer), Some(Answer::Done(0x1234)));
        let (t, request) = Expedited::write(5, ObjectId::new(0x2000, 0), &0xBEEFu16.to_le_bytes());
        let answer = s
            .handle(&request, 0.0, &mut od, NmtState::PreOperational)
            .expect("answer");
        assert_eq!(t.answer(&answer), Some(Answer::Done(0)));
        // The server stages a write; the node applies it at its boundary.
        od.take_pending_writes().for_each(drop);
        let (t, request) = Expedited::read(5, ObjectId::new(0x2000, 0));
        let answer = s
            .handle(&request, 0.0, &mut od, NmtState::PreOperational)
            .expect("answer");
        assert_eq!(t.answer(&answer), Some(Answer::Done(0xBEEF)));
    }

    #[test]
    fn an_abort_a_long_value_and_a_stranger_are_told_apart() {
        let (mut s, mut od) = server();
        // The server aborts a write to an object it does not have.
        let (t, request) = Expedited::write(5, ObjectId::new(0x2002, 0), &[1]);
        let answer = s
            .handle(&request, 0.0, &mut od, NmtState::PreOperational)
            .expect("answer");
        match t.answer(&answer) {
            Some(Answer::Failed(SdoError::ServerAbort { code, .. }, None)) => {
                assert_eq!(code, AbortCode::OBJECT_DOES_NOT_EXIST)
            }
            other => panic!("{other:?}"),
        }
        // Nine bytes come segmented: the transfer aborts it with a length mismatch.
        let (t, request) = Expedited::read(5, ObjectId::new(0x1008, 0));
        let answer = s
            .handle(&request, 0.0, &mut od, NmtState::PreOperational)
            .expect("answer");
        match t.answer(&answer) {
            Some(Answer::Failed(SdoError::ClientAbort { code, .. }, Some(abort))) => {
                assert_eq!(code, AbortCode::LENGTH_MISMATCH);
                assert_eq!(abort.id(), 0x605);
                assert_eq!(abort.data()[0], 0x80);
            }
            other => panic!("{other:?}"),
        }
        // Another node's answer, or one about another object, is not this transfer's.
        let (t, _) = Expedited::read(6, ObjectId::new(0x2000, 0));
        assert_eq!(t.answer(&answer), None);
        let (t, _) = Expedited::read(5, ObjectId::new(0x2000, 1));
        assert_eq!(t.answer(&answer), None);
        let (e, abort) = t.timeout();
        assert_eq!(e.code(), AbortCode::TIMEOUT);
        assert_eq!(abort.data()[4..8], 0x0504_0000u32.to_le_bytes());
    }
}
