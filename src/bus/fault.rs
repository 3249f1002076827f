//! What went wrong with a bus, named: errno of a send or receive, or a CAN error frame.

use super::{BusError, BusErrorFrame};

/// The cause of a bus fault, as the operator sees it in the log, the recording and the EMCY.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusFault {
    /// The interface is administratively down (ENETDOWN): `ip link set can0 down`, a network
    /// manager, or a driver restarting the controller.
    InterfaceDown,
    /// The interface is gone (ENODEV, ENXIO): unplugged adapter, removed or renamed device.
    InterfaceGone,
    /// The transmit queue is full (ENOBUFS): nobody acknowledges the frames (no other node,
    /// a cable fault) or the controller is bus-off and stopped sending.
    TransmitQueueFull,
    /// The controller went bus-off (error frame): too many transmit errors, it stopped.
    BusOff,
    /// The controller is error passive (error frame): its error counters passed 127.
    ErrorPassive,
    /// The controller's error counters passed the warning level (96).
    ErrorWarning,
    /// The controller or the socket lost frames (receive or transmit overflow).
    Overflow,
    /// No node acknowledged a frame, or the transceiver reports a wiring fault.
    NoAcknowledge,
    /// Any other error of the socket, with its errno.
    Io(i32),
}

impl BusFault {
    /// The cause of a failed send or receive; `None` for a closed in-process bus, which ends a run.
    pub fn from_error(error: &BusError) -> Option<BusFault> {
        match error {
            BusError::Io { source, .. } => Some(match source.raw_os_error() {
                Some(libc::ENETDOWN) => BusFault::InterfaceDown,
                Some(libc::ENODEV) | Some(libc::ENXIO) => BusFault::InterfaceGone,
                Some(libc::ENOBUFS) | Some(libc::EAGAIN) => BusFault::TransmitQueueFull,
                Some(errno) => BusFault::Io(errno),
                None => BusFault::Io(0),
            }),
            BusError::NoSuchInterface(_) => Some(BusFault::InterfaceGone),
            BusError::Closed => None,
        }
    }

    /// The fault an error frame reports, if it is one (lost arbitration, for one, is not).
    pub fn from_error_frame(e: &BusErrorFrame) -> Option<BusFault> {
        // Class bits and controller detail bits after linux/can/error.h.
        const BUS_OFF: u32 = 0x040;
        const CONTROLLER: u32 = 0x004;
        const NO_ACK: u32 = 0x020;
        const TRANSCEIVER: u32 = 0x010;
        const CTRL_OVERFLOW: u8 = 0x01 | 0x02;
        const CTRL_WARNING: u8 = 0x04 | 0x08;
        const CTRL_PASSIVE: u8 = 0x10 | 0x20;
        if e.class & BUS_OFF != 0 {
            return Some(BusFault::BusOff);
        }
        if e.class & CONTROLLER != 0 {
            let detail = e.data[1];
            if detail & CTRL_PASSIVE != 0 {
                return Some(BusFault::ErrorPassive);
            }
            if detail & CTRL_OVERFLOW != 0 {
                return Some(BusFault::Overflow);
            }
            if detail & CTRL_WARNING != 0 {
                return Some(BusFault::ErrorWarning);
            }
        }
        if e.class & (NO_ACK | TRANSCEIVER) != 0 {
            return Some(BusFault::NoAcknowledge);
        }
        None
    }

    /// True when the bus cannot carry frames until it comes back: the cycle stops commanding.
    pub fn is_loss(self) -> bool {
        // A full transmit queue loses the frame, not the bus: the next period tries again, and
        // a bus that really stopped shows as bus-off or a downed interface.
        matches!(
            self,
            BusFault::InterfaceDown | BusFault::InterfaceGone | BusFault::BusOff | BusFault::Io(_)
        )
    }

    /// True when the socket must be opened again to reach the interface (its index changed).
    pub fn needs_reopen(self) -> bool {
        matches!(self, BusFault::InterfaceGone | BusFault::Io(_))
    }

