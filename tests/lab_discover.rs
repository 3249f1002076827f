//! `actuator discover` on records of the independent simulator (tests/lab_indep): the loop adds
//! nothing to a complete model, and adds two missing effects one after the other, the error
//! falling at each rung, and writes a final model that `compare` reads.

use std::collections::BTreeSet;

use actuatord::lab::data::to_csv;

mod lab_common;
mod lab_indep;
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
}
