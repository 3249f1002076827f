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

/// The demo's loop on the reference solenoid over `steps` (time, position), recorded to `path`.
fn demo_recording(
    path: &Path,
    steps: &[(f64, f64)],
    faults: &[&str],
    duration_s: f64,
) -> actuatord::demo::DemoSummary {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = Script {
        setpoints: steps
            .iter()
            .map(|&(at_s, position_m)| SetpointStep { at_s, position_m })
            .collect(),
        faults: faults.iter().map(|f| f.parse().expect("fault")).collect(),
        duration_s,
    };
    run(
        &root.join("config/solenoid.toml"),
        &root.join("config/plants/solenoid.toml"),
        &script,
        path,
    )
    .expect("demo runs")
}

#[test]
fn python_mcap_reads_the_channels_and_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let recording = dir.path().join("short.mcap");
    let summary = demo_recording(
        &recording,
        &[(0.0, 0.005), (0.5, 0.008)],
        &["supply_x0.5@1s"],
        1.5,
    );
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

/// A daemon killed mid-run (a crash, `kill -9`) leaves a recording without its footer, cut in
/// the middle of a record: the incident's own record, the one a user puts into the lab. The
/// lab reads it up to its last complete record and says where it was cut; a strict reader
/// names the cut instead of a bare parse error.
#[test]
fn a_recording_cut_by_a_killed_writer_is_read_up_to_its_last_record() {
    let dir = tempfile::tempdir().expect("tempdir");
    let full = dir.path().join("full.mcap");
    let summary = demo_recording(&full, &[(0.0, 0.005), (1.0, 0.008), (3.0, 0.004)], &[], 5.0);
    let bytes = std::fs::read(&full).expect("recording");
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 6 / 10]).expect("cut written");

    let whole = actuatord::recording::read_recording(&full).expect("reads");
    assert_eq!(whole.cut, None);
    assert_eq!(whole.cycles.len() as u64, summary.cycle.cycles);
    let part = actuatord::recording::read_recording(&cut).expect("a cut recording reads");
    let at = part.cut.as_ref().expect("the cut is reported");
    assert!(
        !part.cycles.is_empty() && part.cycles.len() < whole.cycles.len(),
        "{} of {} cycles",
        part.cycles.len(),
        whole.cycles.len()
    );
    // What is read is what was written, record for record, up to the cut.
    assert_eq!(part.cycles[..], whole.cycles[..part.cycles.len()]);
    assert_eq!(at.bytes, bytes.len() * 6 / 10);
    let strict = actuatord::recording::read_cycles(&cut).expect_err("strict reader");
    assert!(
        strict.to_string().contains("without its footer"),
        "{strict}"
    );

    // The lab, as a user runs it after the crash.
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(["compare", "--family", "solenoid", "--data"])
        .arg(&cut)
        .output()
        .expect("actuator runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("cut: the file ends without its footer")
            && stdout.contains(&format!("({} samples)", part.cycles.len())),
        "{stdout}"
    );
}
