//! The controller node and a simulated solenoid node in lock-step, frame by frame, without
//! threads or clocks: what the daemon does with what it hears, deterministically.

use actuatord::bus::Frame;
use actuatord::canopen::NmtCommand;
use actuatord::daemon::node::CycleTiming;
use actuatord::daemon::record::{CycleRecord, Record};
use actuatord::daemon::{Config, ControllerNode};
use actuatord::device::{
    messages, Emcy, FaultResetPdo, FaultStatePdo, LoopStatusPdo, SensorPdo, SetpointPdo,
};
use actuatord::simnode::SimNode;
use actuatord::supervise::{FaultKind, FaultState};
use std::path::Path;

const PERIOD: f64 = 0.0025;
/// How close the reference solenoid holds a set-point: its guide sticks (breakaway 0.83 N over
/// Coulomb 0.55 N, the paper's Fig. 17), so steps end at a stick-slip offset, with the adaptive
/// compensation inside the paper's 25-50 µm.
const HELD_M: f64 = 50e-6;

struct Rig {
    controller: ControllerNode,
    sim: SimNode,
    k: u64,
    /// Frames the controller sent, with the cycle they were sent in.
    sent: Vec<(u64, Frame)>,
    records: Vec<CycleRecord>,
}

impl Rig {
    fn new(faults: &[&str]) -> Self {
        let config = Config::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/solenoid.toml"
        )))
        .expect("shipped config");
        let plant = actuatord::physics::load_plant(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/plants/solenoid.toml"
        )))
        .expect("shipped plant");
        let faults = faults.iter().map(|f| f.parse().expect("fault")).collect();
        let mut rig = Rig {
            controller: ControllerNode::new(&config).expect("controller"),
            sim: SimNode::new(16, plant, PERIOD, faults),
            k: 0,
            sent: vec![],
            records: vec![],
        };
        let mut to_sim = vec![];
        rig.sim.boot(&mut |_| {});
        rig.controller.boot(&mut |f| to_sim.push(*f), &mut |_| {});
        rig.deliver_to_sim(&to_sim);
        rig
    }

    fn deliver_to_sim(&mut self, frames: &[Frame]) -> Vec<Frame> {
        let mut answers = vec![];
        for f in frames {
            self.sim.handle(f, &mut |a| answers.push(*a), &mut |_| {});
        }
        answers
    }

    /// Inject a frame from a third node (automation, cansend) into the controller.
    fn inject(&mut self, frame: Frame) {
        let t = self.k as f64 * PERIOD;
        self.controller.handle(&frame, t, &mut |_| {});
    }

    fn cycle(&mut self) {
        self.cycle_with(&[], false);
    }

    /// One cycle; `early` frames arrive before the SYNC; `hold_answers` delays the sensor
    /// answer past the deadline and returns it, as a slow bus would.
    fn cycle_with(&mut self, early: &[Frame], hold_answers: bool) -> Vec<Frame> {
        let t = self.k as f64 * PERIOD;
        for f in early {
            self.controller.handle(f, t, &mut |_| {});
        }
        self.controller.begin_cycle();
        let sync = self.controller.sync_frame();
        let answers = self.deliver_to_sim(&[sync]);
        if !hold_answers {
            // As the cycle does: stop listening once every axis has its sensor frame.
            for a in &answers {
                if self.controller.all_sensors_in() {
                    break;
                }
                self.controller.handle(a, t, &mut |_| {});
            }
        }
        if self.k % 40 == 0 {
            let hb = self.sim.heartbeat();
            self.controller.handle(&hb, t, &mut |_| {});
        }
        let mut out = vec![];
        let mut recs = vec![];
        self.controller
            .finish_cycle(t, CycleTiming::default(), &mut |f| out.push(*f), &mut |r| {
                if let Record::Cycle(c) = r {
                    recs.push(c)
                }
            });
        self.deliver_to_sim(&out);
        self.sent.extend(out.into_iter().map(|f| (self.k, f)));
        self.records.extend(recs);
        self.k += 1;
        if hold_answers {
            answers
        } else {
            vec![]
        }
    }

    fn run_until(&mut self, t_s: f64) {
        while (self.k as f64) * PERIOD < t_s - 1e-9 {
            self.cycle();
        }
    }

    fn position(&self) -> f64 {
        self.records.last().map_or(f64::NAN, |r| r.position)
    }

    fn emcys(&self) -> Vec<(u64, Emcy)> {
        self.sent
            .iter()
            .filter(|(_, f)| f.id() == messages::EMCY.cob_id(1))
            .map(|(k, f)| (*k, Emcy::decode(f).expect("emcy decodes")))
            .collect()
    }
}

