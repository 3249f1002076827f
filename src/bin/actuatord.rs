//! `actuatord`: the control daemon. Argument parsing, start-up and shutdown only.

use actuatord::bus::SocketCanBus;
use actuatord::daemon::notify::{watchdog_interval, Notifier};
use actuatord::daemon::{run_cycle_reloadable, Config, ControllerNode, CycleSettings, Recorder};
use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// Intelligent actuator control daemon: a fixed-rate control cycle over SocketCAN.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Configuration file (TOML).
    #[arg(long, default_value = "/etc/actuatord/actuatord.toml")]
    config: PathBuf,
    /// CAN interface, overriding [bus] iface of the configuration.
    #[arg(long)]
    iface: Option<String>,
    /// Record every cycle to this MCAP file.
    #[arg(long)]
    record: Option<PathBuf>,
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

fn run(args: Args) -> anyhow::Result<()> {
    let mut config = Config::load(&args.config)?;
    if let Some(iface) = args.iface.clone() {
        config.bus.iface = iface;
    }
    if let Some(d) = args.duration_s {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration-s must be > 0, got {d}"
        );
    }
    let load = actuatord::daemon::bus_load::bus_load(&config);
    tracing::info!(
        "bus load {:.1} % of {} kbit/s ({:.0} frames/s, {:.0} kbit/s worst case with stuffing; limit {:.0} %)",
        load.load * 100.0,
        config.bus.bitrate_bps / 1000,
        load.frames_per_s,
        load.bits_per_s / 1000.0,
        config.bus.max_load * 100.0
    );
    let mut bus = SocketCanBus::open(&config.bus.iface)?;
    let mut node = ControllerNode::new(&config)?;
    let (sink, recorder) = Recorder::spawn(args.record.as_deref(), config.record.queue_depth)?;
    tracing::info!(
        config = %args.config.display(),
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
        record_frames: args.record.is_some() && config.record.can_frames,
    };
    // Signals are handled off the real-time thread, on a small runtime of their own; they are
    // registered before the cycle starts, so a SIGTERM right after start-up is never lost.
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
    // SIGHUP hands a new, validated configuration to the cycle, which applies it at a boundary.
    let (reload_tx, reload_rx) = std::sync::mpsc::sync_channel::<Box<Config>>(1);
    let notifier = Notifier::from_env().map_err(|e| anyhow::anyhow!("NOTIFY_SOCKET: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let progress = Arc::new(AtomicU64::new(0));
    let (done_tx, mut done_rx) = tokio::sync::oneshot::channel();
    let cycle_stop = stop.clone();
    let cycle_progress = progress.clone();
    let cycle_sink = sink.clone();
    let cycle = std::thread::Builder::new()
        .name("actuatord-cycle".into())
        .spawn(move || {
            let result = run_cycle_reloadable(
                &mut bus,
                &mut node,
                settings,
                &cycle_stop,
                &cycle_progress,
                &cycle_sink,
                Some(reload_rx),
            );
            let _ = done_tx.send(());
            (result, node.counters())
        })?;
    drop(sink);

    runtime.block_on(async {
        // Ready once the first cycle has run: the bus works and the loop is live.
        let mut poll = tokio::time::interval(std::time::Duration::from_millis(5));
        while progress.load(Ordering::Relaxed) == 0 {
            tokio::select! {
                _ = poll.tick() => {}
                _ = &mut done_rx => return anyhow::Ok(()),
            }
        }
        notify(&notifier, "READY=1\nSTATUS=cycle running");
        // The watchdog is fed only while the cycle makes progress, so a stalled cycle gets the
        // service restarted by systemd (WatchdogSec).
        let watchdog = watchdog_interval();
        let mut feed =
            tokio::time::interval(watchdog.map_or(std::time::Duration::from_secs(3600), |w| w / 2));
        let mut last_seen = 0;
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
                _ = &mut done_rx => break,
                _ = hup.recv() => {
                    match Config::load(&args.config) {
                        Ok(mut new) => {
                            if let Some(iface) = &args.iface {
                                new.bus.iface = iface.clone();
                            }
                            match reload_tx.try_send(Box::new(new)) {
                                Ok(()) => tracing::info!("SIGHUP: {} read, taking effect at the next cycle", args.config.display()),
                                Err(_) => tracing::warn!("SIGHUP: a reload is still pending; this one is ignored"),
                            }
                        }
                        Err(e) => tracing::error!("SIGHUP: {e}; keeping the running configuration"),
                    }
                }
                _ = feed.tick(), if watchdog.is_some() => {
                    let now = progress.load(Ordering::Relaxed);
                    if now != last_seen {
                        notify(&notifier, "WATCHDOG=1");
                        last_seen = now;
                    } else {
                        tracing::error!("the cycle made no progress: not feeding the watchdog");
                    }
                }
            }
        }
        notify(&notifier, "STOPPING=1");
        anyhow::Ok(())
    })?;
    stop.store(true, Ordering::Relaxed);
    let (result, counters) = cycle
        .join()
        .map_err(|_| anyhow::anyhow!("the cycle thread panicked"))?;
    let report = recorder.finish()?;
    let cycle = result?;
    tracing::info!(
        cycles = cycle.cycles,
        overruns = cycle.overruns,
        sensor_missed = counters.sensor_missed,
        frames_malformed = counters.frames_malformed,
        frames_unknown = counters.frames_unknown,
        faults_raised = counters.faults_raised,
        records_dropped = report.dropped,
        "stopped"
    );
    if let Some(path) = report.path {
        tracing::info!("recording written: {}", path.display());
    }
    Ok(())
}
