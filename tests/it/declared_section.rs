//! Sections declared once (`[axis.observer]`, `[axis.adaptive_friction]`,
//! `[axis.parameter_estimation]`, `[axis.dither]`): their TOML keys, defaults, range checks,
//! dictionary entries and SDO writes all come from the one declaration, and agree with each
//! other.

use actuatord::canopen::od::Access as OdAccess;
use actuatord::canopen::od::{Handle, ObjectId};
use actuatord::canopen::{NmtState, ObjectDictionary, Value};
use actuatord::control::{AdaptiveFrictionSection, DitherSection, FrictionCompensationSection};
use actuatord::daemon::config::{AxisConfig, Config};
use actuatord::daemon::dictionary;
use actuatord::device::objects::axis_intelligence::{
    ADAPTIVE_FRICTION, OBSERVER, PARAMETER_ESTIMATION,
};
use actuatord::device::objects::index;
use actuatord::param::{Access, Declared, Kind, COMMAND_UNIT, FORCE_PER_COMMAND_UNIT};
use actuatord::supervise::{LimitsSection, ObserverSection, ParameterEstimationSection};
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

/// The handle of entry `name` of the object at `offset` in axis 0's block (another section may
/// declare the same name).
fn entry_of(od: &ObjectDictionary, offset: u16, name: &str) -> Option<Handle> {
    (1..=u8::MAX)
        .map(|sub| od.handle(ObjectId::new(index::axis(0, offset), sub)))
        .take_while(Option::is_some)
        .flatten()
        .find(|h| od.entry(*h).name == name)
}

/// Every entry of section `S` (the object at `offset` of axis 0's block) is its declaration
/// (name, unit, range, documentation, access), and a value written over the dictionary lands
/// in its field.
fn entries_and_writes_follow<S: Declared>(
    section: fn(&AxisConfig) -> Option<&S>,
    offset: u16,
    writable: usize,
) {
    let mut config = shipped();
    // The shipped solenoid is a voltage axis (checked: the units below are a voltage's).
    assert_eq!(
        config.axis[0].command,
        actuatord::daemon::config::CommandKind::Voltage
    );
    let (command_unit, force_per_command) = ("V", "N/V");
    let mut od = dictionary::build(&config).expect("dictionary");
    let declared_writable: Vec<_> = S::PARAMS
        .iter()
        .filter(|p| p.access == Access::PreOperational)
        .collect();
    assert_eq!(declared_writable.len(), writable);
    for p in S::PARAMS {
        let h = entry_of(&od, offset, p.name);
        if p.access == Access::Restart {
            assert!(h.is_none(), "{} needs a restart: no entry", p.name);
            continue;
        }
        let e = od.entry(h.expect(p.name));
        let unit = match p.unit {
            COMMAND_UNIT => command_unit,
            FORCE_PER_COMMAND_UNIT => force_per_command,
            unit => unit,
        };
        assert_eq!(e.unit, unit, "{}", p.name);
        assert_eq!(e.description, p.doc, "{}", p.name);
        assert_eq!(e.access, OdAccess::ReadWritePreOperational, "{}", p.name);
        assert_eq!(
            e.min.and_then(|v| v.as_f64()),
            p.min.is_finite().then_some(p.min),
            "{}",
            p.name
        );
        assert_eq!(
            e.max.and_then(|v| v.as_f64()),
            p.max.is_finite().then_some(p.max),
            "{}",
            p.name
        );
    }
    for p in declared_writable {
        let h = entry_of(&od, offset, p.name).expect(p.name);
        let now = section(&config.axis[0]).and_then(|o| o.get(p.name));
        let wanted = match p.kind {
            Kind::Count => now.map(|v| if v + 3.0 <= p.max { v + 3.0 } else { v - 1.0 }),
            // Another value within the declared range.
            _ => now.map(|v| {
                if v * 1.5 <= p.max {
                    v * 1.5
                } else {
                    0.5 * (v + p.min)
                }
            }),
        }
        .expect("a number");
        let value = match od.entry(h).default {
            Value::Unsigned32(_) => Value::Unsigned32(wanted as u32),
            Value::Unsigned8(_) => Value::Unsigned8(wanted as u8),
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
    entries_and_writes_follow::<ObserverSection>(|a| a.observer.as_ref(), OBSERVER, 7);
}

#[test]
fn the_adaptive_friction_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<AdaptiveFrictionSection>(
        |a| a.adaptive_friction.as_ref(),
        ADAPTIVE_FRICTION,
        7,
    );
}

#[test]
fn a_declared_command_unit_follows_the_axis_command() {
    use actuatord::daemon::config::CommandKind;
    for (command, unit) in [
        (CommandKind::Voltage, "V"),
        (CommandKind::Duty, ""),
        (CommandKind::Torque, "N m"),
        (CommandKind::Velocity, "m/s"),
    ] {
        let mut config = shipped();
        config.axis[0].command = command;
        // Within a duty's bounds, so that every command kind takes them.
        config.axis[0].controller.output_min = 0.0;
        config.axis[0].controller.output_max = 1.0;
        config.axis[0].safe_command = 0.0;
        let od = dictionary::build(&config).expect("dictionary");
        let h = entry_of(&od, ADAPTIVE_FRICTION, "compensation_max").expect("declared entry");
        assert_eq!(od.entry(h).unit, unit, "{command:?}");
        let h = od.handle_by_name(Some(0), "safe_command").expect("entry");
        assert_eq!(od.entry(h).unit, unit, "{command:?}");
    }
}

#[test]
fn the_friction_compensation_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<FrictionCompensationSection>(
        |a| a.friction_compensation.as_ref(),
        index::FRICTION_COMPENSATION,
        5,
    );
}

