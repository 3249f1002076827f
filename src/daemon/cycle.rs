//! The fixed-rate cycle: sleep to the release time, SYNC, gather sensor frames until the sensor
//! deadline, control, send. Runs on its own thread; never touches disk or takes a shared lock.

use super::node::{ControllerNode, CycleTiming};
use super::reconfigure::{BuilderLink, Built};
use super::record::{Event, Record};
use super::recorder::RecordSink;
use super::rt;
use super::state::StateSink;
use crate::bus::{Bus, BusError, BusEvent, BusFault, Frame};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

/// Frames handled before SYNC per cycle: about a period's worth of a saturated 1 Mbit/s bus at
/// the shortest frames (20 per ms), with room to spare at 400 Hz.
const MAX_FRAMES_BEFORE_SYNC: usize = 64;

/// Cycle timing and real-time requests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleSettings {
    pub period_s: f64,
    pub sensor_deadline_s: f64,
    /// SCHED_FIFO priority, 0 for none.
    pub realtime_priority: i32,
    pub lock_memory: bool,
    /// Stop by itself after this long (tests, demo); None runs until told to stop.
    pub duration_s: Option<f64>,
    /// Record every CAN frame sent and received.
    pub record_frames: bool,
}

/// What the cycle thread reports when it ends.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CycleReport {
    pub cycles: u64,
    pub overruns: u64,
    pub realtime: bool,
    pub memory_locked: bool,
}

/// The work of one cycle around the sans-I/O node, whatever wakes it up: the real-time loop
/// below, or the naive baseline the real-time bench compares it with.
pub struct CycleRunner<'a> {
    pub bus: &'a mut dyn Bus,
    pub node: &'a mut ControllerNode,
    pub sink: &'a RecordSink,
    start_ns: u64,
    start_instant: Instant,
    period_ns: u64,
    sensor_wait: Duration,
    last_latency_s: f64,
    record_frames: bool,
    built: Option<Receiver<Box<Built>>>,
    /// The interface went away: the socket must be opened again before it can carry frames.
    reopen_needed: bool,
    /// Since a bus-off: the controller reported its restart, or a frame came in.
    bus_alive_seen: bool,
}

impl<'a> CycleRunner<'a> {
    /// Read both clocks once; every release time derives from them.
    pub fn new(
        bus: &'a mut dyn Bus,
        node: &'a mut ControllerNode,
        sink: &'a RecordSink,
        period_s: f64,
        sensor_deadline_s: f64,
    ) -> Self {
        node.set_stage_clock(rt::monotonic_ns);
        // The cycle's time 0 is now: the error field stamps its entries by the wall clock.
        let unix_now_s = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        node.set_wall_clock_at_start(unix_now_s);
        Self {
            bus,
            node,
            sink,
            start_ns: rt::monotonic_ns(),
            start_instant: Instant::now(),
            period_ns: (period_s * 1e9).round() as u64,
            sensor_wait: Duration::from_secs_f64(sensor_deadline_s),
            last_latency_s: 0.0,
            record_frames: false,
            built: None,
            reopen_needed: false,
            bus_alive_seen: false,
        }
    }

    /// New configurations (SIGHUP reloads and SDO parameter writes) are built off this thread
    /// by the builder of [`super::reconfigure`]; each takes effect at the next cycle boundary,
    /// and what it replaced goes back to the builder to be dropped there.
    pub fn reconfigure_with(mut self, link: Option<BuilderLink>) -> Self {
        if let Some(link) = link {
            self.node.attach_builder(link.input);
            self.built = Some(link.built);
        }
        self
    }

    /// Also hand every frame sent and received to the recorder.
    pub fn record_frames(mut self, on: bool) -> Self {
        self.record_frames = on;
        self
    }

    /// CLOCK_MONOTONIC time of cycle `k`'s release.
    pub fn release_ns(&self, k: u64) -> u64 {
        self.start_ns + k * self.period_ns
    }

    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// Announce the node and start the actuator nodes. A bus that fails here is a bus fault
    /// like any other: the cycle starts and waits for the bus.
    pub fn boot(&mut self) -> Result<(), BusError> {
        let mut error = None;
        let bus = &mut *self.bus;
        let sink = self.sink;
        self.node.boot(
            &mut |f| {
                if let Err(e) = bus.send(f) {
                    error.get_or_insert(e);
                }
            },
            &mut |r| sink.push(r),
        );
        match error {
            Some(e) => self.bus_failed(e, 0.0),
            None => Ok(()),
        }
    }

