//! SocketCAN backend: a raw CAN socket on a kernel interface (can0, vcan0, ...).

use super::{Bus, BusError, BusErrorFrame, BusEvent, Frame};
use socketcan::{CanFilter, CanFrame, CanSocket, EmbeddedFrame, Frame as _, Socket, SocketOptions};
use std::io::ErrorKind;
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

/// The receive buffer the daemon asks for: about half a second of a saturated 500 kbit/s bus
/// (the kernel caps it at `net.core.rmem_max` and counts its own overhead per frame).
pub const RECEIVE_BUFFER_BYTES: usize = 1 << 20;

/// A raw SocketCAN socket with error frames requested, so bus-off and friends are reported.
///
/// Frames that complete a cycle (the sensors' answers to SYNC) can be given a socket of their
/// own ([`Bus::prioritise`]), as a CAN controller gives them a dedicated receive mailbox: one
/// socket is one FIFO, and behind a backlog of foreign traffic (a flood, or what piled up while
/// the thread was held) a sensor frame that came in time would be read after its deadline.
pub struct SocketCanBus {
    iface: String,
    socket: CanSocket,
    /// Standard identifiers let through by the kernel (all when empty); kept for a reopen.
    accept: Vec<u32>,
    /// The socket of the prioritised identifiers, read before `socket`.
    urgent: Option<CanSocket>,
    /// The prioritised standard identifiers (none when empty); kept for a reopen.
    urgent_ids: Vec<u32>,
}

impl SocketCanBus {
    /// Open `iface`. A missing interface is reported as such, not as a bare errno.
    pub fn open(iface: &str) -> Result<Self, BusError> {
        let socket = Self::open_socket(iface)?;
        Ok(Self {
            iface: iface.to_string(),
            socket,
            accept: Vec::new(),
            urgent: None,
            urgent_ids: Vec::new(),
        })
    }

    /// Let only these standard identifiers through (and error frames), as a node's acceptance
    /// filter does: the kernel drops the rest before they wake the reader.
    pub fn accept_only(&mut self, ids: &[u32]) -> Result<(), BusError> {
        self.accept = ids.to_vec();
        self.apply_filters()
    }

    /// Filters of both sockets: the urgent one takes the prioritised identifiers, the main one
    /// everything it accepts but those, so each frame is read exactly once.
    fn apply_filters(&mut self) -> Result<(), BusError> {
        // Match the id, standard frames only (CAN_EFF_FLAG in the mask, clear in the id).
        let mask = libc::CAN_SFF_MASK | libc::CAN_EFF_FLAG;
        self.urgent = None;
        if !self.urgent_ids.is_empty() {
            let urgent = Self::open_socket(&self.iface)?;
            // Error frames come through the main socket only; this one is for data.
            urgent.set_error_filter_drop_all().map_err(|e| self.io(e))?;
            let filters: Vec<CanFilter> = self
                .urgent_ids
                .iter()
                .map(|id| CanFilter::new(*id, mask))
                .collect();
            urgent.set_filters(&filters).map_err(|e| self.io(e))?;
            self.urgent = Some(urgent);
        }
        let urgent = |id: &u32| self.urgent_ids.contains(id);
        if !self.accept.is_empty() {
            let filters: Vec<CanFilter> = self
                .accept
                .iter()
                .filter(|id| !urgent(id))
                .map(|id| CanFilter::new(*id, mask))
                .collect();
            return self.socket.set_filters(&filters).map_err(|e| self.io(e));
        }
        if self.urgent_ids.is_empty() {
            return Ok(());
        }
        // Everything but the prioritised identifiers: inverted filters, joined (all must match).
        let filters: Vec<CanFilter> = self
            .urgent_ids
            .iter()
            .map(|id| CanFilter::new_inverted(*id, mask))
            .collect();
        self.socket.set_join_filters(true).map_err(|e| self.io(e))?;
        self.socket.set_filters(&filters).map_err(|e| self.io(e))
    }

    fn open_socket(iface: &str) -> Result<CanSocket, BusError> {
        if !std::path::Path::new("/sys/class/net").join(iface).exists() {
            return Err(BusError::NoSuchInterface(iface.to_string()));
        }
        let io = |source| BusError::Io {
            iface: iface.to_string(),
            source,
        };
        let socket = CanSocket::open(iface).map_err(io)?;
        // Error frames (bus-off, error passive, restarts, ...) arrive as events of their own.
        socket.set_error_filter_accept_all().map_err(io)?;
        // Reads never block; waiting is done with ppoll, whose timeout has nanosecond resolution
        // and costs no socket option change per call.
        socket.set_nonblocking(true).map_err(io)?;
        // A burst of foreign traffic waits in the socket rather than being dropped before the
        // cycle reads it. Best effort: the kernel caps it, and a smaller buffer still works.
        let size = RECEIVE_BUFFER_BYTES as libc::c_int;
        // SAFETY: a valid socket, a pointer to a c_int with its size.
        unsafe {
            libc::setsockopt(
                socket.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&size as *const libc::c_int).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        Ok(socket)
    }

    /// The receive buffer the kernel granted, bytes (it doubles the request for its overhead).
    pub fn receive_buffer_bytes(&self) -> Option<usize> {
        let mut size: libc::c_int = 0;
        let mut len = std::mem::size_of::<libc::c_int>() as libc::socklen_t;
        // SAFETY: a valid socket, a pointer to a c_int and its size.
        let rc = unsafe {
            libc::getsockopt(
                self.socket.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&mut size as *mut libc::c_int).cast(),
                &mut len,
            )
        };
        (rc == 0).then_some(size as usize)
    }

