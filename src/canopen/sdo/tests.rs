//! Frame-level tests of the server (every transfer type, every abort) and of the client.

use super::*;
use crate::canopen::nmt::NmtState;
use crate::canopen::od::{EntrySpec, ObjectDictionary, ObjectId, Value};

const NODE: u8 = 0x05;
const PRE: NmtState = NmtState::PreOperational;
const OP: NmtState = NmtState::Operational;

fn od() -> ObjectDictionary {
    ObjectDictionary::builder()
        .var(0x1000, EntrySpec::ro("device_type", 0x0001_0192u32))
        .var(
            0x1008,
            EntrySpec::ro(
                "manufacturer_device_name",
                Value::string("actuatord").expect("ascii"),
            ),
        )
        .var(
            0x1017,
            EntrySpec::rw("producer_heartbeat_time", 100u16)
                .range(Some(Value::Unsigned16(1)), None),
        )
        .record(
            0x2001,
            "axis0_controller",
            Some(0),
            vec![
                EntrySpec::rw_preop("q0_per_m", 2231.0f64).between(-1e12, 1e12),
                EntrySpec::rw("level", 5i8)
                    .range(Some(Value::Integer8(-10)), Some(Value::Integer8(10))),
                EntrySpec::wo("fault_reset", false),
                EntrySpec::rw("label", Value::string("").expect("ascii")),
            ],
        )
        .build()
        .expect("valid")
}

struct Rig {
    server: SdoServer,
    od: ObjectDictionary,
    t: f64,
}

impl Rig {
    fn new() -> Self {
        Self {
            server: SdoServer::new(NODE),
            od: od(),
            t: 0.0,
        }
    }

    /// Send one request, expect exactly one response, return its 8 bytes.
    fn ask(&mut self, data: [u8; 8], state: NmtState) -> [u8; 8] {
        let req = Frame::new(0x600 + u32::from(NODE), &data).expect("frame");
        self.t += 0.001;
        let resp = self
            .server
            .handle(&req, self.t, &mut self.od, state)
            .expect("a response");
        assert_eq!(resp.id(), 0x580 + u32::from(NODE));
        let mut out = [0u8; 8];
        out.copy_from_slice(resp.data());
        out
    }
}

fn abort_code(resp: [u8; 8]) -> Option<u32> {
    (resp[0] == 0x80).then(|| u32::from_le_bytes([resp[4], resp[5], resp[6], resp[7]]))
}

fn init(cmd: u8, index: u16, sub: u8, data: [u8; 4]) -> [u8; 8] {
    let [lo, hi] = index.to_le_bytes();
    [cmd, lo, hi, sub, data[0], data[1], data[2], data[3]]
}

#[test]
fn expedited_upload_carries_size_and_data() {
    let mut rig = Rig::new();
    let r = rig.ask(init(0x40, 0x1000, 0, [0; 4]), OP);
    assert_eq!(r, [0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x01, 0x00]);
    let r = rig.ask(init(0x40, 0x1017, 0, [0; 4]), OP);
    // 2 bytes: n = 2 unused bytes -> 0x4B.
    assert_eq!(r, [0x4B, 0x17, 0x10, 0x00, 100, 0, 0, 0]);
    let r = rig.ask(init(0x40, 0x2001, 0, [0; 4]), OP);
    assert_eq!(r[0], 0x4F, "1 byte: highest subindex");
    assert_eq!(r[4], 4);
}

#[test]
fn segmented_upload_toggles_and_flags_the_last_segment() {
    let mut rig = Rig::new();
    let r = rig.ask(init(0x40, 0x1008, 0, [0; 4]), OP);
    assert_eq!(r, [0x41, 0x08, 0x10, 0x00, 9, 0, 0, 0]);
    let r = rig.ask([0x60, 0, 0, 0, 0, 0, 0, 0], OP);
    assert_eq!(r, [0x00, b'a', b'c', b't', b'u', b'a', b't', b'o']);
    let r = rig.ask([0x70, 0, 0, 0, 0, 0, 0, 0], OP);
    // 2 bytes, n = 5, c = 1, t = 1: 0x10 | 5 << 1 | 1 = 0x1B.
    assert_eq!(r, [0x1B, b'r', b'd', 0, 0, 0, 0, 0]);
    assert!(!rig.server.is_busy());
}