    /// A send or receive failed: a bus fault for the node, or the end of the run when the bus
    /// is closed for good (an in-process bus whose peers are gone).
    fn bus_failed(&mut self, error: BusError, t_s: f64) -> Result<(), BusError> {
        let Some(cause) = BusFault::from_error(&error) else {
            return Err(error);
        };
        if cause.needs_reopen() {
            self.reopen_needed = true;
        }
        let sink = self.sink;
        self.node.on_bus_fault(cause, t_s, &mut |r| sink.push(r));
        if self.node.bus_lost() == Some(BusFault::BusOff) {
            self.bus_alive_seen = false;
        }
        Ok(())
    }

    /// Read what is queued, at most `limit` events. `Ok(false)` when the bus was lost meanwhile.
    fn drain(&mut self, limit: usize, t_s: f64) -> Result<bool, BusError> {
        for _ in 0..limit {
            match self.bus.recv_until(Instant::now()) {
                Ok(Some(event)) => self.on_event(event, t_s),
                Ok(None) => break,
                Err(e) => {
                    self.bus_failed(e, t_s)?;
                    if self.node.bus_lost().is_some() {
                        return Ok(false);
                    }
                }
            }
        }
        Ok(true)
    }

    fn on_event(&mut self, event: BusEvent, t_s: f64) {
        let sink = self.sink;
        let mut record = |r: Record| sink.push(r);
        match event {
            BusEvent::Frame(frame) => {
                self.bus_alive_seen = true;
                if self.record_frames {
                    record(Record::Frame {
                        t_s,
                        frame,
                        received: true,
                    });
                }
                self.node.handle(&frame, t_s, &mut record)
            }
            BusEvent::ErrorFrame(error) => {
                self.node.counters_mut().bus_errors += 1;
                record(Record::Event(Event::BusError { t_s, error }));
                if error.is_restart() {
                    self.bus_alive_seen = true;
                }
                if let Some(cause) = BusFault::from_error_frame(&error) {
                    self.node.on_bus_fault(cause, t_s, &mut record);
                    if cause == BusFault::BusOff {
                        self.bus_alive_seen = false;
                    }
                }
            }
        }
    }

    /// A period of a lost bus: open the socket again if the interface went away, read what
    /// came, and say whether the bus may carry this cycle's SYNC (which is the real test).
    fn try_bus(&mut self, t_s: f64) -> Result<bool, BusError> {
        if self.reopen_needed {
            match self.bus.reopen() {
                Ok(()) => self.reopen_needed = false,
                Err(BusError::Closed) => return Err(BusError::Closed),
                Err(_) => return Ok(false),
            }
        }
        // Errors while lost only confirm the loss (and clear the socket's pending error).
        for _ in 0..MAX_FRAMES_BEFORE_SYNC {
            match self.bus.recv_until(Instant::now()) {
                Ok(Some(event)) => self.on_event(event, t_s),
                Ok(None) => break,
                Err(BusError::Closed) => return Err(BusError::Closed),
                Err(e) => {
                    if BusFault::from_error(&e).is_some_and(BusFault::needs_reopen) {
                        self.reopen_needed = true;
                    }
                    break;
                }
            }
        }
        // A bus-off controller queues frames without sending them: wait for its restart.
        Ok(self.node.bus_lost() != Some(BusFault::BusOff) || self.bus_alive_seen)
    }

