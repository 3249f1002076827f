//! The simulated node's runtime: frames from a bus into the node, heartbeats on time.

use super::node::{SimEvent, SimNode};
use crate::bus::{Bus, BusError, BusEvent, BusFault, Frame};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// While the bus is lost, it is tried this often (a real node's controller restarts as often).
const BUS_RETRY: Duration = Duration::from_millis(10);

/// The frames a node answers one call with, at most four (a real node's transmit queue; more
/// are dropped), sent after the call so the node is not borrowed while the bus is.
#[derive(Default)]
struct Outbox {
    frames: [Option<Frame>; 4],
    n: usize,
}

impl Outbox {
    fn push(&mut self, frame: &Frame) {
        if let Some(slot) = self.frames.get_mut(self.n) {
            *slot = Some(*frame);
            self.n += 1;
        }
    }

    /// Send them in order; the first failure stops the rest.
    fn send(&self, bus: &mut dyn Bus) -> Result<(), BusError> {
        self.frames.iter().flatten().try_for_each(|f| bus.send(f))
    }
}

/// Run `node` on `bus` until `stop` is set, `duration` has passed, or every other node is gone.
/// A failing bus is waited for, as a real node's CAN controller would: the node keeps its plant
/// and goes on where it was once frames flow again.
pub fn run_sim_node(
    bus: &mut dyn Bus,
    node: &mut SimNode,
    heartbeat_period: Duration,
    duration: Option<Duration>,
    stop: &AtomicBool,
    on_event: &mut dyn FnMut(SimEvent),
) -> Result<(), BusError> {
    let start = Instant::now();
    let end = duration.map(|d| start + d);
    let mut send_error = None;
    node.boot(&mut |f| {
        if let Err(e) = bus.send(f) {
            send_error.get_or_insert(e);
        }
    });
    if let Some(e) = send_error {
        return Err(e);
    }
    let mut next_heartbeat = start + heartbeat_period;
    // Wake at least this often to notice `stop`.
    let poll = Duration::from_millis(50);
    let mut lost: Option<(BusFault, Instant, bool)> = None;
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if end.is_some_and(|e| now >= e) {
            break;
        }
        if let Some((cause, since, reopen)) = lost {
            std::thread::sleep(BUS_RETRY);
            if reopen && bus.reopen().is_err() {
                continue;
            }
            // The heartbeat is the probe: it goes out when the bus is back.
            match bus.send(&node.heartbeat()) {
                Ok(()) => {
                    lost = None;
                    next_heartbeat = Instant::now() + heartbeat_period;
                    on_event(SimEvent::BusRestored {
                        cause,
                        outage_s: since.elapsed().as_secs_f64(),
                    });
                }
                Err(BusError::Closed) => break,
                Err(e) => {
                    let reopen = BusFault::from_error(&e).is_some_and(BusFault::needs_reopen);
                    lost = Some((cause, since, reopen));
                }
            }
            continue;
        }
        let fail = |e: BusError, on_event: &mut dyn FnMut(SimEvent)| match BusFault::from_error(&e)
        {
            None => None,
            Some(cause) => {
                on_event(SimEvent::BusLost(cause));
                Some((cause, Instant::now(), cause.needs_reopen()))
            }
        };
        if now >= next_heartbeat {
            next_heartbeat += heartbeat_period;
            if let Err(e) = bus.send(&node.heartbeat()) {
                match fail(e, on_event) {
                    Some(l) => lost = Some(l),
                    None => break,
                }
            }
            continue;
        }
        let wake = next_heartbeat.min(now + poll);
        let wake = end.map_or(wake, |e| wake.min(e));
        // A heartbeat consumer's deadline: the node's clock runs on without SYNC.
        let wake = node.deadline_s().map_or(wake, |d| {
            wake.min(start + Duration::from_secs_f64(d.max(0.0)) + Duration::from_micros(100))
        });
        let event = bus.recv_until(wake);
        let mut out = Outbox::default();
        node.poll(start.elapsed().as_secs_f64(), &mut |f| out.push(f));
        if let Err(e) = out.send(bus) {
            match fail(e, on_event) {
                Some(l) => lost = Some(l),
                None => return Ok(()),
            }
        }
        let event = match event {
            Ok(e) => e,
            Err(e) => {
                // Nobody left to talk to (the in-process bus of a finished run): a normal end.
                match fail(e, on_event) {
                    Some(l) => lost = Some(l),
                    None => break,
                }
                continue;
            }
        };
        match event {
            Some(BusEvent::Frame(frame)) => {
                let mut out = Outbox::default();
                node.handle(&frame, &mut |f| out.push(f), on_event);
                if let Err(e) = out.send(bus) {
                    match fail(e, on_event) {
                        Some(l) => lost = Some(l),
                        None => return Ok(()),
                    }
                }
            }
            Some(BusEvent::ErrorFrame(_)) | None => {}
        }
    }
    Ok(())
}