#[test]
fn a_friction_compensation_write_to_an_axis_without_one_starts_from_neutral() {
    let mut config = shipped();
    config.axis[0].friction_compensation = None;
    let mut od = dictionary::build(&config).expect("dictionary");
    let enabled = entry_of(&od, index::FRICTION_COMPENSATION, "enabled").expect("entry");
    assert_eq!(od.value(enabled), Value::Boolean(false));
    let h = entry_of(&od, index::FRICTION_COMPENSATION, "coulomb_pos_n").expect("entry");
    od.stage_value(h, Value::Real64(0.3), NmtState::PreOperational)
        .expect("within range");
    for w in od.take_pending_writes().collect::<Vec<_>>() {
        dictionary::apply_write(&mut config, &w).expect("applies");
    }
    let f = config.axis[0]
        .friction_compensation
        .clone()
        .expect("created by the write");
    assert_eq!(
        f,
        FrictionCompensationSection {
            coulomb_pos_n: 0.3,
            ..FrictionCompensationSection::neutral()
        }
    );
    // Neutral: no compensation in either direction but the one written.
    let ff = FrictionCompensationSection::neutral().feed_forward();
    assert_eq!((ff.compensation(1.0), ff.compensation(-1.0)), (0.0, 0.0));
}

#[test]
fn the_limits_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<LimitsSection>(|a| Some(&a.limits), index::LIMITS, 13);
}

#[test]
fn a_limit_left_out_is_an_infinite_bound_in_the_dictionary_and_back() {
    let mut config = shipped();
    config.axis[0].limits.current_max_a = None;
    let mut od = dictionary::build(&config).expect("dictionary");
    let h = entry_of(&od, index::LIMITS, "current_max_a").expect("entry");
    assert_eq!(od.value(h), Value::Real64(f64::INFINITY), "not watched");
    od.stage_value(h, Value::Real64(2.5), NmtState::PreOperational)
        .expect("within range");
    let h = entry_of(&od, index::LIMITS, "position_min_m").expect("entry");
    od.stage_value(
        h,
        Value::Real64(f64::NEG_INFINITY),
        NmtState::PreOperational,
    )
    .expect("an open bound");
    for w in od.take_pending_writes().collect::<Vec<_>>() {
        dictionary::apply_write(&mut config, &w).expect("applies");
    }
    assert_eq!(config.axis[0].limits.current_max_a, Some(2.5));
    assert_eq!(
        config.axis[0].limits.position_min_m, None,
        "no longer watched"
    );

    // In the file, "not watched" is a key left out; an infinite value is refused by name.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config");
    let bad = text.replacen(
        "[axis.limits]\n",
        "[axis.limits]\nheartbeat_timeout_s = inf\n",
        1,
    );
    let bad = if text.contains("\nheartbeat_timeout_s") {
        // The shipped file sets it: drop its own line so the key is given once.
        let own = text
            .lines()
            .find(|l| l.starts_with("heartbeat_timeout_s"))
            .expect("line");
        bad.replacen(&format!("{own}\n"), "", 1)
    } else {
        bad
    };
    let err = Config::from_toml(&bad, &path).expect_err("infinite");
    assert!(
        err.to_string()
            .contains("limits.heartbeat_timeout_s must be finite"),
        "{err}"
    );
}

