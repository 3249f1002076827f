//! The paper's comparison in simulation: PID + friction compensation versus the robust
//! controller on the `motor_gear` plant.

use std::path::Path;

use actuatord::design::{design_robust, run_comparison, ComparisonConfig, ComparisonTable};

#[test]
fn comparison_table_has_the_papers_rows_and_plausible_figures() {
    let d = design_robust(Path::new("config/plants/motor_gear.toml")).expect("design");
    let rows = run_comparison(&d, &ComparisonConfig::default()).expect("comparison");
    eprintln!("{}", ComparisonTable(&rows));
    // 4 sine tests × (amplitude error, phase lag) + 2 bandwidths.
    assert_eq!(rows.len(), 10);
    for r in &rows {
        assert!(r.pid_fc.is_finite() && r.robust.is_finite(), "{r}");
    }
    let find = |test: &str, metric: &str| {
        rows.iter()
            .find(|r| r.test == test && r.metric == metric)
            .expect("row present")
    };
    // 2 Hz, 10°: both track (amplitude within 30 %, lag below 45°).
    let a = find("sine 2 Hz, 10°", "amplitude error");
    let p = find("sine 2 Hz, 10°", "phase lag");
    for (amp, lag) in [(a.pid_fc, p.pid_fc), (a.robust, p.robust)] {
        assert!(
            amp.abs() < 30.0 && lag > 0.0 && lag < 45.0,
            "{amp} % {lag}°"
        );
    }
    // The paper's direction: less phase lag at 2 Hz and a wider 10° bandwidth for the robust
    // controller.
    assert!(p.robust < p.pid_fc, "{p}");
    let b = find("sweep 10°", "-3 dB bandwidth");
    assert!(b.robust > b.pid_fc, "{b}");
    let json = serde_json::to_string(&rows).expect("serialise");
    assert!(json.contains("\"paper_pid_fc\":5.67"));
    assert!(json.contains("\"verdict_robust\":"));
}
