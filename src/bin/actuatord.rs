//! `actuatord`: the control daemon. Argument parsing, start-up and shutdown only.

use actuatord::bus::SocketCanBus;
use actuatord::bus::{Bus, BusError};
use actuatord::daemon::config::BusConfig;
use actuatord::daemon::node::NodeCounters;
use actuatord::daemon::notify::{watchdog_interval, Notifier};
use actuatord::daemon::reconfigure::Builder;
use actuatord::daemon::record_dir;
use actuatord::daemon::state::{self, StateWriter};
use actuatord::daemon::{
    run_cycle_with, Config, ControllerNode, CycleReport, CycleServices, CycleSettings, Recorder,
};
use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// Intelligent actuator control daemon: a fixed-rate control cycle over SocketCAN.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Configuration file (TOML). Repeat it for several CAN buses: each configuration is one bus
    /// with its own cycle thread.
    #[arg(long, default_value = "/etc/actuatord/actuatord.toml")]
    config: Vec<PathBuf>,
    /// CAN interface, overriding [bus] iface of the configuration (one configuration only).
    #[arg(long)]
    iface: Option<String>,
    /// Record every cycle to this MCAP file (with several buses: one file per bus, named
    /// after the interface). An existing file is replaced: for a service use --record-dir.
    #[arg(long, conflicts_with = "record_dir")]
    record: Option<PathBuf>,
    /// Record every run to a new file in this directory, run-<sequence>-<UTC start time>.mcap
    /// (one per bus with several), never overwriting one; the oldest go beyond the budget.
    #[arg(long)]
    record_dir: Option<PathBuf>,
    /// With --record-dir: keep at most this many recordings, this run's included.
    #[arg(long, default_value_t = 20)]
    record_keep: usize,
    /// With --record-dir: remove the oldest recordings while the earlier ones take more than
    /// this many MiB (0: no size limit).
    #[arg(long, default_value_t = 0)]
    record_max_mib: u64,
    /// Stop by itself after this many seconds (default: run until SIGTERM or SIGINT).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Log filter, e.g. "info" or "actuatord=debug" (RUST_LOG also works).
    #[arg(long, default_value = "info")]
    log: String,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(&args.log));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e:#}");
            eprintln!("actuatord: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Tell systemd (Type=notify); never blocks, a failure is logged, never fatal.
fn notify(notifier: &Option<Notifier>, message: &str) {
    if let Some(n) = notifier {
        if let Err(e) = n.send(message) {
            tracing::warn!("sd_notify {message:?}: {e}");
        }
    }
}

/// One bus: its configuration, cycle thread, recorder and the builder of new configurations.
struct BusCycle {
    config_path: PathBuf,
    iface: String,
    thread: std::thread::JoinHandle<(Result<CycleReport, BusError>, NodeCounters)>,
    recorder: Recorder,
    /// Builds SIGHUP reloads and SDO parameter writes off the cycle thread.
    builder: Builder,
    progress: Arc<AtomicU64>,
    state: Option<StateWriter>,
}

/// Load a configuration (with the interface override) and log its bus load.
fn load_config(path: &Path, iface: Option<&str>) -> anyhow::Result<Config> {
    let mut config = Config::load(path)?;
    if let Some(iface) = iface {
        config.bus.iface = iface.to_string();
    }
    Ok(config)
}

/// Where one bus records: the given file, or one file per interface when there are several.
fn record_path(record: &Path, iface: &str, buses: usize) -> PathBuf {
    if buses == 1 {
        return record.to_path_buf();
    }
    let stem = record
        .file_stem()
        .map_or("record".into(), |s| s.to_string_lossy().to_string());
    let ext = record
        .extension()
        .map_or("mcap".into(), |s| s.to_string_lossy().to_string());
    record.with_file_name(format!("{stem}-{iface}.{ext}"))
}

/// Open the bus, waiting up to `[bus] startup_wait_s` for the interface to exist and be up:
/// at boot a network manager may bring it up after us, and exiting at once would only have the
/// service manager restart us into the same state until it gives up.
fn open_bus(config: &Config, stop: &AtomicBool) -> anyhow::Result<SocketCanBus> {
    let iface = &config.bus.iface;
    let wait = std::time::Duration::from_secs_f64(config.bus.startup_wait_s);
    let start = std::time::Instant::now();
    let mut last_log: Option<std::time::Instant> = None;
    loop {
        let reason = match interface_up(iface) {
            Ok(true) => match SocketCanBus::open(iface) {
                Ok(bus) => {
                    if last_log.is_some() {
                        tracing::info!(
                            "{iface} is up after {:.1} s: starting",
                            start.elapsed().as_secs_f64()
                        );
                    }
                    return Ok(bus);
                }
                Err(e) => e.to_string(),
            },
            Ok(false) => {
                format!("CAN interface {iface} is down (bring it up: ip link set {iface} up)")
            }
            Err(e) => e.to_string(),
        };
        let waited = start.elapsed();
        if waited >= wait || stop.load(Ordering::Relaxed) {
            anyhow::bail!(
                "{reason}; gave up after waiting {:.1} s ({} = {})",
                waited.as_secs_f64(),
                startup_wait_key(),
                config.bus.startup_wait_s
            );
        }
        if last_log.is_none_or(|t| t.elapsed() >= std::time::Duration::from_secs(5)) {
            tracing::warn!(
                "{reason}; waiting for it ({:.0} of {} s, {})",
                waited.as_secs_f64(),
                config.bus.startup_wait_s,
                startup_wait_key()
            );
            last_log = Some(std::time::Instant::now());
        }
        std::thread::sleep(std::time::Duration::from_millis(200).min(wait.saturating_sub(waited)));
    }
}

/// Whether `iface` exists and is administratively up (IFF_UP in its sysfs flags).
/// `[bus] startup_wait_s`, as the messages about waiting for the interface name it.
fn startup_wait_key() -> String {
    format!(
        "[{}] {}",
        actuatord::param_key!(Config, bus),
        actuatord::param_key!(BusConfig, startup_wait_s)
    )
}

fn interface_up(iface: &str) -> Result<bool, BusError> {
    let flags = Path::new("/sys/class/net").join(iface).join("flags");
    let text = std::fs::read_to_string(&flags)
        .map_err(|_| BusError::NoSuchInterface(iface.to_string()))?;
    let value = u32::from_str_radix(text.trim().trim_start_matches("0x"), 16).unwrap_or(0);
    Ok(value & libc::IFF_UP as u32 != 0)
}

#[allow(clippy::too_many_arguments)]
fn start_bus(
    config_path: &Path,
    config: Config,
    args: &Args,
    record: Option<PathBuf>,
    stop: &Arc<AtomicBool>,
    ended: &tokio::sync::mpsc::UnboundedSender<usize>,
    index: usize,
) -> anyhow::Result<BusCycle> {
    let load = actuatord::daemon::bus_load::bus_load(&config);
    tracing::info!(
        "{}: bus load {:.1} % of {} kbit/s ({:.0} frames/s, {:.0} kbit/s worst case with stuffing; limit {:.0} %)",
        config.bus.iface,
        load.load * 100.0,
        config.bus.bitrate_bps / 1000,
        load.frames_per_s,
        load.bits_per_s / 1000.0,
        config.bus.max_load * 100.0
    );
    let mut bus = open_bus(&config, stop)?;
    if let Some(bytes) = bus.receive_buffer_bytes() {
        tracing::info!(
            "{}: receive buffer {} KiB (asked for {} KiB; the kernel caps it at net.core.rmem_max)",
            config.bus.iface,
            bytes / 1024,
            actuatord::bus::RECEIVE_BUFFER_BYTES / 1024
        );
    }
    let mut node = ControllerNode::new(&config)?;
    // Standard nodes (CiA 402 drives, CiA 401 modules) get their PDO layout over SDO before
    // the cycle starts them.
    for (index, axis) in config.axis.iter().enumerate() {
        if axis.profile == actuatord::daemon::profile_config::ProfileKind::Actuatord {
            continue;
        }
        let layout = actuatord::daemon::profile_setup::configure(&mut bus, &config.node, axis)?;
        for pdo in layout.pdos.iter().filter(|p| p.enabled) {
            tracing::info!(
                axis = %axis.name,
                node = axis.actuator_node_id,
                profile = axis.profile.name(),
                "{} on 0x{:03X}, transmission type {}, {}",
                pdo.label(),
                pdo.cob_id,
                pdo.transmission_type,
                pdo.objects
                    .iter()
                    .map(|o| format!("{}/{}", o.id, o.bits))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
        node.set_node_layout(index, &layout);
    }
    // The sensors' answers to SYNC get a socket of their own, so a backlog of other traffic
    // cannot hold them past the sensor deadline.
    bus.prioritise(&node.cycle_frame_ids())?;
    let (state_sink, state_writer) = match &config.state.file {
        Some(file) => {
            restore_state(&mut node, file);
            let every = (config.state.save_interval_s / config.cycle.period_s).round() as u64;
            let (sink, writer) = StateWriter::spawn(file, &node, every)?;
            (Some(sink), Some(writer))
        }
        None => (None, None),
    };
    let (sink, recorder) = Recorder::spawn(record.as_deref(), config.record.queue_depth)?;
    tracing::info!(
        config = %config_path.display(),
        iface = %config.bus.iface,
        period_ms = config.cycle.period_s * 1e3,
        axes = config.axis.len(),
        "starting"
    );
    let settings = CycleSettings {
        period_s: config.cycle.period_s,
        sensor_deadline_s: config.cycle.sensor_deadline_s,
        realtime_priority: config.cycle.realtime_priority,
        lock_memory: config.cycle.lock_memory,
        duration_s: args.duration_s,
        record_frames: record.is_some() && config.record.can_frames,
    };
    // SIGHUP and SDO parameter writes: the builder reads, validates and builds the new
    // configuration; the cycle swaps it in at a boundary.
    let reload_path = config_path.to_path_buf();
    let reload_iface = args.iface.clone();
    let (builder, link) = Builder::spawn(
        config.clone(),
        config_path.display().to_string(),
        Box::new(move || load_config(&reload_path, reload_iface.as_deref())),
    )?;
    let progress = Arc::new(AtomicU64::new(0));
    let cycle_stop = stop.clone();
    let cycle_progress = progress.clone();
    let ended = ended.clone();
    let thread = std::thread::Builder::new()
        .name(format!("cycle-{}", config.bus.iface))
        .spawn(move || {
            let result = run_cycle_with(
                &mut bus,
                &mut node,
                settings,
                &cycle_stop,
                &cycle_progress,
                &sink,
                CycleServices {
                    reconfigure: Some(link),
                    state: state_sink,
                },
            );
            let _ = ended.send(index);
            (result, node.counters())
        })?;
    Ok(BusCycle {
        config_path: config_path.to_path_buf(),
        iface: config.bus.iface.clone(),
        thread,
        recorder,
        builder,
        progress,
        state: state_writer,
    })
}

/// Give the axes what they learned before this start. A state file that cannot be read is set
/// aside (`<file>.rejected`) and the axes learn again: a machine should not refuse to start
/// over what it can learn anew.
fn restore_state(node: &mut ControllerNode, file: &Path) {
    match state::load(file) {
        Ok(Some(s)) => {
            for line in state::restore(node, &s, file) {
                tracing::info!("{line}");
            }
        }
        Ok(None) => tracing::info!(
            "{}: no state file yet; the axes learn from scratch",
            file.display()
        ),
        Err(e) => {
            tracing::error!("state file not used: {e}");
            match state::set_aside(file) {
                Ok(aside) => tracing::warn!(
                    "{} moved to {}; the axes learn again",
                    file.display(),
                    aside.display()
                ),
                Err(e) => tracing::error!("{e}"),
            }
        }
    }
}

fn run(args: Args) -> anyhow::Result<()> {
    if let Some(d) = args.duration_s {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration-s must be > 0, got {d}"
        );
    }
    anyhow::ensure!(
        args.iface.is_none() || args.config.len() == 1,
        "--iface overrides the interface of one configuration; with several, set [{}] {} in each",
        actuatord::param_key!(Config, bus),
        actuatord::param_key!(BusConfig, iface)
    );
    let configs = args
        .config
        .iter()
        .map(|p| load_config(p, args.iface.as_deref()))
        .collect::<anyhow::Result<Vec<_>>>()?;
    for (i, c) in configs.iter().enumerate() {
        if let Some(j) = configs[..i].iter().position(|o| o.bus.iface == c.bus.iface) {
            anyhow::bail!(
                "{} and {} both use the CAN interface {}: one configuration per bus",
                args.config[j].display(),
                args.config[i].display(),
                c.bus.iface
            );
        }
    }
    for (i, c) in configs.iter().enumerate() {
        let same = configs[..i]
            .iter()
            .position(|o| o.state.file.is_some() && o.state.file == c.state.file);
        if let Some(j) = same {
            anyhow::bail!(
                "{} and {} both keep their state in {}: one state file per configuration",
                args.config[j].display(),
                args.config[i].display(),
                c.state.file.as_deref().unwrap_or(Path::new("")).display()
            );
        }
    }
    // Signals are handled off the real-time threads, on a small runtime of their own; they are
    // registered before the cycles start, so a SIGTERM right after start-up is never lost.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    let (mut term, mut int, mut hup) = runtime.block_on(async {
        use tokio::signal::unix::{signal, SignalKind};
        anyhow::Ok((
            signal(SignalKind::terminate())?,
            signal(SignalKind::interrupt())?,
            signal(SignalKind::hangup())?,
        ))
    })?;
    let notifier = Notifier::from_env().map_err(|e| anyhow::anyhow!("NOTIFY_SOCKET: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let (ended_tx, mut ended_rx) = tokio::sync::mpsc::unbounded_channel();
    let buses = configs.len();
    let records: Vec<Option<PathBuf>> = match (&args.record, &args.record_dir) {
        (Some(r), _) => configs
            .iter()
            .map(|c| Some(record_path(r, &c.bus.iface, buses)))
            .collect(),
        (None, Some(dir)) => {
            let ifaces: Vec<&str> = configs.iter().map(|c| c.bus.iface.as_str()).collect();
            let now = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            let run = record_dir::prepare_run(
                dir,
                &ifaces,
                record_dir::RecordBudget {
                    max_files: args.record_keep.max(1),
                    max_bytes: args.record_max_mib.saturating_mul(1 << 20),
                },
                now,
            )?;
            for removed in &run.removed {
                tracing::info!("recording budget: removed {}", removed.display());
            }
            run.paths.into_iter().map(Some).collect()
        }
        (None, None) => vec![None; buses],
    };
    let mut cycles = Vec::with_capacity(buses);
    for (index, ((path, config), record)) in
        args.config.iter().zip(configs).zip(records).enumerate()
    {
        match start_bus(path, config, &args, record, &stop, &ended_tx, index) {
            Ok(c) => cycles.push(c),
            Err(e) => {
                // The buses already running get their safe state before the daemon gives up.
                stop.store(true, Ordering::Relaxed);
                for c in cycles {
                    let _ = c.thread.join();
                    let _ = c.recorder.finish();
                }
                return Err(e);
            }
        }
    }
    drop(ended_tx);

    runtime.block_on(async {
        // Ready once every cycle has run once: the buses work and the loops are live.
        let mut poll = tokio::time::interval(std::time::Duration::from_millis(5));
        while cycles.iter().any(|c| c.progress.load(Ordering::Relaxed) == 0) {
            tokio::select! {
                _ = poll.tick() => {}
                _ = ended_rx.recv() => return anyhow::Ok(()),
            }
        }
        notify(&notifier, "READY=1\nSTATUS=cycle running");
        // The watchdog is fed only while every cycle makes progress, so a stalled cycle gets
        // the service restarted by systemd (WatchdogSec).
        let watchdog = watchdog_interval();
        let mut feed =
            tokio::time::interval(watchdog.map_or(std::time::Duration::from_secs(3600), |w| w / 2));
        let mut last_seen = vec![0; cycles.len()];
        loop {
            tokio::select! {
                _ = term.recv() => {
                    tracing::info!("SIGTERM: commanding the safe state and stopping");
                    break;
                }
                _ = int.recv() => {
                    tracing::info!("SIGINT: commanding the safe state and stopping");
                    break;
                }
                _ = ended_rx.recv() => break,
                _ = hup.recv() => {
                    for c in &cycles {
                        // The builder reads and builds it off the cycle thread, and logs how it went.
                        if !c.builder.reload() {
                            tracing::warn!("SIGHUP: reloads of {} are still pending; this one is ignored", c.config_path.display());
                        }
                    }
                }
                _ = feed.tick(), if watchdog.is_some() => {
                    let now: Vec<u64> = cycles.iter().map(|c| c.progress.load(Ordering::Relaxed)).collect();
                    if now.iter().zip(&last_seen).all(|(n, l)| n != l) {
                        notify(&notifier, "WATCHDOG=1");
                    } else {
                        tracing::error!("a cycle made no progress: not feeding the watchdog");
                    }
                    last_seen = now;
                }
            }
        }
        notify(&notifier, "STOPPING=1");
        anyhow::Ok(())
    })?;
    stop.store(true, Ordering::Relaxed);
    let mut first_error = None;
    for c in cycles {
        let (result, counters) = c
            .thread
            .join()
            .map_err(|_| anyhow::anyhow!("the cycle thread of {} panicked", c.iface))?;
        c.builder.join();
        let report = c.recorder.finish()?;
        if let Some(writer) = c.state {
            let w = writer.finish();
            tracing::info!(
                iface = %c.iface,
                writes = w.writes,
                unchanged = w.unchanged,
                errors = w.errors,
                "state file"
            );
        }
        match result {
            Ok(cycle) => tracing::info!(
                iface = %c.iface,
                cycles = cycle.cycles,
                overruns = cycle.overruns,
                sensor_missed = counters.sensor_missed,
                frames_malformed = counters.frames_malformed,
                frames_unknown = counters.frames_unknown,
                faults_raised = counters.faults_raised,
                records_dropped = report.dropped,
                "stopped"
            ),
            Err(e) => {
                first_error.get_or_insert(anyhow::anyhow!(e));
            }
        }
        if let Some(path) = report.path {
            tracing::info!("recording written: {}", path.display());
        }
    }
    first_error.map_or(Ok(()), Err)
}
