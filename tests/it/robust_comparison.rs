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
        Path::new("config/plants/motor_gear.toml"),
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
    // The paper's bands as numbers beside today's keys: each row with a figure carries the band
    // its verdict was judged against, each row without one nulls.
    let parsed: Vec<serde_json::Value> = serde_json::from_str(&json).expect("parse");
    for (r, v) in rows.iter().zip(&parsed) {
        for (side, ours, paper, verdict) in [
            ("pid_fc", r.pid_fc, r.paper_pid_fc, &r.verdict_pid_fc),
            ("robust", r.robust, r.paper_robust, &r.verdict_robust),
        ] {
            let min = v[format!("paper_min_{side}")].as_f64();
            let max = v[format!("paper_max_{side}")].as_f64();
            match paper {
                Some(p) => {
                    let (min, max) = (min.expect("paper_min"), max.expect("paper_max"));
                    assert!(min <= p && p <= max, "{r}");
                    assert_eq!(verdict == "inside", ours >= min && ours <= max, "{r}");
                }
                None => {
                    assert!(v[format!("paper_min_{side}")].is_null(), "{r}");
                    assert!(v[format!("paper_max_{side}")].is_null(), "{r}");
                    assert_eq!(verdict, "no figure");
                }
            }
        }
    }
    // The 2 Hz lag's bands: ±50 % of 5.67° and of 1.76°.
    let v = &parsed[rows.iter().position(|r| std::ptr::eq(r, lag)).expect("row")];
    let num = |k: &str| v[k].as_f64().expect(k);
    assert!((num("paper_min_pid_fc") - 2.835).abs() < 1e-9);
    assert!((num("paper_max_pid_fc") - 8.505).abs() < 1e-9);
    assert!((num("paper_min_robust") - 0.88).abs() < 1e-9);
    assert!((num("paper_max_robust") - 2.64).abs() < 1e-9);
}

/// Peak armature voltage of the 10°, 20 Hz sine by inverse dynamics of the rigid drive, written
/// here independently of the plant model: `U = R_a (J θ'' + F_C sgn θ' + f_v θ' + T_l) / (h K_T)
/// + K_e h θ'`, `J = J_l + J_g + h² J_m` referred to the load.
fn peak_voltage_20hz_10deg(plant: &str) -> (f64, f64) {
    let spec = actuatord::physics::load_spec(Path::new(plant)).expect("plant file");
    let p = actuatord::control::robust::MotorGearParams::from_spec(&spec).expect("params");
    let (a, w) = (10f64.to_radians(), 2.0 * std::f64::consts::PI * 20.0);
    let j = p.load_inertia_kg_m2 + p.gear_inertia_kg_m2 + p.ratio * p.ratio * p.motor_inertia_kg_m2;
    let mut peak: f64 = 0.0;
    for k in 0..2000 {
        let t = k as f64 / 2000.0 / 20.0;
        let (th, v, acc) = (
            a * (w * t).sin(),
            a * w * (w * t).cos(),
            -a * w * w * (w * t).sin(),
        );
        let friction = if v >= 0.0 {
            p.coulomb_pos_nm + p.viscous_pos_nm_s_per_rad * v
        } else {
            -p.coulomb_neg_nm + p.viscous_neg_nm_s_per_rad * v
        };
        let load = p.payload_max_nm * th / p.payload_full_scale_rad;
        let u = p.resistance_ohm * (j * acc + friction + load)
            / (p.ratio * p.torque_constant_nm_per_a)
            + p.back_emf_v_s_per_rad * p.ratio * v;
        peak = peak.max(u.abs());
    }
    (peak, p.u_max_v)
}

#[test]
fn the_rebuilt_plant_can_track_20_hz_at_10_degrees_and_the_heavier_reading_cannot() {
    // docs/papers.md: the rebuilt plant needs about 19 V of its 24 V bridge; the heavier reading
    // of Table 1 (the project's plant before) needs far more than its bridge gives.
    let (bao, limit) = peak_voltage_20hz_10deg("config/plants/motor_gear.toml");
    assert!(bao < 0.85 * limit, "{bao} V of {limit} V");
    let (heavy, limit) = peak_voltage_20hz_10deg("tests/data/motor_gear_heavy_reading.toml");
    assert!(heavy > 3.0 * limit, "{heavy} V of {limit} V");
}
