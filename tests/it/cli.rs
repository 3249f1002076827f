//! Whole-program behaviour of the binaries that needs no CAN interface.

use crate::common::paths::repo_file;
use std::process::Command;

fn actuatord() -> Command {
    Command::new(env!("CARGO_BIN_EXE_actuatord"))
}

#[test]
fn a_missing_interface_is_a_clear_error_and_a_failure() {
    let out = actuatord()
        .args([
            "--config",
            &repo_file("config/solenoid.toml"),
            "--iface",
            "nosuchcan7",
        ])
        .output()
        .expect("actuatord runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("CAN interface nosuchcan7 does not exist"),
        "{err}"
    );
}

#[test]
fn an_invalid_config_names_file_key_and_rule_and_the_daemon_refuses_to_start() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("bad.toml");
    let text = std::fs::read_to_string(repo_file("config/solenoid.toml"))
        .expect("config")
        .replace("sensor_deadline_s = 0.0015", "sensor_deadline_s = 0.004");
    std::fs::write(&bad, text).expect("write");
    let out = actuatord()
        .args(["--config", bad.to_str().expect("utf-8 path")])
        .output()
        .expect("actuatord runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(
            "bad.toml: [cycle] sensor_deadline_s must be shorter than period_s (0.0025), got 0.004"
        ),
        "{err}"
    );
}

#[test]
fn a_missing_config_file_is_named() {
    let out = actuatord()
        .args(["--config", "/nonexistent/actuatord.toml"])
        .output()
        .expect("actuatord runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent/actuatord.toml: cannot read"),
        "{err}"
    );
}

#[test]
fn the_dbc_command_prints_the_committed_dbc() {
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .arg("dbc")
        .output()
        .expect("actuator runs");
    assert!(out.status.success());
    let committed = std::fs::read_to_string(repo_file("dbc/actuatord.dbc")).expect("dbc");
    assert_eq!(String::from_utf8_lossy(&out.stdout), committed);
}

