//! `actuator bench soak`: the daemon and a simulated node as processes on a SocketCAN interface
//! for minutes, with everything a vehicle throws at them in turn: bursts of foreign frames,
//! bus outages (the interface down and up), SIGHUP with valid and invalid files, SDO writes,
//! stalls of the actuator node, fault resets. It reports what must hold over time: no crash,
//! flat memory, periods held, every injected fault raised, every cycle recorded.
//!
//! A benchmark, not a test: it prints figures (the README keeps them).

use crate::bus::{Bus, BusEvent, Frame, SocketCanBus};
use crate::daemon::config::{CycleConfig, LimitsSection};
use crate::daemon::recorder::read_cycles;
use crate::daemon::Config;
use crate::device::Emcy;
use crate::param_key;
use serde::Serialize;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What to soak, and where.
#[derive(Debug, Clone)]
pub struct SoakOptions {
    pub config: PathBuf,
    pub plant: PathBuf,
    pub iface: String,
    pub minutes: f64,
    /// The daemon's binary (default: `actuatord` beside this program).
    pub daemon: Option<PathBuf>,
    /// Where the recordings and logs go (default: a temporary directory, removed afterwards).
    pub out: Option<PathBuf>,
}

/// The figures of one soak.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SoakReport {
    pub minutes: f64,
    pub iface: String,
    /// Processes that ended by themselves, or not with status 0 when told to stop.
    pub crashes: Vec<String>,
    pub daemon_rss_start_kib: u64,
    pub daemon_rss_end_kib: u64,
    pub sim_rss_start_kib: u64,
    pub sim_rss_end_kib: u64,
    /// Periods of the daemon's run time (wall clock / period).
    pub periods_elapsed: u64,
    pub cycles_run: u64,
    pub cycles_without_bus: u64,
    pub overruns: u64,
    pub flood_frames_sent: u64,
    pub outages_injected: u64,
    pub bus_faults_raised: u64,
    pub interface_down_emcy: u64,
    pub stalls_injected: u64,
    pub sensor_timeout_emcy: u64,
    pub other_emcy: u64,
    pub sighup_valid: u64,
    pub sighup_invalid: u64,
    pub reloads_applied: u64,
    pub reloads_refused: u64,
    pub sdo_writes: u64,
    pub sdo_writes_failed: u64,
    pub fault_resets: u64,
    pub records_written: u64,
    pub records_dropped: u64,
}

impl std::fmt::Display for SoakReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let pct = |a: u64, b: u64| 100.0 * a as f64 / (b.max(1)) as f64;
        writeln!(
            f,
            "soak: {:.1} min on {}, actuatord and actuator sim as processes",
            self.minutes, self.iface
        )?;
        writeln!(
            f,
            "  crashes                 {}{}",
            self.crashes.len(),
            if self.crashes.is_empty() {
                String::new()
            } else {
                format!(" ({})", self.crashes.join("; "))
            }
        )?;
        writeln!(
            f,
            "  resident memory         actuatord {} -> {} KiB, actuator sim {} -> {} KiB",
            self.daemon_rss_start_kib,
            self.daemon_rss_end_kib,
            self.sim_rss_start_kib,
            self.sim_rss_end_kib
        )?;
        writeln!(
            f,
            "  periods                 {} elapsed: {} cycles run ({:.2} %), {} without the bus, {} overruns ({:.2} % of the cycles)",
            self.periods_elapsed,
            self.cycles_run,
            pct(self.cycles_run, self.periods_elapsed),
            self.cycles_without_bus,
            self.overruns,
            pct(self.overruns, self.cycles_run)
        )?;
        writeln!(
            f,
            "  bus outages             {} injected, {} bus faults raised, {} EMCY interface_down",
            self.outages_injected, self.bus_faults_raised, self.interface_down_emcy
        )?;
        writeln!(
            f,
            "  actuator stalls         {} injected (SIGSTOP 100 ms), {} EMCY sensor_timeout",
            self.stalls_injected, self.sensor_timeout_emcy
        )?;
        writeln!(
            f,
            "  other EMCY              {} (limits that latched meanwhile, e.g. following error in the safe state)",
            self.other_emcy
        )?;
        writeln!(
            f,
            "  SIGHUP                  {} valid, {} invalid: {} reloads applied, {} refused",
            self.sighup_valid, self.sighup_invalid, self.reloads_applied, self.reloads_refused
        )?;
        writeln!(
            f,
            "  SDO writes              {} ({} failed), fault resets {}, flood frames {}",
            self.sdo_writes, self.sdo_writes_failed, self.fault_resets, self.flood_frames_sent
        )?;
        write!(
            f,
            "  recording               {} cycle records for {} cycles run, {} dropped",
            self.records_written, self.cycles_run, self.records_dropped
        )
    }
}