#[test]
fn eight_byte_values_go_segmented_both_ways() {
    let mut rig = Rig::new();
    let r = rig.ask(init(0x40, 0x2001, 1, [0; 4]), PRE);
    assert_eq!(r, [0x41, 0x01, 0x20, 0x01, 8, 0, 0, 0]);
    let r1 = rig.ask([0x60, 0, 0, 0, 0, 0, 0, 0], PRE);
    let r2 = rig.ask([0x70, 0, 0, 0, 0, 0, 0, 0], PRE);
    assert_eq!(r1[0], 0x00);
    assert_eq!(r2[0], 0x10 | (6 << 1) | 1);
    let mut bytes = [0u8; 8];
    bytes[..7].copy_from_slice(&r1[1..]);
    bytes[7] = r2[1];
    assert_eq!(f64::from_le_bytes(bytes), 2231.0);

    let v = 1234.5f64.to_le_bytes();
    let r = rig.ask(init(0x21, 0x2001, 1, [8, 0, 0, 0]), PRE);
    assert_eq!(r, [0x60, 0x01, 0x20, 0x01, 0, 0, 0, 0]);
    let r = rig.ask([0x00, v[0], v[1], v[2], v[3], v[4], v[5], v[6]], PRE);
    assert_eq!(r[0], 0x20);
    assert!(
        rig.od.pending_writes().is_empty(),
        "nothing staged before the last segment"
    );
    let r = rig.ask([0x10 | (6 << 1) | 1, v[7], 0, 0, 0, 0, 0, 0], PRE);
    assert_eq!(r[0], 0x30);
    let w: Vec<_> = rig.od.take_pending_writes().collect();
    assert_eq!(w.len(), 1);
    assert_eq!(w[0].value, Value::Real64(1234.5));
}

#[test]
fn expedited_download_with_and_without_size() {
    let mut rig = Rig::new();
    // 2 bytes, size indicated: 0x2B.
    let r = rig.ask(init(0x2B, 0x1017, 0, [200, 0, 0xAA, 0xAA]), OP);
    assert_eq!(r, [0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0]);
    // Size not indicated (0x22): the type's size is taken.
    let r = rig.ask(init(0x22, 0x2001, 2, [0xFD, 0xAA, 0xAA, 0xAA]), OP);
    assert_eq!(r[0], 0x60);
    let w: Vec<_> = rig.od.take_pending_writes().map(|w| w.value).collect();
    assert_eq!(w, vec![Value::Unsigned16(200), Value::Integer8(-3)]);
}

#[test]
fn segmented_download_of_a_string_without_size() {
    let mut rig = Rig::new();
    let r = rig.ask(init(0x20, 0x2001, 4, [0; 4]), OP);
    assert_eq!(r[0], 0x60);
    rig.ask([0x00, b'c', b'o', b'i', b'l', b' ', b'n', b'o'], OP);
    // 4 bytes, n = 3, c = 1.
    let r = rig.ask([0x10 | (3 << 1) | 1, b'r', b't', b'h', b'!', 0, 0, 0], OP);
    assert_eq!(r[0], 0x30);
    let w: Vec<_> = rig.od.take_pending_writes().collect();
    assert_eq!(w[0].value, Value::string("coil north!").expect("ascii"));
}

#[test]
fn empty_string_uploads_as_one_empty_segment() {
    let mut rig = Rig::new();
    let r = rig.ask(init(0x40, 0x2001, 4, [0; 4]), OP);
    assert_eq!(r, [0x41, 0x01, 0x20, 0x04, 0, 0, 0, 0]);
    let r = rig.ask([0x60, 0, 0, 0, 0, 0, 0, 0], OP);
    assert_eq!(r[0], (7 << 1) | 1);
}

