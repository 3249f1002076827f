//! The controller node against simulated standard nodes (a CiA 402 drive, a CiA 401 I/O module),
//! frame by frame without clocks: the start-up over SDO, the closed loop, a drive fault and its
//! reset, a refused mapping and a mapping taken from an EDS. The same runs on vcan in
//! `tests/vcan_profiles.rs`.

use crate::common::lockstep::SimBus;
use crate::common::paths::root;
use actuatord::bus::Frame;
use actuatord::daemon::config::Config;
use actuatord::daemon::node::CycleTiming;
use actuatord::daemon::profile_setup::{configure, SetupError};
use actuatord::daemon::record::{CycleRecord, Event, Record, RejoinFailure, RejoinStage};
use actuatord::daemon::ControllerNode;
use actuatord::device::profile::cia402::State;
use actuatord::device::{Emcy, FaultResetPdo};
use actuatord::simnode::{DriveFault, Profile, ProfileNode, SimNode};
use actuatord::supervise::FaultKind;
use std::path::Path;

fn sim(profile: Profile, plant: &str, drive_faults: Vec<DriveFault>, period_s: f64) -> SimNode {
    let plant = actuatord::physics::load_plant(&root().join(plant)).expect("plant");
    let mut node = SimNode::new(16, plant, period_s, vec![]).with_profile(ProfileNode::new(
        profile,
        16,
        drive_faults,
    ));
    node.boot(&mut |_| {});
    node
}

struct Rig {
    controller: ControllerNode,
    sim: SimNode,
    period_s: f64,
    k: u64,
    /// Frames the controller sent, with their cycle.
    sent: Vec<(u64, Frame)>,
    /// Every frame on the bus after the start-up.
    bus: Vec<Frame>,
    records: Vec<CycleRecord>,
    /// The controller's events, with their cycle.
    events: Vec<(u64, Event)>,
    /// The node's SDO answers are lost on the way (a node that does not answer).
    mute_sdo: bool,
}

impl Rig {
    /// Set the node up over SDO as the daemon does, then boot the controller.
    fn new(config: &Config, mut sim: SimNode) -> Result<Self, SetupError> {
        let layout = configure(&mut SimBus::new(&mut sim), &config.node, &config.axis[0])?;
        let mut controller = ControllerNode::new(config).expect("controller");
        controller.set_node_layout(0, &layout);
        let mut rig = Self {
            controller,
            sim,
            period_s: config.cycle.period_s,
            k: 0,
            sent: vec![],
            bus: vec![],
            records: vec![],
            events: vec![],
            mute_sdo: false,
        };
        let mut out = vec![];
        rig.controller.boot(&mut |f| out.push(*f), &mut |_| {});
        rig.deliver(&out);
        Ok(rig)
    }

    fn deliver(&mut self, frames: &[Frame]) -> Vec<Frame> {
        let mut answers = Vec::new();
        for f in frames {
            self.sent.push((self.k, *f));
            self.bus.push(*f);
            self.sim.handle(f, &mut |a| answers.push(*a), &mut |_| {});
        }
        if self.mute_sdo {
            answers.retain(|a| a.id() != 0x590);
        }
        self.bus.extend(&answers);
        answers
    }

    fn hand_to_controller(&mut self, frame: &Frame) {
        let t = self.k as f64 * self.period_s;
        let (k, events) = (self.k, &mut self.events);
        self.controller.handle(frame, t, &mut |r| {
            if let Record::Event(e) = r {
                events.push((k, e));
            }
        });
    }

    fn cycle(&mut self) {
        let t = self.k as f64 * self.period_s;
        if self.k % ((0.1 / self.period_s).round() as u64) == 0 {
            let hb = self.sim.heartbeat();
            self.hand_to_controller(&hb);
        }
        self.controller.begin_cycle();
        let sync = self.controller.sync_frame();
        for a in self.deliver(&[sync]) {
            self.hand_to_controller(&a);
        }
        let mut out = Vec::new();
        let (k, records, events) = (self.k, &mut self.records, &mut self.events);
        self.controller
            .finish_cycle(
                t,
                CycleTiming::default(),
                &mut |f| out.push(*f),
                &mut |r| match r {
                    Record::Cycle(c) => records.push(c),
                    Record::Event(e) => events.push((k, e)),
                    _ => {}
                },
            );
        for a in self.deliver(&out) {
            self.hand_to_controller(&a);
        }
        self.k += 1;
    }

