//! Transport: frames on SocketCAN or on an in-process bus. The only layer that touches sockets.

mod candump;
mod fault;

mod inproc;
mod socketcan_bus;

pub use crate::canopen::{Frame, FrameError};
pub use candump::{parse_candump_line, write_candump_line, CandumpError, CandumpRecord};
pub use fault::BusFault;
pub use inproc::{InProcBus, InProcEndpoint};
pub use socketcan_bus::{SocketCanBus, RECEIVE_BUFFER_BYTES};

use std::time::Instant;

/// What a receive can bring: a data frame, or an error frame reported by the CAN controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BusEvent {
    Frame(Frame),
    /// A CAN error frame (bus-off, error-passive, lost arbitration, ...), as the driver describes it.
    ErrorFrame(BusErrorFrame),
}

/// An error frame from the controller: the error class bits of the id and the data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BusErrorFrame {
    pub class: u32,
    pub data: [u8; 8],
}

impl BusErrorFrame {
    /// The controller was restarted after bus-off (by `restart-ms` or by hand): the bus is back.
    pub fn is_restart(&self) -> bool {
        self.class & 0x100 != 0
    }
}

impl std::fmt::Display for BusErrorFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Bit names after linux/can/error.h, so an operator can match them to kernel docs.
        const NAMES: [(u32, &str); 10] = [
            (0x001, "tx-timeout"),
            (0x002, "lost-arbitration"),
            (0x004, "controller"),
            (0x008, "protocol-violation"),
            (0x010, "transceiver"),
            (0x020, "no-ack"),
            (0x040, "bus-off"),
            (0x080, "bus-error"),
            (0x100, "restarted"),
            (0x200, "error-counter"),
        ];
        write!(f, "CAN error frame class=0x{:03X}", self.class)?;
        for (bit, name) in NAMES {
            if self.class & bit != 0 {
                write!(f, " {name}")?;
            }
        }
        Ok(())
    }
}

/// Transport failures. A closed bus or an I/O error is something the caller must act on.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    #[error("CAN interface {iface}: {source}")]
    Io {
        iface: String,
        #[source]
        source: std::io::Error,
    },
    #[error("CAN interface {0} does not exist (for a virtual bus: ip link add dev {0} type vcan && ip link set {0} up)")]
    NoSuchInterface(String),
    #[error("bus closed: every other endpoint is gone")]
    Closed,
}

/// A CAN bus endpoint: send frames, receive until a deadline.
///
/// Every frame sent reaches every other endpoint of the same bus (vcan semantics), never the sender.
pub trait Bus: Send {
    /// Queue one frame for transmission. Never blocks longer than the driver's transmit queue.
    fn send(&mut self, frame: &Frame) -> Result<(), BusError>;

    /// Wait for the next frame or error frame, until `deadline`. `Ok(None)` means the deadline passed.
    fn recv_until(&mut self, deadline: Instant) -> Result<Option<BusEvent>, BusError>;

    /// The interface name, for messages.
    fn name(&self) -> &str;

    /// Deliver frames with these standard identifiers ahead of any backlog of other traffic
    /// (the frames that complete a cycle). Buses with no queue to wait in have nothing to do.
    fn prioritise(&mut self, _ids: &[u32]) -> Result<(), BusError> {
        Ok(())
    }

    /// Open the connection to the interface again (it was removed and came back, so the old
    /// socket points nowhere). Buses without such a connection have nothing to do.
    fn reopen(&mut self) -> Result<(), BusError> {
        Ok(())
    }
}
