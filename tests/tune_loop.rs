//! The loop record → fit → tune → run → compare, on plants the reference configurations were
//! not made for (tests/data/*_heavy.toml: more mass, another spring, a weaker drive, three
//! times the friction). The reference configuration runs the plant in lock-step and the daemon's
//! record is written as the lab's CSV; `actuator fit` and `actuator tune` run as a user runs
//! them; the tuned file passes the daemon's validation and runs the same tour again.

use std::path::Path;

use actuatord::daemon::Config;
use actuatord::lockstep::{write_csv, LockStep, LockStepSample};

mod lab_common;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The reference configuration with the installation's tour `tour` (steps every `dt_s` from
/// 1 s, starting at `tour[0]`), written to `dir`: the tour is what both runs track and what
/// `tune` keeps the command's limits for.
fn with_tour(dir: &Path, reference: &Path, tour: &[f64], dt_s: f64) -> std::path::PathBuf {
    let text = std::fs::read_to_string(reference).expect("reference configuration");
    let mut doc: toml_edit::DocumentMut = text.parse().expect("TOML");
    let axis = doc["axis"]
        .as_array_of_tables_mut()
        .and_then(|a| a.get_mut(0))
        .expect("an axis");
    axis["initial_setpoint_m"] = toml_edit::value(tour[0]);
    let mut steps = toml_edit::ArrayOfTables::new();
    for (i, &p) in tour.iter().enumerate().skip(1) {
        let mut t = toml_edit::Table::new();
        t["at_s"] = toml_edit::value(1.0 + dt_s * (i - 1) as f64);
        t["position_m"] = toml_edit::value(p);
        steps.push(t);
    }
    axis["setpoints"] = toml_edit::Item::ArrayOfTables(steps);
    let path = dir.join(reference.file_name().expect("file name"));
    std::fs::write(&path, doc.to_string()).expect("written");
    path
}

/// Run `config` against the plant file over its tour, and one second more.
fn run(config: &Config, plant: &Path) -> Vec<LockStepSample> {
    let spec = actuatord::physics::load_spec(plant).expect("plant file");
    let mut rig = LockStep::new(config, spec.build().expect("plant"), Vec::new()).expect("rig");
    let end = config.axis[0].setpoints.last().map_or(0.0, |s| s.at_s) + 1.0;
    let mut out = Vec::new();
    rig.run(end, &mut |s| out.push(*s));
    assert_eq!(rig.controller().counters().faults_raised, 0, "no fault");
    out
}

/// RMS of the following error (against the reference the axis applied) from 1 s on.
fn rms_error(samples: &[LockStepSample]) -> f64 {
    let e: Vec<f64> = samples
        .iter()
        .filter(|s| s.record.t_s >= 1.0)
        .map(|s| s.record.following_error)
        .collect();
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

/// Mean |error| over the last 50 ms before each set-point change: what is left once settled.
fn settled_error(samples: &[LockStepSample], tour: usize, dt_s: f64) -> f64 {
    let mut sum = 0.0;
    let mut n = 0;
    for k in 1..tour {
        let end = 1.0 + dt_s * k as f64;
        for s in samples
            .iter()
            .filter(|s| s.record.t_s < end && s.record.t_s >= end - 0.05)
        {
            sum += s.record.following_error.abs();
            n += 1;
        }
    }
    sum / n as f64
}

struct Loop {
    before_rms: f64,
    after_rms: f64,
    before_settled: f64,
    after_settled: f64,
    tune_output: String,
}

fn the_loop(family: &str, reference: &str, plant: &str, tour: &[f64], dt_s: f64) -> Loop {
    let dir = tempfile::tempdir().expect("tempdir");
    let reference = with_tour(dir.path(), &root().join(reference), tour, dt_s);
    let plant = root().join(plant);
    let config = Config::load(&reference).expect("reference configuration");
    let before = run(&config, &plant);
    let csv = dir.path().join("before.csv");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&csv).expect("csv"));
    write_csv(&mut file, &before, config.axis[0].command, false).expect("csv written");
    drop(file);
    let fitted = dir.path().join("fitted.toml");
    let tuned = dir.path().join("tuned.toml");
    let p = |p: &Path| p.display().to_string();
    lab_common::actuator(
        dir.path(),
        &[
            "fit",
            "--data",
            &p(&csv),
            "--family",
            family,
            "--with",
            "spring,viscous,coulomb",
            "--out",
            &p(&fitted),
        ],
    );
    let tune_output = lab_common::actuator(
        dir.path(),
        &[
            "tune",
            "--model",
            &p(&fitted),
            "--config",
            &p(&reference),
            "--out",
            &p(&tuned),
        ],
    );
    println!("{tune_output}");
    // The tuned file is a configuration the daemon accepts.
    let tuned_config = Config::load(&tuned).expect("the tuned configuration passes validation");
    assert_ne!(
        tuned_config.axis[0].controller.q_per_m, config.axis[0].controller.q_per_m,
        "the controller was designed"
    );
    let after = run(&tuned_config, &plant);
    let l = Loop {
        before_rms: rms_error(&before),
        after_rms: rms_error(&after),
        before_settled: settled_error(&before, tour.len(), dt_s),
        after_settled: settled_error(&after, tour.len(), dt_s),
        tune_output,
    };
    println!(
        "{family}: RMS following error {:.1} µm -> {:.1} µm ({:.1}x), settled error {:.1} µm -> {:.1} µm",
        l.before_rms * 1e6,
        l.after_rms * 1e6,
        l.before_rms / l.after_rms,
        l.before_settled * 1e6,
        l.after_settled * 1e6
    );
    l
}