    /// Run cycle `k`, woken at `woke_ns`; returns when its last frame went out (CLOCK_MONOTONIC).
    /// Bus faults do not end it: a lost bus makes it a short cycle that only tries the bus.
    pub fn run_once(&mut self, k: u64, woke_ns: u64) -> Result<u64, BusError> {
        let release_ns = self.release_ns(k);
        let release = self.start_instant + Duration::from_nanos(k * self.period_ns);
        let t_s = (k * self.period_ns) as f64 * 1e-9;
        let sink = self.sink;
        if let Some(built) = self.built.as_ref().and_then(|rx| rx.try_recv().ok()) {
            // The node hands what it replaced back to the builder.
            let _ = self
                .node
                .apply_built(built, t_s, &mut |r: Record| sink.push(r));
        }
        let was_lost = self.node.bus_lost().is_some();
        if was_lost && !self.try_bus(t_s)? {
            self.node.bus_lost_cycle();
            return Ok(rt::monotonic_ns());
        }

        // Whatever is queued now arrived before this cycle's SYNC: handle it (setpoints, NMT,
        // heartbeats, sensor frames that missed the last deadline), then mark every axis as
        // waiting, so a late frame can never pass for this cycle's and add a period of lag.
        // Bounded, so a flood of frames cannot hold the cycle here; the rest waits in the
        // socket queue (a full queue drops frames, counted by the kernel or the bus).
        if !was_lost && !self.drain(MAX_FRAMES_BEFORE_SYNC, t_s)? {
            self.node.bus_lost_cycle();
            return Ok(rt::monotonic_ns());
        }
        self.node.begin_cycle();
        let sync = self.node.sync_frame();
        if let Err(e) = self.bus.send(&sync) {
            if !was_lost {
                self.bus_failed(e, t_s)?;
            }
            if self.node.bus_lost().is_some() {
                self.node.bus_lost_cycle();
                return Ok(rt::monotonic_ns());
            }
        }
        if was_lost {
            // SYNC went out: the bus is back, this cycle runs in full and announces the outage.
            self.node.bus_restored(t_s, &mut |r: Record| sink.push(r));
        }
        if self.record_frames {
            sink.push(Record::Frame {
                t_s,
                frame: sync,
                received: false,
            });
        }
        // The nodes answer the SYNC, not the release: a SYNC that went out late (the thread
        // woke late, or read a burst of frames first) moves the deadline with it, so a node is
        // never counted late for our delay; but never past 90 % of the period, where the
        // command could no longer go out before the next release.
        let latest = release + Duration::from_nanos(self.period_ns * 9 / 10);
        let sensor_deadline =
            (Instant::now() + self.sensor_wait).min(latest.max(release + self.sensor_wait));
        while !self.node.all_sensors_in() {
            match self.bus.recv_until(sensor_deadline) {
                Ok(Some(event)) => self.on_event(event, t_s),
                Ok(None) => break,
                Err(e) => {
                    self.bus_failed(e, t_s)?;
                    if self.node.bus_lost().is_some() {
                        self.node.bus_lost_cycle();
                        return Ok(rt::monotonic_ns());
                    }
                }
            }
        }
        let sensors_in_ns = self.node.all_sensors_in().then(rt::monotonic_ns);

        let mut send_error = None;
        {
            let bus = &mut *self.bus;
            let record_frames = self.record_frames;
            let mut send = |f: &Frame| {
                if let Err(e) = bus.send(f) {
                    send_error.get_or_insert(e);
                }
                if record_frames {
                    sink.push(Record::Frame {
                        t_s,
                        frame: *f,
                        received: false,
                    });
                }
            };
            // Each axis' record is pushed right after its command went out: stamp it then.
            let mut record_stamped = |mut r: Record| {
                if let Record::Cycle(c) = &mut r {
                    let now = rt::monotonic_ns();
                    c.cycle_latency = now.saturating_sub(release_ns) as f64 * 1e-9;
                    c.sensor_to_command = sensors_in_ns
                        .filter(|_| c.sensor_fresh)
                        .map_or(0.0, |s| now.saturating_sub(s) as f64 * 1e-9);
                }
                sink.push(r);
            };
            let timing = CycleTiming {
                wake_latency_s: woke_ns.saturating_sub(release_ns) as f64 * 1e-9,
                previous_cycle_latency_s: self.last_latency_s,
            };
            self.node
                .finish_cycle(t_s, timing, &mut send, &mut record_stamped);
        }
        let sent_ns = rt::monotonic_ns();
        self.last_latency_s = sent_ns.saturating_sub(release_ns) as f64 * 1e-9;
        if let Some(e) = send_error {
            self.bus_failed(e, t_s)?;
        }
        Ok(sent_ns)
    }

    /// Leave operation: the safe command to every axis. On a lost bus it cannot reach them;
    /// that is no new error (the loss was recorded when it began).
    pub fn shutdown(&mut self) -> Result<(), BusError> {
        let mut send_error = None;
        let bus = &mut *self.bus;
        self.node.shutdown(&mut |f| {
            if let Err(e) = bus.send(f) {
                send_error.get_or_insert(e);
            }
        });
        match send_error {
            Some(BusError::Closed) => Err(BusError::Closed),
            Some(e) if self.node.bus_lost().is_none() => {
                let t_s = self.node.counters().cycles as f64 * self.period_ns as f64 * 1e-9;
                self.bus_failed(e, t_s)
            }
            _ => Ok(()),
        }
    }
}

/// Run the cycle until `stop` is set, `duration_s` has passed, or the bus fails.
/// `progress` is set to the number of the cycle just run, for a watchdog outside the thread.
pub fn run_cycle(
    bus: &mut dyn Bus,
    node: &mut ControllerNode,
    settings: CycleSettings,
    stop: &AtomicBool,
    progress: &AtomicU64,
    sink: &RecordSink,
) -> Result<CycleReport, BusError> {
    run_cycle_with(
        bus,
        node,
        settings,
        stop,
        progress,
        sink,
        CycleServices::default(),
    )
}

