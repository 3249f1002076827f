//! Records of one actuator at several supplies, given together with `--data` repeated: the lab
//! takes each as a stretch of its own and names friction that follows the supply, which no
//! single record at a held supply can show (the pneumatic cylinder of shared/data, simulated).

use std::path::Path;

use actuatord::lab::data::to_csv;
use actuatord::physics::{EffectKind, Family, PlantSpec};

use crate::lab_common;
use lab_common::{closed_loop_with_fault, sensor, Run, Supply};

fn actuator(dir: &Path, args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&lab_common::actuator(dir, args)).expect("JSON")
}

#[test]
fn friction_that_follows_the_supply_is_named_from_records_taken_together() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut truth = PlantSpec::new(Family::LinearAxis);
    for e in [
        EffectKind::Viscous,
        EffectKind::Coulomb,
        EffectKind::SupplyFriction,
    ] {
        truth.add_effect(e).expect("effect");
    }
    for (k, v) in [
        ("viscous.damping_pos_n_s_per_m", 4.0),
        ("viscous.damping_neg_n_s_per_m", 4.5),
        ("coulomb.coulomb_pos_n", 1.0),
        ("coulomb.coulomb_neg_n", 0.9),
        ("supply_friction.exponent", 1.0),
    ] {
        truth.set(k, v).expect(k);
    }
    // Three records at a held supply each: half, nominal and one and a half times 24 V.
    let mut files = Vec::new();
    for (i, supply) in [12.0, 24.0, 36.0].into_iter().enumerate() {
        let seed = 11 + i as u64;
        let mut spec = truth.clone();
        sensor(&mut spec, seed);
        let data = closed_loop_with_fault(&spec, seed, 8.0, Supply::Held(supply), Run::Track, None);
        let name = format!("axis_{supply}v.csv");
        std::fs::write(dir.path().join(&name), to_csv(&data)).expect("write CSV");
        files.push(name);
    }
    let model = ["--family", "linear_axis", "--with", "viscous,coulomb"];
    let mut together: Vec<&str> = vec!["diagnose", "--json"];
    for f in &files {
        together.extend(["--data", f.as_str()]);
    }
    let joint = actuator(dir.path(), &[&together[..], &model[..]].concat());
    assert_eq!(joint["verdict"], "supply_friction", "{joint:#}");
    // One record at a held supply says nothing about the supply.
    let single = actuator(
        dir.path(),
        &[
            &["diagnose", "--json", "--data", files[2].as_str()][..],
            &model[..],
        ]
        .concat(),
    );
    let candidate = single["candidates"]
        .as_array()
        .expect("candidates")
        .iter()
        .find(|c| c["effect"] == "supply_friction")
        .expect("supply_friction assessed");
    assert_eq!(candidate["significant"], false, "{single:#}");
    // Added and refitted, the exponent is found and the error falls.
    let mut fit: Vec<&str> = vec!["fit", "--json", "--out", "fitted.toml"];
    for f in &files {
        fit.extend(["--data", f.as_str()]);
    }
    let fitted = actuator(
        dir.path(),
        &[
            &fit[..],
            &[
                "--family",
                "linear_axis",
                "--with",
                "viscous,coulomb,supply_friction",
            ][..],
        ]
        .concat(),
    );
    let exponent = fitted["parameters"]
        .as_array()
        .expect("parameters")
        .iter()
        .find(|p| p["name"] == "supply_friction.exponent")
        .and_then(|p| p["value"].as_f64())
        .expect("exponent");
    assert!((exponent - 1.0).abs() < 0.2, "exponent {exponent}");
    let base = joint["nrmse_base"].as_f64().expect("nrmse_base");
    let with = joint["candidates"][0]["nrmse"].as_f64().expect("nrmse");
    assert!(with < 0.8 * base, "{base} -> {with}");
}