/// The axis' own writable keys are declared with the objects they are entries of, and
/// `[[axis]]` borrows those declarations: the key, its entry and its SDO write agree.
#[test]
fn the_axis_own_entries_and_sdo_writes_are_the_declaration() {
    use actuatord::device::objects::{AxisKeys, SetpointKeys};
    let mut config = shipped();
    let mut od = dictionary::build(&config).expect("dictionary");
    for (offset, params) in [
        (index::AXIS, AxisKeys::PARAMS),
        (index::SETPOINT, SetpointKeys::PARAMS),
    ] {
        for p in params {
            assert_eq!(
                AxisConfig::spec(p.name),
                Some(p),
                "[[axis]] borrows {}",
                p.name
            );
            let e = od.entry(entry_of(&od, offset, p.name).expect(p.name));
            assert_eq!(e.description, p.doc, "{}", p.name);
            assert_eq!(e.access, OdAccess::ReadWritePreOperational, "{}", p.name);
        }
    }
    let safe = actuatord::param_key!(AxisConfig, safe_command);
    let rate = actuatord::param_key!(AxisConfig, setpoint_rate_max_m_per_s);
    let h = entry_of(&od, index::AXIS, safe).expect("entry");
    assert_eq!(od.entry(h).unit, "V", "the command's unit");
    assert_eq!(
        od.entry(h).max,
        Some(Value::Real64(1000.0)),
        "the command's bound"
    );
    od.stage_value(h, Value::Real64(1.5), NmtState::PreOperational)
        .expect("within range");
    let h = entry_of(&od, index::SETPOINT, rate).expect("entry");
    assert_eq!(od.value(h), Value::Real64(f64::INFINITY), "steps");
    od.stage_value(h, Value::Real64(0.25), NmtState::PreOperational)
        .expect("within range");
    for w in od.take_pending_writes().collect::<Vec<_>>() {
        dictionary::apply_write(&mut config, &w).expect("applies");
    }
    assert_eq!(config.axis[0].safe_command, 1.5);
    assert_eq!(config.axis[0].setpoint_rate_max_m_per_s, Some(0.25));
    od.stage_value(h, Value::Real64(f64::INFINITY), NmtState::PreOperational)
        .expect("steps again");
    for w in od.take_pending_writes().collect::<Vec<_>>() {
        dictionary::apply_write(&mut config, &w).expect("applies");
    }
    assert_eq!(config.axis[0].setpoint_rate_max_m_per_s, None, "steps");
}

#[test]
fn the_parameter_estimation_entries_and_sdo_writes_are_the_declaration() {
    entries_and_writes_follow::<ParameterEstimationSection>(
        |a| a.parameter_estimation.as_ref(),
        PARAMETER_ESTIMATION,
        5,
    );
}

#[test]
fn a_write_lands_in_the_section_of_its_object_when_two_declare_the_name() {
    // Both the observer and the estimation declare moving_speed_m_per_s; the observer's is
    // writable, the estimation's needs a reload. A write to the observer's entry changes only it.
    assert!(ObserverSection::spec("moving_speed_m_per_s").is_some());
    assert!(ParameterEstimationSection::spec("moving_speed_m_per_s").is_some());
    let mut config = shipped();
    let before = config.axis[0].parameter_estimation.clone();
    let observer = config.axis[0].observer.clone().expect("observer");
    let mut od = dictionary::build(&config).expect("dictionary");
    let h = entry_of(&od, OBSERVER, "moving_speed_m_per_s").expect("the observer's entry");
    assert!(entry_of(&od, PARAMETER_ESTIMATION, "moving_speed_m_per_s").is_none());
    let wanted = observer.moving_speed_m_per_s * 2.0;
    od.stage_value(h, Value::Real64(wanted), NmtState::PreOperational)
        .expect("within range");
    for w in od.take_pending_writes().collect::<Vec<_>>() {
        dictionary::apply_write(&mut config, &w).expect("applies");
    }
    let after = config.axis[0].observer.as_ref().expect("observer");
    assert_eq!(after.moving_speed_m_per_s, wanted);
    assert_eq!(config.axis[0].parameter_estimation, before);
}