/// Kills the child if the soak ends early (an error), so nothing is left running.
struct Proc {
    name: &'static str,
    child: Child,
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Proc {
    fn signal(&self, sig: libc::c_int) {
        // SAFETY: kill(2) on a child we own and have not reaped.
        unsafe { libc::kill(self.child.id() as libc::pid_t, sig) };
    }

    fn rss_kib(&self) -> u64 {
        std::fs::read_to_string(format!("/proc/{}/status", self.child.id()))
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("VmRSS:"))
                    .and_then(|l| l.split_whitespace().nth(1))
                    .and_then(|v| v.parse().ok())
            })
            .unwrap_or(0)
    }

    /// Still running? If not, a crash, named.
    fn check(&mut self, crashes: &mut Vec<String>) {
        if let Ok(Some(status)) = self.child.try_wait() {
            crashes.push(format!("{} ended by itself: {status}", self.name));
        }
    }
}

/// EMCYs seen on the bus, by what they announce.
#[derive(Debug, Default, Clone, Copy)]
struct EmcyCounts {
    interface_down: u64,
    sensor_timeout: u64,
    other: u64,
}

/// Listens on its own socket and counts the controller's EMCYs; rides out the outages.
fn listen(iface: String, node_id: u8, stop: Arc<AtomicBool>, counts: Arc<Mutex<EmcyCounts>>) {
    let emcy_id = crate::device::messages::EMCY.cob_id(node_id);
    let mut bus: Option<SocketCanBus> = None;
    while !stop.load(Ordering::Relaxed) {
        let Some(b) = bus.as_mut() else {
            bus = SocketCanBus::open(&iface).ok();
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        match b.recv_until(Instant::now() + Duration::from_millis(50)) {
            Ok(Some(BusEvent::Frame(f))) if f.id() == emcy_id => {
                if let Ok(e) = Emcy::decode(&f) {
                    let mut c = counts.lock().unwrap_or_else(|p| p.into_inner());
                    match e.error_code {
                        0 => {}
                        0xFF20 => c.interface_down += 1,
                        0x8100 => c.sensor_timeout += 1,
                        _ => c.other += 1,
                    }
                }
            }
            Ok(_) => {}
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

fn ip_link(iface: &str, state: &str) -> anyhow::Result<()> {
    let status = Command::new("ip")
        .args(["link", "set", iface, state])
        .status()
        .map_err(|e| anyhow::anyhow!("ip link set {iface} {state}: {e}"))?;
    anyhow::ensure!(
        status.success(),
        "ip link set {iface} {state} failed: the soak's outages need CAP_NET_ADMIN (root, or scripts/vcan-run)"
    );
    Ok(())
}

/// Send `frame`, riding out a moment of a downed interface.
fn send(bus: &mut SocketCanBus, frame: &Frame) {
    let _ = bus.send(frame);
}

/// Read an unsigned counter of the daemon's dictionary by name.
fn read_u64(
    bus: &mut SocketCanBus,
    od: &crate::canopen::ObjectDictionary,
    node_id: u8,
    name: &str,
) -> Option<u64> {
    let h = od.lookup(name).ok()?;
    let bytes = crate::client::sdo_read(bus, node_id, od.entry(h).id, Duration::from_millis(500))
        .ok()?
        .ok()?;
    let mut le = [0u8; 8];
    let n = bytes.len().min(8);
    le[..n].copy_from_slice(&bytes[..n]);
    Some(u64::from_le_bytes(le))
}

/// Write an object of the daemon's dictionary by name, from its text form.
fn write_text(
    bus: &mut SocketCanBus,
    od: &crate::canopen::ObjectDictionary,
    node_id: u8,
    name: &str,
    value: &str,
) -> bool {
    let Ok(h) = od.lookup(name) else { return false };
    let entry = od.entry(h);
    let Ok(bytes) = crate::canopen::sdo::encode_text(Some(entry.data_type), value) else {
        return false;
    };
    crate::client::sdo_write(bus, node_id, entry.id, &bytes, Duration::from_millis(500))
        .is_ok_and(|o| o.is_ok())
}

/// The daemon's binary: the option, else `actuatord` beside the running program.
fn daemon_binary(opt: &Option<PathBuf>) -> anyhow::Result<PathBuf> {
    if let Some(p) = opt {
        return Ok(p.clone());
    }
    let exe = std::env::current_exe()?;
    let p = exe.with_file_name("actuatord");
    anyhow::ensure!(
        p.exists(),
        "{} not found: build it (cargo build --release) or pass --daemon",
        p.display()
    );
    Ok(p)
}

/// Run the soak.
pub fn run(opts: &SoakOptions) -> anyhow::Result<SoakReport> {
    anyhow::ensure!(
        opts.minutes > 0.0 && opts.minutes.is_finite(),
        "--minutes must be > 0, got {}",
        opts.minutes
    );
    let daemon_bin = daemon_binary(&opts.daemon)?;
    let sim_bin = std::env::current_exe()?;
    let dir = opts.out.clone().unwrap_or_else(|| {
        std::env::temp_dir().join(format!("actuator-soak-{}", std::process::id()))
    });
    std::fs::create_dir_all(&dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    let result = soak(opts, &dir, &daemon_bin, &sim_bin);
    if opts.out.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

fn soak(
    opts: &SoakOptions,
    dir: &Path,
    daemon_bin: &Path,
    sim_bin: &Path,
) -> anyhow::Result<SoakReport> {
    let text = std::fs::read_to_string(&opts.config)
        .map_err(|e| anyhow::anyhow!("{}: {e}", opts.config.display()))?;
    let config = Config::load(&opts.config)?;
    let node_id = config.node.node_id;
    let period_s = config.cycle.period_s;
    let od = crate::daemon::dictionary::build(&config)?;
    let config_path = dir.join("soak.toml");
    std::fs::write(&config_path, &text)?;
    let records = dir.join("recordings");
    let log_path = dir.join("actuatord.log");

    let mut sim = Proc {
        name: "actuator sim",
        child: Command::new(sim_bin)
            .args(["sim", "--iface", &opts.iface, "--plant"])
            .arg(&opts.plant)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()?,
    };
    std::thread::sleep(Duration::from_millis(300));
    let mut daemon = Proc {
        name: "actuatord",
        child: Command::new(daemon_bin)
            .arg("--config")
            .arg(&config_path)
            .args(["--iface", &opts.iface, "--record-dir"])
            .arg(&records)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log_path)?)
            .spawn()?,
    };
    let started = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    let counts = Arc::new(Mutex::new(EmcyCounts::default()));
    let listener = {
        let (iface, stop, counts) = (opts.iface.clone(), stop.clone(), counts.clone());
        std::thread::spawn(move || listen(iface, node_id, stop, counts))
    };
    let mut bus = SocketCanBus::open(&opts.iface)?;
    let mut report = SoakReport {
        minutes: opts.minutes,
        iface: opts.iface.clone(),
        ..Default::default()
    };
    // Memory at start: after the daemon's first seconds (its buffers are allocated by then).
    std::thread::sleep(Duration::from_secs(3));
    report.daemon_rss_start_kib = daemon.rss_kib();
    report.sim_rss_start_kib = sim.rss_kib();

    let end = started + Duration::from_secs_f64(opts.minutes * 60.0);
    let reset = Frame::new(
        crate::device::messages::FAULT_RESET.cob_id(node_id),
        &[config.axis.first().map_or(16, |a| a.actuator_node_id)],
    )?;
    let nmt_start = Frame::new(0x000, &[0x01, node_id])?;
    let flood = Frame::new(0x5FF, &[0x55; 8])?;
    let mut round: u64 = 0;
    let mut progress_at = Instant::now();
    while Instant::now() < end {
        match round % 5 {
            0 => {
                // A burst of foreign traffic: 4000 frames/s (a saturated 500 kbit/s bus) for 1 s.
                for _ in 0..400 {
                    for _ in 0..10 {
                        send(&mut bus, &flood);
                        report.flood_frames_sent += 1;
                    }
                    std::thread::sleep(Duration::from_micros(2500));
                }
            }
            1 => {
                // The interface goes down for a second, as a network manager or a bus-off
                // restart does; afterwards the operator starts the controller again.
                ip_link(&opts.iface, "down")?;
                report.outages_injected += 1;
                std::thread::sleep(Duration::from_secs(1));
                ip_link(&opts.iface, "up")?;
                std::thread::sleep(Duration::from_millis(500));
                send(&mut bus, &nmt_start);
                std::thread::sleep(Duration::from_millis(100));
                send(&mut bus, &reset);
                report.fault_resets += 1;
            }
            2 => {
                // SIGHUP with a valid change, then with a file the daemon must refuse.
                let limit = param_key!(LimitsSection, following_error_m);
                let valid = if round % 10 == 2 {
                    text.replace(&format!("{limit} = 0.002"), &format!("{limit} = 0.003"))
                } else {
                    text.clone()
                };
                std::fs::write(&config_path, valid)?;
                daemon.signal(libc::SIGHUP);
                report.sighup_valid += 1;
                std::thread::sleep(Duration::from_millis(500));
                std::fs::write(
                    &config_path,
                    text.replace(
                        &format!("{} = 0.0025", param_key!(CycleConfig, period_s)),
                        &format!("{} = -1.0", param_key!(CycleConfig, period_s)),
                    ),
                )?;
                daemon.signal(libc::SIGHUP);
                report.sighup_invalid += 1;
                std::thread::sleep(Duration::from_millis(500));
                std::fs::write(&config_path, &text)?;
            }
            3 => {
                // SDO writes: setpoints through the dictionary, as a supervisor would.
                for (i, value) in ["0.006", "0.009", "0.005"].iter().enumerate() {
                    report.sdo_writes += 1;
                    if !write_text(
                        &mut bus,
                        &od,
                        node_id,
                        "axis0_setpoint.setpoint_position",
                        value,
                    ) {
                        report.sdo_writes_failed += 1;
                    }
                    std::thread::sleep(Duration::from_millis(300 + 100 * i as u64));
                }
            }
            _ => {
                // The actuator node stalls for 100 ms (five times the sensor timeout): the
                // controller must raise sensor_timeout; then the operator resets it.
                sim.signal(libc::SIGSTOP);
                report.stalls_injected += 1;
                std::thread::sleep(Duration::from_millis(100));
                sim.signal(libc::SIGCONT);
                std::thread::sleep(Duration::from_millis(300));
                send(&mut bus, &reset);
                report.fault_resets += 1;
            }
        }
        // Settle between events, so that each fault is one incident of its own.
        std::thread::sleep(Duration::from_secs(3));
        daemon.check(&mut report.crashes);
        sim.check(&mut report.crashes);
        if !report.crashes.is_empty() {
            break;
        }
        round += 1;
        if progress_at.elapsed() >= Duration::from_secs(60) {
            progress_at = Instant::now();
            eprintln!(
                "soak: {:.1} of {:.1} min, {} events, actuatord {} KiB",
                started.elapsed().as_secs_f64() / 60.0,
                opts.minutes,
                round,
                daemon.rss_kib()
            );
        }
    }
    report.daemon_rss_end_kib = daemon.rss_kib();
    report.sim_rss_end_kib = sim.rss_kib();
    report.bus_faults_raised =
        read_u64(&mut bus, &od, node_id, "loop_statistics.bus_faults").unwrap_or(0);
    report.cycles_without_bus =
        read_u64(&mut bus, &od, node_id, "loop_statistics.bus_lost_cycles").unwrap_or(0);
    let run_s = started.elapsed().as_secs_f64();
    report.periods_elapsed = (run_s / period_s) as u64;

    // Stop as systemd does; each must end with status 0.
    daemon.signal(libc::SIGTERM);
    let status = daemon.child.wait()?;
    if report.crashes.is_empty() && !status.success() {
        report
            .crashes
            .push(format!("actuatord on SIGTERM: {status}"));
    }
    sim.signal(libc::SIGINT);
    let status = sim.child.wait()?;
    if !status.success() && !report.crashes.iter().any(|c| c.starts_with("actuator sim")) {
        report
            .crashes
            .push(format!("actuator sim on SIGINT: {status}"));
    }
    stop.store(true, Ordering::Relaxed);
    let _ = listener.join();
    let c = *counts.lock().unwrap_or_else(|p| p.into_inner());
    report.interface_down_emcy = c.interface_down;
    report.sensor_timeout_emcy = c.sensor_timeout;
    report.other_emcy = c.other;

    let mut log = String::new();
    std::fs::File::open(&log_path)?.read_to_string(&mut log)?;
    let field = |line: &str, key: &str| -> Option<u64> {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .and_then(|v| v.parse().ok())
    };
    if let Some(line) = log.lines().rev().find(|l| l.contains(" stopped ")) {
        report.cycles_run = field(line, "cycles=").unwrap_or(0);
        report.overruns = field(line, "overruns=").unwrap_or(0);
        report.records_dropped = field(line, "records_dropped=").unwrap_or(0);
    }
    report.reloads_applied = log.matches("configuration reloaded").count() as u64;
    report.reloads_refused = log.matches("keeping the running configuration").count() as u64;
    report.records_written = recorded_cycles(&records)?;
    Ok(report)
}

/// Cycle records in the run's recording (the only file in the fresh directory).
fn recorded_cycles(dir: &Path) -> anyhow::Result<u64> {
    let mut n = 0;
    for entry in std::fs::read_dir(dir)? {
        n += read_cycles(&entry?.path())?.len() as u64;
    }
    Ok(n)
}