    fn run(&mut self, seconds: f64) {
        for _ in 0..(seconds / self.period_s).round() as u64 {
            self.cycle();
        }
    }

    /// Mean recorded position over [a, b) s.
    fn mean_position(&self, a: f64, b: f64) -> f64 {
        let v: Vec<f64> = self
            .records
            .iter()
            .filter(|r| r.t_s >= a && r.t_s < b)
            .map(|r| r.position)
            .collect();
        assert!(!v.is_empty(), "no records in [{a}, {b})");
        v.iter().sum::<f64>() / v.len() as f64
    }

    fn emcys(&self) -> Vec<(u64, Emcy)> {
        self.sent
            .iter()
            .filter(|(_, f)| f.id() == 0x081)
            .map(|(k, f)| (*k, Emcy::decode(f).expect("EMCY decodes")))
            .collect()
    }
}

fn drive_config() -> Config {
    Config::load(&root().join("config/cia402_linear_axis.toml")).expect("config")
}

#[test]
fn a_cia402_drive_in_cst_closes_the_loop_with_the_intelligent_functions_on() {
    let config = drive_config();
    let a = &config.axis[0];
    assert!(a.adaptive_friction.is_some() && a.observer.is_some() && a.schedule.is_some());
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("the drive takes its mapping");
    rig.run(4.0);
    let p = rig.sim.profile().expect("profile node");
    assert_eq!(p.drive_state(), State::OperationEnabled);
    for (until, target) in [(1.0, 0.0), (2.0, 0.02), (3.0, 0.0202), (4.0, -0.03)] {
        let mean = rig.mean_position(until - 0.2, until);
        eprintln!(
            "cia402: setpoint {:.2} mm: position {:.4} mm",
            target * 1e3,
            mean * 1e3
        );
        // The axis sticks (breakaway 3 N against 2 N of Coulomb friction): it rests within a
        // few tens of µm, where the friction compensation and the integrator leave it.
        assert!((mean - target).abs() < 40e-6, "{target}: {mean}");
    }
    let last = rig.records.last().expect("records");
    // The DC link voltage (6079h in TPDO2) is the axis' supply, and the schedule reads it.
    assert!((last.supply_voltage - 24.0).abs() < 0.1, "{last:?}");
    assert!((last.gain_schedule_factor - 1.0).abs() < 0.01);
    assert_eq!(last.drive_statusword & 0x6F, 0x27, "operation enabled");
    assert!(last.command_torque.abs() < 100.0 && last.command_voltage == 0.0);
    // Nothing latched: no EMCY at all.
    assert!(rig.emcys().is_empty(), "{:?}", rig.emcys());
    // One command RPDO per cycle once operational, on RPDO1's COB-ID, 4 bytes as mapped.
    let rpdos = rig.sent.iter().filter(|(_, f)| f.id() == 0x210).count();
    assert_eq!(rpdos as u64, rig.k);
    assert!(rig
        .sent
        .iter()
        .filter(|(_, f)| f.id() == 0x210)
        .all(|(_, f)| f.len() == 4));
    // The configuration's DBC describes every frame on the bus, the drive's PDOs as mapped.
    let text = actuatord::daemon::profile_dbc::render_config_dbc(&config).expect("dbc");
    let dbc = can_dbc::Dbc::try_from(text.as_str()).expect("the DBC parses");
    for f in &rig.bus {
        let m = dbc
            .messages
            .iter()
            .find(|m| m.id == can_dbc::MessageId::Standard(f.id() as u16))
            .unwrap_or_else(|| panic!("frame {f} has no DBC message"));
        assert_eq!(m.size as usize, f.len(), "frame {f} vs DBC {}", m.name);
    }
}

