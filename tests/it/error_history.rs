//! The pre-defined error field (1003h) of the daemon, in lock step with the simulated linear
//! axis: a commander goes quiet and comes back (EMCY 8250h, then 0000h); the field holds the
//! error with its time, refuses any write to sub 0 but 0, is cleared by 0, and goes through the
//! state file's TOML into a restarted node.

use crate::common::lockstep::Rig;
use crate::common::paths::root;
use actuatord::canopen::od::ObjectId;
use actuatord::canopen::sdo::{response_cob_id, SdoClient, SdoOutcome};
use actuatord::canopen::Value;
use actuatord::daemon::config::Config;
use actuatord::daemon::state::{self, StateFile};
use actuatord::device::SetpointPdo;
use std::path::Path;

const PERIOD_S: f64 = 0.001;
const FIELD: u16 = 0x1003;

fn config() -> Config {
    let path = root().join("config/linear_axis.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config")
        + "\n[axis.setpoint_timeout]\ntimeout_s = 0.1\nreaction = \"hold\"\n";
    let config = Config::from_toml(&text, &path).expect("valid config");
    assert_eq!(config.cycle.period_s, PERIOD_S);
    config
}

fn rig() -> Rig {
    let plant = actuatord::physics::load_plant(&root().join("config/plants/linear_axis.toml"))
        .expect("shipped plant");
    Rig::new(&config(), plant, &[])
}

fn commander_sends(rig: &mut Rig, position: f64) {
    rig.inject(
        SetpointPdo {
            position,
            axis_node_id: 16,
        }
        .encode(1),
    );
}

/// What the daemon's dictionary shows at 1003h sub `sub` (an SDO read sees the same).
fn read(rig: &Rig, sub: u8) -> Value {
    rig.lockstep
        .controller()
        .dictionary()
        .read(ObjectId::new(FIELD, sub))
        .expect("1003h is readable")
}

/// One SDO transfer with the daemon: the request goes in before the next cycle, the answer
/// comes out of it.
fn sdo_write(rig: &mut Rig, sub: u8, bytes: &[u8]) -> SdoOutcome {
    let mut client = SdoClient::new(1);
    let t = rig.lockstep.time_s();
    let request = client.start_download(ObjectId::new(FIELD, sub), bytes, t);
    rig.inject(request);
    rig.cycle();
    let answer = rig
        .lockstep
        .sent()
        .iter()
        .find(|f| f.id() == response_cob_id(1))
        .copied()
        .expect("the daemon answers in the next cycle");
    assert_eq!(client.handle(&answer, t), None, "an expedited answer");
    client.outcome().cloned().expect("the transfer ended")
}

/// The commander streams 5 mm from 0.1 s to 0.3 s, is quiet until 0.6 s, then sends 4 mm.
fn quiet_commander(rig: &mut Rig) {
    rig.run_until(0.1);
    while rig.lockstep.time_s() < 0.3 - 1e-9 {
        commander_sends(rig, 0.005);
        rig.cycle();
    }
    rig.run_until(0.6);
    commander_sends(rig, 0.004);
    rig.run_until(0.7);
}

