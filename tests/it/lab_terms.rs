//! A force outside the catalogue, declared by the user as a term of the model file: on the
//! independent simulator's cogging axis, `fit` finds its pitch and amplitude within 2 % of the
//! truth and the error falls to a third; declared as a candidate, `diagnose` names it and
//! `discover` adds it.

use crate::lab_common;
use crate::lab_indep;

use actuatord::lab::data::to_csv;
use lab_indep::{simulate_for, Hidden, Plant, Truth};

fn json(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&lab_common::actuator(dir, args)).expect("JSON")
}

/// The servo axis' complete catalogue model with the user's cogging term (`candidate` as given).
fn cogged_model(candidate: bool) -> String {
    format!(
        "family = \"linear_axis\"\n\n[viscous]\n\n[coulomb]\n\n[lab]\n\n[[lab.term]]\n\
         name = \"cogging\"\n\
         force = \"a*sin(2*pi*y/pitch) + b*cos(2*pi*y/pitch)\"   # N\n\
         params = {{ a = [-200, 200], b = [-200, 200], pitch = [0.002, 0.05] }}\n\
         candidate = {candidate}\n"
    )
}

/// The independent simulator's cogging axis (seed 4) as `axis.csv` and the model with the term
/// as `cogged.toml`, in a fresh directory.
fn cogging_axis(candidate: bool) -> (tempfile::TempDir, Truth) {
    let dir = tempfile::tempdir().expect("tempdir");
    let truth = Truth::draw(Plant::ServoAxis, Some(Hidden::Cogging), 4);
    std::fs::write(
        dir.path().join("axis.csv"),
        to_csv(&simulate_for(&truth, 4, 0.5)),
    )
    .expect("write CSV");
    std::fs::write(dir.path().join("cogged.toml"), cogged_model(candidate)).expect("model");
    (dir, truth)
}

#[test]
fn a_declared_cogging_term_is_fitted_to_the_true_pitch_and_amplitude() {
    let (dir, truth) = cogging_axis(false);
    let (amp, pitch, _) = truth.cogging.expect("cogging drawn");
    let fit = json(
        dir.path(),
        &[
            "fit",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "cogged.toml",
            "--out",
            "fitted.toml",
        ],
    );
    let param = |name: &str| {
        fit["parameters"]
            .as_array()
            .and_then(|ps| ps.iter().find(|p| p["name"] == name))
            .unwrap_or_else(|| panic!("no {name} in {fit:#}"))
            .clone()
    };
    // No parameter of the fitted model ended at its bound.
    let at_bound: Vec<&serde_json::Value> = fit["parameters"]
        .as_array()
        .expect("parameters")
        .iter()
        .filter(|p| p["status"] == "at_bound")
        .collect();
    assert!(at_bound.is_empty(), "at a bound: {at_bound:?}");
    let p = param("cogging.pitch");
    let got = p["value"].as_f64().expect("pitch");
    assert!((got / pitch - 1.0).abs() < 0.02, "pitch {got} vs {pitch}");
    // Its interval is the profile's over the searched grid: it holds the truth and is narrow.
    let (lo, hi) = (
        p["low"].as_f64().expect("pitch interval"),
        p["high"].as_f64().expect("pitch interval"),
    );
    assert!(
        lo <= pitch && pitch <= hi,
        "pitch {pitch} outside [{lo}, {hi}]"
    );
    assert!(
        hi - lo < 0.1 * pitch,
        "pitch interval [{lo}, {hi}] for {pitch}"
    );
    let (a, b) = (
        param("cogging.a")["value"].as_f64().expect("a"),
        param("cogging.b")["value"].as_f64().expect("b"),
    );
    // The command is a voltage and the drive's gain is held at its declared value: every force
    // comes out on the drive's scale, so the amplitude is compared per unit of mass.
    let mass = param("linear_axis.mass_kg")["value"]
        .as_f64()
        .expect("mass");
    let (fitted, true_) = (a.hypot(b) / mass, amp / truth.mass);
    assert!(
        (fitted / true_ - 1.0).abs() < 0.1,
        "amplitude per mass {fitted} vs {true_}"
    );
    // Without the term, the complete catalogue model leaves the cogging in its error.
    std::fs::write(
        dir.path().join("plain.toml"),
        "family = \"linear_axis\"\n\n[viscous]\n\n[coulomb]\n",
    )
    .expect("model");
    let plain = json(
        dir.path(),
        &[
            "fit",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "plain.toml",
            "--out",
            "plain_fitted.toml",
        ],
    );
    let (with, without) = (
        fit["nrmse"].as_f64().expect("nrmse"),
        plain["nrmse"].as_f64().expect("nrmse"),
    );
    eprintln!("NRMSE with the term {with:.4}, without {without:.4}");
    assert!(with < 0.5 * without, "with {with} vs without {without}");
    // The written model reads back with the term in it.
    let written = std::fs::read_to_string(dir.path().join("fitted.toml")).expect("written");
    assert!(written.contains("[[lab.term]]") && written.contains("name = \"cogging\""));
}

#[test]
fn a_declared_candidate_term_is_named_by_diagnose_and_added_by_discover() {
    let (dir, truth) = cogging_axis(true);
    let (_, pitch, _) = truth.cogging.expect("cogging drawn");
    let dg = json(
        dir.path(),
        &[
            "diagnose",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "cogged.toml",
        ],
    );
    assert_eq!(dg["verdict"], "cogging", "{dg:#}");
    let found = json(
        dir.path(),
        &[
            "discover",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "cogged.toml",
            "--out",
            "found.toml",
        ],
    );
    // `--with` makes the declared candidate part of the model for any command.
    let compared = |with: &[&str]| {
        let mut args = vec![
            "fit",
            "--json",
            "--data",
            "axis.csv",
            "--model",
            "cogged.toml",
            "--out",
            "f.toml",
        ];
        args.extend_from_slice(with);
        json(dir.path(), &args)["nrmse"].as_f64().expect("nrmse")
    };
    let (without, with) = (compared(&[]), compared(&["--with", "cogging"]));
    assert!(with < 0.5 * without, "fit: {without} -> {with}");
    let err = lab_common::actuator_fails(
        dir.path(),
        &[
            "compare",
            "--data",
            "axis.csv",
            "--model",
            "cogged.toml",
            "--with",
            "coging",
        ],
    );
    assert!(
        err.contains("cogged.toml") && err.contains("coging"),
        "{err}"
    );
    let steps: Vec<&str> = found["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .filter_map(|s| s["effect"].as_str())
        .collect();
    assert_eq!(steps, ["cogging"], "{found:#}");
    let written =
        actuatord::lab::model::Model::load(&dir.path().join("found.toml")).expect("reads");
    let term = written.spec.term("cogging").expect("the term");
    assert!(!term.candidate, "the term is part of the written model");
    let got = written.value("cogging.pitch");
    assert!((got / pitch - 1.0).abs() < 0.02, "pitch {got} vs {pitch}");
}
