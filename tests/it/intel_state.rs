//! What an axis learns: visible in the object dictionary, kept through a parameter write and a
//! configuration reload, and carried by the state file into a new daemon.

use crate::common::paths::root;
use actuatord::canopen::od::ObjectId;
use actuatord::canopen::{NmtCommand, ObjectDictionary, SdoClient, Value};
use actuatord::daemon::config::{Config, SetpointStep};
use actuatord::daemon::state::{self, StateFile};
use actuatord::daemon::ControllerNode;
use actuatord::lockstep::LockStep;

/// The learned table as `config/solenoid.toml` describes it (commented out there).
const LEARNED_TABLE: &str = "
[axis.learned_table]
position_edges_m = [0.0, 0.006, 0.012, 0.025]
supply_voltage_edges_v = [18.0, 24.0, 32.0]
averaging_count = 20
min_count = 3
learn_interval_s = 0.1
";

/// The shipped solenoid axis (with a learned table) on a tour of steps every 0.25 s between 4 and 12 mm: the
/// excitation the estimation windows and the observer bands need; then small steps.
fn config(edit: &str) -> Config {
    let path = root().join("config/solenoid.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config") + LEARNED_TABLE + edit;
    let mut c = Config::from_toml(&text, &path).expect("valid config");
    let t = [
        0.004, 0.009, 0.006, 0.011, 0.005, 0.010, 0.007, 0.012, 0.0045, 0.0085,
    ];
    // 110 s of large steps (what the estimation and the observer learn from), then 10 s of small
    // ones (0.2 mm, what the friction compensation adapts on) at 5 and at 9 mm.
    let small = |i: usize| {
        let centre = if i < 20 { 0.005 } else { 0.009 };
        centre + if i % 2 == 1 { 2e-4 } else { 0.0 }
    };
    c.axis[0].setpoints = (0..480)
        .map(|i| SetpointStep {
            at_s: 0.25 * i as f64,
            position_m: if i < 440 {
                t[i % t.len()]
            } else {
                small(i - 440)
            },
        })
        .collect();
    c.axis[0].initial_setpoint_m = 0.004;
    c
}

fn rig(c: &Config) -> LockStep {
    let plant = actuatord::physics::load_plant(&root().join("config/plants/solenoid.toml"))
        .expect("shipped plant");
    LockStep::new(c, plant, vec![]).expect("rig")
}

fn real(od: &ObjectDictionary, name: &str) -> f64 {
    let h = od.handle_by_name(Some(0), name).expect(name);
    match od.value(h) {
        Value::Real64(v) => v,
        other => panic!("{name}: {other:?}"),
    }
}

fn unsigned(od: &ObjectDictionary, name: &str) -> u64 {
    let h = od.handle_by_name(Some(0), name).expect(name);
    match od.value(h) {
        Value::Unsigned8(v) => u64::from(v),
        Value::Unsigned16(v) => u64::from(v),
        Value::Unsigned32(v) => u64::from(v),
        other => panic!("{name}: {other:?}"),
    }
}

/// Write `value` to the entry `name` of axis 0 over SDO, in pre-operational, and run a cycle
/// so it takes effect at the boundary.
fn sdo_write(rig: &mut LockStep, name: &str, value: f64) {
    let node = rig.controller_mut();
    let h = node.dictionary().handle_by_name(Some(0), name).expect(name);
    let id: ObjectId = node.dictionary().entry(h).id;
    node.handle(&NmtCommand::EnterPreOperational.encode(1), 0.0, &mut |_| {});
    let mut client = SdoClient::new(1);
    let request = client.start_download(id, &value.to_le_bytes(), 0.0);
    node.handle(&request, 0.0, &mut |_| {});
    rig.cycle();
}

