//! The README's first command: the scripted demo on the in-process bus, as a user runs it.

use actuatord::demo::{run, Script};
use actuatord::supervise::FaultKind;
use std::path::Path;

#[test]
fn the_demo_tracks_its_steps_and_raises_the_supply_fault() {
    let dir = tempfile::tempdir().expect("tempdir");
    let recording = dir.path().join("demo.mcap");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = Script::standard().expect("script");
    let summary = run(
        &root.join("config/solenoid.toml"),
        &root.join("config/plants/solenoid.toml"),
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