#[test]
fn a_fault_raised_and_cleared_stays_in_1003h_through_the_state_file() {
    let mut rig = rig();
    assert_eq!(read(&rig, 0), Value::Unsigned8(0), "nothing at start");
    quiet_commander(&mut rig);
    let emcys = rig.emcys();
    let (lost_at, lost) = *emcys
        .iter()
        .find(|(_, e)| e.error_code == 0x8250)
        .expect("EMCY 8250h");
    assert!(
        emcys.iter().any(|(k, e)| e.error_code == 0 && *k > lost_at),
        "the commander's return is announced: {emcys:?}"
    );
    // Every EMCY that announced an error is in the field, newest first; the resets are not.
    let errors: Vec<_> = emcys
        .iter()
        .rev()
        .filter(|(_, e)| e.error_code != 0)
        .collect();
    eprintln!(
        "error history: EMCYs sent {:?}; 1003h holds {} entries",
        emcys
            .iter()
            .map(|(k, e)| format!("{:04X}h@{k}", e.error_code))
            .collect::<Vec<_>>(),
        errors.len()
    );
    assert_eq!(read(&rig, 0), Value::Unsigned8(errors.len() as u8));
    for (sub, (_, e)) in (1u8..).zip(&errors) {
        let field = u32::from(e.error_code)
            | u32::from(e.error_register) << 16
            | u32::from(e.axis_node_id) << 24;
        assert_eq!(read(&rig, sub), Value::Unsigned32(field), "sub {sub}");
    }
    let newest = rig.lockstep.controller().error_field().get(0).expect("one");
    assert_eq!(newest.error_code, 0x8250);
    assert_eq!(newest.additional_info >> 8, 16, "axis node 16");
    assert_eq!(
        newest.additional_info & 0xFF,
        u16::from(lost.error_register)
    );
    // Lock step has no wall clock: the entry carries the node's time of the cycle it went out,
    // which 2F01h shows beside it.
    assert_eq!(newest.time_s, lost_at as f64 * PERIOD_S);
    let time = rig
        .lockstep
        .controller()
        .dictionary()
        .read(ObjectId::new(0x2F01, 1))
        .expect("2F01h is readable");
    assert_eq!(time, Value::Real64(newest.time_s));
    // Past the entries the field holds, the subindexes read 0.
    assert_eq!(
        read(&rig, errors.len() as u8 + 1),
        Value::Unsigned32(0),
        "an empty entry"
    );

    // Through the state file's text into a new node, as a restart reads it.
    let text = StateFile::of_node(rig.lockstep.controller())
        .to_toml()
        .expect("toml");
    assert!(text.contains("[[error_history]]"), "{text}");
    let file = StateFile::from_toml(&text, Path::new("state.toml")).expect("reads back");
    let mut restarted = self::rig();
    let lines = state::restore(
        restarted.lockstep.controller_mut(),
        &file,
        Path::new("state.toml"),
    );
    assert!(
        lines
            .iter()
            .any(|l| l.contains(&format!("{} errors of earlier runs", errors.len()))),
        "{lines:?}"
    );
    restarted.cycle();
    for sub in 0..=errors.len() as u8 {
        assert_eq!(read(&restarted, sub), read(&rig, sub), "sub {sub}");
    }
    assert_eq!(
        restarted.lockstep.controller().error_field().get(0),
        Some(newest),
        "with its time"
    );
}

#[test]
fn sub_0_refuses_any_value_but_0_which_clears_the_field() {
    let mut rig = rig();
    quiet_commander(&mut rig);
    let held = read(&rig, 0);
    assert_ne!(held, Value::Unsigned8(0));
    let first = read(&rig, 1);

    // The commander keeps sending meanwhile, so no new error comes in between.
    commander_sends(&mut rig, 0.004);
    // CiA 301: any other value is refused as invalid (0609 0030h), and nothing changes.
    let refused = sdo_write(&mut rig, 0, &[1]).expect_err("refused");
    assert_eq!(refused.code().0, 0x0609_0030, "{refused}");
    assert_eq!((read(&rig, 0), read(&rig, 1)), (held, first));
    // The entries themselves are read-only.
    commander_sends(&mut rig, 0.004);
    let refused = sdo_write(&mut rig, 1, &[0, 0, 0, 0]).expect_err("refused");
    assert_eq!(refused.code().0, 0x0601_0002, "{refused}");

    // 0 clears it at the cycle boundary: sub 0 and every entry read 0, the node holds nothing.
    commander_sends(&mut rig, 0.004);
    sdo_write(&mut rig, 0, &[0]).expect("0 is taken");
    assert_eq!(read(&rig, 0), Value::Unsigned8(0));
    assert_eq!(read(&rig, 1), Value::Unsigned32(0));
    assert!(rig.lockstep.controller().error_field().is_empty());
    let file = StateFile::of_node(rig.lockstep.controller());
    assert!(
        file.error_history.is_empty(),
        "the clear reaches the state file"
    );
    assert!(!file.to_toml().expect("toml").contains("error_history"));

    // The commander goes quiet again: the next error is the only one.
    rig.run_until(0.9);
    assert_eq!(read(&rig, 0), Value::Unsigned8(1));
    assert_eq!(
        rig.lockstep
            .controller()
            .error_field()
            .get(0)
            .map(|e| e.error_code),
        Some(0x8250)
    );
}
