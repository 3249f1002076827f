//! The README's model-lab walkthrough, command by command as a user types it (in a folder with
//! the project's `config/`): each command succeeds, the verdicts its comments promise come true,
//! the refitted model's error falls, and the report shows both models.

use std::path::Path;

use crate::lab_common;

/// The `actuator ...` lines of the README's code block under `## The model lab`, with the
/// comment each carries.
fn walkthrough() -> Vec<(Vec<String>, String)> {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .expect("README.md");
    let section = readme
        .split("\n## The model lab")
        .nth(1)
        .expect("a model lab section");
    let block = section
        .split("```sh\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("a sh code block");
    block
        .lines()
        .filter(|l| l.starts_with("actuator "))
        .map(|l| {
            let (cmd, comment) = l.split_once('#').unwrap_or((l, ""));
            let args = cmd.split_whitespace().skip(1).map(String::from).collect();
            (args, comment.trim().to_string())
        })
        .collect()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from).expect("read_dir") {
        let entry = entry.expect("entry");
        let target = to.join(entry.file_name());
        if entry.file_type().expect("type").is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).expect("copy");
        }
    }
}

fn run(dir: &Path, args: &[String]) -> String {
    lab_common::actuator(dir, args)
}

fn nrmse(dir: &Path, model: &[&str]) -> f64 {
    let mut args: Vec<String> = ["compare", "--data", "run.csv", "--json"]
        .iter()
        .chain(model)
        .map(|s| s.to_string())
        .collect();
    args.dedup();
    let json: serde_json::Value = serde_json::from_str(&run(dir, &args)).expect("JSON");
    json["nrmse"].as_f64().expect("nrmse")
}

#[test]
fn the_readme_walkthrough_names_the_missing_effect_and_the_refit_lowers_the_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    copy_dir(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("config"),
        &dir.path().join("config"),
    );
    let steps = walkthrough();
    assert!(steps.len() >= 5, "the walkthrough has its steps: {steps:?}");
    let mut promised = 0;
    for (args, comment) in &steps {
        let out = run(dir.path(), args);
        if let Some(verdict) = comment.strip_prefix("verdict: ") {
            promised += 1;
            assert!(
                out.contains(&format!("verdict: {verdict} is most likely missing")),
                "promised verdict {verdict}: {out}"
            );
        }
    }
    // The README promises a verdict; a walkthrough whose comment lost it would check nothing.
    assert!(
        promised > 0,
        "no `# verdict: ...` comment in the walkthrough: {steps:?}"
    );
    // The refitted model (with the named effect) explains the data better than the rough
    // one refitted (`diagnose` refits it), in the figure `compare` gives.
    let rough_fit = dir.path().join("rough.toml");
    run(
        dir.path(),
        &[
            "fit",
            "--data",
            "run.csv",
            "--family",
            "solenoid",
            "--with",
            "spring,viscous",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([rough_fit.display().to_string()])
        .collect::<Vec<_>>(),
    );
    let rough = nrmse(dir.path(), &["--model", "rough.toml"]);
    let fitted = nrmse(dir.path(), &["--model", "fitted.toml"]);
    assert!(
        fitted < 0.8 * rough,
        "NRMSE with the named effect {fitted} against {rough} without"
    );
    let html = std::fs::read_to_string(dir.path().join("report/index.html")).expect("report");
    assert!(html.matches("<svg").count() >= 4, "plots in the report");
    assert!(html.contains("fitted"), "the fitted model is in the report");
}

