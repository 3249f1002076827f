//! Recordings are for other tools: the Python `mcap` package (PyPI), as an outside client,
//! reads a demo recording and finds the channels with schemas and the expected counts.

use actuatord::daemon::config::SetpointStep;
use actuatord::demo::{run, Script};
use std::path::Path;
use std::process::Command;

const READER: &str = r#"
import json, sys
from mcap.reader import make_reader
counts, encodings = {}, {}
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    for schema, channel, message in reader.iter_messages():
        counts[channel.topic] = counts.get(channel.topic, 0) + 1
        encodings[channel.topic] = [schema.encoding, channel.message_encoding]
        json.loads(message.data)
print(json.dumps({"counts": counts, "encodings": encodings}))
"#;

#[test]
fn python_mcap_reads_the_channels_and_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let recording = dir.path().join("short.mcap");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = Script {
        setpoints: vec![
            SetpointStep {
                at_s: 0.0,
                position_m: 0.005,
            },
            SetpointStep {
                at_s: 0.5,
                position_m: 0.008,
            },
        ],
        faults: vec!["supply_x0.5@1s".parse().expect("fault")],
        duration_s: 1.5,
    };
    let summary = run(
        &root.join("config/solenoid.toml"),
        &root.join("config/plants/solenoid.toml"),
        &script,
        &recording,
    )
    .expect("demo runs");
    let out = Command::new("python3")
        .args(["-c", READER])
        .arg(&recording)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "python mcap reader failed (scripts/setup-test-deps installs it): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json from python");
    let count = |topic: &str| v["counts"][topic].as_u64().unwrap_or(0);
    assert_eq!(count("/actuatord/cycle"), summary.cycle.cycles, "{v}");
    // Every cycle: SYNC and command out, the sensor frame in (unless it missed its deadline).
    assert!(
        count("/actuatord/can") >= 2 * summary.cycle.cycles + summary.cycle.cycles / 2,
        "{v}"
    );
    assert!(
        count("/actuatord/events") >= 2,
        "start and the supply fault: {v}"
    );
    for topic in ["/actuatord/cycle", "/actuatord/can", "/actuatord/events"] {
        assert_eq!(
            v["encodings"][topic],
            serde_json::json!(["jsonschema", "json"]),
            "{topic}"
        );
    }
}
