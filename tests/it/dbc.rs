//! The DBC file and the codec must agree: frames made by the codec are decoded with
//! `dbc/actuatord.dbc` (parsed by the can-dbc crate, decoded by hand from its signal definitions)
//! and every signal must come back as it went in.

use actuatord::bus::Frame;
use actuatord::device;
use actuatord::device::{
    messages, CommandPdo, Emcy, FaultDiagnosisPdo, FaultStatePdo, SensorPdo, TunedGainsPdo,
    TunedParametersPdo, SUPERVISED_FLAGGED, SUPERVISED_FLAG_NAMES, SYMPTOM_NAMES,
};
use actuatord::supervise::{
    FaultFlags, FaultKind, FaultState, SupervisedFault, SupervisedFaults, Symptom,
};
use can_dbc::{ByteOrder, Dbc, MessageId, ValueType};
use proptest::prelude::*;

const CONTROLLER: u8 = 1;
const ACTUATOR: u8 = 16;

fn dbc_text() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/dbc/actuatord.dbc"))
        .expect("dbc/actuatord.dbc is readable")
}

fn dbc() -> Dbc {
    Dbc::try_from(dbc_text().as_str()).expect("dbc/actuatord.dbc parses")
}

/// Decode one signal of `frame` from its DBC definition: Intel byte order, sign, factor, offset.
fn dbc_decode(db: &Dbc, frame: &Frame, signal: &str) -> f64 {
    let message = db
        .messages
        .iter()
        .find(|m| m.id == MessageId::Standard(frame.id() as u16))
        .unwrap_or_else(|| panic!("no DBC message for id 0x{:X}", frame.id()));
    assert_eq!(message.size as usize, frame.len(), "{}: DLC", message.name);
    let s = message
        .signals
        .iter()
        .find(|s| s.name == signal)
        .unwrap_or_else(|| panic!("{} has no signal {signal}", message.name));
    assert_eq!(s.byte_order, ByteOrder::LittleEndian, "{signal}");
    let mut bytes = [0u8; 8];
    bytes[..frame.len()].copy_from_slice(frame.data());
    let word = u64::from_le_bytes(bytes) >> s.start_bit;
    let mask = if s.size == 64 {
        u64::MAX
    } else {
        (1u64 << s.size) - 1
    };
    let raw = word & mask;
    let raw = match s.value_type {
        ValueType::Signed if raw & (1 << (s.size - 1)) != 0 => (raw | !mask) as i64,
        _ => raw as i64,
    };
    raw as f64 * s.factor + s.offset
}

fn node_for(m: &device::Message) -> u8 {
    match m.id_base {
        messages::IdBase::Actuator => ACTUATOR,
        _ => CONTROLLER,
    }
}

#[test]
fn committed_dbc_is_the_rendered_table() {
    assert_eq!(
        dbc_text(),
        device::dbc::render(CONTROLLER, ACTUATOR),
        "dbc/actuatord.dbc is stale: run `cargo run --bin actuator -- dbc > dbc/actuatord.dbc`"
    );
}

