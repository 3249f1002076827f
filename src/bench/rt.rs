//! `actuator bench rt`: how well the cycle keeps time, against a naive baseline in the same run.
//!
//! The daemon's cycle machinery (absolute-deadline sleep, SCHED_FIFO when granted) and a naive
//! `tokio::time::interval` loop doing the same work run one after the other in this process,
//! each against a simulated solenoid node, and both are measured the same way: wake-up lateness
//! after the release time, cycles that missed their deadline, release-to-command and
//! sensor-to-command latency, and compute time per stage of the cycle.

use crate::bus::{Bus, Frame, InProcBus, InProcEndpoint, SocketCanBus};
use crate::daemon::node::{Stage, STAGES};
use crate::daemon::record::{Event, Record};
use crate::daemon::recorder::RecordSink;
use crate::daemon::{rt, run_cycle, Config, ControllerNode, CycleRunner, CycleSettings};
use crate::simnode::{run_sim_node, SimNode};
use hdrhistogram::Histogram;
use serde::Serialize;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Extra load during the measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Load {
    None,
    /// A busy thread per core.
    Cpu,
    /// Unrelated frames sent as fast as one thread can.
    CanFlood,
}

impl Load {
    /// Every load, as the command line lists them.
    pub const ALL: [Load; 3] = [Load::None, Load::Cpu, Load::CanFlood];

    /// The name as given on the command line and in the JSON report.
    pub fn name(self) -> &'static str {
        match self {
            Load::None => "none",
            Load::Cpu => "cpu",
            Load::CanFlood => "can-flood",
        }
    }
}

#[derive(Debug, Clone)]
pub struct RtBenchOptions {
    pub config: PathBuf,
    pub plant: PathBuf,
    /// Cycle period; None takes the configuration's.
    pub period_s: Option<f64>,
    pub seconds: f64,
    pub load: Load,
    /// Run on this SocketCAN interface instead of the in-process bus.
    pub iface: Option<String>,
}

/// Percentiles of a distribution, in the unit its name says.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Percentiles {
    pub min: f64,
    pub p50: f64,
    pub p99: f64,
    pub p999: f64,
    pub max: f64,
    pub count: u64,
}

impl Percentiles {
    fn of(h: &Histogram<u64>) -> Self {
        if h.is_empty() {
            return Self::default();
        }
        Self {
            min: h.min() as f64,
            p50: h.value_at_quantile(0.5) as f64,
            p99: h.value_at_quantile(0.99) as f64,
            p999: h.value_at_quantile(0.999) as f64,
            max: h.max() as f64,
            count: h.len(),
        }
    }
}

/// Compute time of one stage, ns.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct StageFigures {
    pub p50: f64,
    pub p99: f64,
    /// The largest seen, like LinuxCNC's `tmax`.
    pub max: f64,
}

