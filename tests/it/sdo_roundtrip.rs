//! SDO client and server talking over an in-process CAN bus: every data type both ways,
//! expedited and segmented, and writes that take effect only at the cycle boundary.

use crate::sdo_common;

use actuatord::bus::{Bus, BusEvent, InProcBus, InProcEndpoint};
use actuatord::canopen::od::{EntrySpec, ObjectDictionary, ObjectId, Value};
use actuatord::canopen::sdo::{encode_text, format_bytes, SdoError, SdoOutcome};
use actuatord::canopen::{AbortCode, NmtState, SdoClient, SdoServer};
use actuatord::device::objects::index;
use std::time::{Duration, Instant};

const NODE: u8 = 1;

/// Two ends of a bus: the tool's and the daemon's, served in turn on one thread.
struct Link {
    tool: InProcEndpoint,
    daemon: InProcEndpoint,
    server: SdoServer,
    client: SdoClient,
}

impl Link {
    fn new() -> Self {
        let mut eps = InProcBus::endpoints(2);
        let daemon = eps.pop().expect("two endpoints");
        let tool = eps.pop().expect("two endpoints");
        Self {
            tool,
            daemon,
            server: SdoServer::new(NODE),
            client: SdoClient::new(NODE),
        }
    }

    fn recv(ep: &mut InProcEndpoint) -> Option<actuatord::bus::Frame> {
        match ep.recv_until(Instant::now() + Duration::from_millis(200)) {
            Ok(Some(BusEvent::Frame(f))) => Some(f),
            _ => None,
        }
    }

    /// Run one transfer to its end; returns the outcome and how many requests went out.
    fn run(
        &mut self,
        first: actuatord::bus::Frame,
        od: &mut ObjectDictionary,
        state: NmtState,
    ) -> (SdoOutcome, usize) {
        self.tool.send(&first).expect("bus open");
        let mut requests = 1;
        for _ in 0..200 {
            let req = Self::recv(&mut self.daemon).expect("request arrives");
            if let Some(resp) = self.server.handle(&req, 0.0, od, state) {
                self.daemon.send(&resp).expect("bus open");
            } else {
                break;
            }
            let resp = Self::recv(&mut self.tool).expect("response arrives");
            match self.client.handle(&resp, 0.0) {
                Some(next) => {
                    self.tool.send(&next).expect("bus open");
                    requests += 1;
                }
                None => break,
            }
        }
        let outcome = self.client.outcome().cloned().expect("transfer finished");
        (outcome, requests)
    }

    fn read(&mut self, od: &mut ObjectDictionary, id: ObjectId) -> (SdoOutcome, usize) {
        let first = self.client.start_upload(id, 0.0);
        self.run(first, od, NmtState::PreOperational)
    }

    fn write(
        &mut self,
        od: &mut ObjectDictionary,
        id: ObjectId,
        bytes: &[u8],
        state: NmtState,
    ) -> (SdoOutcome, usize) {
        let first = self.client.start_download(id, bytes, 0.0);
        self.run(first, od, state)
    }
}

fn every_type() -> ObjectDictionary {
    let long = "a VISIBLE_STRING that needs several segments: 0123456789";
    ObjectDictionary::builder()
        .record(
            0x2100,
            "types",
            None,
            vec![
                EntrySpec::rw("boolean", false),
                EntrySpec::rw("integer8", 0i8),
                EntrySpec::rw("integer16", 0i16),
                EntrySpec::rw("integer32", 0i32),
                EntrySpec::rw("unsigned8", 0u8),
                EntrySpec::rw("unsigned16", 0u16),
                EntrySpec::rw("unsigned32", 0u32),
                EntrySpec::rw("real32", 0.0f32),
                EntrySpec::rw("real64", 0.0f64),
                EntrySpec::rw("visible_string", Value::string(long).expect("ascii")),
            ],
        )
        .build()
        .expect("valid")
}

#[test]
fn every_data_type_round_trips() {
    let mut od = every_type();
    let mut link = Link::new();
    let values = [
        "true",
        "-128",
        "-32768",
        "-2147483648",
        "255",
        "65535",
        "4294967295",
        "-0.125",
        "2231.0000001",
        "coil temperature compensated, north side",
    ];
    for (i, text) in values.iter().enumerate() {
        let id = ObjectId::new(0x2100, i as u8 + 1);
        let data_type = od.entry(od.handle(id).expect("entry")).data_type;
        let bytes = encode_text(Some(data_type), text).expect("parses");
        let (outcome, requests) = link.write(&mut od, id, &bytes, NmtState::Operational);
        assert_eq!(outcome, Ok(vec![]), "{id} {text}");
        let expected_requests = if bytes.len() <= 4 {
            1
        } else {
            1 + bytes.len().div_ceil(7)
        };
        assert_eq!(requests, expected_requests, "{id}: expedited up to 4 bytes");
        // Not visible before the cycle boundary...
        let (before, _) = link.read(&mut od, id);
        assert_ne!(format_bytes(Some(data_type), &before.expect("read")), *text);
        // ... and exactly the written value after it.
        assert_eq!(od.take_pending_writes().count(), 1);
        let (after, _) = link.read(&mut od, id);
        let after = after.expect("read");
        assert_eq!(after, bytes);
        assert_eq!(format_bytes(Some(data_type), &after), *text);
    }
}