#[test]
fn linear_axis_tuned_from_its_fit_tracks_at_least_twice_as_well() {
    let tour = [0.0, 0.01, -0.01, 0.02, 0.0, -0.02, 0.015, -0.005, 0.0];
    let l = the_loop(
        "linear_axis",
        "config/linear_axis.toml",
        "tests/data/linear_axis_heavy.toml",
        &tour,
        0.5,
    );
    assert!(
        l.after_rms <= 0.5 * l.before_rms,
        "tuned {} against untuned {}",
        l.after_rms,
        l.before_rms
    );
    assert!(l.after_settled <= 0.5 * l.before_settled);
    // The report states the goal, the margins per direction and the robustness.
    for needle in ["goal:", "positive", "negative", "robustness over", "from "] {
        assert!(
            l.tune_output.contains(needle),
            "{needle}: {}",
            l.tune_output
        );
    }
}

#[test]
fn solenoid_tuned_from_its_fit_settles_closer() {
    // Steps of 0.5 to 0.8 mm around 9 mm: within the drive's range, so that the controller,
    // not the magnet's limits, sets the tracking (on steps of 10 mm the command saturates at
    // 0 V and 24 V whatever the controller).
    let tour = [
        0.009, 0.009, 0.0095, 0.0088, 0.0096, 0.009, 0.0085, 0.0093, 0.0087, 0.0095, 0.009, 0.0095,
        0.0088, 0.0096, 0.009, 0.0085, 0.0093, 0.0087, 0.0095, 0.009,
    ];
    let l = the_loop(
        "solenoid",
        "config/solenoid.toml",
        "tests/data/solenoid_heavy.toml",
        &tour,
        0.4,
    );
    // The transients of the designed loop are slower than the reference's (the goal keeps the
    // command inside 0..24 V), but what is left once settled falls by far more than half, and
    // the whole tour's error falls too.
    assert!(
        l.after_settled <= 0.5 * l.before_settled,
        "tuned {} against untuned {}",
        l.after_settled,
        l.before_settled
    );
    assert!(
        l.after_rms <= 0.8 * l.before_rms,
        "tuned {} against untuned {}",
        l.after_rms,
        l.before_rms
    );
    assert!(l.tune_output.contains("designed on the negative direction"));
}

#[test]
fn tune_refuses_a_model_whose_intervals_are_too_wide() {
    let dir = tempfile::tempdir().expect("tempdir");
    let model = dir.path().join("wide.toml");
    std::fs::write(
        &model,
        "# solenoid.mass_kg = 5.0e-1, 95 % interval [1.0e-1, 9.0e-1]\n\
         family = \"solenoid\"\n[solenoid]\nmass_kg = 0.5\n\
         [spring]\nstiffness_n_per_m = 1650.0\n[viscous]\ndamping_pos_n_s_per_m = 20.0\n\
         damping_neg_n_s_per_m = 20.0\n",
    )
    .expect("model written");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .current_dir(dir.path())
        .args(["tune", "--model"])
        .arg(&model)
        .arg("--config")
        .arg(root().join("config/solenoid.toml"))
        .args(["--out", "tuned.toml"])
        .output()
        .expect("actuator runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("solenoid.mass_kg") && err.contains("too wide to design from"),
        "{err}"
    );
    assert!(!dir.path().join("tuned.toml").exists());
}
