//! systemd's notification protocol (`sd_notify`): READY, WATCHDOG, STOPPING, STATUS.
//!
//! Sent without ever blocking: a datagram socket whose reader is slow (or gone) must not stall
//! the daemon; a message that does not fit is dropped and reported to the caller.

use std::io;
use std::os::unix::net::UnixDatagram;

/// The service manager's socket from `$NOTIFY_SOCKET`, if the daemon runs under one.
pub struct Notifier {
    socket: UnixDatagram,
    addr: std::os::unix::net::SocketAddr,
}

impl Notifier {
    /// `Ok(None)` when `$NOTIFY_SOCKET` is not set (not started by systemd with Type=notify).
    pub fn from_env() -> io::Result<Option<Self>> {
        let Some(path) = std::env::var_os("NOTIFY_SOCKET") else {
            return Ok(None);
        };
        let bytes = path.as_encoded_bytes();
        let addr = if let Some(name) = bytes.strip_prefix(b"@") {
            // Abstract socket namespace, as systemd uses for some services.
            <std::os::unix::net::SocketAddr as std::os::linux::net::SocketAddrExt>::from_abstract_name(
                name,
            )?
        } else {
            std::os::unix::net::SocketAddr::from_pathname(&path)?
        };
        let socket = UnixDatagram::unbound()?;
        socket.set_nonblocking(true)?;
        Ok(Some(Self { socket, addr }))
    }

    /// Send one message such as `"READY=1\nSTATUS=cycle running"`.
    pub fn send(&self, message: &str) -> io::Result<()> {
        self.socket
            .send_to_addr(message.as_bytes(), &self.addr)
            .map(|_| ())
    }
}

/// `$WATCHDOG_USEC` as a duration, when systemd asks for watchdog pings (and for this process).
pub fn watchdog_interval() -> Option<std::time::Duration> {
    if let Some(pid) = std::env::var_os("WATCHDOG_PID") {
        if pid.to_str().and_then(|p| p.parse::<u32>().ok()) != Some(std::process::id()) {
            return None;
        }
    }
    let usec: u64 = std::env::var("WATCHDOG_USEC").ok()?.parse().ok()?;
    (usec > 0).then(|| std::time::Duration::from_micros(usec))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_socket_drops_instead_of_blocking() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("notify");
        let reader = UnixDatagram::bind(&path).expect("bind");
        let n = Notifier {
            socket: UnixDatagram::unbound().expect("socket"),
            addr: std::os::unix::net::SocketAddr::from_pathname(&path).expect("addr"),
        };
        n.socket.set_nonblocking(true).expect("nonblocking");
        let mut refused = 0;
        for _ in 0..1000 {
            if n.send("WATCHDOG=1").is_err() {
                refused += 1;
            }
        }
        assert!(refused > 0, "the queue of an unread socket is finite");
        let mut buf = [0u8; 64];
        let got = reader.recv(&mut buf).expect("first message");
        assert_eq!(&buf[..got], b"WATCHDOG=1");
    }
}