#[test]
fn the_estimation_rules_are_the_declared_ranges() {
    let config = shipped();
    let section = config.axis[0]
        .parameter_estimation
        .clone()
        .expect("the shipped solenoid diagnoses");
    section.check().expect("the shipped values are in range");
    let spec = ParameterEstimationSection::spec("max_distance").expect("declared");
    assert_eq!((spec.kind, spec.bits), (Kind::Count, 8));
    let spec = ParameterEstimationSection::spec("fault_table").expect("declared");
    assert_eq!((spec.kind, spec.optional), (Kind::Path, true));
    assert!(!section.present("fault_table") && section.present("window_updates"));

    let mut s = section.clone();
    assert!(
        s.set("window_updates", 9.0).is_err(),
        "six parameters need ten updates"
    );
    assert!(
        s.set("max_distance", 7.0).is_err(),
        "there are six symptoms"
    );
    s.set("max_distance", 6.0).expect("in range");
    assert_eq!(s.max_distance, 6);
    let mut s = section.clone();
    s.relative_floor[4] = -0.1;
    assert_eq!(
        s.check().expect_err("a negative floor").name,
        "relative_floor"
    );
    s.relative_floor[4] = f64::INFINITY;
    s.check().expect("inf: not judged");

    // Over the whole configuration, the error names the section and key.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config");
    let bad = text.replacen(
        "[axis.parameter_estimation]\n",
        "[axis.parameter_estimation]\nnominal = { current_time_constant_s = 0.01, \
         damping_ratio = 0.5, natural_frequency_rad_per_s = inf, static_gain_m_per_v = 1e-3, \
         coulomb_friction_n = 0.5, pretension_n = 1.0 }\n",
        1,
    );
    let err = Config::from_toml(&bad, &path).expect_err("an infinite nominal value");
    assert!(
        err.to_string()
            .contains("parameter_estimation.nominal must be a finite number, got inf"),
        "{err}"
    );
}

#[test]
fn dither_keys_are_optional_until_adaptation_needs_them() {
    let fixed: DitherSection =
        toml::from_str("amplitude = 0.5\nfrequency_hz = 50.0\n").expect("a fixed dither");
    assert!(!fixed.adapt);
    assert_eq!(fixed.amplitude_min, None);
    assert!(!fixed.present("amplitude_min"));
    fixed
        .check_adaptation()
        .expect("nothing more is needed without adaptation");
    let c = fixed.config(0.0025);
    assert_eq!((c.amplitude_min, c.amplitude_max), (0.5, 0.5));
    assert_eq!((c.frequency_min_hz, c.frequency_max_hz), (50.0, 50.0));

    let optional: Vec<_> = DitherSection::PARAMS
        .iter()
        .filter(|p| p.optional)
        .map(|p| p.name)
        .collect();
    assert_eq!(optional.len(), 10);
    assert!(DitherSection::PARAMS
        .iter()
        .all(|p| p.access == Access::Restart));
    let mut text = String::from("amplitude = 0.5\nfrequency_hz = 50.0\nadapt = true\n");
    for (k, name) in optional.iter().enumerate() {
        let adapting: DitherSection = toml::from_str(&text).expect("parses");
        let err = adapting.check_adaptation().expect_err("a key is missing");
        assert_eq!(err.name, *name, "the first missing key is named");
        // Values in range for every key (the rates and bands are not judged here).
        text.push_str(&format!("{name} = {}\n", 10.0 + k as f64));
    }
    let adapting: DitherSection = toml::from_str(&text).expect("parses");
    adapting.check_adaptation().expect("every key given");
    assert_eq!(adapting.ripple_max_m, Some(18.0));

    let mut negative = fixed.clone();
    negative.amplitude = -1.0;
    assert_eq!(negative.check().expect_err("negative").name, "amplitude");
    negative.amplitude = 0.5;
    negative.ripple_max_m = Some(0.0);
    assert_eq!(negative.check().expect_err("zero").name, "ripple_max_m");
    let err = toml::from_str::<DitherSection>("amplitude = 0.5\nfrequency = 50.0\n")
        .expect_err("misspelled key");
    assert!(err.to_string().contains("frequency"), "{err}");
}

