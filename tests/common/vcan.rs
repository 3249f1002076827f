//! The vcan suites' rig (tests/vcan.rs, tests/vcan_profiles.rs): the test interface, the
//! processes they start under real-time priorities, and the `candump` capture they judge.

use actuatord::bus::{parse_candump_line, CandumpRecord, Frame};
use std::io::{BufRead, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, Command};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub fn iface() -> String {
    std::env::var("ACTUATORD_TEST_IFACE").unwrap_or_else(|_| "vcan0".into())
}

/// A repository file (`tests/common/paths.rs` knows where the repository is).
pub fn root(path: &str) -> PathBuf {
    super::paths::root().join(path)
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

/// True inside Debian's user-mode kernel, where `scripts/vcan-run` runs the suites on hosts
/// without CAN (CI among them).
pub fn in_user_mode_kernel() -> bool {
    std::fs::read_to_string("/proc/cpuinfo").is_ok_and(|c| {
        c.lines()
            .any(|l| l.starts_with("vendor_id") && l.contains("User Mode Linux"))
    })
}

/// `program` run under SCHED_FIFO at `priority` through `chrt`.
///
/// Inside the user-mode kernel a refused `chrt` fails the test: `scripts/vcan-run` runs the
/// suite there with the privileges it needs, and the suites' timing checks (the shipped 20 ms
/// sensor timeout, the fault latency) assume the nodes and the capture run real-time, so a run
/// without it would fail them for a reason the rig made. On a host with its own vcan (a
/// developer's machine, `vcan-run`'s direct path) the run goes on without SCHED_FIFO and says
/// so: the logic is still tested, and a timing check that fails there names this line's cause.
pub fn realtime(priority: u32, program: &str) -> Command {
    let probe = Command::new("chrt")
        .args(["-f", &priority.to_string(), "true"])
        .output();
    let refused = match &probe {
        Ok(out) if out.status.success() => None,
        Ok(out) => Some(format!(
            "{}: {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )),
        Err(e) => Some(e.to_string()),
    };
    let Some(why) = refused else {
        let mut c = Command::new("chrt");
        c.args(["-f", &priority.to_string(), program]);
        return c;
    };
    assert!(
        !in_user_mode_kernel(),
        "chrt -f {priority} refused inside the user-mode kernel ({why}): {program} must run under \
         SCHED_FIFO there, where scripts/vcan-run gives the suite what it needs"
    );
    eprintln!("vcan rig: chrt -f {priority} refused ({why}); {program} runs without SCHED_FIFO");
    Command::new(program)
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

/// How long the rig waits for an event (a heartbeat, a count of SYNCs, a log line) before the
/// run fails. A guard against a run that hangs, never a measure of speed: the suites run on a
/// 2-core host beside other builds, where the user-mode kernel runs several times slower than
/// alone; a whole suite takes under two minutes unloaded.
pub const DEADLINE: Duration = Duration::from_secs(120);

/// How often a wait looks again.
const POLL: Duration = Duration::from_millis(20);

/// SYNC (CiA 301), the cycle's clock on every bus of the suites.
pub const SYNC: u32 = 0x080;

/// The heartbeat the controller (node 1) sends last, when it stops.
pub const STOPPED_HEARTBEAT: (u32, u8) = (0x701, 0x04);

/// A growing capture read as it is written: each look reads only what was added since.
pub struct CaptureWatch {
    path: PathBuf,
    read: u64,
    partial: Vec<u8>,
    records: Vec<CandumpRecord>,
}

impl CaptureWatch {
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            read: 0,
            partial: Vec::new(),
            records: Vec::new(),
        }
    }

    /// The records captured so far (complete lines only: candump may be writing the last).
    pub fn records(&mut self) -> &[CandumpRecord] {
        if let Ok(mut f) = std::fs::File::open(&self.path) {
            let mut bytes = Vec::new();
            if f.seek(SeekFrom::Start(self.read)).is_ok() && f.read_to_end(&mut bytes).is_ok() {
                self.read += bytes.len() as u64;
                self.partial.extend_from_slice(&bytes);
                if let Some(end) = self.partial.iter().rposition(|b| *b == b'\n') {
                    let lines: Vec<u8> = self.partial.drain(..=end).collect();
                    self.records.extend(
                        String::from_utf8_lossy(&lines)
                            .lines()
                            .filter_map(|l| parse_candump_line(l).ok()),
                    );
                }
            }
        }
        &self.records
    }

    /// Look at the capture until `check` says it holds what the test waits for (`Ok`), at most
    /// [`DEADLINE`]; then fail naming `what` was awaited and what the last look saw (`Err`).
    pub fn wait<T>(
        &mut self,
        what: &str,
        mut check: impl FnMut(&[CandumpRecord]) -> Result<T, String>,
    ) -> T {
        let start = Instant::now();
        loop {
            let seen = match check(self.records()) {
                Ok(v) => return v,
                Err(seen) => seen,
            };
            assert!(
                start.elapsed() < DEADLINE,
                "waited {:.0} s for {what} in {}; saw {seen}",
                DEADLINE.as_secs_f64(),
                self.path.display()
            );
            std::thread::sleep(POLL);
        }
    }

    /// SYNCs captured so far on `iface` (every interface: `None`).
    pub fn syncs_on(&mut self, iface: Option<&str>) -> usize {
        count(self.records(), iface, SYNC)
    }

    /// SYNCs captured so far.
    pub fn syncs(&mut self) -> usize {
        self.syncs_on(None)
    }

    /// Wait until `n` SYNCs were captured on `iface` (every interface: `None`): the cycle ran
    /// that many periods, however long the guest took for them. Returns the count.
    pub fn wait_for_syncs_on(&mut self, iface: Option<&str>, n: usize) -> usize {
        let on = iface.map_or(String::new(), |i| format!(" on {i}"));
        self.wait(&format!("{n} SYNCs{on}"), |r| {
            let c = count(r, iface, SYNC);
            if c >= n {
                Ok(c)
            } else {
                Err(format!("{c} SYNCs, {} frames in all", r.len()))
            }
        })
    }

    /// [`CaptureWatch::wait_for_syncs_on`] every interface.
    pub fn wait_for_syncs(&mut self, n: usize) -> usize {
        self.wait_for_syncs_on(None, n)
    }

    /// Wait until a frame with `id` (and, when given, first data byte `byte`) was captured on
    /// `iface` (every interface: `None`); `what` names it for the failure.
    pub fn wait_for_frame(&mut self, iface: Option<&str>, id: u32, byte: Option<u8>, what: &str) {
        self.wait(what, |r| {
            let hit = r.iter().any(|rec| {
                iface.is_none_or(|i| rec.iface == i)
                    && rec.frame.id() == id
                    && byte.is_none_or(|b| rec.frame.data().first() == Some(&b))
            });
            if hit {
                Ok(())
            } else {
                Err(format!(
                    "{} frames, {} SYNCs, none 0x{id:03X}{}",
                    r.len(),
                    count(r, iface, SYNC),
                    byte.map_or(String::new(), |b| format!("#{b:02X}"))
                ))
            }
        })
    }

    /// Wait for the heartbeat (or boot-up) of node `node_id` on `iface`: the node is up, and
    /// the capture is live.
    pub fn wait_for_node(&mut self, iface: Option<&str>, node_id: u8) {
        let id = 0x700 + u32::from(node_id);
        self.wait_for_frame(
            iface,
            id,
            None,
            &format!("the heartbeat of node {node_id} (0x{id:03X})"),
        );
    }

    /// Wait for the controller's last frame, its stopped heartbeat, on `iface`: everything the
    /// daemon sent before it is in the capture.
    pub fn wait_for_stop(&mut self, iface: Option<&str>) {
        let (id, state) = STOPPED_HEARTBEAT;
        self.wait_for_frame(
            iface,
            id,
            Some(state),
            "the controller's stopped heartbeat (0x701#04), its last frame",
        );
    }
}

fn count(records: &[CandumpRecord], iface: Option<&str>, id: u32) -> usize {
    records
        .iter()
        .filter(|r| r.frame.id() == id && iface.is_none_or(|i| r.iface == i))
        .count()
}

/// A capture's frames with their kernel time stamps, as the tests judge them.
pub struct Capture {
    pub frames: Vec<(f64, Frame)>,
}

impl Capture {
    pub fn read(path: &Path) -> Self {
        Self {
            frames: read_capture(path),
        }
    }

    /// The frames of `records` captured on `iface`.
    pub fn on(records: &[CandumpRecord], iface: &str) -> Self {
        Self {
            frames: records
                .iter()
                .filter(|r| r.iface == iface)
                .map(|r| (r.time_s, r.frame))
                .collect(),
        }
    }

    pub fn with_id(&self, id: u32) -> impl Iterator<Item = &(f64, Frame)> {
        self.frames.iter().filter(move |(_, f)| f.id() == id)
    }

    /// Times of the SYNCs, in order: the n-th is the cycle clock's n-th tick.
    pub fn syncs(&self) -> Vec<f64> {
        self.with_id(SYNC).map(|(t, _)| *t).collect()
    }

    pub fn sync_count(&self) -> usize {
        self.with_id(SYNC).count()
    }

    /// Frames of `id` after the n-th SYNC (0-based), in order.
    pub fn after_sync(&self, n: usize, id: u32) -> Vec<Frame> {
        let mut seen = 0;
        let mut out = vec![];
        for (_, f) in &self.frames {
            if f.id() == SYNC {
                seen += 1;
            } else if seen > n && f.id() == id {
                out.push(*f);
            }
        }
        out
    }

    /// Frames of `id` from the last one sent before the first frame matching `pred`, in order:
    /// what was on the bus as that frame arrived, and everything after it. Counting SYNCs would
    /// depend on whether the cycle's frame of `id` went out before or after it within its period.
    pub fn since_last_before(&self, pred: impl Fn(&Frame) -> bool, id: u32) -> Vec<Frame> {
        let at = self
            .frames
            .iter()
            .position(|(_, f)| pred(f))
            .unwrap_or(self.frames.len());
        let start = self.frames[..at]
            .iter()
            .rposition(|(_, f)| f.id() == id)
            .unwrap_or(at);
        self.frames[start..]
            .iter()
            .filter(|(_, f)| f.id() == id)
            .map(|(_, f)| *f)
            .collect()
    }

    /// The SYNC count when the first frame matching `pred` appeared.
    pub fn sync_count_at(&self, pred: impl Fn(&Frame) -> bool) -> Option<usize> {
        let mut seen = 0;
        for (_, f) in &self.frames {
            if f.id() == SYNC {
                seen += 1;
            } else if pred(f) {
                return Some(seen);
            }
        }
        None
    }
}

/// A child's stderr, passed on to the test's own and kept, so that a test can wait for a line
/// the child logs (a reload done, a fault seen) instead of sleeping for it.
pub struct LogTail {
    lines: Arc<Mutex<Vec<String>>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl LogTail {
    pub fn new(stderr: ChildStderr) -> Self {
        let lines = Arc::new(Mutex::new(Vec::new()));
        let kept = Arc::clone(&lines);
        let reader = std::thread::spawn(move || {
            for line in std::io::BufReader::new(stderr).lines() {
                let Ok(line) = line else { return };
                eprintln!("{line}");
                kept.lock().expect("log lock").push(line);
            }
        });
        Self {
            lines,
            reader: Some(reader),
        }
    }

    /// How many lines so far contain `needle`.
    pub fn count(&self, needle: &str) -> usize {
        let lines = self.lines.lock().expect("log lock");
        lines.iter().filter(|l| l.contains(needle)).count()
    }

    /// Wait until `n` lines contain `needle`, at most [`DEADLINE`].
    pub fn wait_for(&self, needle: &str, n: usize) {
        let start = Instant::now();
        loop {
            let c = self.count(needle);
            if c >= n {
                return;
            }
            assert!(
                start.elapsed() < DEADLINE,
                "waited {:.0} s for {n} log lines with {needle:?}; saw {c}",
                DEADLINE.as_secs_f64()
            );
            std::thread::sleep(POLL);
        }
    }

    /// Everything logged, once the child closed its stderr (it has ended).
    pub fn finish(mut self) -> String {
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        self.lines.lock().expect("log lock").join("\n")
    }
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
