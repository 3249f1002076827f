//! The EDS writer of the stack, checked over the daemon's dictionary.

use super::{daemon_dictionary, AxisParameters, DeviceParameters};
use crate::canopen::eds::*;
use crate::canopen::od::*;
use std::collections::BTreeMap;

/// A minimal INI reader: section -> key -> value, failing on anything malformed.
fn parse_ini(text: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let mut out: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut current = None;
    for line in text.split("\r\n") {
        if line.is_empty() {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            assert!(
                out.insert(name.to_string(), BTreeMap::new()).is_none(),
                "section {name} twice"
            );
            current = Some(name.to_string());
            continue;
        }
        let (k, v) = line
            .split_once('=')
            .unwrap_or_else(|| panic!("bad line {line:?}"));
        let section = current.clone().expect("key before any section");
        let keys = out.get_mut(&section).expect("section exists");
        assert!(
            keys.insert(k.to_string(), v.to_string()).is_none(),
            "{section}: key {k} twice"
        );
    }
    out
}

fn od() -> ObjectDictionary {
    daemon_dictionary(
        &DeviceParameters::default(),
        &[AxisParameters::default(), AxisParameters::default()],
    )
    .expect("fits")
}

#[test]
fn every_object_and_entry_has_its_section_and_keys() {
    let od = od();
    let text = render_eds(&od, &EdsInfo::default());
    let ini = parse_ini(&text);
    for s in [
        "FileInfo",
        "DeviceInfo",
        "MandatoryObjects",
        "OptionalObjects",
        "ManufacturerObjects",
    ] {
        assert!(ini.contains_key(s), "{s}");
    }
    let listed: usize = ["MandatoryObjects", "OptionalObjects", "ManufacturerObjects"]
        .iter()
        .map(|s| ini[*s]["SupportedObjects"].parse::<usize>().expect("count"))
        .sum();
    assert_eq!(listed, od.objects().len());
    assert_eq!(ini["MandatoryObjects"]["1"], "0x1000");
    assert_eq!(ini["MandatoryObjects"]["3"], "0x1018");
    for object in od.objects() {
        let head = &ini[&format!("{:04X}", object.index)];
        assert_eq!(head["ObjectType"], format!("0x{:X}", object.kind.code()));
        for e in od.object_entries(object) {
            let section = if object.kind == ObjectKind::Var {
                format!("{:04X}", object.index)
            } else {
                assert_eq!(
                    head["SubNumber"],
                    od.object_entries(object).len().to_string()
                );
                format!("{:04X}sub{:X}", object.index, e.id.sub)
            };
            let keys = &ini[&section];
            assert_eq!(
                keys["DataType"],
                format!("0x{:04X}", e.data_type.code()),
                "{section}"
            );
            assert_eq!(keys["AccessType"], access_type(e.access));
            assert_eq!(keys["PDOMapping"], u8::from(e.pdo_mappable).to_string());
            let default = &keys["DefaultValue"];
            assert_eq!(
                Value::parse(e.data_type, default).ok(),
                Some(e.default),
                "{section}"
            );
        }
    }
    let q0 = &ini["2001sub1"];
    assert_eq!(q0["ParameterName"], "q0_per_m");
    assert_eq!(q0["LowLimit"], "-1000000000000.0");
    assert!(q0["Description"].ends_with("writable in pre-operational only"));
    assert_eq!(ini["2101"]["ParameterName"], "axis1_controller");
    assert_eq!(ini["1018"]["SubNumber"], "5");
    assert_eq!(
        ini["DeviceInfo"]["RevisionNumber"],
        format!(
            "0x{:X}",
            ini["1018sub3"]["DefaultValue"].parse::<u32>().expect("u32")
        )
    );
}

#[test]
fn output_is_deterministic_and_free_of_comment_syntax() {
    let od = od();
    let a = render_eds(&od, &EdsInfo::default());
    assert_eq!(a, render_eds(&od, &EdsInfo::default()));
    assert!(!a.contains(';'));
    assert!(!a.contains("CreationDate"));
}
