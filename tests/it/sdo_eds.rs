//! The generated EDS as an outside tool reads it: the Python `canopen` package (installed by
//! `scripts/setup-test-deps`; a required test dependency), and a structural check of the INI text.

use crate::sdo_common;

use actuatord::canopen::eds::access_type;
use actuatord::canopen::od::{ObjectKind, Value};
use actuatord::canopen::{render_eds, EdsInfo};
use std::collections::BTreeMap;
use std::process::Command;

fn python_canopen_available() -> bool {
    Command::new("python3")
        .args(["-c", "import canopen"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// Prints one line per sub-entry as the package understood it:
/// index sub name data_type access_type pdo default|min|max
const DUMP: &str = r#"
import sys, canopen
od = canopen.import_od(sys.argv[1], node_id=1)
def show(v):
    print(f"{v.index:04X} {v.subindex:02X} {v.name} {v.data_type} {v.access_type} {int(v.pdo_mappable)} {v.default!r}|{v.min!r}|{v.max!r}")
for obj in od.values():
    if isinstance(obj, canopen.objectdictionary.ODVariable):
        show(obj)
    else:
        for sub in obj.values():
            show(sub)
print("objects", len(list(od.values())))
"#;

#[test]
fn python_canopen_reads_every_entry_as_written() {
    let (_, od) = sdo_common::solenoid_dictionary();
    let text = render_eds(&od, &EdsInfo::default());
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("actuatord.eds");
    std::fs::write(&path, &text).expect("write EDS");

    structural_check(&text, &od);
    assert!(
        python_canopen_available(),
        "python3 with the canopen package is needed for this test: run scripts/setup-test-deps \
         (or pip install canopen)"
    );
    let out = Command::new("python3")
        .args(["-c", DUMP])
        .arg(&path)
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "canopen.import_od failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let seen: BTreeMap<(u16, u8), Vec<&str>> = stdout
        .lines()
        .filter(|l| !l.starts_with("objects"))
        .map(|l| {
            let f: Vec<&str> = l.splitn(7, ' ').collect();
            let index = u16::from_str_radix(f[0], 16).expect("index");
            let sub = u8::from_str_radix(f[1], 16).expect("sub");
            ((index, sub), f)
        })
        .collect();
    assert_eq!(seen.len(), od.entries().len(), "{stdout}");
    assert!(stdout.contains(&format!("objects {}", od.objects().len())));
    for e in od.entries() {
        let f = &seen[&(e.id.index, e.id.sub)];
        assert_eq!(f[2], e.name, "{}", e.id);
        assert_eq!(f[3], e.data_type.code().to_string(), "{}", e.id);
        assert_eq!(f[4], access_type(e.access), "{}", e.id);
        assert_eq!(f[5], u8::from(e.pdo_mappable).to_string(), "{}", e.id);
        let mut parts = f[6].split('|');
        let default = parts.next().expect("default");
        let expected = match e.default {
            Value::VisibleString(s) => format!("'{}'", s.as_str()),
            Value::Boolean(b) => u8::from(b).to_string(),
            Value::Real32(_) | Value::Real64(_) => python_float(&e.default),
            other => other.to_string(),
        };
        assert_eq!(default, expected, "{} default", e.id);
        // Integer limits are read; the package skips real ones (it parses limits as integers).
        if !e.data_type.is_real() {
            let bound = |v: Option<Value>| v.map_or("None".to_string(), |v| v.to_string());
            assert_eq!(parts.next(), Some(bound(e.min).as_str()), "{} min", e.id);
            assert_eq!(parts.next(), Some(bound(e.max).as_str()), "{} max", e.id);
        }
    }
    // Records and arrays come back with their names, so tools can address by name.
    for o in od.objects().iter().filter(|o| o.kind != ObjectKind::Var) {
        assert!(
            text.contains(&format!("ParameterName={}\r\n", o.name)),
            "{}",
            o.name
        );
    }
    eprintln!(
        "python canopen read {} entries of {} objects",
        seen.len(),
        od.objects().len()
    );
}

/// Python's repr of a float: "inf", "-inf", "1e-09", "2231.0", ...
fn python_float(v: &Value) -> String {
    let x = v.as_f64().expect("real");
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let rust = format!("{x:?}");
    match rust.split_once('e') {
        Some((m, e)) => {
            let exp: i32 = e.parse().expect("exponent");
            if (-4..16).contains(&exp) {
                format!("{x}")
            } else {
                format!("{m}e{}{:02}", if exp < 0 { '-' } else { '+' }, exp.abs())
            }
        }
        None => rust,
    }
}

#[test]
fn eds_structure_without_outside_tools() {
    let (_, od) = sdo_common::solenoid_dictionary();
    structural_check(&render_eds(&od, &EdsInfo::default()), &od);
}

fn structural_check(text: &str, od: &actuatord::canopen::ObjectDictionary) {
    let mut sections = BTreeMap::new();
    let mut current = String::new();
    for line in text.split("\r\n").filter(|l| !l.is_empty()) {
        if let Some(s) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = s.to_string();
            assert!(sections.insert(current.clone(), 0).is_none(), "{s} twice");
        } else {
            assert!(line.contains('='), "{line}");
            *sections.get_mut(&current).expect("in a section") += 1;
        }
    }
    for e in od.entries() {
        let kind = od.object(e.id.index).map(|o| o.kind);
        let name = if kind == Some(ObjectKind::Var) {
            format!("{:04X}", e.id.index)
        } else {
            format!("{:04X}sub{:X}", e.id.index, e.id.sub)
        };
        assert!(sections.get(&name).is_some_and(|&keys| keys >= 6), "{name}");
    }
}
