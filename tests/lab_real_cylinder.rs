//! The lab on measurements nobody here made: an excerpt of the pneumatic cylinder at 3 bar
//! (CC0, tests/data/README.md). The figures and the verdict are those docs/lab.md reports for
//! it ("Real data": viscous only 0.143 / 0.141, with Coulomb friction 0.132 / 0.129, verdict
//! undecided between a dead zone and a saturation, the dead zone in the answer at 1 and 7 bar
//! too).

use std::path::Path;

mod lab_common;

const ROUGH: &str =
    "family = \"linear_axis\"\ncommand = \"force\"\n\n[linear_axis]\nmass_kg = 0.3\n\
travel_min_m = -10.0\ntravel_max_m = 10.0\nsupply_voltage_v = 100000.0\n\n[viscous]\n";

fn json(dir: &Path, args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&lab_common::actuator(dir, args)).expect("JSON")
}

#[test]
fn cylinder_excerpt_gives_the_documented_figures_and_verdict() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/pneumatic_cylinder_3bar.csv");
    let data = data.to_str().expect("UTF-8 path");
    std::fs::write(dir.path().join("rough.toml"), ROUGH).expect("model");
    std::fs::write(
        dir.path().join("friction.toml"),
        format!("{ROUGH}\n[coulomb]\n"),
    )
    .expect("model");
    for (model, train, held) in [
        ("rough.toml", 0.143, 0.141),
        ("friction.toml", 0.132, 0.129),
    ] {
        let c = json(
            dir.path(),
            &[
                "compare",
                "--json",
                "--data",
                data,
                "--model",
                model,
                "--holdout",
                "0.3",
            ],
        );
        let h = &c["holdout"];
        let got = (
            h["training"]["nrmse"].as_f64().expect("training"),
            h["held_out"]["nrmse"].as_f64().expect("held out"),
        );
        assert!(
            (got.0 - train).abs() < 6e-4 && (got.1 - held).abs() < 6e-4,
            "{model}: NRMSE {got:?}, docs/lab.md gives {train} / {held}"
        );
    }
    let d = json(
        dir.path(),
        &[
            "diagnose",
            "--json",
            "--data",
            data,
            "--model",
            "friction.toml",
        ],
    );
    // The dead zone cuts the most, but a saturation of the same command explains nearly as
    // much: the record does not decide, and the answer is the set.
    assert_eq!(d["verdict"], "undecided", "{d:#}");
    let set: Vec<&str> = d["undecided"]["effects"]
        .as_array()
        .expect("the undecided set")
        .iter()
        .filter_map(|e| e.as_str())
        .collect();
    assert_eq!(set, ["deadzone", "saturation"], "{d:#}");
    let separated_by = d["undecided"]["separated_by"].as_str().unwrap_or_default();
    assert!(
        separated_by.contains("commands both below and beyond the drive's limit"),
        "{separated_by}"
    );
}