#[test]
fn a_drive_fault_is_the_axis_fault_with_the_drive_code_and_a_reset_brings_it_back() {
    let config = drive_config();
    let fault: DriveFault = "0x4310@1.5s".parse().expect("fault");
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![fault],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("setup");
    rig.run(2.0);
    assert_eq!(rig.sim.profile().expect("p").drive_state(), State::Fault);
    let emcys = rig.emcys();
    let (k, emcy) = emcys.first().expect("an EMCY for the drive fault");
    assert_eq!(emcy.error_code, 0x4310, "{emcy:?}");
    assert!(emcy.flags.contains(FaultKind::NodeState));
    // Raised within a few cycles of the fault (1.5 s = cycle 750).
    let fault_cycle = (1.5 / config.cycle.period_s).round() as u64;
    assert!(
        (fault_cycle..fault_cycle + 5).contains(k),
        "EMCY at cycle {k}"
    );
    // The reset: the fault_reset frame of the controller, as automation sends it.
    let reset = FaultResetPdo { axis_node_id: 16 }.encode(1);
    rig.hand_to_controller(&reset);
    let reset_cycle = rig.k;
    rig.run(1.5);
    assert_eq!(
        rig.sim.profile().expect("p").drive_state(),
        State::OperationEnabled
    );
    // Through the state machine: fault reset (0x80) after a word with bit 7 low, then
    // shutdown, switch on, enable operation.
    let words: Vec<u16> = rig
        .sent
        .iter()
        .filter(|(k, f)| *k + 1 >= reset_cycle && f.id() == 0x210)
        .map(|(_, f)| u16::from_le_bytes([f.data()[0], f.data()[1]]))
        .collect();
    let mut changes: Vec<u16> = words.clone();
    changes.dedup();
    assert_eq!(
        &changes[..5],
        &[0x00, 0x80, 0x06, 0x07, 0x0F],
        "{changes:x?}"
    );
    // An EMCY "error reset" followed, and no second drive fault.
    let after: Vec<_> = rig
        .emcys()
        .into_iter()
        .filter(|(k, _)| *k >= reset_cycle)
        .collect();
    assert_eq!(
        after.first().map(|(_, e)| e.error_code),
        Some(0),
        "{after:?}"
    );
    assert!(
        after.iter().all(|(_, e)| e.error_code != 0x4310),
        "{after:?}"
    );
    let last = rig.records.last().expect("records");
    assert_eq!(last.fault_state, 0, "{last:?}");
    // Back on its setpoint (20.2 mm since 2 s of the schedule), ramped up from where the spring
    // pulled it while the drive was off.
    let mean = rig.mean_position(2.8, 3.0);
    assert!((mean - 0.0202).abs() < 40e-6, "{mean}");
}

#[test]
fn a_cia401_module_closes_the_loop_of_the_solenoid() {
    let config = Config::load(&root().join("config/cia401_solenoid.toml")).expect("config");
    let node = sim(
        Profile::Cia401,
        "config/plants/solenoid.toml",
        vec![],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("the module takes its mapping");
    rig.run(3.0);
    for (until, target) in [(1.0, 0.005), (2.0, 0.010), (3.0, 0.0102)] {
        let mean = rig.mean_position(until - 0.2, until);
        eprintln!(
            "cia401: setpoint {:.2} mm: position {:.4} mm",
            target * 1e3,
            mean * 1e3
        );
        // The reference solenoid sticks (the paper's Fig. 17 friction): steps end at a
        // stick-slip offset, inside the paper's 25-50 µm with adaptive compensation.
        assert!((mean - target).abs() < 50e-6, "{target}: {mean}");
    }
    let last = rig.records.last().expect("records");
    assert!((last.supply_voltage - 24.0).abs() < 0.1, "{last:?}");
    assert!(
        last.current > 0.1,
        "the coil current comes from analog input 2"
    );
    assert!((last.gain_schedule_factor - 1.0).abs() < 0.01);
    // RPDO2 carries analog output 1 in mV: the command the controller recorded.
    let (_, f) = rig
        .sent
        .iter()
        .rev()
        .find(|(_, f)| f.id() == 0x310)
        .expect("RPDO2");
    let mv = i16::from_le_bytes([f.data()[0], f.data()[1]]);
    assert!((f64::from(mv) * 1e-3 - last.command_voltage).abs() < 1e-3);
}

#[test]
fn a_refused_mapping_is_reported_by_object_and_abort_code() {
    let text = std::fs::read_to_string(root().join("config/cia401_solenoid.toml"))
        .expect("config")
        .replace("position_input = 1\n", "position_input = 9\n");
    let config = Config::from_toml(&text, Path::new("bad.toml")).expect("valid as a file");
    let node = sim(
        Profile::Cia401,
        "config/plants/solenoid.toml",
        vec![],
        0.0025,
    );
    let e = Rig::new(&config, node)
        .err()
        .expect("analog input 9 does not exist");
    let message = e.to_string();
    eprintln!("{message}");
    assert!(
        message.contains("1A01:01")
            && message.contains("TPDO2 (1801h/1A01h) mapping entry 1")
            && message.contains("0x06040041"),
        "{message}"
    );
    // The wrong device: a drive where a module is expected.
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        0.0025,
    );
    let e = Rig::new(&config, node).err().expect("not a CiA 401 device");
    assert!(e.to_string().contains("0x00020192"), "{e}");
}