#[test]
fn what_the_axis_learned_is_in_the_dictionary_and_survives_a_parameter_write() {
    let c = config("");
    let mut rig = rig(&c);
    rig.run(120.0, &mut |_| {});
    // Cycle 48000 publishes (every status period): the dictionary then shows this cycle's values.
    rig.cycle();
    let node = rig.controller();
    let learned = node.axes()[0].learned();
    let od = node.dictionary();
    let (pos, neg) = learned.friction_compensation.expect("adaptive friction");
    assert_eq!(real(od, "friction_compensation_pos"), pos);
    assert_eq!(real(od, "friction_compensation_neg"), neg);
    let nominal = learned.nominal.expect("nominal learned in 120 s");
    assert_eq!(
        real(od, "nominal_natural_frequency_rad_per_s"),
        nominal.p.values[2]
    );
    assert!(
        nominal.window_spread.iter().all(|s| *s > 0.0),
        "{nominal:?}"
    );
    // The estimate is of the plant: its natural frequency against √(c / m) of
    // config/plants/solenoid.toml, √(1650 N/m / 0.4956 kg) = 57.7 rad/s, within 10 % (measured
    // 54.4 rad/s, -5.7 %).
    let plant = actuatord::physics::load_spec(&root().join("config/plants/solenoid.toml"))
        .expect("shipped plant");
    let get = |name: &str| plant.get(name).expect(name);
    let truth = (get("spring.stiffness_n_per_m") / get("solenoid.mass_kg")).sqrt();
    let estimate = real(od, "estimate_natural_frequency_rad_per_s");
    println!("natural frequency: estimate {estimate:.2} rad/s, plant {truth:.2} rad/s");
    assert!(
        (estimate / truth - 1.0).abs() < 0.1,
        "estimate {estimate} rad/s against the plant's {truth} rad/s"
    );
    let bands = learned
        .observer_bands
        .expect("observer bands learned in 120 s");
    assert_eq!(real(od, "observer_x4_pos_low_m"), bands[0].0);
    assert_eq!(real(od, "observer_x4_neg_high_m"), bands[1].1);
    let cells = unsigned(od, "learned_table_cells");
    assert!(cells >= 2, "the tour crosses position bands: {cells} cells");
    assert_eq!(
        real(od, "compensation_max"),
        c.axis[0]
            .adaptive_friction
            .as_ref()
            .expect("configured")
            .compensation_max
    );

    // A parameter write rebuilds the axis; what it learned goes with it.
    let table = node.axes()[0]
        .learned_table()
        .expect("configured")
        .to_state();
    sdo_write(&mut rig, "band_sigmas", 5.0);
    let node = rig.controller();
    assert_eq!(real(node.dictionary(), "band_sigmas"), 5.0, "write applied");
    let after = node.axes()[0].learned();
    assert_eq!(after.observer_bands, Some(bands));
    assert_eq!(after.nominal, Some(nominal));
    let (p2, n2) = after.friction_compensation.expect("kept");
    // One cycle of adaptation may have passed since.
    assert!(
        (p2 - pos).abs() < 1e-3 && (n2 - neg).abs() < 1e-3,
        "{p2} {n2}"
    );
    assert_eq!(
        node.axes()[0]
            .learned_table()
            .expect("kept")
            .to_state()
            .cells,
        table.cells
    );
}

#[test]
fn a_reload_keeps_what_was_learned_and_the_state_file_carries_it_to_a_new_daemon() {
    let c = config("");
    let mut rig = rig(&c);
    rig.run(120.0, &mut |_| {});
    let learned = rig.controller().axes()[0].learned();
    assert!(learned.nominal.is_some() && learned.observer_bands.is_some());

    // SIGHUP with a changed limit: the axis is rebuilt, nothing learned is lost.
    let mut changed = c.clone();
    changed.axis[0].limits.following_error_m = Some(0.004);
    rig.controller_mut().reload(changed, 120.0, &mut |_| {});
    assert_eq!(rig.controller().axes()[0].learned(), learned);

    // The file written at shutdown gives a fresh daemon the same start.
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("state.toml");
    let kept = StateFile::of_node(rig.controller());
    state::write_atomic(&file, &kept.to_toml().expect("toml")).expect("write");
    let mut fresh = ControllerNode::new(&c).expect("node");
    assert_ne!(fresh.axes()[0].learned(), learned);
    let loaded = state::load(&file).expect("readable").expect("present");
    let lines = state::restore(&mut fresh, &loaded, &file);
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert_eq!(fresh.axes()[0].learned(), learned);
    assert_eq!(
        fresh.axes()[0].learned_table().map(|t| t.to_state()),
        rig.controller().axes()[0]
            .learned_table()
            .map(|t| t.to_state())
    );
}