/// What the daemon adds around the cycle: new configurations (SIGHUP) and the state writer.
#[derive(Default)]
pub struct CycleServices {
    /// The builder of new configurations (SIGHUP, SDO parameter writes), off the cycle thread.
    pub reconfigure: Option<BuilderLink>,
    /// What the axes learned is offered to it every so many cycles, and once at the end.
    pub state: Option<StateSink>,
}

/// [`run_cycle`] with the daemon's services.
pub fn run_cycle_with(
    bus: &mut dyn Bus,
    node: &mut ControllerNode,
    settings: CycleSettings,
    stop: &AtomicBool,
    progress: &AtomicU64,
    sink: &RecordSink,
    services: CycleServices,
) -> Result<CycleReport, BusError> {
    let CycleServices { reconfigure, state } = services;
    let realtime =
        settings.realtime_priority > 0 && rt::set_fifo_priority(settings.realtime_priority).is_ok();
    let memory_locked = settings.lock_memory && rt::lock_memory().is_ok();
    sink.push(Record::Event(Event::Started {
        realtime_requested: settings.realtime_priority > 0,
        realtime,
        lock_requested: settings.lock_memory,
        memory_locked,
    }));
    let limit = settings
        .duration_s
        .map(|d| (d / settings.period_s).round() as u64);

    let mut runner = CycleRunner::new(
        bus,
        node,
        sink,
        settings.period_s,
        settings.sensor_deadline_s,
    )
    .record_frames(settings.record_frames)
    .reconfigure_with(reconfigure);
    let period_ns = runner.period_ns();
    let mut k: u64 = 0;
    let mut outcome = runner.boot();
    while outcome.is_ok() && !stop.load(Ordering::Relaxed) && limit.is_none_or(|n| k < n) {
        rt::sleep_until_ns(runner.release_ns(k));
        let woke_ns = rt::monotonic_ns();
        let sent_ns = match runner.run_once(k, woke_ns) {
            Ok(ns) => ns,
            Err(e) => {
                outcome = Err(e);
                break;
            }
        };
        progress.store(k + 1, Ordering::Relaxed);
        if let Some(state) = state
            .as_ref()
            .filter(|s| (k + 1) % s.every_cycles() == 0 || s.errors_changed(runner.node))
        {
            state.offer(runner.node);
        }
        // Overrun: the next release time has already passed. Skip the lost periods instead of
        // running a burst of late cycles.
        k += 1;
        let next_ns = runner.release_ns(k);
        if sent_ns > next_ns {
            let late_ns = sent_ns - next_ns;
            runner.node.counters_mut().overruns += 1;
            sink.push(Record::Event(Event::Overrun {
                t_s: ((k - 1) * period_ns) as f64 * 1e-9,
                cycle: k - 1,
                late_s: late_ns as f64 * 1e-9,
            }));
            k += late_ns / period_ns + 1;
        }
    }
    let shutdown = runner.shutdown();
    // What was learned is kept even when the bus has failed.
    if let Some(state) = state {
        state.finish(runner.node);
    }
    outcome?;
    shutdown?;
    Ok(CycleReport {
        cycles: runner.node.counters().cycles,
        overruns: runner.node.counters().overruns,
        realtime,
        memory_locked,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::NmtState;
    use crate::daemon::Config;
    use crate::device::Emcy;
    use std::path::Path;
    use std::sync::atomic::AtomicI32;
    use std::sync::{Arc, Mutex};

    /// A bus that fails with its errno while that is not 0, and keeps what went out while up.
    #[derive(Clone, Default)]
    struct SwitchedBus {
        errno: Arc<AtomicI32>,
        sent: Arc<Mutex<Vec<Frame>>>,
        reopened: Arc<AtomicU64>,
    }

    impl SwitchedBus {
        fn sent(&self) -> Vec<Frame> {
            self.sent.lock().expect("lock").clone()
        }
    }

    impl Bus for SwitchedBus {
        fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
            match self.errno.load(Ordering::Relaxed) {
                0 => {
                    self.sent.lock().expect("lock").push(*frame);
                    Ok(())
                }
                e => Err(BusError::Io {
                    iface: "test0".into(),
                    source: std::io::Error::from_raw_os_error(e),
                }),
            }
        }

        fn recv_until(&mut self, _deadline: Instant) -> Result<Option<BusEvent>, BusError> {
            Ok(None)
        }

        fn name(&self) -> &str {
            "test0"
        }

        fn reopen(&mut self) -> Result<(), BusError> {
            self.reopened.fetch_add(1, Ordering::Relaxed);
            Ok(())
        }
    }

    fn node(on_loss: crate::daemon::config::BusLossPolicy) -> ControllerNode {
        let mut config = Config::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/solenoid.toml"
        )))
        .expect("shipped config");
        config.bus.on_loss = on_loss;
        ControllerNode::new(&config).expect("node")
    }

    /// Runs cycles 0..n with the bus failing with `errno` over `down`; SYNCs sent per cycle.
    fn run(
        node: &mut ControllerNode,
        errno: i32,
        down: std::ops::Range<u64>,
        n: u64,
    ) -> (SwitchedBus, Vec<usize>) {
        let bus = SwitchedBus::default();
        let mut driven = bus.clone();
        let (sink, _rx) = RecordSink::channel(1 << 16);
        let mut syncs_per_cycle = Vec::new();
        let mut runner = CycleRunner::new(&mut driven, node, &sink, 0.0025, 0.0);
        runner.boot().expect("boot");
        for k in 0..n {
            let e = if down.contains(&k) { errno } else { 0 };
            bus.errno.store(e, Ordering::Relaxed);
            let before = bus.sent().len();
            runner
                .run_once(k, runner.release_ns(k))
                .expect("a bus fault is no error");
            syncs_per_cycle.push(
                bus.sent()[before..]
                    .iter()
                    .filter(|f| f.id() == 0x080)
                    .count(),
            );
        }
        (bus, syncs_per_cycle)
    }

    /// The EMCYs of the bus itself (axis 0), with their index among the frames sent.
    fn bus_emcys(sent: &[Frame]) -> Vec<(usize, Emcy)> {
        sent.iter()
            .enumerate()
            .filter(|(_, f)| f.id() == 0x081)
            .map(|(i, f)| (i, Emcy::decode(f).expect("EMCY decodes")))
            .filter(|(_, e)| e.axis_node_id == 0)
            .collect()
    }

    #[test]
    fn an_interface_going_down_is_a_fault_the_cycle_outlives() {
        let mut n = node(crate::daemon::config::BusLossPolicy::SafeState);
        let (bus, syncs) = run(&mut n, libc::ENETDOWN, 10..50, 60);
        // A SYNC every period but the lost ones, and again from the first period back.
        for (k, count) in syncs.iter().enumerate() {
            let expected = usize::from(!(10..50).contains(&(k as u64)));
            assert_eq!(*count, expected, "SYNCs in cycle {k}");
        }
        let c = n.counters();
        assert_eq!(c.bus_faults, 1, "one outage, one fault");
        assert_eq!(c.bus_lost_cycles, 40);
        assert_eq!(n.bus_lost(), None);
        // The outage is named by its EMCY, sent with the first frames after it.
        let sent = bus.sent();
        let emcy = bus_emcys(&sent);
        assert_eq!(emcy.len(), 1, "{emcy:?}");
        assert_eq!(emcy[0].1.error_code, BusFault::InterfaceDown.emcy_code());
        // Safe state: pre-operational, the safe command out, no more commands until a start.
        assert_eq!(n.state(), NmtState::PreOperational);
        let back = sent
            .iter()
            .skip(1)
            .position(|f| f.id() == 0x080)
            .map(|i| i + 1);
        assert!(back.is_some());
        let commands_after = sent[emcy[0].0..].iter().filter(|f| f.id() == 0x210).count();
        assert_eq!(
            commands_after, 0,
            "no command after the EMCY (the safe one before it)"
        );
        assert_eq!(
            bus.reopened.load(Ordering::Relaxed),
            0,
            "a down interface keeps its socket"
        );
    }

    #[test]
    fn with_continue_the_axes_are_commanded_again_after_the_loss() {
        let mut n = node(crate::daemon::config::BusLossPolicy::Continue);
        let (bus, _) = run(&mut n, libc::ENXIO, 5..20, 30);
        assert_eq!(n.state(), NmtState::Operational);
        assert_eq!(n.counters().bus_faults, 1);
        assert!(
            bus.reopened.load(Ordering::Relaxed) >= 1,
            "a vanished interface is opened again"
        );
        let sent = bus.sent();
        let emcy = bus_emcys(&sent);
        assert_eq!(emcy.len(), 1, "{emcy:?}");
        assert_eq!(emcy[0].1.error_code, BusFault::InterfaceGone.emcy_code());
        assert_eq!(
            sent[emcy[0].0..].iter().filter(|f| f.id() == 0x210).count(),
            10,
            "a command in each of the 10 cycles after the loss"
        );
    }
}