#[test]
fn the_loop_reaches_small_and_large_setpoints() {
    let mut rig = Rig::new(&[]);
    // Schedule of config/solenoid.toml: 5 mm, 10 mm at 1 s, 10.2 mm at 2 s, 20 mm at 3 s.
    for (until, target) in [(1.0, 0.005), (2.0, 0.010), (3.0, 0.0102), (4.0, 0.020)] {
        rig.run_until(until);
        let err = (rig.position() - target).abs();
        assert!(
            err < HELD_M,
            "at {until} s: position {} vs {target}",
            rig.position()
        );
    }
    assert_eq!(rig.controller.counters().sensor_missed, 0);
    assert_eq!(rig.controller.counters().faults_raised, 0);
}

#[test]
fn a_setpoint_frame_moves_the_axis() {
    let mut rig = Rig::new(&[]);
    rig.run_until(0.5);
    rig.inject(
        SetpointPdo {
            position: 0.0125,
            axis_node_id: 16,
        }
        .encode(1),
    );
    rig.run_until(0.95);
    assert!(
        (rig.position() - 0.0125).abs() < HELD_M,
        "{}",
        rig.position()
    );
}

#[test]
fn a_supply_drop_raises_emcy_and_fault_state_within_its_persistence_and_reset_clears_it() {
    let mut rig = Rig::new(&["supply_x0.6@0.5s"]);
    rig.run_until(0.6);
    let emcys = rig.emcys();
    assert_eq!(emcys.len(), 1, "{emcys:?}");
    let (k, e) = emcys[0];
    assert_eq!(e.error_code, 0x3100);
    assert!(e.flags.contains(FaultKind::SupplyVoltage));
    // Injected before SYNC #200; supply_time_s = 10 ms = 4 cycles of persistence.
    let latency = k - 200;
    assert!((3..=5).contains(&latency), "latency {latency} periods");
    let state = rig
        .sent
        .iter()
        .filter(|(_, f)| f.id() == messages::FAULT_STATE.cob_id(1))
        .map(|(k, f)| (*k, FaultStatePdo::decode(f).expect("decodes")))
        .find(|(_, s)| s.state == FaultState::Fault)
        .expect("a fault_state frame with the fault");
    assert_eq!(
        state.0, k,
        "fault_state goes out in the cycle the fault latches"
    );
    // Safe state: 0 V commanded.
    assert_eq!(rig.records.last().map(|r| r.command_voltage), Some(0.0));

    // Reset while the supply is still low: it trips again. Fault reset frame, then NMT reset.
    rig.inject(FaultResetPdo { axis_node_id: 16 }.encode(1));
    rig.run_until(0.7);
    assert_eq!(rig.emcys().len(), 3, "reset EMCY then the fault again");
    assert_eq!(rig.emcys()[1].1.error_code, 0);
    rig.inject(NmtCommand::ResetNode.encode(1));
    rig.cycle();
    assert!(
        rig.emcys()
            .iter()
            .filter(|(_, e)| e.error_code == 0)
            .count()
            >= 2
    );
}

#[test]
fn malformed_and_unknown_frames_are_counted_and_the_loop_goes_on() {
    let mut rig = Rig::new(&[]);
    rig.run_until(0.2);
    let garbage = [
        Frame::new(0x190, &[1, 2]).expect("frame"),
        Frame::new(0x201, &[0xFF]).expect("frame"),
        Frame::new(0x000, &[0x55, 1]).expect("frame"),
        Frame::new(0x5FF, &[0; 8]).expect("frame"),
        Frame::new_extended(0x1234567, &[1]).expect("frame"),
    ];
    for g in garbage {
        rig.inject(g);
    }
    rig.run_until(1.0);
    let c = rig.controller.counters();
    assert_eq!(c.frames_malformed, 3);
    assert_eq!(c.frames_unknown, 2);
    assert!((rig.position() - 0.005).abs() < HELD_M);
    let status = rig
        .sent
        .iter()
        .rev()
        .find(|(_, f)| f.id() == messages::LOOP_STATUS.cob_id(1))
        .map(|(_, f)| LoopStatusPdo::decode(f).expect("decodes"))
        .expect("loop_status sent");
    assert_eq!(status.frames_malformed, 3);
}