#[test]
fn a_mapping_from_the_eds_is_checked_on_the_node() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The simulated drive's own EDS: its factory mapping has no position actual value.
    let eds = dir.path().join("drive.eds");
    std::fs::copy(root().join("dbc/actuator-sim-cia402.eds"), &eds).expect("copy EDS");
    let text = std::fs::read_to_string(root().join("config/cia402_linear_axis.toml"))
        .expect("config")
        .replace("[axis.cia402]\n", "eds = \"drive.eds\"\n\n[axis.cia402]\n");
    let config_path = dir.path().join("drive.toml");
    std::fs::write(&config_path, &text).expect("write");
    let config = Config::load(&config_path).expect("config");
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        0.002,
    );
    let e = Rig::new(&config, node)
        .err()
        .expect("factory mapping lacks 6064h");
    assert!(
        e.to_string().contains("no enabled RPDO maps 6071:00"),
        "{e}"
    );

    // An EDS whose defaults are the layout the daemon would write: taken as it is, checked on
    // the node by reading back, no writes. A node that has it passes; one that does not is
    // named with the first entry that differs.
    let mut configured = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        0.002,
    );
    configure(
        &mut SimBus::new(&mut configured),
        &drive_config().node,
        &drive_config().axis[0],
    )
    .expect("daemon's layout");
    let od = configured.profile().expect("p").dictionary().clone();
    let mut od_eds = actuatord::canopen::render_eds(&od, &actuatord::canopen::EdsInfo::default());
    // Defaults of an EDS are what the node starts with: write the configured values as such.
    for e in od.entries() {
        if (0x1400..=0x1BFF).contains(&e.id.index) {
            let h = od.handle(e.id).expect("entry");
            let section = format!("[{:04X}sub{:X}]", e.id.index, e.id.sub);
            let start = od_eds.find(&section).expect("section");
            let key = od_eds[start..].find("DefaultValue=").expect("default") + start;
            let end = od_eds[key..].find("\r\n").expect("line end") + key;
            od_eds.replace_range(key..end, &format!("DefaultValue={}", od.value(h)));
        }
    }
    std::fs::write(&eds, &od_eds).expect("write EDS");
    let rig = Rig::new(&config, configured).expect("the node has the EDS mapping");
    assert_eq!(
        rig.controller
            .profile_link(0)
            .map(|l| l.statusword().is_some()),
        Some(true)
    );
    let fresh = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        0.002,
    );
    let e = Rig::new(&config, fresh)
        .err()
        .expect("factory mapping differs");
    assert!(
        matches!(e, SetupError::Mismatch { .. }) && e.to_string().contains("RPDO1"),
        "{e}"
    );
}

#[test]
fn the_simulated_nodes_eds_files_are_what_the_sim_prints() {
    for profile in ["cia402", "cia401"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
            .args(["sim", "--profile", profile, "--print-eds"])
            .output()
            .expect("actuator sim --print-eds");
        assert!(out.status.success());
        let file =
            std::fs::read(root().join(format!("dbc/actuator-sim-{profile}.eds"))).expect("eds");
        assert!(
            out.stdout == file,
            "dbc/actuator-sim-{profile}.eds is stale: regenerate it with actuator sim --profile {profile} --print-eds"
        );
    }
}

