//! A geared axis driven by its armature voltage, no current recorded, on records of the
//! independent simulator (tests/it/lab_indep/gear.rs, `Gear::draw_voltage`): the model declares the
//! data sheet's constants but the armature's inductance, which the lab identifies from the data
//! (`compare` reports it with its interval, `fit` writes it); a complete model is diagnosed as
//! such and a missing Coulomb friction is named.
//!
//! `LAB_VERBOSE=1` prints every candidate.

use actuatord::lab::data::to_csv;
use actuatord::lab::diagnose::{diagnose, DiagnoseOptions};
use actuatord::lab::signals::prepare;
use actuatord::lab::Model;

use crate::lab_common;
use crate::lab_indep;
use lab_indep::gear::{Gear, GearHidden};

/// Seconds of record per case.
const LENGTH_S: f64 = 6.0;

/// `compare --json` on a record of `gear` and its model file with the effects `with`: the
/// drive-torque fit and the armature inductance the data give `(value, low, high)`, H.
fn compare(gear: &Gear, seed: u64, with: &[&str], right: bool) -> (f64, (f64, f64, f64)) {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::write(
        dir.path().join("gear.csv"),
        to_csv(&gear.simulate(seed, LENGTH_S)),
    )
    .expect("write CSV");
    std::fs::write(dir.path().join("gear.toml"), gear.model_file(with, right))
        .expect("write model");
    let args = [
        "compare",
        "--json",
        "--data",
        "gear.csv",
        "--model",
        "gear.toml",
    ];
    let out: serde_json::Value =
        serde_json::from_str(&lab_common::actuator(dir.path(), &args)).expect("JSON");
    let drive = out["drive"]
        .as_array()
        .and_then(|a| {
            a.iter()
                .find(|c| c["name"] == "motor_gear.inductance_h")
                .cloned()
        })
        .expect("the armature inductance reported");
    let f = |k: &str| drive[k].as_f64().expect("a number");
    (
        out["fit"].as_f64().expect("fit"),
        (f("value"), f("low"), f("high")),
    )
}

#[test]
fn a_voltage_driven_gears_armature_comes_from_the_data() {
    for seed in [1, 2, 3] {
        let gear = Gear::draw_voltage(None, seed);
        let a = gear.armature.expect("an armature");
        let (fit, (l, lo, hi)) = compare(&gear, seed, &gear.complete_effects(), true);
        eprintln!(
            "gear seed {seed} dt {:.1} ms: L_a/R_a {:.2} ms, the data say {:.2} ms \
             [{:.2}, {:.2}]; drive-torque fit at the family's inductance {fit:.1} %",
            gear.dt * 1e3,
            a.inductance / a.resistance * 1e3,
            l / a.resistance * 1e3,
            lo / a.resistance * 1e3,
            hi / a.resistance * 1e3,
        );
        let err = l / a.inductance - 1.0;
        assert!(
            err.abs() < 0.4,
            "seed {seed}: inductance {l:.3e} H against {:.3e} H",
            a.inductance
        );
    }
}

fn verdict(hidden: Option<GearHidden>, seed: u64) -> Option<String> {
    let gear = Gear::draw_voltage(hidden, seed);
    let data = gear.simulate(seed, LENGTH_S);
    let with: Vec<&str> = gear
        .complete_effects()
        .into_iter()
        .filter(|e| Some(*e) != hidden.map(GearHidden::lab_name))
        .collect();
    let model = Model::from_toml(&gear.model_file(&with, false), "gear.toml").expect("model");
    let prep = prepare(&data, None);
    let dg = diagnose(
        &model,
        &data,
        &prep,
        &DiagnoseOptions::default(),
        &|_, _, _| {},
    )
    .expect("diagnosis runs");
    lab_common::print_candidates(&dg);
    eprintln!(
        "voltage gear {:<12} seed {seed} dt {:.1} ms: NRMSE {:.4}, verdict {}",
        hidden.map_or("(complete)", GearHidden::lab_name),
        gear.dt * 1e3,
        dg.nrmse_base,
        dg.verdict.as_deref().unwrap_or("none")
    );
    dg.verdict
}

#[test]
fn a_voltage_driven_gear_is_diagnosed() {
    let mut wrong = Vec::new();
    for (hidden, seeds) in [(None, [1, 2]), (Some(GearHidden::Coulomb), [3, 4])] {
        for seed in seeds {
            let got = verdict(hidden, seed);
            if got.as_deref() != hidden.map(GearHidden::lab_name) {
                wrong.push((hidden, seed, got));
            }
        }
    }
    assert!(wrong.is_empty(), "wrong verdicts: {wrong:?}");
}

/// The armature and the verdicts on seeds 1-8 (`LAB_SEEDS=...` for others): the figures of
/// docs/lab.md.
#[test]
#[ignore = "sweep over seeds; run with scripts/lab-sweeps"]
fn voltage_driven_gear_sweep() {
    let seeds = lab_common::sweep_seeds(1..=8);
    let mut errors = Vec::new();
    let mut wrong = Vec::new();
    for &seed in &seeds {
        let gear = Gear::draw_voltage(None, seed);
        let a = gear.armature.expect("an armature");
        let (_, (l, lo, hi)) = compare(&gear, seed, &gear.complete_effects(), true);
        let inside = (lo..=hi).contains(&a.inductance);
        eprintln!(
            "seed {seed} dt {:.1} ms: L_a/R_a {:.2} ms, the data say {:.2} ms ({:+.0} %), truth \
             {} the interval",
            gear.dt * 1e3,
            a.inductance / a.resistance * 1e3,
            l / a.resistance * 1e3,
            100.0 * (l / a.inductance - 1.0),
            if inside { "inside" } else { "outside" }
        );
        errors.push(l / a.inductance - 1.0);
        for hidden in [None, Some(GearHidden::Coulomb), Some(GearHidden::Viscous)] {
            let got = verdict(hidden, seed);
            if got.as_deref() != hidden.map(GearHidden::lab_name) {
                wrong.push((hidden, seed, got));
            }
        }
    }
    let (lo, hi) = errors
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &e| (a.min(e), b.max(e)));
    eprintln!(
        "inductance error {:+.0} % .. {:+.0} %; wrong verdicts: {wrong:?}",
        100.0 * lo,
        100.0 * hi
    );
    assert!(wrong.is_empty(), "wrong verdicts: {wrong:?}");
}
