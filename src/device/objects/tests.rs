use super::*;
use crate::canopen::od::*;
use crate::canopen::NmtState;

const PRE: NmtState = NmtState::PreOperational;
const OP: NmtState = NmtState::Operational;

fn solenoid() -> AxisParameters {
    AxisParameters {
        name: "solenoid".into(),
        controller: crate::control::ControllerSection {
            q_per_m: vec![2231.0, -4204.0, 2000.0],
            p: vec![-1.616, 0.616],
            output_min: 0.0,
            output_max: 24.0,
            ..AxisParameters::default().controller
        },
        initial_setpoint_m: 0.005,
        limits: crate::supervise::LimitsSection {
            position_min_m: Some(-0.0005),
            position_max_m: Some(0.0255),
            heartbeat_timeout_s: Some(0.5),
            ..AxisParameters::default().limits
        },
        ..AxisParameters::default()
    }
}

#[test]
fn daemon_dictionary_has_the_standard_and_axis_objects() {
    let axes = [solenoid(), AxisParameters::default()];
    let od = daemon_dictionary(&DeviceParameters::default(), &axes).expect("fits");
    for index in [
        0x1000, 0x1001, 0x1008, 0x100A, 0x1016, 0x1017, 0x1018, 0x1200, 0x2F00,
    ] {
        assert!(od.object(index).is_some(), "{index:04X}");
    }
    for axis in 0..2 {
        for offset in [0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x10] {
            let o = od.object(index::axis(axis, offset)).expect("axis object");
            assert_eq!(o.axis, Some(axis));
            assert_eq!(index::split(o.index), Some((axis, offset)));
        }
    }
    let q0 = od.handle_by_name(Some(0), "q0_per_m").expect("q0");
    assert_eq!(od.value(q0), Value::Real64(2231.0));
    assert_eq!(od.entry(q0).access, Access::ReadWritePreOperational);
    assert_eq!(
        od.read(ObjectId::new(0x1016, 1)),
        Ok(Value::Unsigned32((16 << 16) | 500))
    );
    assert_eq!(
        od.read(ObjectId::new(0x1016, 2)),
        Ok(Value::Unsigned32(16 << 16))
    );
    assert_eq!(
        od.read(ObjectId::new(0x1200, 1)),
        Ok(Value::Unsigned32(0x601))
    );
    assert_eq!(
        od.read(ObjectId::new(0x2000, 1)),
        Ok(Value::string("solenoid").expect("ascii"))
    );
    // Within an axis (and node-wide), every entry name is unique, so (axis, name) finds it.
    for e in od.entries() {
        if e.id.sub == 0
            && od
                .object(e.id.index)
                .is_some_and(|o| o.kind != ObjectKind::Var)
        {
            continue;
        }
        assert_eq!(
            od.handle_by_name(e.axis, e.name).map(|h| od.entry(h).id),
            Some(e.id)
        );
    }
    // Results are read-only; learned results and statistics too.
    for name in [
        "friction_compensation",
        "drive_gain_down",
        "observer_x4_neg",
        "fault_state",
    ] {
        let h = od.handle_by_name(Some(1), name).expect(name);
        assert_eq!(od.entry(h).access, Access::ReadOnly, "{name}");
    }
}

#[test]
fn safety_relevant_objects_are_refused_while_operational() {
    let mut od = daemon_dictionary(&DeviceParameters::default(), &[solenoid()]).expect("fits");
    let q0 = ObjectId::new(0x2001, 1);
    let bytes = 2000.0f64.to_le_bytes();
    assert_eq!(od.stage_write(q0, &bytes, OP), Err(OdError::RefusedInState));
    assert_eq!(od.stage_write(q0, &bytes, PRE), Ok(()));
    // The setpoint is a plain rw entry, bounded by the travel.
    let sp = ObjectId::new(0x2004, 1);
    assert_eq!(od.stage_write(sp, &0.01f64.to_le_bytes(), OP), Ok(()));
    assert_eq!(
        od.stage_write(sp, &0.03f64.to_le_bytes(), OP),
        Err(OdError::TooHigh)
    );
    // output_min must stay below output_max.
    assert_eq!(
        od.stage_write(ObjectId::new(0x2001, 13), &30.0f64.to_le_bytes(), PRE),
        Err(OdError::TooHigh)
    );
}

