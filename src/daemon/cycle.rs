//! The fixed-rate cycle: sleep to the release time, SYNC, gather sensor frames until the sensor
//! deadline, control, send. Runs on its own thread; never touches disk or takes a shared lock.

use super::node::{ControllerNode, CycleTiming, PreparedReload};
use super::record::{Event, Record};
use super::recorder::RecordSink;
use super::rt;
use super::state::StateSink;
use crate::bus::{Bus, BusError, BusEvent, Frame};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
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
    reload: Option<Receiver<Box<PreparedReload>>>,
    retired: Option<SyncSender<Box<PreparedReload>>>,
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
            reload: None,
            retired: None,
        }
    }

    /// New configurations (SIGHUP), built off this thread, arrive on `rx`; each takes effect at
    /// the next cycle boundary, and what it replaced goes back on `retired` to be dropped there.
    pub fn reload_from(
        mut self,
        rx: Option<Receiver<Box<PreparedReload>>>,
        retired: Option<SyncSender<Box<PreparedReload>>>,
    ) -> Self {
        self.reload = rx;
        self.retired = retired;
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

    /// Announce the node and start the actuator nodes.
    pub fn boot(&mut self) -> Result<(), BusError> {
        let mut result = Ok(());
        let bus = &mut *self.bus;
        let sink = self.sink;
        self.node.boot(
            &mut |f| {
                if let Err(e) = bus.send(f) {
                    result = Err(e);
                }
            },
            &mut |r| sink.push(r),
        );
        result
    }

    /// Run cycle `k`, woken at `woke_ns`; returns when its last frame went out (CLOCK_MONOTONIC).
    pub fn run_once(&mut self, k: u64, woke_ns: u64) -> Result<u64, BusError> {
        let release_ns = self.release_ns(k);
        let release = self.start_instant + Duration::from_nanos(k * self.period_ns);
        let t_s = (k * self.period_ns) as f64 * 1e-9;
        let sink = self.sink;
        let mut record = |r: Record| sink.push(r);
        if let Some(prepared) = self.reload.as_ref().and_then(|rx| rx.try_recv().ok()) {
            let replaced = self.node.apply_reload(prepared, t_s, &mut record);
            if let Some(tx) = &self.retired {
                // With nobody to take it, it is dropped here: a rare free, not a blocked cycle.
                let _ = tx.try_send(replaced);
            }
        }

        // Whatever is queued now arrived before this cycle's SYNC: handle it (setpoints, NMT,
        // heartbeats, sensor frames that missed the last deadline), then mark every axis as
        // waiting, so a late frame can never pass for this cycle's and add a period of lag.
        // Bounded, so a flood of frames cannot hold the cycle here; the rest waits in the
        // socket queue (a full queue drops frames, counted by the kernel or the bus).
        for _ in 0..MAX_FRAMES_BEFORE_SYNC {
            match self.bus.recv_until(Instant::now())? {
                Some(event) => on_event(self.node, event, t_s, self.record_frames, &mut record),
                None => break,
            }
        }
        self.node.begin_cycle();
        let sync = self.node.sync_frame();
        self.bus.send(&sync)?;
        if self.record_frames {
            record(Record::Frame {
                t_s,
                frame: sync,
                received: false,
            });
        }
        let sensor_deadline = release + self.sensor_wait;
        while !self.node.all_sensors_in() {
            match self.bus.recv_until(sensor_deadline)? {
                Some(event) => on_event(self.node, event, t_s, self.record_frames, &mut record),
                None => break,
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
        match send_error {
            Some(e) => Err(e),
            None => Ok(sent_ns),
        }
    }

    /// Leave operation: the safe command to every axis.
    pub fn shutdown(&mut self) -> Result<(), BusError> {
        let mut send_error = None;
        let bus = &mut *self.bus;
        self.node.shutdown(&mut |f| {
            if let Err(e) = bus.send(f) {
                send_error.get_or_insert(e);
            }
        });
        send_error.map_or(Ok(()), Err)
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
    /// New configurations, built off the cycle thread, each taken at the next cycle boundary.
    pub reload: Option<Receiver<Box<PreparedReload>>>,
    /// What a reload replaced goes back here, to be dropped off the cycle thread.
    pub retired: Option<SyncSender<Box<PreparedReload>>>,
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
    let CycleServices {
        reload,
        retired,
        state,
    } = services;
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
    .reload_from(reload, retired);
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
        if let Some(state) = state.as_ref().filter(|s| (k + 1) % s.every_cycles() == 0) {
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

fn on_event(
    node: &mut ControllerNode,
    event: BusEvent,
    t_s: f64,
    record_frames: bool,
    record: &mut dyn FnMut(Record),
) {
    match event {
        BusEvent::Frame(frame) => {
            if record_frames {
                record(Record::Frame {
                    t_s,
                    frame,
                    received: true,
                });
            }
            node.handle(&frame, t_s, record)
        }
        BusEvent::ErrorFrame(error) => {
            node.counters_mut().bus_errors += 1;
            record(Record::Event(Event::BusError { t_s, error }));
        }
    }
}