#[test]
fn a_config_names_the_dither_key_adaptation_needs() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let text = std::fs::read_to_string(&path).expect("shipped config");
    let with = format!(
        "{text}\n[axis.dither]\namplitude = 0.5\nfrequency_hz = 50.0\nadapt = true\n\
         amplitude_min = 0.1\n"
    );
    let err = Config::from_toml(&with, &path).expect_err("adaptation needs its bands");
    assert!(
        err.to_string()
            .ends_with("dither.amplitude_max is needed with adapt = true"),
        "{err}"
    );
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

#[test]
fn the_sections_a_reload_changes_take_their_declared_defaults_and_ranges() {
    use actuatord::control::{CorrectionSection, LearnedTableSection, PneumaticAdaptiveSection};
    let t: LearnedTableSection =
        toml::from_str("position_edges_m = [0.0, 0.01]\nsupply_voltage_edges_v = [20.0, 30.0]\n")
            .expect("the rest has defaults");
    assert_eq!(
        (t.averaging_count, t.min_count, t.learn_interval_s),
        (20, 3, 1.0)
    );
    assert_eq!(t.supply_pressure_edges_pa, None);
    t.check().expect("in range");
    for bad in [0.0, f64::INFINITY] {
        let mut t = t.clone();
        t.learn_interval_s = bad;
        assert_eq!(t.check().expect_err("refused").name, "learn_interval_s");
    }
    assert!(
        LearnedTableSection::defaults().is_none(),
        "the edges have no default"
    );
    let err = toml::from_str::<LearnedTableSection>("supply_voltage_edges_v = [20.0, 30.0]\n")
        .expect_err("the position edges are needed");
    assert!(err.to_string().contains("position_edges_m"), "{err}");

    let c: CorrectionSection = toml::from_str(
        "pole_m = 0.03\nc0 = 1.0\nc1_per_m = 10.0\nreference_position_m = 0.01\nmin_gain_ratio = 0.2\n",
    )
    .expect("c2 has a default");
    assert_eq!(c.c2_per_m2, 0.0);

    let text = "forgetting = 0.975\nmin_duty = 0.05\nmin_position_step_m = 1e-5\nmin_updates = 3\n\
                eigenvalue_valid = 0.5\ndrive_gain_min_m_per_s = 0.01\n";
    let err = toml::from_str::<PneumaticAdaptiveSection>(text).expect_err("one key is missing");
    assert!(err.to_string().contains("drive_gain_max_m_per_s"), "{err}");
    let full = format!("{text}drive_gain_max_m_per_s = 1.0\n");
    let p: PneumaticAdaptiveSection = toml::from_str(&full).expect("every key");
    assert_eq!(p.min_updates, 3);
    let err = toml::from_str::<PneumaticAdaptiveSection>(&format!("{full}forgeting = 0.9\n"))
        .expect_err("misspelled");
    assert!(err.to_string().contains("forgeting"), "{err}");
}

#[test]
fn the_schedule_factors_follow_their_declared_ranges() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let config = shipped();
    let s = config.axis[0]
        .schedule
        .clone()
        .expect("the shipped solenoid is scheduled");
    s.check().expect("in range");
    let text = std::fs::read_to_string(&path).expect("shipped config");
    let line = |key: &str| {
        text.lines()
            .find(|l| l.starts_with(&format!("{key} =")))
            .map(str::to_string)
            .expect("the shipped schedule has the key")
    };
    let points = s.gain_factor.as_ref().expect("gain_factor").len();
    let column = |v: f64| {
        let mut c = vec![1.0; points];
        c[0] = v;
        format!("{c:?}")
    };
    for (key, value, rule) in [
        ("gain_factor", 0.0, "must be a finite number > 0, got 0"),
        (
            "command_limit_factor",
            1.5,
            "must be a number in (0, 1], got 1.5",
        ),
        (
            "command_limit_factor",
            0.0,
            "must be a number in (0, 1], got 0",
        ),
    ] {
        let bad = text.replacen(&line(key), &format!("{key} = {}", column(value)), 1);
        let err = Config::from_toml(&bad, &path).expect_err("out of range");
        assert!(
            err.to_string().ends_with(&format!("schedule.{key} {rule}")),
            "{err}"
        );
    }
}