#[test]
fn too_many_axes_or_a_long_name_are_build_errors() {
    let many = vec![AxisParameters::default(); MAX_AXES + 1];
    assert!(daemon_dictionary(&DeviceParameters::default(), &many).is_err());
    let long = AxisParameters {
        name: "x".repeat(STRING_CAPACITY + 1),
        ..AxisParameters::default()
    };
    assert!(daemon_dictionary(&DeviceParameters::default(), &[long]).is_err());
    let all = vec![AxisParameters::default(); MAX_AXES];
    assert!(daemon_dictionary(&DeviceParameters::default(), &all).is_ok());
}

#[test]
fn lookup_takes_an_address_or_a_name() {
    let od = daemon_dictionary(&DeviceParameters::default(), &[solenoid()]).expect("fits");
    let id = |text: &str| od.lookup(text).map(|h| od.entry(h).id);
    assert_eq!(id("2001:1"), Ok(ObjectId::new(0x2001, 1)));
    assert_eq!(
        id("axis0_controller.q0_per_m"),
        Ok(ObjectId::new(0x2001, 1))
    );
    assert_eq!(id("producer_heartbeat_time"), Ok(ObjectId::new(0x1017, 0)));
    assert_eq!(id("identity.serial_number"), Ok(ObjectId::new(0x1018, 4)));
    assert_eq!(id("identity"), Err(OdError::NoSubIndex));
    assert_eq!(id("axis0_controller.q9"), Err(OdError::NoSubIndex));
    assert_eq!(id("nothing.here"), Err(OdError::NoObject));
    assert_eq!(id("3000:0"), Err(OdError::NoObject));
}

#[test]
fn one_row_per_entry_with_a_header() {
    let od = daemon_dictionary(&DeviceParameters::default(), &[AxisParameters::default()])
        .expect("defaults fit the table");
    let table = markdown_table(&od);
    let rows = table.lines().count();
    // Every ARRAY and RECORD has a sub 0 that only counts, but 1003h's, which clears.
    let subzero = od
        .objects()
        .iter()
        .filter(|o| o.kind != ObjectKind::Var)
        .count()
        - 1;
    assert_eq!(rows, 2 + od.entries().len() - subzero);
    assert!(table.contains("| 2001:01 | axis0_controller | q0_per_m | REAL64 | V/m | rw-preop |"));
    assert!(table.contains(
        "| 1003:00 | pre_defined_error_field | number_of_errors | UNSIGNED8 |  | rw | 0 | 0 |"
    ));
    assert!(table
        .lines()
        .all(|l| l.matches(" | ").count() == 9 || l.starts_with("|---")));
}

#[test]
fn command_entries_carry_the_unit_of_the_axis_command() {
    use crate::control::AdaptiveFrictionSection;
    let adaptive = AdaptiveFrictionSection {
        model_time_constant_s: 0.02,
        adaptation_gain_per_m_s: 10.0,
        compensation_max: 0.5,
        error_deadband_m: 0.0,
        model_deadband_m: 0.0,
        settled_band_m: 1e-3,
        step_max_m: 1e-3,
    };
    // command, its code, coefficient q_j, force gain
    let expected = [
        (CommandKind::Voltage, 0, "V", "V/m", "N/V"),
        (CommandKind::Duty, 1, "", "1/m", "N"),
        (CommandKind::Torque, 2, "N m", "N m/m", "N/(N m)"),
        (CommandKind::Velocity, 3, "m/s", "1/s", "N s/m"),
    ];
    for (command, code, unit, per_m, force_gain) in expected {
        // Within a duty's bounds, so that every command kind takes them.
        let mut axis = AxisParameters {
            command,
            ..solenoid()
        };
        axis.controller.output_max = 1.0;
        axis.intelligence.adaptive_friction = Some(adaptive.clone());
        let od = daemon_dictionary(&DeviceParameters::default(), &[axis]).expect("fits");
        let unit_of = |name: &str| {
            let h = od.handle_by_name(Some(0), name).expect(name);
            od.entry(h).unit
        };
        for name in [
            "output_min",
            "output_max",
            "safe_command",
            "friction_compensation",
            "friction_compensation_pos",
            "friction_compensation_neg",
            "compensation_max",
        ] {
            assert_eq!(unit_of(name), unit, "{command:?} {name}");
        }
        assert_eq!(unit_of("q0_per_m"), per_m, "{command:?}");
        let h = od.handle_by_name(Some(0), "command_kind").expect("entry");
        assert_eq!(od.value(h), Value::Unsigned8(code), "{command:?}");
        assert_eq!(
            unit_of("force_gain_n_per_command"),
            force_gain,
            "{command:?}"
        );
    }
}