#[test]
fn every_frame_and_signal_of_the_codec_is_in_the_dbc_with_its_unit() {
    let db = dbc();
    for m in messages::ALL {
        let id = MessageId::Standard(m.cob_id(node_for(m)) as u16);
        let dm = db
            .messages
            .iter()
            .find(|x| x.id == id)
            .unwrap_or_else(|| panic!("{} missing from the DBC", m.name));
        assert_eq!(dm.name, m.name);
        assert_eq!(dm.signals.len(), m.signals.len(), "{}", m.name);
        for s in m.signals {
            let ds = dm
                .signals
                .iter()
                .find(|d| d.name == s.name)
                .unwrap_or_else(|| panic!("{}.{} missing", m.name, s.name));
            assert_eq!(ds.unit, s.unit, "{}.{}", m.name, s.name);
            assert_eq!(ds.factor, s.factor, "{}.{}", m.name, s.name);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    // One fraction per signal of the longest message (the EMCY frame, 20 signals).
    #[test]
    fn every_signal_round_trips_through_the_dbc(fractions in proptest::collection::vec(0.0f64..=1.0, 20)) {
        let db = dbc();
        for m in messages::ALL {
            let values: Vec<f64> = m
                .signals
                .iter()
                .zip(&fractions)
                .map(|(s, f)| {
                    let (lo, hi) = s.physical_range();
                    lo + f * (hi - lo)
                })
                .collect();
            let (frame, clipped) = device::pack(m, node_for(m), &values);
            prop_assert_eq!(clipped, 0);
            for (s, v) in m.signals.iter().zip(&values) {
                let got = dbc_decode(&db, &frame, s.name);
                prop_assert!((got - v).abs() <= s.factor * 0.5 + v.abs() * 1e-12,
                    "{}.{}: sent {} got {}", m.name, s.name, v, got);
            }
        }
    }

    #[test]
    fn typed_frames_decode_with_the_dbc(
        position in -0.1f64..0.1,
        current in -30.0f64..30.0,
        supply in 0.0f64..60.0,
        voltage in -30.0f64..30.0,
        duty in -1.0f64..1.0,
        counter in 1u8..=240,
        flags in 0u16..256,
        state in 0u8..4,
        diagnosed in 0usize..8,
        supervised in 0u16..64,
        symptoms in proptest::collection::vec(0usize..3, 6),
        confidence in 0.0f64..=1.0,
        x4 in -0.01f64..0.01,
        gain in 0.0f64..8000.0,
        drive_gain in 0.0f64..0.4,
        comp in 0.0f64..4.0,
    ) {
        let db = dbc();
        let s = SensorPdo { position, current_a: current, supply_voltage_v: supply };
        let f = s.encode(ACTUATOR);
        prop_assert!((dbc_decode(&db, &f, "position") - position).abs() <= 0.5e-7);
        prop_assert!((dbc_decode(&db, &f, "current") - current).abs() <= 0.5e-3);
        prop_assert!((dbc_decode(&db, &f, "supply_voltage") - supply).abs() <= 0.5e-3);

        let c = CommandPdo { voltage_v: voltage, duty, sync_counter: counter };
        let f = c.encode(ACTUATOR);
        prop_assert!((dbc_decode(&db, &f, "command_voltage") - voltage).abs() <= 0.5e-3);
        prop_assert!((dbc_decode(&db, &f, "command_duty") - duty).abs() <= 0.5e-4);
        prop_assert_eq!(dbc_decode(&db, &f, "command_sync_counter"), f64::from(counter));

        let fs = FaultStatePdo {
            axis_node_id: ACTUATOR,
            state: FaultState::from_code(state).expect("valid state"),
            flags: FaultFlags(flags),
            diagnosed_fault: diagnosed.checked_sub(1).map(|i| SupervisedFault::ALL[i]),
            following_error: position,
        };
        let f = fs.encode(CONTROLLER);
        prop_assert_eq!(dbc_decode(&db, &f, "fault_state"), f64::from(state));
        prop_assert!((dbc_decode(&db, &f, "following_error") - position).abs() <= 0.5e-7);
        prop_assert_eq!(dbc_decode(&db, &f, "diagnosed_fault"), diagnosed as f64);
        for kind in FaultKind::ALL {
            let bit = dbc_decode(&db, &f, &format!("fault_{}", kind.name()));
            prop_assert_eq!(bit == 1.0, FaultFlags(flags).contains(kind));
        }

        // Supervised-fault bits, in the order of SUPERVISED_FLAGGED.
        let mut latched = SupervisedFaults::default();
        for (i, fault) in SUPERVISED_FLAGGED.iter().enumerate() {
            if supervised & (1 << i) != 0 {
                latched.insert(*fault);
            }
        }
        let e = Emcy::raised(ACTUATOR, FaultKind::FollowingError, FaultFlags(flags))
            .with_supervision(fs.state, fs.diagnosed_fault, latched);
        let f = e.encode(CONTROLLER);
        prop_assert_eq!(dbc_decode(&db, &f, "emcy_error_code"), f64::from(e.error_code));
        prop_assert_eq!(dbc_decode(&db, &f, "axis_node_id"), f64::from(ACTUATOR));
        prop_assert_eq!(dbc_decode(&db, &f, "fault_state"), f64::from(state));
        prop_assert_eq!(dbc_decode(&db, &f, "diagnosed_fault"), diagnosed as f64);
        for (i, name) in SUPERVISED_FLAG_NAMES.iter().enumerate() {
            prop_assert_eq!(dbc_decode(&db, &f, name) == 1.0, supervised & (1 << i) != 0);
        }

        let sym = [Symptom::Minus, Symptom::Zero, Symptom::Plus];
        let d = FaultDiagnosisPdo {
            axis_node_id: ACTUATOR,
            confidence,
            nominal_learned: flags & 1 != 0,
            latched,
            observer_learned: flags & 2 != 0,
            symptoms: [0, 1, 2, 3, 4, 5].map(|i| sym[symptoms[i]]),
            observer_x4_pos: x4,
            observer_x4_neg: -x4,
        };
        let f = d.encode(CONTROLLER);
        prop_assert!((dbc_decode(&db, &f, "diagnosis_confidence") - confidence).abs() <= 0.005);
        prop_assert_eq!(dbc_decode(&db, &f, "nominal_learned") == 1.0, flags & 1 != 0);
        prop_assert_eq!(dbc_decode(&db, &f, "observer_learned") == 1.0, flags & 2 != 0);
        for (i, name) in SUPERVISED_FLAG_NAMES.iter().enumerate() {
            prop_assert_eq!(dbc_decode(&db, &f, name) == 1.0, supervised & (1 << i) != 0);
        }
        for (i, name) in SYMPTOM_NAMES.iter().enumerate() {
            prop_assert_eq!(dbc_decode(&db, &f, name), symptoms[i] as f64 - 1.0);
        }
        prop_assert!((dbc_decode(&db, &f, "observer_x4_pos") - x4).abs() <= 2.5e-6);
        prop_assert!((dbc_decode(&db, &f, "observer_x4_neg") + x4).abs() <= 2.5e-6);

        let t = TunedParametersPdo {
            axis_node_id: ACTUATOR,
            friction_compensation_v: voltage,
            gain_schedule_factor: confidence * 2.0,
            friction_compensation_pos_v: comp,
            friction_compensation_neg_v: 4.0 - comp,
        };
        let f = t.encode(CONTROLLER);
        prop_assert!((dbc_decode(&db, &f, "friction_compensation") - voltage).abs() <= 0.5e-3);
        prop_assert!((dbc_decode(&db, &f, "gain_schedule_factor") - confidence * 2.0).abs() <= 0.5e-3);
        prop_assert!((dbc_decode(&db, &f, "friction_compensation_pos") - comp).abs() <= 0.5e-3);
        prop_assert!((dbc_decode(&db, &f, "friction_compensation_neg") - (4.0 - comp)).abs() <= 0.5e-3);

        let g = TunedGainsPdo {
            axis_node_id: ACTUATOR,
            gain_down_per_m: gain,
            gain_up_per_m: 8000.0 - gain,
            drive_gain_down_m_per_s: drive_gain,
            drive_gain_up_m_per_s: 0.4 - drive_gain,
            adapted_down: flags & 1 != 0,
            adapted_up: flags & 2 != 0,
        };
        let f = g.encode(CONTROLLER);
        prop_assert!((dbc_decode(&db, &f, "gain_down") - gain).abs() <= 0.25);
        prop_assert!((dbc_decode(&db, &f, "gain_up") - (8000.0 - gain)).abs() <= 0.25);
        prop_assert!((dbc_decode(&db, &f, "drive_gain_down") - drive_gain).abs() <= 0.5e-4);
        prop_assert!((dbc_decode(&db, &f, "drive_gain_up") - (0.4 - drive_gain)).abs() <= 0.5e-4);
        prop_assert_eq!(dbc_decode(&db, &f, "gain_source_down") == 1.0, flags & 1 != 0);
        prop_assert_eq!(dbc_decode(&db, &f, "gain_source_up") == 1.0, flags & 2 != 0);
    }
}