/// `[axis.controller]`: the coefficient arrays are one entry per slot, named by the declaration,
/// in its order, with its unit, range and documentation; a write reaches its slot, a zero written
/// to the last one shortens the array (never below the one coefficient `q_per_m` needs), and the
/// output limits are bounded by the command's range.
#[test]
fn the_controller_entries_and_sdo_writes_are_the_declaration() {
    use actuatord::control::ControllerSection;
    let mut config = shipped();
    let mut od = dictionary::build(&config).expect("dictionary");
    let at = |od: &ObjectDictionary, sub: u8| {
        od.entry(
            od.handle(ObjectId::new(index::axis(0, index::CONTROLLER), sub))
                .expect("entry"),
        )
        .clone()
    };
    let mut sub = 1;
    for p in ControllerSection::PARAMS {
        if p.access == Access::Restart {
            assert!(p.points.is_empty(), "{}", p.name);
            continue;
        }
        let names: Vec<&str> = if p.points.is_empty() {
            vec![p.name]
        } else {
            p.points.to_vec()
        };
        for name in names {
            let e = at(&od, sub);
            assert_eq!(e.name, name);
            assert_eq!(e.description, p.doc, "{name}");
            assert_eq!(e.access, OdAccess::ReadWritePreOperational, "{name}");
            sub += 1;
        }
    }
    assert_eq!(sub, 15, "6 + 6 coefficients and 2 limits");
    assert_eq!(at(&od, 1).unit, "V/m");
    assert_eq!(at(&od, 1).max.and_then(|v| v.as_f64()), Some(1e12));
    assert_eq!(
        at(&od, 4).default,
        Value::Real64(0.0),
        "q3: a slot not used"
    );
    assert_eq!(at(&od, 13).max.and_then(|v| v.as_f64()), Some(1000.0));

    let write = |od: &mut ObjectDictionary, config: &mut Config, name: &str, v: f64| {
        let h = entry_of(od, index::CONTROLLER, name).expect(name);
        od.stage_value(h, Value::Real64(v), NmtState::PreOperational)
            .expect("within range");
        for w in od.take_pending_writes().collect::<Vec<_>>() {
            dictionary::apply_write(config, &w).expect("applies");
        }
    };
    write(&mut od, &mut config, "q4_per_m", 7.0);
    assert_eq!(
        config.axis[0].controller.q_per_m,
        [2231.0, -4204.0, 2000.0, 0.0, 7.0]
    );
    write(&mut od, &mut config, "q4_per_m", 0.0);
    assert_eq!(config.axis[0].controller.q_per_m, [2231.0, -4204.0, 2000.0]);
    write(&mut od, &mut config, "p2", 0.0);
    write(&mut od, &mut config, "p1", 0.0);
    assert!(config.axis[0].controller.p.is_empty(), "p may be empty");
    for name in ["q2_per_m", "q1_per_m", "q0_per_m"] {
        write(&mut od, &mut config, name, 0.0);
    }
    assert_eq!(config.axis[0].controller.q_per_m, [0.0], "q keeps one");
    write(&mut od, &mut config, "output_max", 12.0);
    assert_eq!(config.axis[0].controller.output_max, 12.0);
    let mut c = config.axis[0].controller.clone();
    assert!(c.set("q6_per_m", 1.0).is_err(), "no such slot");
    assert_eq!(
        c.set("q1_per_m", 2e12).expect_err("beyond the range").name,
        "q_per_m"
    );
}