#[test]
fn profile_keys_are_checked_with_their_file_and_key() {
    let text =
        std::fs::read_to_string(root().join("config/cia402_linear_axis.toml")).expect("config");
    for (from, to, key) in [
        ("profile = \"cia402\"\n", "", "command"),
        (
            "command = \"torque\"\n",
            "command = \"voltage\"\n",
            "command",
        ),
        (
            "position_m_per_inc = 1e-6\n",
            "position_m_per_inc = 0.0\n",
            "cia402.position_m_per_inc",
        ),
        (
            "[axis.controller]\n",
            "[axis.cia401]\nposition_input = 1\nposition_m_per_count = 1e-6\n\
             command_output = 1\ncommand_per_count = 0.001\n\n[axis.controller]\n",
            "cia401",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let e = Config::from_toml(&text.replace(from, to), Path::new("drive.toml"))
            .err()
            .unwrap_or_else(|| panic!("{from} -> {to} must be refused"));
        let message = e.to_string();
        assert!(
            message.contains("drive.toml") && message.contains(key),
            "{from} -> {to}: {message}"
        );
    }
}

#[test]
fn a_cia402_drive_in_csv_follows_the_velocity_the_loop_commands() {
    // The drive axis with a P position loop whose output is the target velocity (CSV, 60FFh):
    // the drive's own velocity loop does the rest. The force-model sections do not apply.
    let text =
        std::fs::read_to_string(root().join("config/cia402_linear_axis.toml")).expect("config");
    let (head, tail) = text.split_at(text.find("[axis.controller]").expect("controller"));
    let limits = tail.find("[axis.limits]").expect("limits");
    let text = format!(
        "{}[axis.controller]\n# v = 50 1/s x e, m/s.\nq_per_m = [50.0]\noutput_min = -0.5\noutput_max = 0.5\n\n{}",
        head.replace("command = \"torque\"", "command = \"velocity\""),
        &tail[limits..]
    );
    let config = Config::from_toml(&text, Path::new("csv.toml")).expect("CSV config");
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("setup");
    rig.run(2.0);
    assert_eq!(
        rig.sim.profile().expect("p").drive_state(),
        State::OperationEnabled
    );
    // RPDO1: controlword and the 32-bit target velocity in µm/s.
    let (_, f) = rig
        .sent
        .iter()
        .rev()
        .find(|(_, f)| f.id() == 0x210)
        .expect("RPDO1");
    assert_eq!(f.len(), 6);
    let last = rig.records.last().expect("records");
    let v = i32::from_le_bytes([f.data()[2], f.data()[3], f.data()[4], f.data()[5]]);
    assert!(
        (f64::from(v) * 1e-6 - last.command_velocity).abs() < 2e-6,
        "{v} vs {last:?}"
    );
    let mean = rig.mean_position(1.8, 2.0);
    eprintln!("cia402 CSV: setpoint 20 mm: position {:.4} mm", mean * 1e3);
    assert!((mean - 0.02).abs() < 40e-6, "{mean}");
}

#[test]
fn a_drive_already_in_fault_at_start_up_is_named_by_its_error_code() {
    let config = drive_config();
    let fault: DriveFault = "0x7305@0s".parse().expect("fault");
    let mut node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![fault],
        config.cycle.period_s,
    );
    // SYNCs from before the daemon: the drive faults and sends its EMCY to nobody.
    let mut early = vec![];
    for _ in 0..3 {
        let sync = actuatord::canopen::SyncCounter::default().encode();
        node.handle(&sync, &mut |f| early.push(*f), &mut |_| {});
    }
    assert!(early.iter().any(|f| f.id() == 0x090), "{early:?}");
    assert_eq!(node.profile().expect("p").drive_state(), State::Fault);
    let mut rig = Rig::new(&config, node).expect("setup reads 603Fh");
    rig.run(0.3);
    let emcys = rig.emcys();
    let (_, e) = emcys.first().expect("the axis' fault");
    assert_eq!(e.error_code, 0x7305, "{emcys:?}");
    assert!(e.flags.contains(FaultKind::NodeState));
}