/// The figures of one loop.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopFigures {
    pub name: &'static str,
    pub cycles: u64,
    /// Cycles whose work ended after the next release time.
    pub misses: u64,
    /// Wake-up lateness after the release time, µs (1 µs resolution).
    pub lateness_us: Percentiles,
    /// Release time to the command sent, µs.
    pub cycle_latency_us: Percentiles,
    /// Sensor frame received to command sent, µs.
    pub sensor_to_command_us: Percentiles,
    /// Cycles whose sensor frame missed the sensor deadline.
    pub sensor_missed: u64,
    /// Compute time per stage, ns.
    pub compute_ns: Vec<(String, StageFigures)>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RtBenchReport {
    pub period_s: f64,
    pub seconds: f64,
    pub load: Load,
    pub bus: String,
    /// SCHED_FIFO was granted to the daemon's cycle.
    pub realtime: bool,
    pub daemon: LoopFigures,
    pub baseline: LoopFigures,
    /// Baseline figure over the daemon's: above 1 means the daemon keeps time better.
    pub ratio_lateness_p50: f64,
    pub ratio_lateness_p99: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum RtBenchError {
    #[error(transparent)]
    Config(#[from] crate::daemon::config::ConfigError),
    #[error(transparent)]
    Plant(#[from] crate::physics::PhysicsError),
    #[error(transparent)]
    Node(#[from] crate::daemon::node::NodeError),
    #[error(transparent)]
    Bus(#[from] crate::bus::BusError),
    #[error("--seconds must be > 0 and --period > 0")]
    Options,
    #[error("a bench thread panicked")]
    Panicked,
    #[error("{0}")]
    Runtime(String),
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum LoopKind {
    Daemon,
    Baseline,
}

/// Run both loops and report.
pub fn run(opts: &RtBenchOptions) -> Result<RtBenchReport, RtBenchError> {
    let mut config = Config::load(&opts.config)?;
    if let Some(p) = opts.period_s {
        if !(p.is_finite() && p > 0.0) {
            return Err(RtBenchError::Options);
        }
        config.cycle.period_s = p;
        config.cycle.sensor_deadline_s = 0.6 * p;
        config.node.status_period_s = config.node.status_period_s.max(p);
    }
    if !(opts.seconds.is_finite() && opts.seconds > 0.0) {
        return Err(RtBenchError::Options);
    }
    config.cycle.lock_memory = false;
    config.validate(&opts.config)?;

    let stop_load = Arc::new(AtomicBool::new(false));
    let load_threads = start_load(opts, &stop_load)?;
    let daemon = measure(LoopKind::Daemon, &config, opts);
    let baseline = measure(LoopKind::Baseline, &config, opts);
    stop_load.store(true, Ordering::Relaxed);
    for t in load_threads {
        t.join().map_err(|_| RtBenchError::Panicked)?;
    }
    let (daemon, realtime) = daemon?;
    let (baseline, _) = baseline?;
    let ratio = |b: f64, d: f64| if d > 0.0 { b / d } else { f64::INFINITY };
    Ok(RtBenchReport {
        period_s: config.cycle.period_s,
        seconds: opts.seconds,
        load: opts.load,
        bus: opts.iface.clone().unwrap_or_else(|| "in-process".into()),
        realtime,
        ratio_lateness_p50: ratio(baseline.lateness_us.p50, daemon.lateness_us.p50),
        ratio_lateness_p99: ratio(baseline.lateness_us.p99, daemon.lateness_us.p99),
        daemon,
        baseline,
    })
}

fn start_load(
    opts: &RtBenchOptions,
    stop: &Arc<AtomicBool>,
) -> Result<Vec<std::thread::JoinHandle<()>>, RtBenchError> {
    let mut threads = vec![];
    match opts.load {
        Load::None => {}
        Load::Cpu => {
            let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
            for _ in 0..cores {
                let stop = stop.clone();
                threads.push(std::thread::spawn(move || {
                    let mut x = 0u64;
                    while !stop.load(Ordering::Relaxed) {
                        for i in 0..10_000u64 {
                            x = std::hint::black_box(
                                x.wrapping_mul(6364136223846793005).wrapping_add(i),
                            );
                        }
                    }
                }));
            }
        }
        // The in-process flood is started per loop, on that loop's bus (see `measure`).
        Load::CanFlood if opts.iface.is_none() => {}
        Load::CanFlood => {
            let iface = opts.iface.clone().unwrap_or_default();
            let mut bus = SocketCanBus::open(&iface)?;
            let stop = stop.clone();
            threads.push(std::thread::spawn(move || flood(&mut bus, &stop)));
        }
    }
    Ok(threads)
}

/// Frames with an id nobody here uses, as fast as the bus takes them.
fn flood(bus: &mut dyn Bus, stop: &AtomicBool) {
    let mut n = 0u64;
    while !stop.load(Ordering::Relaxed) {
        n = n.wrapping_add(1);
        let Ok(frame) = Frame::new(0x5FF, &n.to_le_bytes()) else {
            return;
        };
        if bus.send(&frame).is_err() {
            // A full transmit queue on a real interface: give the driver a moment.
            std::thread::sleep(Duration::from_micros(50));
        }
    }
}

fn measure(
    kind: LoopKind,
    config: &Config,
    opts: &RtBenchOptions,
) -> Result<(LoopFigures, bool), RtBenchError> {
    let period_s = config.cycle.period_s;
    let axis = config.axis.first().ok_or(RtBenchError::Options)?;
    let plant = crate::physics::load_plant(&opts.plant)?;
    let mut sim = SimNode::new(axis.actuator_node_id, plant, period_s, vec![]);
    let mut node = ControllerNode::new(config)?;

    let in_proc_flood = opts.load == Load::CanFlood && opts.iface.is_none();
    let (mut daemon_bus, mut sim_bus, flood_bus): (
        Box<dyn Bus>,
        Box<dyn Bus>,
        Option<InProcEndpoint>,
    ) = match &opts.iface {
        Some(iface) => (
            Box::new(SocketCanBus::open(iface)?),
            Box::new(SocketCanBus::open(iface)?),
            None,
        ),
        None => {
            let mut eps = InProcBus::endpoints(if in_proc_flood { 3 } else { 2 });
            let flood_ep = if in_proc_flood { eps.pop() } else { None };
            let sim_ep = eps.pop().ok_or(RtBenchError::Panicked)?;
            let daemon_ep = eps.pop().ok_or(RtBenchError::Panicked)?;
            (Box::new(daemon_ep), Box::new(sim_ep), flood_ep)
        }
    };

    let stop = Arc::new(AtomicBool::new(false));
    let sim_stop = stop.clone();
    let sim_thread = std::thread::spawn(move || {
        run_sim_node(
            sim_bus.as_mut(),
            &mut sim,
            Duration::from_millis(100),
            None,
            &sim_stop,
            &mut |_| {},
        )
    });
    let flood_thread = flood_bus.map(|mut ep| {
        let stop = stop.clone();
        std::thread::spawn(move || flood(&mut ep, &stop))
    });

    let (sink, rx) = RecordSink::channel(1 << 16);
    let collector = std::thread::spawn(move || collect(rx, period_s));
    // Let the simulated node boot before the first SYNC.
    std::thread::sleep(Duration::from_millis(50));
    let settings = CycleSettings {
        period_s,
        sensor_deadline_s: config.cycle.sensor_deadline_s,
        realtime_priority: config.cycle.realtime_priority,
        lock_memory: false,
        duration_s: Some(opts.seconds),
        record_frames: false,
    };
    let loop_thread = {
        let sink = sink.clone();
        let stop = stop.clone();
        std::thread::Builder::new()
            .name(match kind {
                LoopKind::Daemon => "bench-cycle".into(),
                LoopKind::Baseline => "bench-baseline".into(),
            })
            .spawn(move || -> Result<(bool, u64), RtBenchError> {
                match kind {
                    LoopKind::Daemon => {
                        let report = run_cycle(
                            daemon_bus.as_mut(),
                            &mut node,
                            settings,
                            &stop,
                            &std::sync::atomic::AtomicU64::new(0),
                            &sink,
                        )?;
                        Ok((report.realtime, node.counters().sensor_missed))
                    }
                    LoopKind::Baseline => {
                        baseline(daemon_bus.as_mut(), &mut node, settings, &sink)?;
                        Ok((false, node.counters().sensor_missed))
                    }
                }
            })
            .map_err(|e| RtBenchError::Runtime(e.to_string()))?
    };
    let result = loop_thread.join().map_err(|_| RtBenchError::Panicked);
    stop.store(true, Ordering::Relaxed);
    drop(sink);
    let sim_result = sim_thread.join().map_err(|_| RtBenchError::Panicked)?;
    if let Some(t) = flood_thread {
        t.join().map_err(|_| RtBenchError::Panicked)?;
    }
    let mut figures = collector.join().map_err(|_| RtBenchError::Panicked)?;
    let (realtime, sensor_missed) = result??;
    sim_result?;
    figures.name = match kind {
        LoopKind::Daemon => "daemon",
        LoopKind::Baseline => "baseline",
    };
    figures.sensor_missed = sensor_missed;
    Ok((figures, realtime))
}

/// The naive loop: a tokio interval timer, the same work per tick, no real-time requests.
fn baseline(
    bus: &mut dyn Bus,
    node: &mut ControllerNode,
    settings: CycleSettings,
    sink: &RecordSink,
) -> Result<(), RtBenchError> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .map_err(|e| RtBenchError::Runtime(e.to_string()))?;
    let cycles = (settings.duration_s.unwrap_or(1.0) / settings.period_s).round() as u64;
    runtime.block_on(async {
        let mut runner = CycleRunner::new(
            bus,
            node,
            sink,
            settings.period_s,
            settings.sensor_deadline_s,
        );
        runner.boot()?;
        let mut interval = tokio::time::interval(Duration::from_secs_f64(settings.period_s));
        for k in 0..cycles {
            interval.tick().await;
            let sent_ns = runner.run_once(k, rt::monotonic_ns())?;
            if sent_ns > runner.release_ns(k + 1) {
                runner.node.counters_mut().overruns += 1;
                sink.push(Record::Event(Event::Overrun {
                    t_s: k as f64 * settings.period_s,
                    cycle: k,
                    late_s: (sent_ns - runner.release_ns(k + 1)) as f64 * 1e-9,
                }));
            }
        }
        runner.shutdown()?;
        Ok(())
    })
}

fn histogram() -> Histogram<u64> {
    // 1 unit resolution up to 100 s in µs (or ns for stages, up to 100 s too), 3 significant digits.
    Histogram::new_with_bounds(1, 100_000_000_000, 3).expect("constant, valid histogram bounds")
}

fn collect(rx: std::sync::mpsc::Receiver<Record>, _period_s: f64) -> LoopFigures {
    let mut lateness = histogram();
    let mut latency = histogram();
    let mut s2c = histogram();
    let mut stages: Vec<Histogram<u64>> = (0..STAGES).map(|_| histogram()).collect();
    let mut cycles = 0;
    let mut misses = 0;
    for r in rx {
        match r {
            Record::Cycle(c) => {
                cycles += 1;
                let us = |s: f64| ((s * 1e6).round() as u64).max(1);
                let _ = lateness.record(us(c.wake_latency));
                let _ = latency.record(us(c.cycle_latency));
                if c.sensor_fresh {
                    let _ = s2c.record(us(c.sensor_to_command));
                }
                for (h, ns) in stages.iter_mut().zip(c.stage_ns) {
                    if ns > 0 {
                        let _ = h.record(u64::from(ns));
                    }
                }
            }
            Record::Event(Event::Overrun { .. }) => misses += 1,
            Record::Event(_) | Record::Frame { .. } => {}
        }
    }
    LoopFigures {
        name: "",
        cycles,
        misses,
        lateness_us: Percentiles::of(&lateness),
        cycle_latency_us: Percentiles::of(&latency),
        sensor_to_command_us: Percentiles::of(&s2c),
        sensor_missed: 0,
        compute_ns: Stage::ALL
            .iter()
            .zip(&stages)
            .filter(|(_, h)| !h.is_empty())
            .map(|(s, h)| {
                (
                    s.name().to_string(),
                    StageFigures {
                        p50: h.value_at_quantile(0.5) as f64,
                        p99: h.value_at_quantile(0.99) as f64,
                        max: h.max() as f64,
                    },
                )
            })
            .collect(),
    }
}

impl std::fmt::Display for RtBenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "cycle {:.3} ms, {} s per loop, load {:?}, bus {}, SCHED_FIFO {}",
            self.period_s * 1e3,
            self.seconds,
            self.load,
            self.bus,
            if self.realtime {
                "granted"
            } else {
                "not granted"
            }
        )?;
        writeln!(f, "{:<28} {:>12} {:>12}", "", "daemon", "baseline")?;
        let row = |f: &mut std::fmt::Formatter<'_>, name: &str, a: f64, b: f64| {
            writeln!(f, "{name:<28} {a:>12.0} {b:>12.0}")
        };
        let (d, b) = (&self.daemon, &self.baseline);
        row(f, "cycles", d.cycles as f64, b.cycles as f64)?;
        row(f, "deadline misses", d.misses as f64, b.misses as f64)?;
        row(
            f,
            "sensor frames missed",
            d.sensor_missed as f64,
            b.sensor_missed as f64,
        )?;
        for (name, pd, pb) in [
            ("lateness", d.lateness_us, b.lateness_us),
            ("release to command", d.cycle_latency_us, b.cycle_latency_us),
            (
                "sensor to command",
                d.sensor_to_command_us,
                b.sensor_to_command_us,
            ),
        ] {
            row(f, &format!("{name} min/µs"), pd.min, pb.min)?;
            row(f, &format!("{name} p50/µs"), pd.p50, pb.p50)?;
            row(f, &format!("{name} p99/µs"), pd.p99, pb.p99)?;
            row(f, &format!("{name} p99.9/µs"), pd.p999, pb.p999)?;
            row(f, &format!("{name} max/µs"), pd.max, pb.max)?;
        }
        writeln!(f, "compute per stage (daemon), ns:   p50      p99      max")?;
        for (name, s) in &d.compute_ns {
            writeln!(
                f,
                "  {name:<28} {:>8.0} {:>8.0} {:>8.0}",
                s.p50, s.p99, s.max
            )?;
        }
        write!(
            f,
            "baseline / daemon: lateness p50 x{:.1}, p99 x{:.1}",
            self.ratio_lateness_p50, self.ratio_lateness_p99
        )
    }
}
