//! The fixed-rate cycle: sleep to the release time, SYNC, gather sensor frames until the sensor
//! deadline, control, send. Runs on its own thread; never touches disk or takes a shared lock.

use super::node::{ControllerNode, CycleTiming};
use super::record::{Event, Record};
use super::recorder::RecordSink;
use super::rt;
use crate::bus::{Bus, BusError, BusEvent};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

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
}

/// What the cycle thread reports when it ends.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CycleReport {
    pub cycles: u64,
    pub overruns: u64,
    pub realtime: bool,
    pub memory_locked: bool,
}

/// Run the cycle until `stop` is set, `duration_s` has passed, or the bus fails.
pub fn run_cycle(
    bus: &mut dyn Bus,
    node: &mut ControllerNode,
    settings: CycleSettings,
    stop: &AtomicBool,
    sink: &RecordSink,
) -> Result<CycleReport, BusError> {
    let realtime =
        settings.realtime_priority > 0 && rt::set_fifo_priority(settings.realtime_priority).is_ok();
    let memory_locked = settings.lock_memory && rt::lock_memory().is_ok();
    sink.push(Record::Event(Event::Started {
        realtime_requested: settings.realtime_priority > 0,
        realtime,
        lock_requested: settings.lock_memory,
        memory_locked,
    }));

    let period_ns = (settings.period_s * 1e9).round() as u64;
    let sensor_wait = Duration::from_secs_f64(settings.sensor_deadline_s);
    let limit = settings
        .duration_s
        .map(|d| (d / settings.period_s).round() as u64);
    let mut bus_result = Ok(());

    // Both clocks are read together once; deadlines for sleeping and for receiving derive from them.
    let start_ns = rt::monotonic_ns();
    let start_instant = Instant::now();
    let mut record = |r: Record| sink.push(r);
    {
        let mut send = |f: &crate::bus::Frame| {
            if let Err(e) = bus.send(f) {
                bus_result = Err(e);
            }
        };
        node.boot(&mut send, &mut record);
    }
    bus_result?;

    let mut k: u64 = 0;
    let mut last_latency_s = 0.0;
    while !stop.load(Ordering::Relaxed) && limit.is_none_or(|n| k < n) {
        let release_ns = start_ns + k * period_ns;
        rt::sleep_until_ns(release_ns);
        let woke_ns = rt::monotonic_ns();
        let release = start_instant + Duration::from_nanos(k * period_ns);
        let t_s = (k * period_ns) as f64 * 1e-9;

        // Whatever is queued now arrived before this cycle's SYNC: handle it (setpoints, NMT,
        // heartbeats, sensor frames that missed the last deadline), then mark every axis as
        // waiting, so a late frame can never pass for this cycle's and add a period of lag.
        while let Some(event) = bus.recv_until(Instant::now())? {
            on_event(node, event, t_s, &mut record);
        }
        node.begin_cycle();
        bus.send(&node.sync_frame())?;
        let sensor_deadline = release + sensor_wait;
        while !node.all_sensors_in() {
            match bus.recv_until(sensor_deadline)? {
                Some(event) => on_event(node, event, t_s, &mut record),
                None => break,
            }
        }

        let mut send_error = None;
        {
            let mut send = |f: &crate::bus::Frame| {
                if let Err(e) = bus.send(f) {
                    send_error.get_or_insert(e);
                }
            };
            // Each axis' record is pushed right after its command went out: stamp it then.
            let mut record_stamped = |mut r: Record| {
                if let Record::Cycle(c) = &mut r {
                    c.cycle_latency = rt::monotonic_ns().saturating_sub(release_ns) as f64 * 1e-9;
                }
                sink.push(r);
            };
            let timing = CycleTiming {
                wake_latency_s: woke_ns.saturating_sub(release_ns) as f64 * 1e-9,
                previous_cycle_latency_s: last_latency_s,
            };
            node.finish_cycle(t_s, timing, &mut send, &mut record_stamped);
        }
        let sent_ns = rt::monotonic_ns();
        last_latency_s = sent_ns.saturating_sub(release_ns) as f64 * 1e-9;
        if let Some(e) = send_error {
            return Err(e);
        }

        // Overrun: the next release time has already passed. Skip the lost periods instead of
        // running a burst of late cycles.
        k += 1;
        let next_ns = start_ns + k * period_ns;
        if sent_ns > next_ns {
            let late_ns = sent_ns - next_ns;
            let skipped = late_ns / period_ns + 1;
            node.counters_mut().overruns += 1;
            record(Record::Event(Event::Overrun {
                t_s,
                cycle: k - 1,
                late_s: late_ns as f64 * 1e-9,
            }));
            k += skipped;
        }
    }
    let mut send_error = None;
    node.shutdown(&mut |f| {
        if let Err(e) = bus.send(f) {
            send_error.get_or_insert(e);
        }
    });
    if let Some(e) = send_error {
        return Err(e);
    }
    Ok(CycleReport {
        cycles: node.counters().cycles,
        overruns: node.counters().overruns,
        realtime,
        memory_locked,
    })
}

fn on_event(node: &mut ControllerNode, event: BusEvent, t_s: f64, record: &mut dyn FnMut(Record)) {
    match event {
        BusEvent::Frame(frame) => node.handle(&frame, t_s, record),
        BusEvent::ErrorFrame(error) => {
            node.counters_mut().bus_errors += 1;
            record(Record::Event(Event::BusError { t_s, error }));
        }
    }
}