#[test]
fn every_abort_code() {
    let cases: Vec<([u8; 8], NmtState, u32)> = vec![
        (init(0x40, 0x3000, 0, [0; 4]), OP, 0x0602_0000),
        (init(0x40, 0x2001, 9, [0; 4]), OP, 0x0609_0011),
        (init(0x40, 0x2001, 3, [0; 4]), OP, 0x0601_0001),
        (init(0x2F, 0x1000, 0, [1, 0, 0, 0]), PRE, 0x0601_0002),
        (init(0x2F, 0x1017, 0, [1, 0, 0, 0]), PRE, 0x0607_0010),
        (init(0x21, 0x2001, 1, [4, 0, 0, 0]), PRE, 0x0607_0010),
        (init(0x21, 0x2001, 4, [1, 1, 0, 0]), PRE, 0x0607_0010),
        (init(0x2F, 0x2001, 2, [11, 0, 0, 0]), OP, 0x0609_0031),
        (init(0x2F, 0x2001, 2, [0xF5, 0, 0, 0]), OP, 0x0609_0032),
        (init(0x2B, 0x1017, 0, [0, 0, 0, 0]), OP, 0x0609_0032),
        (init(0x2F, 0x2001, 3, [2, 0, 0, 0]), OP, 0x0609_0030),
        (init(0x21, 0x2001, 1, [8, 0, 0, 0]), OP, 0x0800_0022),
        (init(0xA0, 0x2001, 1, [0; 4]), OP, 0x0504_0001),
        (init(0xC0, 0x2001, 1, [0; 4]), OP, 0x0504_0001),
        (init(0xE0, 0x2001, 1, [0; 4]), OP, 0x0504_0001),
        ([0x00, 0, 0, 0, 0, 0, 0, 0], OP, 0x0504_0001),
        ([0x60, 0, 0, 0, 0, 0, 0, 0], OP, 0x0504_0001),
    ];
    for (req, state, code) in cases {
        let mut rig = Rig::new();
        let r = rig.ask(req, state);
        assert_eq!(abort_code(r), Some(code), "{req:02X?} -> {r:02X?}");
        assert_eq!(&r[1..4], &req[1..4], "the abort names the object");
        assert!(rig.od.pending_writes().is_empty());
        assert!(!rig.server.is_busy());
    }
}

#[test]
fn toggle_errors_abort_uploads_and_downloads() {
    let mut rig = Rig::new();
    rig.ask(init(0x40, 0x1008, 0, [0; 4]), OP);
    let r = rig.ask([0x70, 0, 0, 0, 0, 0, 0, 0], OP);
    assert_eq!(abort_code(r), Some(0x0503_0000));
    assert_eq!(&r[1..4], &[0x08, 0x10, 0x00]);
    assert!(!rig.server.is_busy());

    rig.ask(init(0x21, 0x2001, 1, [8, 0, 0, 0]), PRE);
    rig.ask([0x00, 1, 2, 3, 4, 5, 6, 7], PRE);
    let r = rig.ask([(6 << 1) | 1, 8, 0, 0, 0, 0, 0, 0], PRE);
    assert_eq!(abort_code(r), Some(0x0503_0000));
    assert!(rig.od.pending_writes().is_empty(), "never half-applied");
}

#[test]
fn too_long_or_short_segmented_downloads_are_refused_whole() {
    let mut rig = Rig::new();
    // Announced 8, sent 14.
    rig.ask(init(0x21, 0x2001, 1, [8, 0, 0, 0]), PRE);
    rig.ask([0x00, 1, 2, 3, 4, 5, 6, 7], PRE);
    let r = rig.ask([0x10, 1, 2, 3, 4, 5, 6, 7], PRE);
    assert_eq!(abort_code(r), Some(0x0607_0010));
    // Announced 8, sent 7.
    rig.ask(init(0x21, 0x2001, 1, [8, 0, 0, 0]), PRE);
    let r = rig.ask([0x01, 1, 2, 3, 4, 5, 6, 7], PRE);
    assert_eq!(abort_code(r), Some(0x0607_0010));
    // No size, more than the buffer: aborted as soon as it overflows.
    rig.ask(init(0x20, 0x2001, 4, [0; 4]), OP);
    let mut toggle = 0;
    let mut last = [0u8; 8];
    for _ in 0..=(SEGMENT_BUFFER / 7) {
        last = rig.ask([toggle, b'a', b'a', b'a', b'a', b'a', b'a', b'a'], OP);
        if last[0] == 0x80 {
            break;
        }
        toggle ^= 0x10;
    }
    assert_eq!(abort_code(last), Some(0x0607_0010));
    // A string longer than the dictionary stores, but within the buffer.
    rig.ask(init(0x21, 0x2001, 4, [70, 0, 0, 0]), OP);
    let mut toggle = 0;
    for i in 0..10 {
        let c = u8::from(i == 9);
        last = rig.ask([toggle | c, b'a', b'a', b'a', b'a', b'a', b'a', b'a'], OP);
        toggle ^= 0x10;
    }
    assert_eq!(abort_code(last), Some(0x0607_0010));
    assert!(rig.od.pending_writes().is_empty());
}

