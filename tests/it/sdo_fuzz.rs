//! Property tests of the SDO server with arbitrary frames and frame sequences: it never panics,
//! answers every frame with at most one frame (and only on its own COB-ID), stages only whole,
//! checked values, and never keeps a transfer past the timeout.

use crate::sdo_common;

use actuatord::bus::Frame;
use actuatord::canopen::od::ObjectId;
use actuatord::canopen::sdo::{SdoClient, DEFAULT_TIMEOUT_S};
use actuatord::canopen::{NmtState, SdoServer};
use proptest::prelude::*;

const NODE: u8 = 1;

/// A request frame: mostly on the server's COB-ID, with command bytes and multiplexers that
/// hit real objects often enough to reach deep into the state machine.
fn request() -> impl Strategy<Value = Frame> {
    let command = prop_oneof![
        any::<u8>(),
        prop::sample::select(vec![
            0x00u8, 0x01, 0x10, 0x11, 0x0D, 0x1D, 0x20, 0x21, 0x22, 0x23, 0x2B, 0x2F, 0x40, 0x60,
            0x70, 0x80, 0xA0, 0xC0, 0xE0,
        ]),
    ];
    let index = prop_oneof![
        any::<u16>(),
        prop::sample::select(vec![
            0x1000u16, 0x1001, 0x1008, 0x100A, 0x1016, 0x1017, 0x1018, 0x1200, 0x2000, 0x2001,
            0x2002, 0x2003, 0x2004, 0x2005, 0x2010, 0x2F00,
        ]),
    ];
    let sub = prop_oneof![any::<u8>(), 0u8..16];
    let id = prop_oneof![
        8 => Just(0x600 + u32::from(NODE)),
        1 => 0u32..0x800,
    ];
    let len = prop_oneof![8 => Just(8usize), 1 => 0usize..=8];
    (id, command, index, sub, any::<[u8; 4]>(), len).prop_map(|(id, c, i, s, d, len)| {
        let [lo, hi] = i.to_le_bytes();
        let bytes = [c, lo, hi, s, d[0], d[1], d[2], d[3]];
        Frame::new(id, &bytes[..len]).unwrap_or_else(|e| unreachable!("{e}"))
    })
}

fn state() -> impl Strategy<Value = NmtState> {
    prop::sample::select(vec![
        NmtState::PreOperational,
        NmtState::Operational,
        NmtState::Stopped,
        NmtState::Initialising,
    ])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_sequences_never_break_the_server(
        steps in prop::collection::vec((request(), state(), 0.0f64..0.6), 1..120),
    ) {
        let (_, mut od) = sdo_common::solenoid_dictionary();
        let defaults: Vec<_> = od.entries().iter().map(|e| e.default).collect();
        let mut server = SdoServer::new(NODE);
        let mut now = 0.0;
        for (frame, state, dt) in steps {
            now += dt;
            let ours = frame.id() == 0x600 + u32::from(NODE) && !frame.is_extended();
            let served = matches!(state, NmtState::PreOperational | NmtState::Operational);
            let reply = server.handle(&frame, now, &mut od, state);
            if let Some(r) = reply {
                prop_assert!(ours && served, "answered {frame} in {state:?}");
                prop_assert_eq!(r.id(), 0x580 + u32::from(NODE));
                prop_assert_eq!(r.len(), 8);
            }
            if !(ours && served) {
                prop_assert!(reply.is_none());
            }
            // Whatever is staged passed the checks: within bounds, of the entry's type.
            for w in od.pending_writes() {
                let e = od.entry(w.handle);
                prop_assert!(e.access.writable());
                prop_assert_eq!(w.value.data_type(), e.data_type);
                if let (Some(v), Some(min)) = (w.value.as_f64(), e.min.and_then(|m| m.as_f64())) {
                    prop_assert!(v >= min, "{} below min", e.name);
                }
                if let (Some(v), Some(max)) = (w.value.as_f64(), e.max.and_then(|m| m.as_f64())) {
                    prop_assert!(v <= max, "{} above max", e.name);
                }
                if let Some(v) = w.value.as_f64() {
                    prop_assert!(!v.is_nan());
                }
            }
            // Nothing reaches the readable values before the cycle boundary.
            for (i, e) in od.entries().iter().enumerate() {
                let h = od.handle(e.id).unwrap_or_else(|| unreachable!());
                prop_assert_eq!(od.value(h), defaults[i]);
            }
        }
        // No transfer outlives its timeout: one poll past it ends it, once.
        let late = now + DEFAULT_TIMEOUT_S + 0.001;
        let _ = server.poll(late);
        prop_assert!(!server.is_busy());
        prop_assert!(server.poll(late + 10.0).is_none());
    }

    #[test]
    fn a_client_abort_or_a_new_initiate_always_frees_the_server(
        steps in prop::collection::vec(request(), 0..40),
    ) {
        let (_, mut od) = sdo_common::solenoid_dictionary();
        let mut server = SdoServer::new(NODE);
        for f in &steps {
            let _ = server.handle(f, 0.0, &mut od, NmtState::PreOperational);
        }
        let abort = Frame::new(0x601, &[0x80, 0, 0x10, 0, 0, 0, 0, 0]).unwrap_or_else(|e| unreachable!("{e}"));
        prop_assert!(server.handle(&abort, 0.0, &mut od, NmtState::PreOperational).is_none());
        prop_assert!(!server.is_busy());
        // And a proper client still gets a correct answer afterwards.
        let mut client = SdoClient::new(NODE);
        let mut req = Some(client.start_upload(ObjectId::new(0x1008, 0), 0.0));
        while let Some(r) = req.take() {
            let resp = server.handle(&r, 0.0, &mut od, NmtState::PreOperational);
            prop_assert!(resp.is_some());
            req = resp.and_then(|resp| client.handle(&resp, 0.0));
        }
        prop_assert_eq!(client.outcome().cloned(), Some(Ok(b"actuatord".to_vec())));
    }

    #[test]
    fn arbitrary_responses_never_break_the_client(
        frames in prop::collection::vec((0u32..0x800, any::<[u8; 8]>(), 0usize..=8), 0..60),
        upload in any::<bool>(),
        data in prop::collection::vec(any::<u8>(), 0..40),
    ) {
        let mut client = SdoClient::new(NODE).with_timeout(1.0);
        let id = ObjectId::new(0x2001, 1);
        if upload {
            client.start_upload(id, 0.0);
        } else {
            client.start_download(id, &data, 0.0);
        }
        for (i, (cob, bytes, len)) in frames.iter().enumerate() {
            let f = Frame::new(*cob, &bytes[..*len]).unwrap_or_else(|e| unreachable!("{e}"));
            if let Some(out) = client.handle(&f, i as f64 * 0.01) {
                prop_assert_eq!(out.id(), 0x600 + u32::from(NODE));
                prop_assert_eq!(out.len(), 8);
            }
        }
        let _ = client.poll(100.0);
        prop_assert!(client.is_done());
    }
}