/// `config/cia402_csp_homing.toml` against the simulated drive: homing (method 17 on its
/// negative limit switch, 1 mm home offset) before any motion, then CSP: every target position
/// the daemon sent is judged against the position the drive answers, counted in cycles.
#[test]
fn a_cia402_drive_is_homed_then_follows_the_target_positions_in_csp() {
    let config = Config::load(&root().join("config/cia402_csp_homing.toml")).expect("config");
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("the drive takes its mapping and homing");
    rig.run(6.0);
    let link = rig.controller.profile_link(0).expect("link");
    assert_eq!(link.homed(), Some(true), "{:?}", link.homing_failure());
    // The home point is the switch's edge; it reads -1 mm.
    let p = rig.sim.profile().expect("profile node");
    let home = p.position_origin_m() - 0.001;
    eprintln!("csp: home point at {:.4} mm of the travel", home * 1e3);
    assert!((home + 0.025).abs() < 5e-6, "{home}");
    // RPDO1: controlword, 607Ah, 6060h. The modes asked for: homing, then CSP, never back.
    let rpdos: Vec<(u64, u16, i32, i8)> = rig
        .sent
        .iter()
        .filter(|(_, f)| f.id() == 0x210)
        .map(|(k, f)| {
            let d = f.data();
            (
                *k,
                u16::from_le_bytes([d[0], d[1]]),
                i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
                d[6] as i8,
            )
        })
        .collect();
    let mut modes: Vec<i8> = rpdos.iter().map(|r| r.3).collect();
    modes.dedup();
    assert_eq!(modes, [6, 8], "homing, then CSP");
    let started = rpdos
        .iter()
        .position(|r| r.1 & 0x10 != 0)
        .expect("start bit");
    let csp = rpdos.iter().position(|r| r.3 == 8).expect("CSP");
    assert!(started < csp);
    // Before CSP the target is where the axis stands: no step when the drive switches.
    let records = &rig.records;
    let moved = records
        .iter()
        .position(|r| (r.reference_position - r.position).abs() > 1e-9)
        .expect("the axis moves at last");
    assert!(
        moved > csp,
        "the axis moved at cycle {moved}, CSP from {csp}"
    );
    // Each target sent, against the position the drive answers one cycle later.
    let mut worst: f64 = 0.0;
    for (r, next) in rpdos.iter().zip(records.iter().skip(1)).skip(csp + 1) {
        let target = f64::from(r.2) * 1e-6;
        worst = worst.max((next.position - target).abs());
    }
    let last = records.last().expect("records");
    eprintln!(
        "csp: worst |position - target of the cycle before| {:.1} um; at 6 s {:.4} mm for -5 mm",
        worst * 1e6,
        last.position * 1e3
    );
    // The drive's band: 0.25 mm while the target ramps at 20 mm/s, 20 µm at rest.
    assert!(worst < 250e-6, "{worst}");
    assert!((last.position + 0.005).abs() < 20e-6, "{}", last.position);
    assert!(rig.emcys().is_empty(), "{:?}", rig.emcys());
}

/// A homing that does not attain home in time is the axis' fault, with its own EMCY code, and
/// the axis does not move.
#[test]
fn a_homing_timeout_is_the_axis_fault_and_the_axis_stays() {
    let text = std::fs::read_to_string(root().join("config/cia402_csp_homing.toml"))
        .expect("config")
        .replace("timeout_s = 10.0", "timeout_s = 0.2");
    let config = Config::from_toml(&text, Path::new("cia402_csp_homing.toml")).expect("config");
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        config.cycle.period_s,
    );
    let mut rig = Rig::new(&config, node).expect("set up");
    rig.run(1.0);
    let link = rig.controller.profile_link(0).expect("link");
    let failure = link.homing_failure().expect("homing failed");
    assert!(failure.to_string().contains("timeout_s = 0.2"), "{failure}");
    let emcys = rig.emcys();
    assert!(
        emcys
            .iter()
            .any(|(_, e)| e.error_code == actuatord::daemon::profile_homing::HOMING_FAILED),
        "{emcys:?}"
    );
    // Never switched to CSP.
    assert!(rig
        .sent
        .iter()
        .filter(|(_, f)| f.id() == 0x210)
        .all(|(_, f)| f.data()[6] == 6));
}

