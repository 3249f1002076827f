//! The paper's comparison in simulation: PID + friction compensation versus the robust
//! controller on the plant rebuilt for Bao, Mao & Luo (2016), each figure held against the
//! paper's.

use std::path::Path;

use actuatord::control::robust::DesignOptions;
use actuatord::design::{
    design_robust_with, run_comparison, ComparisonConfig, ComparisonRow, ComparisonTable,
};

fn rows() -> Vec<ComparisonRow> {
    let d = design_robust_with(
        Path::new("config/plants/motor_gear_bao.toml"),
        DesignOptions::bao_2016(),
    )
    .expect("design");
    assert!(d.synthesis.nominal_discrete_stable);
    assert_eq!(d.synthesis.vertices_stable.0, d.synthesis.vertices_stable.1);
    let rows = run_comparison(&d, &ComparisonConfig::default()).expect("comparison");
    eprintln!("{}", ComparisonTable(&rows));
    rows
}

fn find<'a>(rows: &'a [ComparisonRow], test: &str, metric: &str) -> &'a ComparisonRow {
    rows.iter()
        .find(|r| r.test == test && r.metric == metric)
        .expect("row present")
}

#[test]
fn comparison_reaches_the_papers_figures() {
    let rows = rows();
    // 4 sine tests × (amplitude error, phase lag) + 2 bandwidths.
    assert_eq!(rows.len(), 10);
    for r in &rows {
        assert!(r.pid_fc.is_finite() && r.robust.is_finite(), "{r}");
    }
    // 2 Hz, 10°: the paper's 1.76° (robust) and 5.67° (PID+FC); the bound 2.5° for the
    // robust loop, ±50 % of the paper's figure for PID+FC; neither loses or gains more than
    // 10 % amplitude (the paper: no amplitude loss at 2 Hz).
    let lag = find(&rows, "sine 2 Hz, 10°", "phase lag");
    assert!(lag.robust > 0.0 && lag.robust <= 2.5, "{lag}");
    assert!(lag.pid_fc >= 2.835 && lag.pid_fc <= 8.505, "{lag}");
    assert_eq!(lag.verdict_robust, "inside");
    assert_eq!(lag.verdict_pid_fc, "inside");
    let amp2 = find(&rows, "sine 2 Hz, 10°", "amplitude error");
    assert!(
        amp2.robust.abs() < 10.0 && amp2.pid_fc.abs() < 10.0,
        "{amp2}"
    );
    // 20 Hz, 10°: the robust loop keeps the amplitude (within ±10 %), PID+FC loses about half
    // (-75..-25 %).
    let amp = find(&rows, "sine 20 Hz, 10°", "amplitude error");
    assert!(amp.robust >= -10.0 && amp.robust <= 10.0, "{amp}");
    assert!(amp.pid_fc >= -75.0 && amp.pid_fc <= -25.0, "{amp}");
    assert_eq!(amp.verdict_robust, "inside");
    assert_eq!(amp.verdict_pid_fc, "inside");
    // -3 dB bandwidth at 1°: the robust loop reaches the paper's 61 rad/s (issue: ≥ 55);
    // PID+FC, held up by stiction at each reversal, lands within ±50 % of the paper's 16.6.
    let b1 = find(&rows, "sweep 1°", "-3 dB bandwidth");
    assert!(b1.robust >= 55.0, "{b1}");
    assert!(b1.pid_fc >= 8.3 && b1.pid_fc <= 24.9, "{b1}");
    assert_eq!(b1.verdict_pid_fc, "inside");
    // Stiction is a small-amplitude effect: PID+FC's 10° bandwidth is several times its 1°.
    let b10 = find(&rows, "sweep 10°", "-3 dB bandwidth");
    assert!(b10.pid_fc > 2.0 * b1.pid_fc, "{b10} {b1}");
    // At 10° the bridge's 24 V keep the robust loop's bandwidth below its 1° figure, but it
    // still reaches beyond the 20 Hz test (125.7 rad/s); PID+FC stays below 20 Hz there.
    assert!(b10.robust > 125.7 && b10.pid_fc < 125.7, "{b10}");
    let json = serde_json::to_string(&rows).expect("serialise");
    assert!(json.contains("\"paper_pid_fc\":5.67"));
    assert!(json.contains("\"verdict_robust\":"));
}