/// The lab reads the daemon's own recording: a short run with setpoint steps, compared and
/// diagnosed as MCAP, every recorded cycle a sample. The run is the controller node and the
/// simulated node in lock-step, recorded by the daemon's recorder: the same records on every
/// run, whatever the machine's load.
#[test]
fn the_lab_reads_a_recording_of_the_daemon() {
    use actuatord::daemon::config::SetpointStep;
    use actuatord::daemon::record::Record;
    use actuatord::daemon::{Config, Recorder};
    use actuatord::lockstep::LockStep;
    let dir = tempfile::tempdir().expect("tempdir");
    let recording = dir.path().join("steps.mcap");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut config = Config::load(&root.join("config/solenoid.toml")).expect("config");
    config.axis[0].setpoints = (0..8)
        .map(|i| SetpointStep {
            at_s: 0.4 * i as f64,
            position_m: if i % 2 == 0 { 0.004 } else { 0.010 },
        })
        .collect();
    let plant = actuatord::physics::load_spec(&root.join("config/plants/solenoid.toml"))
        .expect("plant")
        .build()
        .expect("plant builds");
    let mut rig = LockStep::new(&config, plant, Vec::new()).expect("lock-step rig");
    let (sink, recorder) = Recorder::spawn(Some(&recording), 1 << 16).expect("recorder");
    rig.run(3.2, &mut |s| sink.push(Record::Cycle(s.record)));
    drop(sink);
    let report = recorder.finish().expect("recording written");
    assert_eq!(report.dropped, 0);
    let cycles = actuatord::daemon::recorder::read_cycles(&recording)
        .expect("recording")
        .len();
    let data = recording.display().to_string();
    let out = run(
        dir.path(),
        &[
            "compare",
            "--data",
            &data,
            "--family",
            "solenoid",
            "--with",
            "spring,viscous,coulomb",
            "--json",
        ]
        .map(String::from),
    );
    let json: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    let samples = json["data_samples"].as_u64().expect("data_samples") as usize;
    assert_eq!(samples, cycles, "one sample per recorded cycle");
    let as_given = json["nrmse"].as_f64().expect("nrmse");
    // Fitted to the recording, the model must find the simulated plant's own parameters: the
    // recording carries what the daemon saw, and the plant file says what was there.
    let fitted = dir.path().join("fitted.toml");
    run(
        dir.path(),
        &[
            "fit",
            "--data",
            &data,
            "--family",
            "solenoid",
            "--with",
            "spring,viscous,coulomb",
            "--out",
            &fitted.display().to_string(),
        ]
        .map(String::from),
    );
    let plant =
        actuatord::physics::load_spec(&root.join("config/plants/solenoid.toml")).expect("plant");
    let model: toml::Table = std::fs::read_to_string(&fitted)
        .expect("fitted model")
        .parse()
        .expect("fitted model is TOML");
    // The spring is what a few seconds of steps pin down best; the mass and the damping less so.
    for (name, tolerance) in [
        ("spring.stiffness_n_per_m", 0.02),
        ("spring.pretension_n", 0.1),
        ("solenoid.mass_kg", 0.1),
        ("viscous.damping_pos_n_s_per_m", 0.1),
    ] {
        let (truth, found) = (
            plant.get(name).expect("plant parameter"),
            name.split_once('.')
                .and_then(|(t, k)| model.get(t)?.get(k)?.as_float())
                .unwrap_or_else(|| panic!("{name} in the fitted model")),
        );
        println!("fitted to the recording: {name} {found:.4} (plant {truth:.4})");
        assert!(
            (found - truth).abs() < tolerance * truth.abs(),
            "{name}: fitted {found}, the plant has {truth}"
        );
    }
    let out = run(
        dir.path(),
        &[
            "compare",
            "--data",
            &data,
            "--model",
            &fitted.display().to_string(),
            "--json",
        ]
        .map(String::from),
    );
    let json: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    let with_fit = json["nrmse"].as_f64().expect("nrmse");
    println!("NRMSE as given {as_given:.3}, fitted {with_fit:.3}");
    assert!(
        with_fit < 0.1 * as_given,
        "NRMSE fitted {with_fit} against {as_given} as given"
    );
    let out = run(
        dir.path(),
        &[
            "diagnose",
            "--data",
            &data,
            "--family",
            "solenoid",
            "--with",
            "spring,viscous",
            "--json",
        ]
        .map(String::from),
    );
    let json: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    assert!(
        json["candidates"].as_array().is_some_and(|c| !c.is_empty()),
        "{out}"
    );
    // The simulated solenoid has Coulomb friction, which the model was given without.
    assert_eq!(json["verdict"].as_str(), Some("coulomb"), "{out}");
    // And with it the held-out motion is predicted better than without it.
    let coulomb = json["candidates"]
        .as_array()
        .and_then(|c| c.iter().find(|c| c["effect"] == "coulomb"))
        .expect("the coulomb candidate");
    let better = coulomb["prediction_improvement"]
        .as_f64()
        .expect("a prediction");
    let (with, without) = (
        coulomb["prediction"]["skill"].as_f64().expect("skill"),
        json["base_prediction"]["skill"]
            .as_f64()
            .expect("base skill"),
    );
    println!("prediction skill without coulomb {without:.2}, with {with:.2}");
    assert!(better > 0.2 && with > without, "{out}");
}