/// At start-up each standard node gets the daemon's heartbeat to watch, 1016h sub 1 = the
/// daemon's node-ID and its heartbeat period plus the margin (100 + 100 ms by default), and a
/// drive its abort connection option 6007h (quick stop by default, fault as configured).
#[test]
fn each_standard_node_is_given_the_daemons_heartbeat_to_watch() {
    use actuatord::canopen::od::ObjectId;
    use actuatord::canopen::Value;
    let value = |sim: &SimNode, index: u16, sub: u8| {
        let od = sim.profile().expect("profile node").dictionary();
        od.value(od.handle(ObjectId::new(index, sub)).expect("entry"))
    };
    let drive = Rig::new(
        &drive_config(),
        sim(
            Profile::Cia402,
            "config/plants/linear_axis_drive.toml",
            vec![],
            0.002,
        ),
    )
    .expect("set up");
    assert_eq!(value(&drive.sim, 0x1016, 1), Value::Unsigned32(0x0001_00C8));
    assert_eq!(value(&drive.sim, 0x6007, 0), Value::Integer16(3));
    let text = std::fs::read_to_string(root().join("config/cia402_linear_axis.toml"))
        .expect("config")
        .replace(
            "heartbeat_period_s = 0.1\n",
            "heartbeat_period_s = 0.1\nheartbeat_consumer_margin_s = 0.05\n",
        )
        .replace(
            "[axis.cia402]\n",
            "[axis.cia402]\nabort_connection_option = \"fault\"\n",
        );
    let config = Config::from_toml(&text, Path::new("cia402.toml")).expect("config");
    let drive = Rig::new(
        &config,
        sim(
            Profile::Cia402,
            "config/plants/linear_axis_drive.toml",
            vec![],
            0.002,
        ),
    )
    .expect("set up");
    assert_eq!(value(&drive.sim, 0x1016, 1), Value::Unsigned32(0x0001_0096));
    assert_eq!(value(&drive.sim, 0x6007, 0), Value::Integer16(1));
    let config = Config::load(&root().join("config/cia401_solenoid.toml")).expect("config");
    let module = Rig::new(
        &config,
        sim(
            Profile::Cia401,
            "config/plants/solenoid.toml",
            vec![],
            config.cycle.period_s,
        ),
    )
    .expect("set up");
    assert_eq!(
        value(&module.sim, 0x1016, 1),
        Value::Unsigned32(0x0001_00C8)
    );
    // A consumer time 1016h cannot hold is refused at start-up, naming the keys.
    let text = std::fs::read_to_string(root().join("config/cia402_linear_axis.toml"))
        .expect("config")
        .replace("heartbeat_period_s = 0.1\n", "heartbeat_period_s = 70.0\n");
    let config = Config::from_toml(&text, Path::new("cia402.toml")).expect("config");
    let e = Rig::new(
        &config,
        sim(
            Profile::Cia402,
            "config/plants/linear_axis_drive.toml",
            vec![],
            0.002,
        ),
    )
    .err()
    .expect("refused");
    assert!(
        e.to_string().contains(
            "[node] heartbeat_period_s + heartbeat_consumer_margin_s = 70100 ms does not fit \
             the consumer heartbeat time 1016h (1..=65535 ms)"
        ),
        "{e}"
    );
}

/// The node's rejoin events, in order, with their cycle.
fn rejoin_stages(rig: &Rig) -> Vec<(u64, RejoinStage)> {
    rig.events
        .iter()
        .filter_map(|(k, e)| match e {
            Event::NodeRejoin {
                node_id: 16, stage, ..
            } => Some((*k, *stage)),
            _ => None,
        })
        .collect()
}

