use super::*;

fn small() -> ObjectDictionary {
    ObjectDictionary::builder()
        .var(0x1001, EntrySpec::ro("error_register", 0u8))
        .record(
            0x2000,
            "gains",
            Some(0),
            vec![
                EntrySpec::rw_preop("kp", 1.0f64).between(0.0, 10.0),
                EntrySpec::rw("level", 5u8)
                    .range(Some(Value::Unsigned8(1)), Some(Value::Unsigned8(9))),
                EntrySpec::rw_preop("low", 0.0f64),
                EntrySpec::rw_preop("high", 1.0f64),
                EntrySpec::wo("reset", false),
            ],
        )
        .ordered(ObjectId::new(0x2000, 3), ObjectId::new(0x2000, 4))
        .build()
        .expect("valid table")
}

const PRE: NmtState = NmtState::PreOperational;
const OP: NmtState = NmtState::Operational;

#[test]
fn lookups_tell_a_missing_object_from_a_missing_subindex() {
    let od = small();
    assert_eq!(od.find(ObjectId::new(0x3000, 0)), Err(OdError::NoObject));
    assert_eq!(od.find(ObjectId::new(0x2000, 9)), Err(OdError::NoSubIndex));
    assert_eq!(od.find(ObjectId::new(0x1001, 1)), Err(OdError::NoSubIndex));
    assert_eq!(od.read(ObjectId::new(0x2000, 0)), Ok(Value::Unsigned8(5)));
    assert_eq!(od.read(ObjectId::new(0x2000, 5)), Err(OdError::WriteOnly));
    let h = od.handle_by_name(Some(0), "kp").expect("kp");
    assert_eq!(od.entry(h).id, ObjectId::new(0x2000, 1));
    assert!(od.handle_by_name(None, "error_register").is_some());
    assert!(od.handle_by_name(None, "kp").is_none());
}

#[test]
fn writes_are_checked_then_staged_and_only_seen_after_the_boundary() {
    let mut od = small();
    let kp = ObjectId::new(0x2000, 1);
    assert_eq!(od.stage_write(kp, &2.5f64.to_le_bytes(), PRE), Ok(()));
    assert_eq!(od.read(kp), Ok(Value::Real64(1.0)), "not applied yet");
    // A second write to the same entry replaces the first.
    assert_eq!(od.stage_write(kp, &3.5f64.to_le_bytes(), PRE), Ok(()));
    assert_eq!(od.pending_writes().len(), 1);
    let taken: Vec<_> = od.take_pending_writes().collect();
    assert_eq!(taken.len(), 1);
    assert_eq!(taken[0].name, "kp");
    assert_eq!(taken[0].axis, Some(0));
    assert_eq!(taken[0].value, Value::Real64(3.5));
    assert_eq!(od.read(kp), Ok(Value::Real64(3.5)));
    assert!(od.pending_writes().is_empty());
}

#[test]
fn every_refusal_has_its_reason_and_stages_nothing() {
    let mut od = small();
    let kp = ObjectId::new(0x2000, 1);
    let level = ObjectId::new(0x2000, 2);
    let cases: [(ObjectId, Vec<u8>, NmtState, OdError); 9] = [
        (ObjectId::new(0x1001, 0), vec![1], PRE, OdError::ReadOnly),
        (ObjectId::new(0x2000, 0), vec![1], PRE, OdError::ReadOnly),
        (
            kp,
            2.0f64.to_le_bytes().to_vec(),
            OP,
            OdError::RefusedInState,
        ),
        (kp, vec![0; 4], PRE, OdError::WrongLength),
        (kp, 11.0f64.to_le_bytes().to_vec(), PRE, OdError::TooHigh),
        (kp, (-1.0f64).to_le_bytes().to_vec(), PRE, OdError::TooLow),
        (
            kp,
            f64::NAN.to_le_bytes().to_vec(),
            PRE,
            OdError::OutOfRange,
        ),
        (level, vec![0], OP, OdError::TooLow),
        (ObjectId::new(0x2000, 5), vec![7], OP, OdError::OutOfRange),
    ];
    for (id, bytes, state, err) in cases {
        assert_eq!(
            od.stage_write(id, &bytes, state),
            Err(err),
            "{id} {bytes:?}"
        );
    }
    assert!(od.pending_writes().is_empty());
    // A plain rw entry and a write-only command are fine while operational.
    assert_eq!(od.stage_write(level, &[9], OP), Ok(()));
    assert_eq!(od.stage_write(ObjectId::new(0x2000, 5), &[1], OP), Ok(()));
}

#[test]
fn ordered_pairs_stay_ordered_against_staged_values() {
    let mut od = small();
    let low = ObjectId::new(0x2000, 3);
    let high = ObjectId::new(0x2000, 4);
    assert_eq!(
        od.stage_write(low, &1.0f64.to_le_bytes(), PRE),
        Err(OdError::TooHigh)
    );
    assert_eq!(
        od.stage_write(high, &0.0f64.to_le_bytes(), PRE),
        Err(OdError::TooLow)
    );
    // Move the window up: the high side first, then the low side against the staged high.
    assert_eq!(od.stage_write(high, &5.0f64.to_le_bytes(), PRE), Ok(()));
    assert_eq!(od.stage_write(low, &4.0f64.to_le_bytes(), PRE), Ok(()));
    assert_eq!(od.take_pending_writes().count(), 2);
    assert_eq!(od.read(low), Ok(Value::Real64(4.0)));
}