    /// Wait until a frame is readable on either socket or `timeout` passed (either way the
    /// caller reads again).
    fn wait_readable(&self, timeout: Duration) -> Result<(), BusError> {
        let pfd = |fd| libc::pollfd {
            fd,
            events: libc::POLLIN,
            revents: 0,
        };
        let mut pfds = [pfd(self.socket.as_raw_fd()), pfd(-1)];
        let mut count = 1;
        if let Some(urgent) = &self.urgent {
            pfds[1] = pfd(urgent.as_raw_fd());
            count = 2;
        }
        let ts = libc::timespec {
            tv_sec: timeout.as_secs() as libc::time_t,
            tv_nsec: timeout.subsec_nanos() as libc::c_long,
        };
        // SAFETY: `count` valid pollfds, a valid timespec, no signal mask change.
        let rc = unsafe { libc::ppoll(pfds.as_mut_ptr(), count, &ts, std::ptr::null()) };
        if rc < 0 {
            let e = std::io::Error::last_os_error();
            if e.kind() != ErrorKind::Interrupted {
                return Err(self.io(e));
            }
        }
        Ok(())
    }

    fn io(&self, source: std::io::Error) -> BusError {
        BusError::Io {
            iface: self.iface.clone(),
            source,
        }
    }
}

impl Bus for SocketCanBus {
    fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        let id: socketcan::Id = if frame.is_extended() {
            socketcan::ExtendedId::new(frame.id())
                .map(Into::into)
                .ok_or_else(|| self.io(ErrorKind::InvalidInput.into()))?
        } else {
            socketcan::StandardId::new(frame.id() as u16)
                .map(Into::into)
                .ok_or_else(|| self.io(ErrorKind::InvalidInput.into()))?
        };
        let can = CanFrame::new(id, frame.data())
            .ok_or_else(|| self.io(ErrorKind::InvalidInput.into()))?;
        self.socket.write_frame(&can).map_err(|e| self.io(e))
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<BusEvent>, BusError> {
        loop {
            if let Some(urgent) = &self.urgent {
                match urgent.read_frame() {
                    Ok(frame) => match event(frame) {
                        Some(event) => return Ok(Some(event)),
                        None => continue,
                    },
                    Err(e) if would_block(&e) => {}
                    Err(e) => return Err(self.io(e)),
                }
            }
            match self.socket.read_frame() {
                Ok(frame) => {
                    if let Some(event) = event(frame) {
                        return Ok(Some(event));
                    }
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return Ok(None);
                    }
                    self.wait_readable(left)?;
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.io(e)),
            }
        }
    }

    fn prioritise(&mut self, ids: &[u32]) -> Result<(), BusError> {
        self.urgent_ids = ids.to_vec();
        self.apply_filters()
    }

    fn name(&self) -> &str {
        &self.iface
    }

    fn reopen(&mut self) -> Result<(), BusError> {
        self.socket = Self::open_socket(&self.iface)?;
        self.apply_filters()
    }
}

/// An interrupted read is retried like an empty one.
fn would_block(e: &std::io::Error) -> bool {
    matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted)
}

/// What the bus reports for one frame the kernel handed out: `None` for what carries nothing
/// this protocol uses (remote frames, and anything but well-formed classic frames).
fn event(frame: CanFrame) -> Option<BusEvent> {
    match frame {
        CanFrame::Data(f) => {
            let frame = if f.is_extended() {
                Frame::new_extended(f.raw_id(), f.data())
            } else {
                Frame::new(f.raw_id(), f.data())
            };
            frame.ok().map(BusEvent::Frame)
        }
        CanFrame::Error(e) => {
            let mut data = [0u8; 8];
            let d = e.data();
            data[..d.len().min(8)].copy_from_slice(&d[..d.len().min(8)]);
            Some(BusEvent::ErrorFrame(BusErrorFrame {
                class: e.error_bits(),
                data,
            }))
        }
        CanFrame::Remote(_) => None,
    }
}
