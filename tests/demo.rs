//! The README's first command: the scripted demo on the in-process bus, as a user runs it.

use actuatord::defaults::{self, Source};
use actuatord::demo::{run_from as run, Script};
use actuatord::physics::Family;
use actuatord::supervise::FaultKind;

#[test]
fn the_demo_tracks_its_steps_and_raises_the_supply_fault() {
    let dir = tempfile::tempdir().expect("tempdir");
    let recording = dir.path().join("demo.mcap");
    let script = Script::standard().expect("script");
    let summary = run(
        &Source::Builtin(defaults::config(Family::Solenoid)),
        &Source::Builtin(defaults::plant(Family::Solenoid)),
        &script,
        &recording,
    )
    .expect("demo runs");
    println!("{summary}");
    assert_eq!(summary.steps.len(), script.setpoints.len());
    // Before any fault every step settles to within a few sensor quanta of friction stick.
    for s in &summary.steps[..5] {
        assert!(
            s.steady_state_error_m.abs() < 30e-6,
            "step to {} m: {} m",
            s.to_m,
            s.steady_state_error_m
        );
        assert!(s.faults.is_empty());
    }
    assert_eq!(summary.injected.len(), 2);
    let (_, raised_cycle, _) = summary
        .faults_raised
        .iter()
        .find(|(_, _, k)| *k == FaultKind::SupplyVoltage)
        .copied()
        .expect("the supply drop is detected");
    // Counted in SYNCs, which is what both nodes share whatever the machine's load: the
    // persistence is 4 cycles; a few missed sensor frames may add to it.
    let injected_sync = summary.injected[1].1;
    let latency = raised_cycle
        .checked_sub(injected_sync)
        .expect("raised after the injection, not before");
    assert!((3..=12).contains(&latency), "latency {latency} periods");
    assert!(std::fs::metadata(&recording).map(|m| m.len()).unwrap_or(0) > 100_000);
}

/// The built-in configurations and plant files: `actuator sim --family F` runs in a folder with
/// no `config/` in sight, as after `cargo install`; a file named on the command line still wins.
#[test]
fn sim_runs_from_any_directory_on_the_built_in_files_and_a_named_file_wins() {
    let dir = tempfile::tempdir().expect("tempdir");
    for family in ["motor_gear", "linear_axis", "pneumatic", "solenoid"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
            .current_dir(dir.path())
            .args([
                "sim",
                "--family",
                family,
                "--record",
                "run.csv",
                "--seconds",
                "0.5",
            ])
            .output()
            .expect("actuator runs");
        assert!(
            out.status.success(),
            "{family}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let csv = std::fs::read_to_string(dir.path().join("run.csv")).expect("csv written");
        assert!(csv.lines().count() > 10, "{family}: {csv}");
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .current_dir(dir.path())
        .args(["sim", "--family", "motor_gear", "--plant", "mine.toml"])
        .args(["--record", "run.csv", "--seconds", "0.5"])
        .output()
        .expect("actuator runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("mine.toml: cannot read"), "{err}");
}