#[test]
fn the_committed_eds_is_the_rendered_dictionary_and_python_canopen_loads_it() {
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(["eds", "--config", &repo_file("config/solenoid.toml")])
        .output()
        .expect("actuator runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let committed = std::fs::read(repo_file("dbc/actuatord.eds")).expect("eds");
    assert!(
        out.stdout == committed,
        "dbc/actuatord.eds is stale: run `cargo run --bin actuator -- eds > dbc/actuatord.eds`"
    );
    // An outside tool reads it: the Python canopen package (installed by scripts/setup-test-deps).
    let script = "import sys, canopen\nod = canopen.import_od(sys.argv[1], 1)\nprint(od['loop_statistics']['cycles'].index, od['axis0_setpoint']['setpoint_position'].subindex)";
    let py = Command::new("python3")
        .args(["-c", script, &repo_file("dbc/actuatord.eds")])
        .output()
        .expect("python3 runs");
    assert!(
        py.status.success(),
        "{}",
        String::from_utf8_lossy(&py.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&py.stdout).trim(), "12032 1");
}

#[test]
fn the_committed_configuration_reference_is_the_rendered_one() {
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .arg("config-doc")
        .output()
        .expect("actuator runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let committed = std::fs::read(repo_file("docs/configuration.md")).expect("configuration.md");
    assert!(
        out.stdout == committed,
        "docs/configuration.md is stale: run \
         `cargo run --bin actuator -- config-doc > docs/configuration.md`"
    );
}

#[test]
fn decode_names_every_frame_of_a_candump_log_and_what_does_not_decode() {
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("capture.log");
    let sensor = actuatord::device::SensorPdo {
        position: 0.0125,
        current_a: 1.5,
        supply_voltage_v: 24.0,
    }
    .encode(16);
    std::fs::write(
        &log,
        format!(
            "{}\n(1.000100) vcan0 080#05\n(1.0002) vcan0 190#0102\n(1.0003) vcan0 5FF#00\nnot a frame\n",
            actuatord::bus::write_candump_line(1.0, "vcan0", &sensor)
        ),
    )
    .expect("write log");
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .arg("decode")
        .arg(&log)
        .output()
        .expect("actuator runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    assert!(
        lines[0].ends_with(":: sensor(position=0.0125 m, current=1.5 A, supply_voltage=24 V)"),
        "{}",
        lines[0]
    );
    assert!(
        lines[1].ends_with(":: sync(sync_counter=5)"),
        "{}",
        lines[1]
    );
    assert!(
        lines[2].ends_with(":: sensor with 2 data bytes, expected 8"),
        "{}",
        lines[2]
    );
    assert!(
        lines[3].ends_with(":: id not in the protocol"),
        "{}",
        lines[3]
    );
    assert!(lines[4].contains("not decoded"), "{}", lines[4]);
}

#[test]
fn a_configuration_whose_traffic_does_not_fit_the_bus_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let slow = dir.path().join("slow.toml");
    let text = std::fs::read_to_string(repo_file("config/solenoid.toml"))
        .expect("config")
        .replace(
            "iface = \"vcan0\"",
            "iface = \"vcan0\"\nbitrate_bps = 125000",
        );
    std::fs::write(&slow, text).expect("write");
    let out = actuatord()
        .args(["--config", slow.to_str().expect("utf-8 path")])
        .output()
        .expect("actuatord runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("slow.toml: [bus] max_load is 70 %, but the configured traffic needs"),
        "{err}"
    );
}

/// `actuator dbc | head`: a reader that has gone away ends the command quietly, as it ends any
/// Unix filter, instead of a panic about a broken pipe. The pipe's read end is closed before the
/// command starts, so its first print meets no reader.
#[test]
fn a_closed_pipe_on_stdout_ends_the_command_without_a_panic() {
    use std::os::fd::{FromRawFd, OwnedFd};
    use std::os::unix::process::ExitStatusExt;
    let mut fds = [0; 2];
    // SAFETY: `fds` has room for the two descriptors pipe(2) writes.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0, "pipe(2)");
    // SAFETY: both descriptors were just opened by pipe(2) and are owned here alone.
    let (read_end, write_end) =
        unsafe { (OwnedFd::from_raw_fd(fds[0]), OwnedFd::from_raw_fd(fds[1])) };
    drop(read_end);
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .arg("dbc")
        .stdout(std::process::Stdio::from(write_end))
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("actuator runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?} {stderr}",
        out.status
    );
}

/// A newcomer's `actuator sim --profile cia402`: without a plant file the drive gets a plant it
/// can command (the linear axis by force, the gear by torque) and goes on to open its bus, which
/// here does not exist; a family without a force or torque command is refused naming the ones
/// that have it.
#[test]
fn a_simulated_drive_without_a_plant_file_picks_one_it_can_command() {
    let sim = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
            .args([
                "sim",
                "--profile",
                "cia402",
                "--iface",
                "actuatord-no-such-bus",
            ])
            .args(extra)
            .current_dir(std::env::temp_dir())
            .output()
            .expect("actuator runs");
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    for family in [
        &[][..],
        &["--family", "linear_axis"],
        &["--family", "motor_gear"],
    ] {
        let err = sim(family);
        assert!(
            err.contains("CAN interface actuatord-no-such-bus does not exist"),
            "{family:?}: {err}"
        );
    }
    for family in ["solenoid", "pneumatic"] {
        let err = sim(&["--family", family]);
        assert!(
            err.contains("--profile cia402 is a servo drive")
                && err.contains("linear_axis (the default) or motor_gear")
                && err.contains(&format!("the {family} plant")),
            "{family}: {err}"
        );
    }
}

#[test]
fn faults_prints_a_state_files_history_and_names_a_file_it_cannot_use() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("state.toml");
    std::fs::write(
        &file,
        "version = 1\n\n[[error_history]]\nerror_code = 33360\nadditional_info = 4113\n\
         time_unix_s = 1700000060.5\n\n[[error_history]]\nerror_code = 8976\n\
         additional_info = 4099\ntime_unix_s = 1700000000.0\n",
    )
    .expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(["faults", "--state"])
        .arg(&file)
        .output()
        .expect("actuator runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].ends_with("state.toml: 2 errors in the history (1003h), newest first"),
        "{text}"
    );
    assert!(
        lines[2].starts_with("  1  8250h  11h         16  2023-11-14 22:14:20.500 UTC"),
        "{text}"
    );
    assert!(
        lines[3].starts_with("  2  2310h  03h         16  2023-11-14 22:13:20.000 UTC"),
        "{text}"
    );
    assert!(lines[3].ends_with("fault: overcurrent"), "{text}");

    std::fs::write(
        &file,
        "version = 1\n[[error_history]]\nerror_code = 70000\n",
    )
    .expect("write");
    for missing in [file.clone(), dir.path().join("none.toml")] {
        let out = Command::new(env!("CARGO_BIN_EXE_actuator"))
            .args(["faults", "--state"])
            .arg(&missing)
            .output()
            .expect("actuator runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert!(err.contains(&missing.display().to_string()), "{err}");
    }
}