#[test]
fn publish_is_type_checked_and_not_staged() {
    let mut od = small();
    let h = od.handle(ObjectId::new(0x1001, 0)).expect("exists");
    assert_eq!(od.publish(h, 0x11u8), Ok(()));
    assert_eq!(
        od.read(ObjectId::new(0x1001, 0)),
        Ok(Value::Unsigned8(0x11))
    );
    assert_eq!(
        od.publish(h, 1u32),
        Err(OdError::TypeMismatch {
            expected: DataType::Unsigned8,
            got: DataType::Unsigned32
        })
    );
    assert!(od.pending_writes().is_empty());
    od.reset_to_defaults();
    assert_eq!(od.read(ObjectId::new(0x1001, 0)), Ok(Value::Unsigned8(0)));
}

#[test]
fn the_staging_area_never_grows_past_the_writable_entries() {
    let mut od = small();
    let cap = od.pending.capacity();
    for i in 0..100u8 {
        let _ = od.stage_write(ObjectId::new(0x2000, 2), &[1 + i % 9], PRE);
        let _ = od.stage_write(
            ObjectId::new(0x2000, 1),
            &f64::from(i % 10).to_le_bytes(),
            PRE,
        );
        let _ = od.stage_write(ObjectId::new(0x2000, 5), &[1], PRE);
    }
    assert_eq!(od.pending_writes().len(), 3);
    assert_eq!(od.pending.capacity(), cap);
}

#[test]
fn builder_refuses_inconsistent_tables() {
    let dup = ObjectDictionary::builder()
        .var(0x1000, EntrySpec::ro("a", 0u32))
        .var(0x1000, EntrySpec::ro("b", 0u32))
        .build();
    assert_eq!(
        dup.err(),
        Some(BuildError::DuplicateIndex { index: 0x1000 })
    );
    let names = ObjectDictionary::builder()
        .record(
            0x2000,
            "r",
            None,
            vec![EntrySpec::ro("a", 0u8), EntrySpec::ro("a", 1u8)],
        )
        .build();
    assert!(matches!(names, Err(BuildError::DuplicateEntryName { .. })));
    let out = ObjectDictionary::builder()
        .var(0x2000, EntrySpec::rw("a", 5.0f64).between(0.0, 1.0))
        .build();
    assert!(matches!(out, Err(BuildError::BadEntry { .. })));
    let mixed = ObjectDictionary::builder()
        .array(
            0x2000,
            "arr",
            None,
            vec![EntrySpec::ro("a", 0u8), EntrySpec::ro("b", 0u16)],
        )
        .build();
    assert!(matches!(mixed, Err(BuildError::BadEntry { .. })));
    let order = ObjectDictionary::builder()
        .var(0x2000, EntrySpec::rw("a", 0u8))
        .ordered(ObjectId::new(0x2000, 0), ObjectId::new(0x2001, 0))
        .build();
    assert!(matches!(order, Err(BuildError::BadOrder(..))));
}

#[test]
fn object_ids_parse_and_print_in_hex() {
    assert_eq!(ObjectId::parse("1018:4"), Some(ObjectId::new(0x1018, 4)));
    assert_eq!(
        ObjectId::parse("0x2001:0x0d"),
        Some(ObjectId::new(0x2001, 13))
    );
    assert_eq!(ObjectId::parse("2001:d"), Some(ObjectId::new(0x2001, 13)));
    assert_eq!(ObjectId::parse("12345:0"), None);
    assert_eq!(ObjectId::parse("1000:100"), None);
    assert_eq!(ObjectId::parse("1000"), None);
    assert_eq!(ObjectId::new(0x2001, 13).to_string(), "2001:0D");
}

#[test]
fn a_counted_array_takes_only_the_value_its_sub_0_admits() {
    // 1003h's layout: sub 0 the number of errors, which only 0 may be written to (a clear).
    let mut od = ObjectDictionary::builder()
        .array_counted(
            0x1003,
            "pre_defined_error_field",
            EntrySpec::rw("number_of_errors", 0u8)
                .range(Some(Value::Unsigned8(0)), Some(Value::Unsigned8(0))),
            vec![
                EntrySpec::ro("error_1", 0u32),
                EntrySpec::ro("error_2", 0u32),
            ],
        )
        .build()
        .expect("valid table");
    assert_eq!(
        od.object(0x1003).map(|o| o.kind),
        Some(ObjectKind::Array),
        "an ARRAY"
    );
    let sub0 = ObjectId::new(0x1003, 0);
    let h = od.handle(sub0).expect("sub 0");
    od.publish(h, Value::Unsigned8(2))
        .expect("the node sets the count");
    for refused in [1u8, 2, 255] {
        assert_eq!(
            od.stage_write(sub0, &[refused], OP),
            Err(OdError::OutOfRange),
            "{refused}: invalid, neither too high nor too low"
        );
    }
    assert!(od.pending_writes().is_empty());
    assert_eq!(
        od.stage_write(ObjectId::new(0x1003, 1), &[0; 4], OP),
        Err(OdError::ReadOnly)
    );
    od.stage_write(sub0, &[0], OP).expect("0 is taken");
    assert_eq!(od.read(sub0), Ok(Value::Unsigned8(2)), "until the boundary");
    assert_eq!(od.take_pending_writes().count(), 1);
    assert_eq!(od.read(sub0), Ok(Value::Unsigned8(0)));
}
