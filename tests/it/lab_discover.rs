//! `actuator discover` on records of the independent simulator (tests/lab_indep): the loop adds
//! nothing to a complete model, and adds two missing effects one after the other, the error
//! falling at each rung, and writes a final model that `compare` reads.

use std::collections::BTreeSet;

use actuatord::lab::data::to_csv;

use crate::lab_common;
use crate::lab_indep;
use lab_indep::{simulate_for, Plant, Truth};

fn json(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&lab_common::actuator(dir, args)).expect("JSON")
}

#[test]
fn discover_adds_both_missing_effects_in_turn_and_nothing_to_a_complete_model() {
    let dir = tempfile::tempdir().expect("tempdir");
    let truth = Truth::draw(Plant::ServoAxis, None, 4);
    std::fs::write(
        dir.path().join("axis.csv"),
        to_csv(&simulate_for(&truth, 4, 0.5)),
    )
    .expect("write CSV");
    // Viscous damping and Coulomb friction both missing.
    let bare = json(
        dir.path(),
        &[
            "discover",
            "--json",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
            "--out",
            "found.toml",
        ],
    );
    let steps = bare["steps"].as_array().expect("steps");
    let added: BTreeSet<&str> = steps.iter().filter_map(|s| s["effect"].as_str()).collect();
    assert_eq!(added, BTreeSet::from(["coulomb", "viscous"]), "{bare:#}");
    let mut before = bare["nrmse_base"].as_f64().expect("nrmse_base");
    for s in steps {
        let after = s["nrmse"].as_f64().expect("nrmse");
        assert!(after < 0.8 * before, "each rung cuts the error: {bare:#}");
        assert!(!s["evidence"].as_str().unwrap_or("").is_empty());
        before = after;
    }
    let with: BTreeSet<&str> = bare["with"]
        .as_array()
        .expect("with")
        .iter()
        .filter_map(|w| w.as_str())
        .collect();
    assert_eq!(with, added);
    // The final model predicts the held-out motion of a plant the lab did not simulate, and
    // its figure is the last rung's.
    let skill = |p: &serde_json::Value| p["skill"].as_f64().expect("skill");
    let last = steps.last().expect("a rung");
    assert_eq!(bare["prediction"], last["prediction"], "{bare:#}");
    // Each effect added predicts the motion better (0.86, then 0.97 with both).
    let skills: Vec<f64> = steps.iter().map(|s| skill(&s["prediction"])).collect();
    assert!(skills.windows(2).all(|w| w[1] > w[0]), "{skills:?}");
    assert!(skill(&bare["prediction"]) > 0.9, "{bare:#}");
    // The final model is a model file the other commands read.
    let c = json(
        dir.path(),
        &[
            "compare",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "found.toml",
        ],
    );
    assert!(c["fit"].as_f64().expect("fit") > 90.0, "{c:#}");
    // The complete model: nothing to add.
    let complete = json(
        dir.path(),
        &[
            "discover",
            "--json",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
            "--with",
            "viscous,coulomb",
        ],
    );
    assert_eq!(
        complete["steps"].as_array().map(Vec::len),
        Some(0),
        "{complete:#}"
    );
    let (b, f) = (
        complete["nrmse_base"].as_f64().expect("base"),
        complete["nrmse_final"].as_f64().expect("final"),
    );
    assert!((b - f).abs() <= 1e-9 * b.max(1.0), "{complete:#}");
    assert!(skill(&complete["prediction"]) > 0.5, "{complete:#}");
}

/// The text between `start` and the next `end` after it.
fn between<'a>(text: &'a str, start: &str, end: &str) -> &'a str {
    let from = text.find(start).map_or(text.len(), |i| i + start.len());
    let rest = &text[from..];
    &rest[..rest.find(end).unwrap_or(rest.len())]
}