/// A drive that reboots while the daemon runs (its electronics browned out; the mechanics
/// went on) comes back with its factory mapping, no watchdog and no home. The daemon sees its
/// boot-up, runs the start-up's SDO plan again one transfer per cycle, starts it, homes it
/// again and resumes the axis on its set-point; the drive ends with the layout it had.
#[test]
fn a_drive_that_reboots_is_configured_again_homed_again_and_the_axis_resumes() {
    let config = Config::load(&root().join("config/cia402_csp_homing.toml")).expect("config");
    let period = config.cycle.period_s;
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        period,
    )
    .with_reboot_at(4.5);
    let mut rig = Rig::new(&config, node).expect("set up");
    let steps = rig
        .controller
        .rejoin(0)
        .expect("a rejoin plan")
        .steps()
        .len();
    let layout = rig.sim.profile().expect("profile").pdos().to_vec();
    rig.run(4.506);
    // The reboot took the drive's layout: factory values, no position in its TPDOs.
    assert_ne!(rig.sim.profile().expect("profile").pdos(), &layout[..]);
    rig.run(4.494);
    let stages = rejoin_stages(&rig);
    eprintln!("reboot: {stages:?}");
    let reboot_cycle = (4.5 / period).round() as u64;
    let [(k0, RejoinStage::Rebooted { steps: s0 }), (k1, RejoinStage::Started { steps: s1 }), (k2, RejoinStage::Resumed)] =
        stages[..]
    else {
        panic!("rebooted, started, resumed: {stages:?}");
    };
    assert_eq!((s0 as usize, s1 as usize), (steps, steps));
    assert!((reboot_cycle..reboot_cycle + 2).contains(&k0), "{k0}");
    // One SDO request per cycle from the boot-up to the start, each answered, none aborted.
    let requests: Vec<u64> = rig
        .sent
        .iter()
        .filter(|(k, f)| *k >= k0 && f.id() == 0x610)
        .map(|(k, _)| *k)
        .collect();
    assert_eq!(requests.len(), steps, "{requests:?}");
    assert!(
        requests.windows(2).all(|w| w[1] == w[0] + 1),
        "{requests:?}"
    );
    assert_eq!(k1, requests[steps - 1] + 1);
    let answers: Vec<&Frame> = rig.bus.iter().filter(|f| f.id() == 0x590).collect();
    assert!(answers.iter().all(|f| f.data()[0] != 0x80));
    eprintln!(
        "reboot: {steps} SDO transfers in {} cycles ({:.0} ms), resumed {:.0} ms after the boot-up",
        k1 - k0,
        (k1 - k0) as f64 * period * 1e3,
        (k2 - k0) as f64 * period * 1e3
    );
    // NMT start for node 16 in the cycle that told it.
    assert!(rig
        .sent
        .iter()
        .any(|(k, f)| *k == k1 && f.id() == 0 && f.data() == [0x01, 16]));
    // The drive has its layout again and its watchdog; homed again, then CSP.
    let p = rig.sim.profile().expect("profile");
    assert_eq!(p.pdos(), &layout[..]);
    let od = p.dictionary();
    let watch = od.value(
        od.handle(actuatord::canopen::od::ObjectId::new(0x1016, 1))
            .expect("1016h"),
    );
    assert_eq!(watch, actuatord::canopen::Value::Unsigned32(0x0001_00C8));
    let link = rig.controller.profile_link(0).expect("link");
    assert_eq!(link.homed(), Some(true), "{:?}", link.homing_failure());
    let mut modes: Vec<i8> = rig
        .sent
        .iter()
        .filter(|(k, f)| *k > k1 && f.id() == 0x210)
        .map(|(_, f)| f.data()[6] as i8)
        .collect();
    modes.dedup();
    assert_eq!(modes, [6, 8], "homing again, then CSP");
    // The axis was in fault while the drive was away, and reset when it resumed.
    let emcys = rig.emcys();
    assert!(
        emcys
            .iter()
            .any(|(k, e)| (k0..k2).contains(k) && e.error_code != 0),
        "{emcys:?}"
    );
    assert!(
        emcys.iter().any(|(k, e)| *k >= k2 && e.error_code == 0),
        "{emcys:?}"
    );
    // Back on its set-point (-5 mm), within the drive's band at rest.
    let last = rig.records.last().expect("records");
    assert_eq!(last.fault_state, 0, "{last:?}");
    assert!((last.position + 0.005).abs() < 20e-6, "{}", last.position);
    // Every cycle closed, the reboot's included.
    assert_eq!(rig.records.len() as u64, rig.k);
}

/// A rebooted node that does not answer is a failed reconfiguration naming the object and
/// the timeout: the axis stays in fault, nothing is started. The fault reset tries again.
#[test]
fn a_rebooted_node_that_does_not_answer_keeps_its_axis_in_fault_until_a_reset() {
    let config = drive_config();
    let period = config.cycle.period_s;
    let node = sim(
        Profile::Cia402,
        "config/plants/linear_axis_drive.toml",
        vec![],
        period,
    )
    .with_reboot_at(1.0);
    let mut rig = Rig::new(&config, node).expect("set up");
    rig.mute_sdo = true;
    rig.run(2.0);
    let stages = rejoin_stages(&rig);
    let [(k0, RejoinStage::Rebooted { .. }), (k1, RejoinStage::Failed { step: 0, failure })] =
        stages[..]
    else {
        panic!("rebooted, failed: {stages:?}");
    };
    assert_eq!(
        failure,
        RejoinFailure::Refused {
            object: actuatord::canopen::od::ObjectId::new(0x1000, 0),
            code: actuatord::canopen::sdo::AbortCode::TIMEOUT
        }
    );
    // The start-up's 0.5 s SDO timeout, counted in cycles.
    let waited = (k1 - k0) as f64 * period;
    assert!((0.5..0.52).contains(&waited), "{waited}");
    assert!(rig.sim.state() != actuatord::canopen::NmtState::Operational);
    assert_ne!(rig.records.last().expect("records").fault_state, 0);
    rig.mute_sdo = false;
    rig.hand_to_controller(&FaultResetPdo { axis_node_id: 16 }.encode(1));
    rig.run(1.0);
    let stages = rejoin_stages(&rig);
    assert!(
        matches!(
            stages[2..],
            [(_, RejoinStage::Started { .. }), (_, RejoinStage::Resumed)]
        ),
        "{stages:?}"
    );
    assert_eq!(rig.sim.state(), actuatord::canopen::NmtState::Operational);
    assert_eq!(rig.records.last().expect("records").fault_state, 0);
}
