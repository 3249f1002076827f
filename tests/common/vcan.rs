//! The vcan suites' rig (tests/vcan.rs, tests/vcan_profiles.rs): the test interface, the
//! processes they start under real-time priorities, and the `candump` capture they judge.

use actuatord::bus::{parse_candump_line, Frame};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};

pub fn iface() -> String {
    std::env::var("ACTUATORD_TEST_IFACE").unwrap_or_else(|_| "vcan0".into())
}

pub fn root(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// Kills a child when dropped, so a failing assertion leaves no process behind.
pub struct Proc(pub Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// SCHED_FIFO priority of the simulated nodes: below the daemon's cycle (80 in the shipped
/// configurations), above everything else. A real actuator answers from its own real-time
/// controller; on the test machine's one guest CPU an ordinary process misses the sensor
/// deadline whenever the guest hands the CPU to another for a few periods.
pub const SIM_PRIORITY: u32 = 70;

/// SCHED_FIFO priority of the `candump` captures the tests read: below the simulated nodes, and
/// real-time too, or the two real-time processes leave it too little of the one guest CPU at
/// 1 kHz and the socket drops frames before the capture sees them.
pub const CAPTURE_PRIORITY: u32 = 60;

/// Receive buffer the capture asks for, bytes. The kernel's default (`rmem_default`, about
/// 200 kB) holds a few hundred CAN frames: at 1 kHz with four frames a cycle, under 100 ms of
/// the capture not being scheduled. The user-mode kernel does hold it that long now and then,
/// and a capture that lost 700 frames left 100 of a window's 400 sensor frames. 16 MiB holds
/// seconds; `candump` forces it past `rmem_max` with CAP_NET_ADMIN, which the suites have.
const CAPTURE_RCVBUF_BYTES: &str = "16777216";

/// `program` run under SCHED_FIFO at `priority` (through `chrt`, where the test may set it),
/// else as it is, with a line on stderr saying so.
pub fn realtime(priority: u32, program: &str) -> Command {
    let chrt_works = Command::new("chrt")
        .args(["-f", &priority.to_string(), "true"])
        .status()
        .is_ok_and(|s| s.success());
    if chrt_works {
        let mut c = Command::new("chrt");
        c.args(["-f", &priority.to_string(), program]);
        c
    } else {
        // The run goes on (a host with vcan but no CAP_SYS_NICE still tests the logic), but its
        // timing figures then come from ordinary scheduling, and the log says so.
        eprintln!("vcan rig: chrt -f {priority} refused; {program} runs without SCHED_FIFO");
        Command::new(program)
    }
}

/// `candump -L` on `interfaces` (with `options` before them), written to `path`, with a
/// receive buffer for seconds of traffic and its drops reported in the capture (`-d`), so
/// that a test short of frames can say whether the bus or the capture lost them.
pub fn candump(path: &Path, options: &[&str], interfaces: &[&str]) -> Proc {
    Proc(
        realtime(CAPTURE_PRIORITY, "candump")
            .args(["-d", "-r", CAPTURE_RCVBUF_BYTES, "-L"])
            .args(options)
            .args(interfaces)
            .stdout(std::fs::File::create(path).expect("capture file"))
            .spawn()
            .expect("candump (can-utils) is installed"),
    )
}

/// `candump` on the test interface, written to `path`.
pub fn candump_to(path: &Path) -> Proc {
    candump(path, &[], &[&iface()])
}

/// The frames of a `candump -L` capture, with their times.
pub fn read_capture(path: &Path) -> Vec<(f64, Frame)> {
    std::fs::read_to_string(path)
        .expect("capture")
        .lines()
        .filter_map(|l| parse_candump_line(l).ok())
        .map(|r| (r.time_s, r.frame))
        .collect()
}

/// Frames the capture's socket dropped (`candump -d` reports a running total on each drop).
pub fn capture_drops(path: &Path) -> u64 {
    std::fs::read_to_string(path)
        .expect("capture")
        .lines()
        .filter_map(|l| l.strip_prefix("DROPCOUNT: "))
        .filter_map(|l| {
            l.rsplit_once("(total drops ")?
                .1
                .strip_suffix(')')?
                .parse()
                .ok()
        })
        .max()
        .unwrap_or(0)
}

pub fn interrupt(p: &mut Proc) {
    // SAFETY: plain kill(2) on a child we own.
    unsafe { libc::kill(p.0.id() as libc::pid_t, libc::SIGINT) };
}

pub fn cansend(frame: &str) {
    let status = Command::new("cansend")
        .args([&iface(), frame])
        .status()
        .expect("cansend (can-utils) is installed");
    assert!(status.success(), "cansend {frame}");
}