#[test]
fn a_stalled_transfer_times_out_once() {
    let mut rig = Rig::new();
    rig.ask(init(0x40, 0x1008, 0, [0; 4]), OP);
    assert!(rig.server.is_busy());
    assert_eq!(rig.server.poll(rig.t + 0.5), None);
    let f = rig
        .server
        .poll(rig.t + DEFAULT_TIMEOUT_S + 0.1)
        .expect("timeout abort");
    let mut d = [0u8; 8];
    d.copy_from_slice(f.data());
    assert_eq!(abort_code(d), Some(0x0504_0000));
    assert_eq!(&d[1..4], &[0x08, 0x10, 0x00]);
    assert_eq!(rig.server.poll(rig.t + 10.0), None);
    assert!(!rig.server.is_busy());
}

#[test]
fn a_late_segment_gets_the_timeout_abort_even_without_poll() {
    let mut rig = Rig::new();
    rig.ask(init(0x21, 0x2001, 1, [8, 0, 0, 0]), PRE);
    rig.t += 5.0;
    let r = rig.ask([0x00, 1, 2, 3, 4, 5, 6, 7], PRE);
    assert_eq!(abort_code(r), Some(0x0504_0000));
    // And a new initiate after a stall simply starts over.
    rig.ask(init(0x40, 0x1008, 0, [0; 4]), OP);
    rig.t += 5.0;
    let r = rig.ask(init(0x40, 0x1000, 0, [0; 4]), OP);
    assert_eq!(r[0], 0x43);
}

#[test]
fn client_abort_ends_a_transfer_silently() {
    let mut rig = Rig::new();
    rig.ask(init(0x40, 0x1008, 0, [0; 4]), OP);
    let abort = Frame::new(0x605, &init(0x80, 0x1008, 0, [0, 0, 4, 5])).expect("frame");
    assert_eq!(rig.server.handle(&abort, 0.1, &mut rig.od, OP), None);
    assert!(!rig.server.is_busy());
}

#[test]
fn other_ids_states_and_short_frames() {
    let mut rig = Rig::new();
    let req = init(0x40, 0x1000, 0, [0; 4]);
    for (id, state) in [
        (0x606, OP),
        (0x585, OP),
        (0x605, NmtState::Stopped),
        (0x605, NmtState::Initialising),
    ] {
        let f = Frame::new(id, &req).expect("frame");
        assert_eq!(
            rig.server.handle(&f, 0.0, &mut rig.od, state),
            None,
            "{id:X} {state:?}"
        );
    }
    let ext = Frame::new_extended(0x605, &req).expect("frame");
    assert_eq!(rig.server.handle(&ext, 0.0, &mut rig.od, OP), None);
    for len in [0, 3, 7] {
        let f = Frame::new(0x605, &req[..len]).expect("frame");
        let r = rig.server.handle(&f, 0.0, &mut rig.od, OP).expect("abort");
        assert_eq!(r.data()[0], 0x80);
        assert_eq!(&r.data()[4..8], &0x0800_0000u32.to_le_bytes());
    }
}