#[test]
fn segmented_string_upload_from_the_default() {
    let mut od = every_type();
    let mut link = Link::new();
    let (outcome, requests) = link.read(&mut od, ObjectId::new(0x2100, 10));
    let text = String::from_utf8(outcome.expect("read")).expect("ascii");
    assert_eq!(
        text,
        "a VISIBLE_STRING that needs several segments: 0123456789"
    );
    assert_eq!(requests, 1 + text.len().div_ceil(7));
}

#[test]
fn daemon_objects_over_the_bus() {
    let (_, mut od) = sdo_common::solenoid_dictionary();
    let mut link = Link::new();
    let pre = NmtState::PreOperational;
    let op = NmtState::Operational;

    let name = ObjectId::new(index::DEVICE_NAME, 0);
    assert_eq!(link.read(&mut od, name).0, Ok(b"actuatord".to_vec()));
    let axis_name = ObjectId::new(index::axis(0, index::AXIS), 1);
    assert_eq!(link.read(&mut od, axis_name).0, Ok(b"solenoid".to_vec()));

    let q0 = ObjectId::new(index::axis(0, index::CONTROLLER), 1);
    let (q0_now, _) = link.read(&mut od, q0);
    assert_eq!(q0_now, Ok(2231.0f64.to_le_bytes().to_vec()));

    // Safety-relevant: refused while operational, accepted in pre-operational.
    let new_q0 = 2100.0f64.to_le_bytes();
    let (refused, _) = link.write(&mut od, q0, &new_q0, op);
    assert_eq!(refused.map_err(|e| e.code()), Err(AbortCode::DEVICE_STATE));
    assert_eq!(link.write(&mut od, q0, &new_q0, pre).0, Ok(vec![]));

    // Out of range: the setpoint must lie within the travel.
    let sp = ObjectId::new(index::axis(0, index::SETPOINT), 1);
    let (too_high, _) = link.write(&mut od, sp, &0.1f64.to_le_bytes(), op);
    assert_eq!(
        too_high,
        Err(SdoError::ServerAbort {
            id: sp,
            code: AbortCode::VALUE_TOO_HIGH
        })
    );
    assert_eq!(
        link.write(&mut od, sp, &0.012f64.to_le_bytes(), op).0,
        Ok(vec![])
    );

    // Read-only results and write-only commands.
    let fault_state = ObjectId::new(index::axis(0, index::FAULT), 1);
    let (ro, _) = link.write(&mut od, fault_state, &[0], pre);
    assert_eq!(ro.map_err(|e| e.code()), Err(AbortCode::WRITE_READ_ONLY));
    let reset = ObjectId::new(index::axis(0, index::FAULT), 5);
    let (wo, _) = link.read(&mut od, reset);
    assert_eq!(wo.map_err(|e| e.code()), Err(AbortCode::READ_WRITE_ONLY));
    let (missing, _) = link.read(&mut od, ObjectId::new(0x2345, 0));
    assert_eq!(
        missing.map_err(|e| e.code()),
        Err(AbortCode::OBJECT_DOES_NOT_EXIST)
    );

    // The cycle boundary hands the node both accepted writes at once, by axis and name.
    let writes: Vec<_> = od
        .take_pending_writes()
        .map(|w| (w.axis, w.name, w.value))
        .collect();
    assert_eq!(
        writes,
        vec![
            (Some(0), "q0_per_m", Value::Real64(2100.0)),
            (Some(0), "setpoint_position", Value::Real64(0.012)),
        ]
    );
    assert_eq!(link.read(&mut od, q0).0, Ok(new_q0.to_vec()));
}

#[test]
fn published_results_are_what_a_read_sees() {
    let (_, mut od) = sdo_common::solenoid_dictionary();
    let mut link = Link::new();
    let overruns = od
        .handle_by_name(None, "overruns")
        .expect("node-wide statistic");
    let band = od
        .handle_by_name(Some(0), "observer_x4_neg")
        .expect("learned");
    od.publish(overruns, 42u32).expect("type matches");
    od.publish(band, 0.25f64).expect("type matches");
    let id = od.entry(overruns).id;
    assert_eq!(link.read(&mut od, id).0, Ok(42u32.to_le_bytes().to_vec()));
    let id = od.entry(band).id;
    assert_eq!(link.read(&mut od, id).0, Ok(0.25f64.to_le_bytes().to_vec()));
}
