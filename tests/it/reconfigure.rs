//! One way to reconfigure: SDO parameter writes and SIGHUP reloads both go to the builder, which
//! reads, validates and builds on its own thread; the node only swaps in what it built. The
//! builder keeps the configuration in force, so a write after a reload builds on the reloaded
//! file and a refused file changes nothing.

use crate::common::paths::root;
use actuatord::bus::Frame;
use actuatord::canopen::od::ObjectId;
use actuatord::canopen::{NmtCommand, ObjectDictionary, SdoClient, Value};
use actuatord::daemon::config::Config;
use actuatord::daemon::node::CycleTiming;
use actuatord::daemon::reconfigure::{Builder, Built};
use actuatord::daemon::ControllerNode;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::Duration;

fn real(od: &ObjectDictionary, axis: Option<usize>, name: &str) -> f64 {
    let h = od.handle_by_name(axis, name).expect(name);
    match od.value(h) {
        Value::Real64(v) => v,
        other => panic!("{name}: {other:?}"),
    }
}

/// The controller node alone, cycle after cycle, as the cycle thread drives it (no actuator
/// answers: parameters are written with the axes stopped anyway).
struct Rig {
    node: ControllerNode,
    k: u64,
    events: Vec<String>,
}

impl Rig {
    fn cycle(&mut self, inbox: &[Frame]) -> Vec<Frame> {
        let t = self.k as f64 * self.node.period_s();
        let events = &mut self.events;
        for f in inbox {
            self.node
                .handle(f, t, &mut |r| events.push(format!("{r:?}")));
        }
        self.node.begin_cycle();
        let _sync = self.node.sync_frame();
        let mut out = Vec::new();
        self.node
            .finish_cycle(t, CycleTiming::default(), &mut |f| out.push(*f), &mut |r| {
                events.push(format!("{r:?}"))
            });
        self.k += 1;
        out
    }

    /// Write `value` to axis 0's `name` over SDO in pre-operational, frame by frame, and run
    /// the cycle whose boundary hands it on.
    fn sdo_write(&mut self, name: &str, value: f64) {
        let h = self
            .node
            .dictionary()
            .handle_by_name(Some(0), name)
            .expect(name);
        let id: ObjectId = self.node.dictionary().entry(h).id;
        let node_id = self.node.node_id();
        self.cycle(&[NmtCommand::EnterPreOperational.encode(node_id)]);
        let mut client = SdoClient::new(node_id);
        let mut request = Some(client.start_download(id, &value.to_le_bytes(), 0.0));
        while client.outcome().is_none() {
            let inbox: Vec<Frame> = request.take().into_iter().collect();
            for f in self.cycle(&inbox) {
                if f.id() == 0x580 + u32::from(node_id) {
                    request = client.handle(&f, 0.0);
                }
            }
        }
        assert!(
            matches!(client.outcome(), Some(Ok(_))),
            "{name}: {:?}",
            client.outcome()
        );
        self.cycle(&[]);
    }

    /// Run cycles until the builder's answer arrives and swap it in, as the cycle thread does;
    /// returns the events of the swap. The bound only keeps a broken builder from hanging the
    /// test.
    fn take_build(&mut self, built: &Receiver<Box<Built>>) -> Vec<String> {
        for _ in 0..5000 {
            if let Ok(b) = built.try_recv() {
                let mut events = Vec::new();
                let back = self
                    .node
                    .apply_built(b, 1.0, &mut |r| events.push(format!("{r:?}")));
                assert!(back.is_none(), "what was replaced goes back to the builder");
                return events;
            }
            self.cycle(&[]);
            std::thread::sleep(Duration::from_millis(1));
        }
        panic!("the builder never answered");
    }
}

#[test]
fn sdo_writes_and_reloads_are_built_off_the_cycle_thread_on_the_configuration_in_force() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("solenoid.toml");
    let text = std::fs::read_to_string(root().join("config/solenoid.toml")).expect("config");
    std::fs::write(&file, &text).expect("write config");
    let config = Config::load(&file).expect("valid config");
    let mut rig = Rig {
        node: ControllerNode::new(&config).expect("node"),
        k: 0,
        events: Vec::new(),
    };

    // Which thread reads the file, each time it is read.
    let readers = Arc::new(Mutex::new(Vec::<Option<String>>::new()));
    let load = {
        let (readers, file) = (readers.clone(), file.clone());
        Box::new(move || {
            let name = std::thread::current().name().map(str::to_string);
            readers.lock().expect("not poisoned").push(name);
            Ok(Config::load(&file)?)
        })
    };
    let (builder, link) =
        Builder::spawn(config.clone(), file.display().to_string(), load).expect("spawn");
    rig.node.attach_builder(link.input);
    for _ in 0..20 {
        rig.cycle(&[]);
    }

    // An SDO write: handed off at the boundary; until the build is swapped in, a read tells
    // what the node runs with.
    let q0 = |rig: &Rig| real(rig.node.dictionary(), Some(0), "q0_per_m");
    let following = |rig: &Rig| real(rig.node.dictionary(), Some(0), "following_error_m");
    assert_eq!(q0(&rig), 2231.0);
    rig.sdo_write("q0_per_m", 2300.0);
    assert_eq!(q0(&rig), 2231.0, "not in force before the swap");
    let events = rig.take_build(&link.built);
    assert!(
        events.iter().any(|e| e.contains("ParametersApplied")),
        "{events:?}"
    );
    assert_eq!(q0(&rig), 2300.0);
    assert_eq!(rig.node.axes().len(), 1);

    // A reload: the file is the truth again (q0 as written there), with its new limit.
    std::fs::write(
        &file,
        text.replace("following_error_m = 0.002", "following_error_m = 0.004"),
    )
    .expect("rewrite config");
    assert!(builder.reload());
    let events = rig.take_build(&link.built);
    assert!(events.iter().any(|e| e.contains("Reloaded")), "{events:?}");
    assert_eq!(following(&rig), 0.004);
    assert_eq!(q0(&rig), 2231.0);

    // An invalid file is refused by the builder; the next write builds on the reloaded file.
    std::fs::write(&file, text.replace("period_s = 0.0025", "period_s = -1.0")).expect("rewrite");
    assert!(builder.reload());
    rig.sdo_write("q0_per_m", 2500.0);
    let events = rig.take_build(&link.built);
    assert!(
        events.iter().any(|e| e.contains("ParametersApplied")),
        "{events:?}"
    );
    assert_eq!(q0(&rig), 2500.0);
    assert_eq!(
        following(&rig),
        0.004,
        "built on the configuration in force"
    );
    assert_eq!(rig.node.period_s(), 0.0025);

    // A write the configuration refuses comes back refused, and changes nothing.
    rig.sdo_write("safe_command", -5.0);
    let events = rig.take_build(&link.built);
    assert!(
        events
            .iter()
            .any(|e| e.contains("ParametersRefused") && e.contains("safe_command")),
        "{events:?}"
    );
    assert_eq!(q0(&rig), 2500.0);
    assert_eq!(real(rig.node.dictionary(), Some(0), "safe_command"), 0.0);

    // The file was read twice, both times on the builder's thread.
    let readers = readers.lock().expect("not poisoned").clone();
    assert_eq!(
        readers,
        vec![Some("reconfigure".to_string()); 2],
        "the file is read by the builder"
    );
    drop(rig);
    builder.join();
}