#[test]
fn a_stuck_sensor_trips_the_following_error_after_the_next_step() {
    let mut rig = Rig::new(&["sensor_stuck@0.8s"]);
    rig.run_until(2.0);
    let emcys = rig.emcys();
    let (k, e) = emcys.first().copied().expect("an EMCY");
    assert_eq!(e.error_code, 0x8611);
    // The step to 10 mm at 1 s cannot show on a frozen sensor: following_error_time_s = 0.3 s.
    let t = k as f64 * PERIOD;
    assert!((1.29..1.32).contains(&t), "raised at {t} s");
}

#[test]
fn a_sensor_frame_that_misses_its_deadline_adds_no_lag() {
    let mut rig = Rig::new(&[]);
    rig.run_until(1.05);
    let late = rig.cycle_with(&[], true);
    let missed = rig.records.last().copied().expect("record");
    assert!(!missed.sensor_fresh);
    let late_position = SensorPdo::decode(&late[0]).expect("sensor").position;
    // The late frame arrives before the next SYNC; that cycle must use its own answer.
    rig.cycle_with(&late, false);
    let next = rig.records.last().copied().expect("record");
    assert!(next.sensor_fresh);
    let own = rig.sim.plant().truth().position;
    assert!(
        (next.position - own).abs() < 5e-6,
        "used {} not its own {own}",
        next.position
    );
    assert!(
        (next.position - late_position).abs() > 1e-6,
        "the axis still moves fast at 1.05 s"
    );
    assert_eq!(rig.controller.counters().sensor_missed, 1);
}

#[test]
fn an_overrun_rate_above_the_threshold_is_a_timing_warning_on_the_bus() {
    let mut rig = Rig::new(&[]);
    rig.run_until(0.5);
    let states = |rig: &Rig, from: u64| -> Vec<FaultState> {
        rig.sent
            .iter()
            .filter(|(k, f)| *k >= from && f.id() == messages::FAULT_STATE.cob_id(1))
            .map(|(_, f)| FaultStatePdo::decode(f).expect("decodes").state)
            .collect()
    };
    assert_eq!(states(&rig, 0).last(), Some(&FaultState::Ok));
    // The cycle thread counts overruns; here 10 % of a status period's cycles overran.
    let from = rig.k;
    rig.controller.counters_mut().overruns += 2;
    rig.run_until(0.6);
    assert!(
        states(&rig, from).contains(&FaultState::Warning),
        "{:?}",
        states(&rig, from)
    );
    // A quiet period clears it again.
    let from = rig.k;
    rig.run_until(0.8);
    assert_eq!(states(&rig, from).last(), Some(&FaultState::Ok));
}

#[test]
fn a_reload_changes_parameters_bumplessly_and_refuses_structural_changes() {
    let mut rig = Rig::new(&[]);
    rig.run_until(0.9);
    let before = rig.records.last().copied().expect("record");
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/config/solenoid.toml"));
    let text = std::fs::read_to_string(path).expect("config");
    let changed = text.replace("following_error_m = 0.002", "following_error_m = 0.003");
    assert_ne!(
        changed, text,
        "the shipped config has following_error_m = 0.002"
    );
    let new = Config::from_toml(&changed, path).expect("valid");
    let mut events = vec![];
    rig.controller
        .reload(new, 0.9, &mut |r| events.push(format!("{r:?}")));
    assert!(
        events
            .iter()
            .any(|e| e.contains("Reloaded") && e.contains("axes_rebuilt: 1")),
        "{events:?}"
    );
    rig.cycle();
    let after = rig.records.last().copied().expect("record");
    // Bumpless: the command goes on from where it was, not from the safe 0 V.
    assert!(
        (after.command_voltage - before.command_voltage).abs() < 0.5,
        "{before:?} -> {after:?}"
    );
    let h = rig
        .controller
        .dictionary()
        .lookup("axis0_limits.following_error_m")
        .expect("object");
    assert_eq!(rig.controller.dictionary().value(h).as_f64(), Some(0.003));

    let structural = text.replace("actuator_node_id = 16", "actuator_node_id = 17");
    let new = Config::from_toml(&structural, path).expect("valid on its own");
    let mut events = vec![];
    rig.controller
        .reload(new, 1.0, &mut |r| events.push(format!("{r:?}")));
    assert!(
        events.iter().any(|e| e.contains("ReloadRefused")),
        "{events:?}"
    );
    rig.run_until(1.5);
    assert!(
        (rig.position() - 0.010).abs() < HELD_M,
        "still controlling axis 16: {}",
        rig.position()
    );
}
