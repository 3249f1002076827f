//! The Debian package: `cargo deb --strip` builds it (cargo-deb, installed by
//! scripts/setup-test-deps), and `dpkg-deb` reads it back as `dpkg` would install it: both
//! binaries, the systemd unit with the package's binary path, the reference configuration as a
//! conffile under /etc/actuatord, the DBC and EDS under /usr/share/actuatord, and the maintainer
//! script that creates the system user the unit runs as.

use crate::common::paths::root;
use std::path::{Path, PathBuf};
use std::process::Command;

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?}: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn build_package(out_dir: &Path) -> PathBuf {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let probe = Command::new(&cargo).args(["deb", "--version"]).output();
    assert!(
        probe.is_ok_and(|o| o.status.success()),
        "cargo-deb is missing: run scripts/setup-test-deps (cargo install cargo-deb --locked)"
    );
    let deb = out_dir.join("actuatord.deb");
    run(Command::new(&cargo)
        .current_dir(root())
        .args(["deb", "--strip", "--output"])
        .arg(&deb));
    deb
}

#[test]
fn the_package_holds_the_binaries_unit_configuration_protocol_files_and_creates_the_user() {
    let dir = tempfile::tempdir().expect("tempdir");
    let deb = build_package(dir.path());

    let listing = run(Command::new("dpkg-deb").arg("-c").arg(&deb));
    let mode_of = |path: &str| {
        listing
            .lines()
            .find(|l| l.ends_with(&format!(" ./{path}")))
            .and_then(|l| l.split_whitespace().next())
            .unwrap_or_else(|| panic!("{path} not in the package:\n{listing}"))
            .to_string()
    };
    for bin in ["usr/bin/actuatord", "usr/bin/actuator"] {
        assert_eq!(mode_of(bin), "-rwxr-xr-x", "{bin}");
    }
    for file in [
        "etc/actuatord/actuatord.toml",
        "usr/share/actuatord/actuatord.dbc",
        "usr/share/actuatord/actuatord.eds",
        "usr/lib/systemd/system/actuatord.service",
        "usr/lib/systemd/system/actuatord.service.d/package.conf",
        "usr/share/actuatord/config/motor_gear.toml",
        "usr/share/actuatord/config/plants/solenoid.toml",
    ] {
        assert_eq!(mode_of(file), "-rw-r--r--", "{file}");
    }

    let info = run(Command::new("dpkg-deb").arg("-I").arg(&deb));
    assert!(info.contains("Package: actuatord"), "{info}");
    assert!(
        info.contains("Depends:") && info.contains("passwd"),
        "{info}"
    );
    let field = |name: &str| {
        run(Command::new("dpkg-deb").arg("-f").arg(&deb).arg(name))
            .trim()
            .to_string()
    };
    assert_eq!(field("Version"), format!("{}-1", env!("CARGO_PKG_VERSION")));

    // The control archive: the conffile, and a postinst that creates the user before the
    // unit is (re)started.
    let control = dir.path().join("control");
    run(Command::new("dpkg-deb").arg("-e").arg(&deb).arg(&control));
    let conffiles = std::fs::read_to_string(control.join("conffiles")).expect("conffiles");
    assert_eq!(conffiles.trim(), "/etc/actuatord/actuatord.toml");
    let postinst = std::fs::read_to_string(control.join("postinst")).expect("postinst");
    let user = postinst
        .find("useradd --system")
        .expect("postinst creates the user");
    let unit = postinst
        .find("deb-systemd-helper")
        .expect("postinst handles the unit");
    assert!(user < unit, "{postinst}");
    run(Command::new("sh").arg("-n").arg(control.join("postinst")));

    // The files as installed: the very files of the repository, and binaries that run.
    let tree = dir.path().join("tree");
    run(Command::new("dpkg-deb").arg("-x").arg(&deb).arg(&tree));
    for (installed, source) in [
        ("etc/actuatord/actuatord.toml", "config/solenoid.toml"),
        ("usr/share/actuatord/actuatord.dbc", "dbc/actuatord.dbc"),
        ("usr/share/actuatord/actuatord.eds", "dbc/actuatord.eds"),
        (
            "usr/lib/systemd/system/actuatord.service",
            "systemd/actuatord.service",
        ),
    ] {
        let a = std::fs::read(tree.join(installed)).expect(installed);
        let b = std::fs::read(root().join(source)).expect(source);
        assert!(a == b, "{installed} differs from {source}");
    }
    let unit_text = std::fs::read_to_string(tree.join("usr/lib/systemd/system/actuatord.service"))
        .expect("unit");
    assert!(unit_text.contains("User=actuatord"));
    let dropin = std::fs::read_to_string(
        tree.join("usr/lib/systemd/system/actuatord.service.d/package.conf"),
    )
    .expect("drop-in");
    assert!(
        dropin.contains(
            "ExecStart=\nExecStart=/usr/bin/actuatord --config /etc/actuatord/actuatord.toml"
        ),
        "{dropin}"
    );
    // The packaged binaries run from a folder without the sources: the daemon reads the
    // installed configuration, the tool renders the installed EDS from its built-in one.
    let bin = tree.join("usr/bin");
    let version = run(Command::new(bin.join("actuatord")).arg("--version"));
    assert!(version.contains(env!("CARGO_PKG_VERSION")), "{version}");
    let eds = run(Command::new(bin.join("actuator"))
        .current_dir(dir.path())
        .arg("eds")
        .arg("--config")
        .arg(tree.join("etc/actuatord/actuatord.toml")));
    let installed_eds =
        std::fs::read_to_string(tree.join("usr/share/actuatord/actuatord.eds")).expect("eds");
    assert!(
        eds == installed_eds,
        "the installed EDS is not the installed configuration's"
    );
}