    /// One name per cause: log, recording, README.
    pub fn name(self) -> &'static str {
        match self {
            BusFault::InterfaceDown => "interface_down",
            BusFault::InterfaceGone => "interface_gone",
            BusFault::TransmitQueueFull => "transmit_queue_full",
            BusFault::BusOff => "bus_off",
            BusFault::ErrorPassive => "error_passive",
            BusFault::ErrorWarning => "error_warning",
            BusFault::Overflow => "overflow",
            BusFault::NoAcknowledge => "no_acknowledge",
            BusFault::Io(_) => "io_error",
        }
    }

    /// EMCY error code: CiA 301 codes where one exists (CAN overrun 8110h, error passive 8120h,
    /// recovered from bus-off 8140h), the manufacturer-specific range for the rest.
    pub fn emcy_code(self) -> u16 {
        match self {
            BusFault::Overflow => 0x8110,
            BusFault::ErrorPassive => 0x8120,
            BusFault::BusOff => 0x8140,
            BusFault::InterfaceDown => 0xFF20,
            BusFault::InterfaceGone => 0xFF21,
            BusFault::TransmitQueueFull => 0xFF22,
            BusFault::ErrorWarning => 0xFF23,
            BusFault::NoAcknowledge => 0xFF24,
            BusFault::Io(_) => 0xFF25,
        }
    }
}

impl std::fmt::Display for BusFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BusFault::Io(errno) => write!(
                f,
                "io_error ({})",
                std::io::Error::from_raw_os_error(*errno)
            ),
            other => f.write_str(other.name()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn io(errno: i32) -> BusError {
        BusError::Io {
            iface: "can0".into(),
            source: std::io::Error::from_raw_os_error(errno),
        }
    }

    #[test]
    fn errnos_name_their_cause() {
        assert_eq!(
            BusFault::from_error(&io(libc::ENETDOWN)),
            Some(BusFault::InterfaceDown)
        );
        assert_eq!(
            BusFault::from_error(&io(libc::ENXIO)),
            Some(BusFault::InterfaceGone)
        );
        assert_eq!(
            BusFault::from_error(&io(libc::ENOBUFS)),
            Some(BusFault::TransmitQueueFull)
        );
        assert_eq!(
            BusFault::from_error(&io(libc::EIO)),
            Some(BusFault::Io(libc::EIO))
        );
        assert_eq!(BusFault::from_error(&BusError::Closed), None);
    }

    #[test]
    fn error_frames_name_their_cause() {
        let frame = |class, detail| BusErrorFrame {
            class,
            data: [0, detail, 0, 0, 0, 0, 0, 0],
        };
        assert_eq!(
            BusFault::from_error_frame(&frame(0x040, 0)),
            Some(BusFault::BusOff)
        );
        assert_eq!(
            BusFault::from_error_frame(&frame(0x004, 0x20)),
            Some(BusFault::ErrorPassive)
        );
        assert_eq!(
            BusFault::from_error_frame(&frame(0x004, 0x08)),
            Some(BusFault::ErrorWarning)
        );
        assert_eq!(
            BusFault::from_error_frame(&frame(0x004, 0x01)),
            Some(BusFault::Overflow)
        );
        assert_eq!(BusFault::from_error_frame(&frame(0x002, 0)), None);
        assert!(BusFault::BusOff.is_loss() && !BusFault::ErrorPassive.is_loss());
        assert!(!BusFault::TransmitQueueFull.is_loss());
        let codes: std::collections::BTreeSet<u16> = [
            BusFault::InterfaceDown,
            BusFault::InterfaceGone,
            BusFault::TransmitQueueFull,
            BusFault::BusOff,
            BusFault::ErrorPassive,
            BusFault::ErrorWarning,
            BusFault::Overflow,
            BusFault::NoAcknowledge,
            BusFault::Io(5),
        ]
        .iter()
        .map(|f| f.emcy_code())
        .collect();
        assert_eq!(codes.len(), 9, "one EMCY code per cause");
    }
}