#[test]
fn report_draws_the_ladder_discover_climbs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let truth = Truth::draw(Plant::ServoAxis, None, 4);
    std::fs::write(
        dir.path().join("axis.csv"),
        to_csv(&simulate_for(&truth, 4, 0.5)),
    )
    .expect("write CSV");
    let base = ["--data", "axis.csv", "--family", "linear_axis"];
    let found = json(
        dir.path(),
        &[&["discover", "--json"][..], &base[..]].concat(),
    );
    lab_common::actuator(
        dir.path(),
        &[&["report", "--discover", "--out", "rep"][..], &base[..]].concat(),
    );
    let html = std::fs::read_to_string(dir.path().join("rep/index.html")).expect("report");
    let ladder = between(&html, "<h2>Discover: the ladder</h2>", "</body>");
    assert!(!ladder.is_empty(), "the report has the ladder");
    let steps = found["steps"].as_array().expect("steps");
    assert_eq!(steps.len(), 2, "{found:#}");
    // The table: one row per rung with the figures of `discover`, in its order.
    let table = between(ladder, "<table>", "</table>");
    let rows: Vec<&str> = table.split("<tr>").skip(2).collect();
    assert_eq!(rows.len(), steps.len(), "{table}");
    for (i, (row, s)) in rows.iter().zip(steps).enumerate() {
        let cell = |x: &str| format!("<td>{x}</td>");
        let f = |key: &str| format!("{:.4}", s[key].as_f64().expect("figure"));
        for want in [
            cell(&(i + 1).to_string()),
            cell(s["effect"].as_str().expect("effect")),
            cell(&f("nrmse_before")),
            cell(&f("nrmse")),
        ] {
            assert!(row.contains(&want), "rung {}: {want} in {row}", i + 1);
        }
    }
    // The bars of the error falling rung by rung, and per rung the residual before and after.
    let bars = between(ladder, "NRMSE step by step", "</svg>");
    assert!(bars.contains("as given (refitted)"), "{bars}");
    for s in steps {
        let effect = s["effect"].as_str().expect("effect");
        assert!(bars.contains(&format!("+{effect}")), "{effect} in the bars");
    }
    // The foot and the rungs: three bars, falling.
    let widths: Vec<f64> = bars
        .split("<rect")
        .skip(1)
        .filter_map(|r| between(r, "width=\"", "\"").parse().ok())
        .collect();
    assert_eq!(widths.len(), 3, "{bars}");
    assert!(widths[0] > widths[1] && widths[1] > widths[2], "{widths:?}");
    for (i, s) in steps.iter().enumerate() {
        let effect = s["effect"].as_str().expect("effect");
        let title = format!("step {}: +{effect}, residual before and after", i + 1);
        let chart = between(ladder, &title, "</svg>");
        assert!(!chart.is_empty() && ladder.contains(&title), "{title}");
        assert!(chart.contains("before (NRMSE") && chart.contains(&format!("after +{effect}")));
        assert!(
            chart.matches("<circle").count() > 100,
            "the residuals' dots"
        );
    }
    assert!(ladder.contains(&format!(
        "final model with {}",
        found["with"]
            .as_array()
            .expect("with")
            .iter()
            .filter_map(|w| w.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    )));
}

