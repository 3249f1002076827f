//! The simulated node's runtime: frames from a bus into the node, heartbeats on time.

use super::node::{SimEvent, SimNode};
use crate::bus::{Bus, BusError, BusEvent};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Run `node` on `bus` until `stop` is set, `duration` has passed, or every other node is gone.
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
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if end.is_some_and(|e| now >= e) {
            break;
        }
        if now >= next_heartbeat {
            bus.send(&node.heartbeat())?;
            next_heartbeat += heartbeat_period;
            continue;
        }
        let wake = next_heartbeat.min(now + poll);
        let wake = end.map_or(wake, |e| wake.min(e));
        let event = match bus.recv_until(wake) {
            Ok(e) => e,
            // Nobody left to talk to (the in-process bus of a finished run): a normal end.
            Err(BusError::Closed) => break,
            Err(e) => return Err(e),
        };
        match event {
            Some(BusEvent::Frame(frame)) => {
                let mut out = [None; 4];
                let mut n = 0;
                node.handle(
                    &frame,
                    &mut |f| {
                        if n < out.len() {
                            out[n] = Some(*f);
                            n += 1;
                        }
                    },
                    on_event,
                );
                for f in out.iter().flatten() {
                    match bus.send(f) {
                        Err(BusError::Closed) => return Ok(()),
                        other => other?,
                    }
                }
            }
            Some(BusEvent::ErrorFrame(_)) | None => {}
        }
    }
    Ok(())
}