/// A choice key (`[axis.fault_reactions]`, `[bus] on_loss`): its declaration lists the values the
/// file takes, a misspelled one is refused with that list, and each value reaches the fault
/// machine or the node.
#[test]
fn choice_keys_list_their_values_and_refuse_others() {
    use actuatord::daemon::config::{BusConfig, BusLossPolicy, FaultReactionsSection};
    use actuatord::supervise::{Reaction, SupervisedFault};
    for p in FaultReactionsSection::PARAMS {
        assert_eq!(p.kind, Kind::Choice, "{}", p.name);
        assert_eq!(
            p.choices,
            [
                "warning",
                "maintenance_requested",
                "halt",
                "quick_stop",
                "fail_safe"
            ]
        );
        assert!(p.optional && p.access == Access::Restart, "{}", p.name);
    }
    let spec = BusConfig::spec("on_loss").expect("declared");
    assert_eq!(spec.choices_text(), "`safe_state` or `continue`");
    let err = toml::from_str::<FaultReactionsSection>("current_gain = \"shrug\"")
        .expect_err("not a reaction");
    assert!(
        err.to_string().contains(
            "expected one of `warning`, `maintenance_requested`, `halt`, `quick_stop`, `fail_safe`"
        ),
        "{err}"
    );
    let r: FaultReactionsSection =
        toml::from_str("current_gain = \"warning\"\nsensor_offset = \"fail_safe\"").expect("ok");
    let machine = r.machine_config();
    let reaction = |f| {
        machine
            .policies
            .iter()
            .find(|p| p.fault == f)
            .map(|p| p.reaction)
    };
    assert_eq!(
        reaction(SupervisedFault::CurrentGain),
        Some(Reaction::Warning)
    );
    assert_eq!(
        reaction(SupervisedFault::SensorOffset),
        Some(Reaction::FailSafe)
    );
    // Left out: the fault machine's default.
    assert_eq!(
        reaction(SupervisedFault::SpringPretension),
        Some(Reaction::Maintenance)
    );
    let bus: BusConfig = toml::from_str("iface = \"can1\"\non_loss = \"continue\"").expect("ok");
    assert_eq!(bus.on_loss, BusLossPolicy::Continue);
    assert_eq!(bus.on_loss.name(), "continue");
    assert_eq!(
        (bus.bitrate_bps, bus.max_load),
        (500_000, 0.7),
        "declared defaults"
    );
}

/// The schedule's read-only view: one entry per point of each column the axis has, named by the
/// declaration, read-only, with the declared unit.
#[test]
fn the_schedule_view_is_the_declaration() {
    use actuatord::control::ScheduleSection;
    use actuatord::device::objects::axis_intelligence::SCHEDULE;
    let config = shipped();
    let s = config.axis[0]
        .schedule
        .clone()
        .expect("the solenoid schedules");
    let supply = s.supply_voltage_v.clone().expect("on the supply voltage");
    let od = dictionary::build(&config).expect("dictionary");
    let points = entry_of(&od, SCHEDULE, "points").expect("count");
    assert_eq!(od.value(points), Value::Unsigned8(supply.len() as u8));
    let mut shown = 0;
    for p in ScheduleSection::PARAMS {
        for (k, name) in p.points.iter().enumerate() {
            let Some(v) = s.point(p.name, k) else {
                continue;
            };
            let e = od.entry(entry_of(&od, SCHEDULE, name).expect(name));
            assert_eq!(e.access, OdAccess::ReadOnly, "{name}");
            assert_eq!(e.unit, p.unit, "{name}");
            assert_eq!(e.default, Value::Real64(v), "{name}");
            shown += 1;
        }
    }
    assert_eq!(shown, 2 * supply.len(), "the supply and the gain factor");
}

/// The axis' own keys: the TOML keys are the declared fields, and their ranges are the rules
/// the configuration applies, with the wording its users know.
#[test]
fn the_axis_own_keys_are_declared() {
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml"))
            .expect("shipped config");
    let id = AxisConfig::spec("actuator_node_id").expect("declared");
    assert_eq!((id.min, id.max), (1.0, 127.0));
    let bad = text.replace("actuator_node_id = 16", "actuator_node_id = 0");
    let err = Config::from_toml(&bad, Path::new("x.toml")).expect_err("node id 0");
    assert_eq!(
        err.to_string(),
        "x.toml: [[axis]] #1 (solenoid) actuator_node_id must be a node id in 1..=127, got 0"
    );
    let bad = text.replace(
        "actuator_node_id = 16",
        "actuator_node_id = 16\nsetpoint_rate_max_m_per_s = -0.5",
    );
    let err = Config::from_toml(&bad, Path::new("x.toml")).expect_err("a negative rate");
    assert!(
        err.to_string()
            .ends_with("setpoint_rate_max_m_per_s must be > 0, got -0.5"),
        "{err}"
    );
    let spec = AxisConfig::spec("command").expect("declared");
    assert_eq!(
        spec.choices,
        ["voltage", "duty", "torque", "velocity", "position"]
    );
    let a = &shipped().axis[0];
    assert!(a.start_node, "declared default");
    assert!(!a.present("setpoint_rate_max_m_per_s"));
}