/// A record no body with a positive mass makes: the command has a slow and a fast component of
/// equal size, the position follows both in phase but the fast one six times weaker, so the
/// balance wants a negative mass (a spring alone would move both alike, a positive mass
/// amplifies the fast one towards its resonance). The least-squares fit pins the mass at its
/// smallest admissible value, 1e-12 kg, and earlier versions wrote that model. Such a fit is a
/// failure to report: `fit` writes no model and names the parameter, `discover` refuses to start
/// from it.
#[test]
fn a_fit_that_collapses_to_a_bound_is_refused_not_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut csv = String::from("time,u,y\n");
    let mut noise = lab_common::Lcg(3);
    let tau = 2.0 * std::f64::consts::PI;
    for k in 0..4000 {
        let t = k as f64 * 0.0025;
        let u = 12.0 + 5.0 * (tau * 0.5 * t).sin() + 5.0 * (tau * 3.0 * t).sin();
        let y = 0.01
            + 0.003 * (tau * 0.5 * t).sin()
            + 0.0005 * (tau * 3.0 * t).sin()
            + 2e-6 * (noise.next() - 0.5);
        csv.push_str(&format!("{t},{u},{y}\n"));
    }
    std::fs::write(dir.path().join("drift.csv"), csv).expect("written");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .expect("actuator runs")
    };
    let on_drift = |command: &str, out: &str| {
        run(&[
            command,
            "--data",
            "drift.csv",
            "--family",
            "solenoid",
            "--with",
            "spring,viscous",
            "--out",
            out,
        ])
    };
    let out = on_drift("fit", "fitted.toml");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a collapsed fit was accepted: {err}");
    assert!(
        err.contains("solenoid.mass_kg = 1.000e-12 ended at its lower bound")
            && err.contains("collapsed")
            && err.contains("not written"),
        "{err}"
    );
    assert!(!dir.path().join("fitted.toml").exists());
    let out = on_drift("discover", "found.toml");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "discover climbed from a collapsed fit: {err}"
    );
    assert!(err.contains("collapsed"), "{err}");
    assert!(!dir.path().join("found.toml").exists());
}

/// A cogging force (periodic in position) is in no catalogue: on a bare axis the ladder adds the
/// two catalogue effects the record has and stops at the cogging, named `unexplained` with its
/// period, never an effect the plant does not have; the report maps the residual.
#[test]
fn a_force_outside_the_catalogue_is_located_and_adds_no_rung_of_its_own() {
    use lab_indep::Hidden;
    let dir = tempfile::tempdir().expect("tempdir");
    let truth = Truth::draw(Plant::ServoAxis, Some(Hidden::Cogging), 4);
    let (_, pitch, _) = truth.cogging.expect("cogging drawn");
    std::fs::write(
        dir.path().join("axis.csv"),
        to_csv(&simulate_for(&truth, 4, 0.5)),
    )
    .expect("write CSV");
    let located = |structure: &serde_json::Value| {
        let s = &structure[0];
        s["against"] == "position"
            && s["kind"] == "periodic"
            && s["period"]
                .as_f64()
                .is_some_and(|p| (p / pitch - 1.0).abs() < 0.05)
            && s["amplitude"].as_f64().is_some_and(|a| a > 0.0)
            && s["share"].as_f64().is_some_and(|a| a > 0.3)
    };
    // The complete catalogue model: nothing of the catalogue is missing, the cogging is.
    let dg = json(
        dir.path(),
        &[
            "diagnose",
            "--json",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
            "--with",
            "viscous,coulomb",
        ],
    );
    assert_eq!(dg["verdict"], "unexplained", "{dg:#}");
    assert!(located(&dg["structure"]), "{:#}", dg["structure"]);
    let text = lab_common::actuator(
        dir.path(),
        &[
            "diagnose",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
            "--with",
            "viscous,coulomb",
        ],
    );
    assert!(
        text.contains("verdict: unexplained") && text.contains("cogging"),
        "{text}"
    );
    // The bare axis: the ladder climbs the catalogue's part and stops at the cogging.
    let found = json(
        dir.path(),
        &[
            "discover",
            "--json",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
        ],
    );
    let added: BTreeSet<&str> = found["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .filter_map(|s| s["effect"].as_str())
        .collect();
    assert!(
        added.is_subset(&BTreeSet::from(["coulomb", "viscous"])),
        "{found:#}"
    );
    assert!(located(&found["unexplained"]), "{found:#}");
    lab_common::actuator(
        dir.path(),
        &[
            "report",
            "--data",
            "axis.csv",
            "--family",
            "linear_axis",
            "--with",
            "viscous,coulomb",
            "--out",
            "report",
        ],
    );
    let html = std::fs::read_to_string(dir.path().join("report/index.html")).expect("report");
    assert!(html.contains("Residual map"), "no residual map");
    assert!(
        html.contains("periodic in position: period"),
        "no structure"
    );
}
