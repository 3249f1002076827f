//! `[axis.setpoint_timeout]` in the daemon, in lock step with the simulated linear axis: a
//! commander streams set-point frames, then goes quiet; the axis reacts after the timeout,
//! counted in cycles, with EMCY 8250h, and the commander's next set-point ends the reaction
//! with EMCY 0000h.

use crate::common::lockstep::Rig;
use crate::common::paths::root;
use actuatord::daemon::config::Config;
use actuatord::device::{Emcy, SetpointPdo};

/// The daemon's period in `config/linear_axis.toml`, s.
const PERIOD_S: f64 = 0.001;
/// The timeout configured below, in cycles.
const TIMEOUT_CYCLES: u64 = 100;

fn rig(reaction: &str) -> Rig {
    let path = root().join("config/linear_axis.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config")
        + &format!("\n[axis.setpoint_timeout]\ntimeout_s = 0.1\n{reaction}\n");
    let config = Config::from_toml(&text, &path).expect("valid config");
    assert_eq!(config.cycle.period_s, PERIOD_S);
    let plant = actuatord::physics::load_plant(&root().join("config/plants/linear_axis.toml"))
        .expect("shipped plant");
    Rig::new(&config, plant, &[])
}

/// A set-point frame from the commander for the axis (node 16), before the next cycle.
fn commander_sends(rig: &mut Rig, position: f64) {
    rig.inject(
        SetpointPdo {
            position,
            axis_node_id: 16,
        }
        .encode(1),
    );
}

/// The controller's EMCYs with `code`, by cycle.
fn emcys_with(rig: &Rig, code: u16) -> Vec<(u64, Emcy)> {
    rig.emcys()
        .into_iter()
        .filter(|(_, e)| e.error_code == code)
        .collect()
}

/// The commander streams 5 mm every cycle from 0.1 s to 0.4 s, then goes quiet until 0.8 s,
/// then sends 4 mm. Returns the cycle of its last set-point before the silence.
fn quiet_commander(rig: &mut Rig) -> u64 {
    rig.run_until(0.1);
    while rig.lockstep.time_s() < 0.4 - 1e-9 {
        commander_sends(rig, 0.005);
        rig.cycle();
    }
    let last = rig.lockstep.cycles() - 1;
    rig.run_until(0.8);
    commander_sends(rig, 0.004);
    rig.run_until(0.9);
    last
}

#[test]
fn a_quiet_commander_sends_the_axis_to_its_safe_position_and_its_return_is_announced() {
    let mut rig = rig("reaction = \"safe_position\"\nsafe_position_m = 0.002");
    let last = quiet_commander(&mut rig);
    let lost = emcys_with(&rig, 0x8250);
    assert_eq!(lost.len(), 1, "{:?}", rig.emcys());
    let (at, emcy) = lost[0];
    eprintln!(
        "setpoint timeout: last set-point in cycle {last}, EMCY 8250h in cycle {at} ({} cycles \
         later, timeout {TIMEOUT_CYCLES})",
        at - last
    );
    // The set-point of cycle `last` is 0.1 s old, and past the timeout, one cycle after.
    assert_eq!(at - last, TIMEOUT_CYCLES + 1);
    assert_eq!(emcy.axis_node_id, 16);
    assert_eq!(emcy.error_register & 0x10, 0x10, "communication error");
    // The reaction: the set-point is the safe position from that cycle, the reference ramps
    // to it at the configured 0.1 m/s and the axis gets there.
    let record = |k: u64| rig.records[k as usize];
    assert_eq!(record(at - 1).setpoint_position, 0.005);
    assert_eq!(record(at).setpoint_position, 0.002);
    let before_return = record((0.8 / PERIOD_S) as u64 - 1);
    assert_eq!(before_return.setpoint_position, 0.002);
    assert_eq!(before_return.reference_position, 0.002);
    // From 4.8 mm it came most of the 2.8 mm back; the loop leaves it where the plant's
    // stiction holds it (0.24 mm short).
    eprintln!(
        "setpoint timeout, safe position: {:.3} mm at the loss, {:.3} mm before the return",
        record(at).position * 1e3,
        before_return.position * 1e3
    );
    assert!(
        (before_return.position - 0.002).abs() < 0.3e-3,
        "{}",
        before_return.position
    );
    // The commander's return: EMCY "error reset" in the cycle its set-point arrived, and its
    // set-point followed.
    let back = emcys_with(&rig, 0x0000);
    assert_eq!(back.len(), 1, "{:?}", rig.emcys());
    assert_eq!(back[0].0, (0.8 / PERIOD_S) as u64);
    assert_eq!(record(back[0].0).setpoint_position, 0.004);
}

#[test]
fn a_quiet_commander_leaves_a_holding_axis_where_its_reference_stands() {
    // The commander asks for 50 mm for 20 ms and stops: at 0.1 m/s the reference needs 0.5 s
    // to get there, so the timeout finds the ramp on its way, and stops it where it stands.
    let mut rig = rig("reaction = \"hold\"");
    rig.run_until(0.1);
    for _ in 0..20 {
        commander_sends(&mut rig, 0.05);
        rig.cycle();
    }
    rig.run_until(0.4);
    let lost = emcys_with(&rig, 0x8250);
    assert_eq!(lost.len(), 1, "{:?}", rig.emcys());
    let at = lost[0].0 as usize;
    let held = rig.records[at].setpoint_position;
    eprintln!(
        "setpoint timeout, hold: set-point held at {:.3} mm",
        held * 1e3
    );
    assert_eq!(held, rig.records[at - 1].reference_position);
    assert!(held > 0.005 && held < 0.05, "{held}");
    assert!(rig.records[at..]
        .iter()
        .all(|r| r.setpoint_position == held));
}

#[test]
fn a_quiet_commander_gets_the_safe_command_of_the_axis() {
    let mut rig = rig("reaction = \"safe_command\"");
    let last = quiet_commander(&mut rig);
    let lost = emcys_with(&rig, 0x8250);
    assert_eq!(lost.len(), 1, "{:?}", rig.emcys());
    let at = lost[0].0;
    assert_eq!(at - last, TIMEOUT_CYCLES + 1);
    // safe_command = 0.0 V until the commander is back; a command before it.
    let record = |k: u64| rig.records[k as usize];
    assert_ne!(record(at - 1).command_voltage, 0.0);
    let back = (0.8 / PERIOD_S) as u64;
    assert!((at..back).all(|k| record(k).command_voltage == 0.0));
    assert_ne!(record(back + 1).command_voltage, 0.0);
}

#[test]
fn a_safe_position_outside_the_travel_is_refused_naming_the_key() {
    let path = root().join("config/linear_axis.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config")
        + "\n[axis.setpoint_timeout]\ntimeout_s = 0.1\nreaction = \"safe_position\"\nsafe_position_m = 0.5\n";
    let err = Config::from_toml(&text, &path).expect_err("refused");
    assert!(
        err.to_string().contains(
            "[[axis]] #1 (linear_axis) setpoint_timeout.safe_position_m must lie within the \
             travel [-0.2, 0.2] m, got 0.5"
        ),
        "{err}"
    );
}