fn load_with(file: &str, from: &str, to: &str) -> Result<Config, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(file)).expect("shipped config");
    assert!(text.contains(from), "{file} holds {from}");
    Config::from_toml(&text.replacen(from, to, 1), Path::new("axis.toml"))
        .map_err(|e| e.to_string())
}

#[test]
fn the_profile_sections_are_checked_by_their_declarations() {
    use actuatord::daemon::profile_config::{Cia401Section, Cia402Section};
    assert!(Cia402Section::PARAMS
        .iter()
        .all(|p| p.access == Access::Restart));
    let drive = "config/cia402_linear_axis.toml";
    let err = load_with(
        drive,
        "velocity_m_per_s_per_unit = 1e-6",
        "velocity_m_per_s_per_unit = 0.0",
    )
    .expect_err("a zero scale");
    assert!(
        err.contains("cia402.velocity_m_per_s_per_unit must be finite and non-zero, got 0"),
        "{err}"
    );
    // A negative scale says the sensor counts the other way: it is taken.
    let c = load_with(
        drive,
        "position_m_per_inc = 1e-6",
        "position_m_per_inc = -1e-6",
    )
    .expect("a negative scale");
    let d = c.axis[0].cia402.as_ref().expect("cia402");
    assert_eq!(d.position_m_per_inc, -1e-6);
    assert_eq!(d.startup_timeout_s, 5.0, "the declared default");
    let err = load_with(
        drive,
        "dc_link_v_per_unit = 0.001",
        "dc_link_v_per_unit = 0.001\nstartup_timeout_s = 0.0",
    )
    .expect_err("no time to wait");
    assert!(
        err.contains("cia402.startup_timeout_s must be > 0, got 0"),
        "{err}"
    );

    assert!(Cia401Section::spec("position_input").is_some());
    let module = "config/cia401_solenoid.toml";
    let err =
        load_with(module, "command_output = 1", "command_output = 255").expect_err("no channel");
    assert!(
        err.contains("cia401.command_output must be a channel (subindex) in 1..=254, got 255"),
        "{err}"
    );
    // A scale is needed only where its channel is wired.
    let err = load_with(module, "supply_per_count = 0.001", "supply_per_count = 0.0")
        .expect_err("a wired supply without a scale");
    assert!(
        err.contains("cia401.supply_per_count must be finite and non-zero, got 0"),
        "{err}"
    );
    let c = load_with(module, "supply_input = 3", "").expect("supply not wired");
    assert_eq!(
        c.axis[0].cia401.as_ref().expect("cia401").supply_input,
        None
    );
    let err = load_with(module, "supply_input = 3", "supply_input = 1").expect_err("twice");
    assert!(
        err.contains("cia401.supply_input analog input 1 is already used"),
        "{err}"
    );
}

#[test]
fn a_setpoint_step_is_checked_by_its_declaration_and_placed_at_its_own_entry() {
    let file = "config/solenoid.toml";
    let err = load_with(file, "at_s = 1.0", "at_s = -1.0").expect_err("before the start");
    assert!(
        err.contains("setpoints #1 at_s must be >= 0 and not earlier than the one before, got -1"),
        "{err}"
    );
    let err = load_with(file, "at_s = 2.0", "at_s = 0.5").expect_err("out of order");
    assert!(
        err.contains("setpoints #2 at_s must be >= 0 and not earlier than the one before, got 0.5"),
        "{err}"
    );
    let err = load_with(file, "position_m = 0.0102", "position_m = inf").expect_err("infinite");
    assert!(
        err.contains("setpoints #2 position_m must be a finite number, got inf"),
        "{err}"
    );
    // A key missing from the second entry is shown at that entry, not at the first.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join(file)).expect("shipped config");
    let second = text
        .lines()
        .position(|l| l == "at_s = 2.0")
        .expect("a second step");
    let err = load_with(file, "position_m = 0.0102", "").expect_err("no position");
    assert!(err.contains("missing field `position_m`"), "{err}");
    assert!(err.contains(&format!("line {second},")), "{err}");
}
