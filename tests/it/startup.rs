//! Start-up without the bus: the daemon waits for its interface for `[bus] startup_wait_s`,
//! saying so, then gives up with a non-zero exit naming the interface.

use std::path::Path;
use std::process::Command;

#[test]
fn the_daemon_waits_for_a_missing_interface_then_exits_non_zero() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml"))
            .expect("config");
    let text = text.replacen(
        "iface = \"vcan0\"\n",
        "iface = \"nosuchcan0\"\nstartup_wait_s = 0.6\n",
        1,
    );
    assert!(text.contains("startup_wait_s = 0.6"), "the [bus] table");
    let config = dir.path().join("absent.toml");
    std::fs::write(&config, text).expect("write config");
    let recordings = dir.path().join("recordings");
    let out = Command::new(env!("CARGO_BIN_EXE_actuatord"))
        .arg("--config")
        .arg(&config)
        .arg("--record-dir")
        .arg(&recordings)
        .output()
        .expect("actuatord runs");
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{log}");
    assert!(
        log.contains("nosuchcan0") && log.contains("waiting for it"),
        "the wait is logged: {log}"
    );
    assert!(
        log.contains("gave up after waiting") && log.contains("startup_wait_s = 0.6"),
        "the end names its cause: {log}"
    );
    // A start that never got its bus leaves no recording behind.
    let files = std::fs::read_dir(&recordings).map_or(0, |d| d.count());
    assert_eq!(files, 0);
}