#[test]
fn client_reads_and_writes_against_the_server() {
    fn run(client: &mut SdoClient, first: Frame, rig: &mut Rig, state: NmtState) {
        let mut req = Some(first);
        for _ in 0..100 {
            let Some(r) = req.take() else { break };
            let Some(resp) = rig.server.handle(&r, 0.0, &mut rig.od, state) else {
                break;
            };
            req = client.handle(&resp, 0.0);
        }
    }
    let mut rig = Rig::new();
    let mut c = SdoClient::new(NODE);
    let f = c.start_upload(ObjectId::new(0x1008, 0), 0.0);
    run(&mut c, f, &mut rig, OP);
    assert_eq!(c.outcome(), Some(&Ok(b"actuatord".to_vec())));

    let f = c.start_download(ObjectId::new(0x2001, 1), &7.25f64.to_le_bytes(), 0.0);
    run(&mut c, f, &mut rig, PRE);
    assert_eq!(c.outcome(), Some(&Ok(vec![])));

    let f = c.start_download(ObjectId::new(0x2001, 1), &7.25f64.to_le_bytes(), 0.0);
    run(&mut c, f, &mut rig, OP);
    assert_eq!(
        c.outcome().and_then(|o| o.clone().err()).map(|e| e.code()),
        Some(AbortCode::DEVICE_STATE)
    );

    let f = c.start_download(ObjectId::new(0x2001, 4), b"", 0.0);
    run(&mut c, f, &mut rig, OP);
    assert_eq!(c.outcome(), Some(&Ok(vec![])));
    let staged: Vec<_> = rig.od.take_pending_writes().map(|w| w.value).collect();
    assert_eq!(
        staged,
        vec![Value::Real64(7.25), Value::string("").expect("ascii")]
    );
}

#[test]
fn client_times_out_and_catches_a_toggle_error() {
    let mut c = SdoClient::new(NODE).with_timeout(0.5);
    let id = ObjectId::new(0x1008, 0);
    c.start_upload(id, 0.0);
    assert_eq!(c.poll(0.4), None);
    let abort = c.poll(0.6).expect("abort");
    assert_eq!(abort.id(), 0x605);
    assert_eq!(&abort.data()[4..8], &0x0504_0000u32.to_le_bytes());
    assert_eq!(
        c.outcome().and_then(|o| o.clone().err()).map(|e| e.code()),
        Some(AbortCode::TIMEOUT)
    );

    c.start_upload(id, 0.0);
    let resp = Frame::new(0x585, &[0x41, 0x08, 0x10, 0x00, 9, 0, 0, 0]).expect("frame");
    assert!(c.handle(&resp, 0.0).is_some());
    let bad = Frame::new(0x585, &[0x10, 1, 2, 3, 4, 5, 6, 7]).expect("frame");
    let abort = c.handle(&bad, 0.0).expect("abort");
    assert_eq!(&abort.data()[4..8], &0x0503_0000u32.to_le_bytes());
    assert!(c.is_done());
    // Frames after the end, or from another node, are ignored.
    assert_eq!(c.handle(&bad, 0.0), None);
    let other = Frame::new(0x586, &[0x41, 0, 0, 0, 0, 0, 0, 0]).expect("frame");
    assert_eq!(c.handle(&other, 0.0), None);
}

#[test]
fn abort_codes_print_with_their_meaning() {
    assert_eq!(
        AbortCode::VALUE_TOO_HIGH.to_string(),
        "0x06090031 (value of parameter written too high)"
    );
    assert_eq!(AbortCode(0x1234_5678).to_string(), "0x12345678");
}

#[test]
fn tool_helpers_parse_and_format_by_type() {
    use crate::canopen::od::DataType;
    assert_eq!(
        format_bytes(Some(DataType::Unsigned16), &[0xE8, 0x03]),
        "1000"
    );
    assert_eq!(format_bytes(None, &[0xE8, 0x03]), "e8 03");
    assert_eq!(format_bytes(Some(DataType::Unsigned16), &[0xE8]), "e8");
    assert_eq!(
        encode_text(Some(DataType::Real32), "1.5"),
        Ok(1.5f32.to_le_bytes().to_vec())
    );
    assert_eq!(encode_text(None, "01 02"), Ok(vec![1, 2]));
    assert!(encode_text(None, "1.5").is_err());
    assert!(encode_text(Some(DataType::Unsigned8), "300").is_err());
}
