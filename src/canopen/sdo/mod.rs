//! SDO, the service data object of CiA 301 §7.2.4: confirmed reads (upload) and writes (download)
//! of object dictionary entries, expedited (up to 4 bytes in one frame) or segmented (7 bytes per
//! frame, with a toggle bit). Block transfer is not supported and answered with an abort.
//!
//! Frame layout (CiA 301 §7.2.4.3, every SDO frame has 8 data bytes):
//!
//! | byte 0 | bytes 1-2 | byte 3 | bytes 4-7 |
//! |---|---|---|---|
//! | command specifier and flags | index, little-endian | subindex | data, size or abort code |
//!
//! A segment frame has the command byte and 7 data bytes. Client to server is COB-ID
//! `600h + node id`, server to client `580h + node id` (CiA 301 §7.3.5, predefined connection set).

mod abort;
mod client;
mod expedited;
mod server;

pub use abort::AbortCode;
pub use client::{encode_text, format_bytes, SdoClient, SdoError, SdoOutcome};
pub use expedited::{Answer, Expedited};
pub use server::SdoServer;

use crate::canopen::Frame;

/// Function code of client → server SDO frames (RSDO of the server).
pub const SDO_RX_FUNCTION: u32 = 0x600;
/// Function code of server → client SDO frames (TSDO of the server).
pub const SDO_TX_FUNCTION: u32 = 0x580;
/// Longest value a segmented transfer carries; longer ones are aborted with
/// [`AbortCode::LENGTH_MISMATCH`]. Holds any value of the dictionary with room to spare.
pub const SEGMENT_BUFFER: usize = 256;
/// A segmented transfer with no frame for this long is aborted with [`AbortCode::TIMEOUT`].
pub const DEFAULT_TIMEOUT_S: f64 = 1.0;

/// COB-ID the server of `node_id` listens on.
pub fn request_cob_id(node_id: u8) -> u32 {
    SDO_RX_FUNCTION + u32::from(node_id)
}

/// COB-ID the server of `node_id` answers on.
pub fn response_cob_id(node_id: u8) -> u32 {
    SDO_TX_FUNCTION + u32::from(node_id)
}

/// Client command specifiers (ccs, bits 7..5 of byte 0), CiA 301 §7.2.4.3.
pub(crate) mod ccs {
    pub const DOWNLOAD_SEGMENT: u8 = 0;
    pub const INITIATE_DOWNLOAD: u8 = 1;
    pub const INITIATE_UPLOAD: u8 = 2;
    pub const UPLOAD_SEGMENT: u8 = 3;
    pub const ABORT: u8 = 4;
}

/// Server command specifiers (scs, bits 7..5 of byte 0).
pub(crate) mod scs {
    pub const UPLOAD_SEGMENT: u8 = 0;
    pub const DOWNLOAD_SEGMENT: u8 = 1;
    pub const INITIATE_UPLOAD: u8 = 2;
    pub const INITIATE_DOWNLOAD: u8 = 3;
    pub const ABORT: u8 = 4;
}

/// Toggle bit (bit 4) of segment frames.
pub(crate) const TOGGLE: u8 = 0x10;

/// An 8-byte SDO frame; SDO ids and lengths always fit.
pub(crate) fn sdo_frame(cob_id: u32, data: [u8; 8]) -> Frame {
    Frame::new(cob_id & 0x7FF, &data).unwrap_or_else(|e| unreachable!("SDO frame layout: {e}"))
}

/// Bytes 0..4 of an initiate or abort frame: command byte, index, subindex.
pub(crate) fn header(command: u8, id: crate::canopen::od::ObjectId) -> [u8; 8] {
    let [lo, hi] = id.index.to_le_bytes();
    [command, lo, hi, id.sub, 0, 0, 0, 0]
}

/// An abort transfer frame (command 80h, CiA 301 §7.2.4.3.17).
pub(crate) fn abort_frame(cob_id: u32, id: crate::canopen::od::ObjectId, code: AbortCode) -> Frame {
    let mut d = header(scs::ABORT << 5, id);
    d[4..8].copy_from_slice(&code.0.to_le_bytes());
    sdo_frame(cob_id, d)
}

/// The multiplexer (index, subindex) of an initiate or abort frame with 8 bytes.
pub(crate) fn multiplexer(d: &[u8]) -> crate::canopen::od::ObjectId {
    match d {
        [_, lo, hi, sub, ..] => {
            crate::canopen::od::ObjectId::new(u16::from_le_bytes([*lo, *hi]), *sub)
        }
        _ => crate::canopen::od::ObjectId::new(0, 0),
    }
}

#[cfg(test)]
mod tests;
