//! `systemd/actuatord.service` must pass `systemd-analyze verify` (with ExecStart pointing at
//! the binary just built, since the unit names its installed path).

use std::process::Command;

#[test]
fn the_unit_verifies_cleanly() {
    let root = env!("CARGO_MANIFEST_DIR");
    let unit = std::fs::read_to_string(format!("{root}/systemd/actuatord.service")).expect("unit");
    for key in [
        "Type=notify",
        "WatchdogSec=",
        "LimitRTPRIO=",
        "LimitMEMLOCK=",
        "NoNewPrivileges=yes",
        "ProtectSystem=strict",
        "User=actuatord",
    ] {
        assert!(unit.contains(key), "unit lacks {key}");
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("actuatord.service");
    std::fs::write(
        &path,
        unit.replace("/usr/local/bin/actuatord", env!("CARGO_BIN_EXE_actuatord")),
    )
    .expect("write unit");
    let out = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .output()
        .expect("systemd-analyze (package systemd) runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let about_us: Vec<_> = stderr
        .lines()
        .filter(|l| l.contains("actuatord.service"))
        .collect();
    assert!(about_us.is_empty(), "{about_us:?}");
}
