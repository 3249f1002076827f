//! Sections declared once (`[axis.observer]`, `[axis.adaptive_friction]`): their TOML keys,
//! defaults, range checks, dictionary entries and SDO writes all come from the one declaration,
//! and agree with each other.

use actuatord::canopen::od::Access as OdAccess;
use actuatord::canopen::{NmtState, Value};
use actuatord::control::AdaptiveFrictionSection;
use actuatord::daemon::config::{AxisConfig, Config};
use actuatord::daemon::dictionary;
use actuatord::param::{Access, Declared, Kind, COMMAND_UNIT};
use actuatord::supervise::ObserverSection;
use std::path::Path;

fn shipped() -> Config {
    Config::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml"))
        .expect("shipped config")
}

#[test]
fn the_toml_keys_are_the_declared_names_and_nothing_else() {
    let observer = shipped().axis[0].observer.clone().expect("observer");
    let mut text = String::new();
    for p in ObserverSection::PARAMS {
        match observer.get(p.name) {
            Some(v) if p.kind == Kind::Count => text.push_str(&format!("{} = {v}\n", p.name)),
            Some(v) => text.push_str(&format!("{} = {v:e}\n", p.name)),
            None => text.push_str(&format!("{} = {:?}\n", p.name, observer.poles)),
        }
    }
    let back: ObserverSection = toml::from_str(&text).expect("every declared key, once");
    assert_eq!(back, observer);
    let extra = format!("{text}residual_max = 1e-5\n");
    let err = toml::from_str::<ObserverSection>(&extra).expect_err("unknown key");
    assert!(err.to_string().contains("residual_max"), "{err}");
    let missing: String = text
        .lines()
        .filter(|l| !l.starts_with("residual_max_m"))
        .map(|l| format!("{l}\n"))
        .collect();
    let err = toml::from_str::<ObserverSection>(&missing).expect_err("missing key");
    assert!(err.to_string().contains("residual_max_m"), "{err}");
}

#[test]
fn writes_and_checks_follow_the_declared_ranges() {
    let mut o = shipped().axis[0].observer.clone().expect("observer");
    o.set("residual_max_m", 3e-5).expect("in range");
    assert_eq!(o.residual_max_m, 3e-5);
    let err = o.set("residual_max_m", 2e3).expect_err("above its range");
    assert_eq!(err.name, "residual_max_m");
    assert_eq!(o.residual_max_m, 3e-5, "a refused write changes nothing");
    assert!(o.set("learn_samples", 2.5).is_err(), "a count is whole");
    assert!(o.set("poles", 0.5).is_err(), "not a single number");
    assert!(o.set("no_such_key", 1.0).is_err());
    o.check().expect("the shipped values are in range");
    o.band_sigmas = 1e6;
    assert_eq!(o.check().expect_err("out of range").name, "band_sigmas");
    o.band_sigmas = 3.0;
    o.poles[2] = 1.5;
    assert_eq!(o.check().expect_err("a pole outside").name, "poles");
}

/// Every entry of section `S` in axis 0's dictionary is its declaration (name, unit, range,
/// documentation, access), and a value written over the dictionary lands in its field.
fn entries_and_writes_follow<S: Declared>(section: fn(&AxisConfig) -> Option<&S>, writable: usize) {
    let mut config = shipped();
    let command_unit = match config.axis[0].command {
        actuatord::daemon::config::CommandKind::Voltage => "V",
        _ => "",
    };
    let mut od = dictionary::build(&config).expect("dictionary");
    let declared_writable: Vec<_> = S::PARAMS
        .iter()
        .filter(|p| p.access == Access::PreOperational)
        .collect();
    assert_eq!(declared_writable.len(), writable);
    for p in S::PARAMS {
        let h = od.handle_by_name(Some(0), p.name);
        if p.access == Access::Restart {
            assert!(h.is_none(), "{} needs a restart: no entry", p.name);
            continue;
        }
        let e = od.entry(h.expect(p.name));
        let unit = if p.unit == COMMAND_UNIT {
            command_unit
        } else {
            p.unit
        };
        assert_eq!(e.unit, unit, "{}", p.name);
        assert_eq!(e.description, p.doc, "{}", p.name);
        assert_eq!(e.access, OdAccess::ReadWritePreOperational, "{}", p.name);
        assert_eq!(e.min.and_then(|v| v.as_f64()), Some(p.min), "{}", p.name);
        assert_eq!(
            e.max.and_then(|v| v.as_f64()),
            p.max.is_finite().then_some(p.max),
            "{}",
            p.name
        );
    }
    for p in declared_writable {
        let h = od.handle_by_name(Some(0), p.name).expect(p.name);
        let now = section(&config.axis[0]).and_then(|o| o.get(p.name));
        let wanted = match p.kind {
            Kind::Count => now.map(|v| v + 3.0),
            _ => now.map(|v| v * 1.5),
        }
        .expect("a number");
        let value = match od.entry(h).default {
            Value::Unsigned32(_) => Value::Unsigned32(wanted as u32),
            _ => Value::Real64(wanted),
        };
        od.stage_value(h, value, NmtState::PreOperational)
            .expect("within range");
        let writes: Vec<_> = od.take_pending_writes().collect();
        for w in &writes {
            dictionary::apply_write(&mut config, w).expect("applies");
        }
        let after = section(&config.axis[0]).and_then(|o| o.get(p.name));
        assert_eq!(after, Some(wanted), "{}", p.name);
    }
}

#[test]
fn the_observer_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<ObserverSection>(|a| a.observer.as_ref(), 7);
}

#[test]
fn the_adaptive_friction_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<AdaptiveFrictionSection>(|a| a.adaptive_friction.as_ref(), 6);
}

actuatord::declare_section! {
    /// A section with one required key and one defaulted key.
    pub struct ExampleSection {
        gain: f64 = { unit: "", min: 0.0, max: 10.0, access: PreOperational, doc: "" },
        band_m: f64 = {
            unit: "m", min: 0.0, max: 1.0, access: PreOperational, doc: "", default: 2e-6,
        },
    }
}

#[test]
fn a_declared_default_stands_in_for_a_missing_key_and_only_there() {
    let s: ExampleSection = toml::from_str("gain = 2.0\n").expect("band_m has a default");
    assert_eq!(s.band_m, 2e-6);
    let s: ExampleSection = toml::from_str("gain = 2.0\nband_m = 0.5\n").expect("both");
    assert_eq!(s.band_m, 0.5);
    let err = toml::from_str::<ExampleSection>("band_m = 0.5\n").expect_err("gain has none");
    assert!(err.to_string().contains("missing field `gain`"), "{err}");
    let err = toml::from_str::<ExampleSection>("gain = 1.0\nbnd_m = 0.5\n").expect_err("typo");
    assert!(err.to_string().contains("bnd_m"), "{err}");
}

#[test]
fn the_algorithm_and_the_configuration_use_one_name_for_the_compensation_limit() {
    // The shipped section goes to the algorithm as it is; the limit is enforced under the
    // configuration's name.
    let config = shipped();
    let mut c = config.axis[0]
        .adaptive_friction_config(0.0025)
        .expect("the shipped solenoid adapts its friction compensation");
    c.initial_pos = c.params.compensation_max * 2.0;
    let err = actuatord::control::AdaptiveFriction::new(c).expect_err("above the limit");
    assert!(err.to_string().contains("compensation_max"), "{err}");
}
