//! Arbitrary frames and frame sequences into the controller node: no panic, every cycle still
//! produces its SYNC and its commands, and the counters account for what was not understood.

use actuatord::bus::Frame;
use actuatord::daemon::node::CycleTiming;
use actuatord::daemon::{Config, ControllerNode};
use proptest::prelude::*;
use std::path::Path;

fn node() -> ControllerNode {
    let config = Config::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/solenoid.toml"
    )))
    .expect("shipped config");
    ControllerNode::new(&config).expect("node")
}

fn frame() -> impl Strategy<Value = Frame> {
    // Ids near the ones the protocol uses, so the decoders see most of the garbage.
    let id = prop_oneof![
        Just(0x000u32),
        Just(0x080),
        Just(0x190),
        Just(0x201),
        Just(0x301),
        Just(0x601),
        Just(0x710),
        0u32..0x800,
    ];
    (id, proptest::collection::vec(any::<u8>(), 0..=8))
        .prop_map(|(id, data)| Frame::new(id, &data).expect("valid frame"))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_frame_sequences_never_break_the_cycle(
        sequence in proptest::collection::vec(proptest::collection::vec(frame(), 0..12), 1..40)
    ) {
        let mut n = node();
        n.boot(&mut |_| {}, &mut |_| {});
        for (k, frames) in sequence.iter().enumerate() {
            let t = k as f64 * 0.0025;
            n.begin_cycle();
            let sync = n.sync_frame();
            prop_assert_eq!(sync.id(), 0x080);
            for f in frames {
                n.handle(f, t, &mut |_| {});
            }
            let mut sent = vec![];
            n.finish_cycle(t, CycleTiming::default(), &mut |f| sent.push(*f), &mut |_| {});
            // While operational, the axis' command goes out every cycle whatever came in.
            if n.state() == actuatord::canopen::NmtState::Operational {
                prop_assert!(sent.iter().any(|f| f.id() == 0x210), "no command in cycle {}", k);
            }
        }
        let c = n.counters();
        prop_assert_eq!(c.cycles, sequence.len() as u64);
    }
}
