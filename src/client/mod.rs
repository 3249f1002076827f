//! Clients of a running daemon over a bus: SDO transfers for `actuator sdo`.

use crate::bus::{Bus, BusError, BusEvent};
use crate::canopen::od::ObjectId;
use crate::canopen::sdo::{SdoClient, SdoOutcome};
use std::time::{Duration, Instant};

/// Read (upload) one object from node `node_id`; the raw bytes, or why not.
pub fn sdo_read(
    bus: &mut dyn Bus,
    node_id: u8,
    id: ObjectId,
    timeout: Duration,
) -> Result<SdoOutcome, BusError> {
    let mut client = SdoClient::new(node_id).with_timeout(timeout.as_secs_f64());
    let start = Instant::now();
    let first = client.start_upload(id, 0.0);
    run(bus, &mut client, first, start)
}

/// Write (download) one object of node `node_id`.
pub fn sdo_write(
    bus: &mut dyn Bus,
    node_id: u8,
    id: ObjectId,
    bytes: &[u8],
    timeout: Duration,
) -> Result<SdoOutcome, BusError> {
    let mut client = SdoClient::new(node_id).with_timeout(timeout.as_secs_f64());
    let start = Instant::now();
    let first = client.start_download(id, bytes, 0.0);
    run(bus, &mut client, first, start)
}

fn run(
    bus: &mut dyn Bus,
    client: &mut SdoClient,
    first: crate::bus::Frame,
    start: Instant,
) -> Result<SdoOutcome, BusError> {
    bus.send(&first)?;
    loop {
        if let Some(outcome) = client.outcome() {
            return Ok(outcome.clone());
        }
        let now_s = start.elapsed().as_secs_f64();
        if let Some(f) = client.poll(now_s) {
            bus.send(&f)?;
            continue;
        }
        // Wake at least every 10 ms to let the client time out.
        if let Some(BusEvent::Frame(frame)) =
            bus.recv_until(Instant::now() + Duration::from_millis(10))?
        {
            if let Some(next) = client.handle(&frame, start.elapsed().as_secs_f64()) {
                bus.send(&next)?;
            }
        }
    }
}
