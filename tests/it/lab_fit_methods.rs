//! The identification methods of `actuator fit` on closed-loop records of known plants (sensor
//! noise and quantisation): recursive least squares ends where the batch fit does and follows
//! a plant that changes; output error, free run and k-step, recovers the plant's parameters and
//! lowers the criterion it minimises below the least-squares start.

use actuatord::lab::methods::{fit_model, FitMethod, FitOptions, MethodFit, Status};
use actuatord::lab::signals::prepare;
use actuatord::lab::{Dataset, Mode, Model};
use actuatord::physics::{EffectKind, Family, Fault, FaultKind, PlantSpec};

use crate::lab_common;
use lab_common::{closed_loop, closed_loop_with_fault, sensor, Run, Supply};

/// A plant of the family with the given effects and parameter values, sensor noise included.
fn plant(family: Family, effects: &[EffectKind], values: &[(&str, f64)], seed: u64) -> PlantSpec {
    let mut spec = PlantSpec::new(family);
    for &e in effects {
        spec.add_effect(e).expect("effect");
    }
    for (k, v) in values {
        spec.set(k, *v).expect(k);
    }
    sensor(&mut spec, seed);
    spec
}

fn axis(seed: u64, coulomb: f64, damping: f64) -> PlantSpec {
    plant(
        Family::LinearAxis,
        &[EffectKind::Viscous, EffectKind::Coulomb],
        &[
            ("linear_axis.mass_kg", 1.3),
            ("viscous.damping_pos_n_s_per_m", damping),
            ("viscous.damping_neg_n_s_per_m", damping * 1.1),
            ("coulomb.coulomb_pos_n", coulomb),
            ("coulomb.coulomb_neg_n", coulomb * 0.9),
        ],
        seed,
    )
}

fn fit(model: &Model, data: &Dataset, opts: FitOptions) -> MethodFit {
    let prep = prepare(data, None);
    fit_model(model, data, &prep, &opts, &|_, _| {}).expect("fit")
}

fn value(f: &MethodFit, name: &str) -> f64 {
    f.parameters
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("{name} not among {:?}", f.parameters))
        .value
}

fn model(family: Family, effects: &[EffectKind]) -> Model {
    Model::from_family(family, effects).expect("model")
}

/// The model the linear-axis records are fitted with: viscous damping and Coulomb friction.
fn axis_model() -> Model {
    model(
        Family::LinearAxis,
        &[EffectKind::Viscous, EffectKind::Coulomb],
    )
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn recursive_without_forgetting_ends_where_least_squares_does() {
    for seed in [3, 8] {
        let data = closed_loop(&axis(seed, 1.1, 4.0), seed, 12.0, false, Run::Track);
        let m = axis_model();
        let ls = fit(&m, &data, FitOptions::default());
        let rec = fit(
            &m,
            &data,
            FitOptions {
                method: FitMethod::Recursive,
                forgetting: 1.0,
                ..FitOptions::default()
            },
        );
        let mut compared = 0;
        for p in ls
            .parameters
            .iter()
            .filter(|p| p.status == Status::Estimated)
        {
            let (lo, hi) = p.interval.expect("interval");
            let r = value(&rec, &p.name);
            assert!(
                (r - p.value).abs() < 0.05 * 0.5 * (hi - lo),
                "seed {seed} {}: recursive {r} vs batch {} (±{})",
                p.name,
                p.value,
                0.5 * (hi - lo)
            );
            compared += 1;
        }
        assert!(compared >= 4, "seed {seed}: {compared} parameters compared");
        let track = rec.track.as_ref().expect("track");
        assert_eq!(track.points.len(), 4);
        assert!(track.points.windows(2).all(|w| w[0].0 < w[1].0));
    }
}

#[test]
fn recursive_with_forgetting_follows_a_friction_rise_that_the_batch_fit_averages() {
    let (coulomb, damping) = (1.0, 4.0);
    for seed in [2, 5] {
        let friction_x3 = Fault {
            kind: FaultKind::Friction(3.0),
            ramp_s: 0.0,
        };
        let data = closed_loop_with_fault(
            &axis(seed, coulomb, damping),
            seed,
            16.0,
            Supply::Nominal,
            Run::Track,
            Some((8.0, friction_x3)),
        );
        let m = axis_model();
        let ls = fit(&m, &data, FitOptions::default());
        let rec = fit(
            &m,
            &data,
            FitOptions {
                method: FitMethod::Recursive,
                forgetting: 0.999,
                ..FitOptions::default()
            },
        );
        let key = "coulomb.coulomb_pos_n";
        let (batch, late) = (value(&ls, key), value(&rec, key));
        assert!(
            relative(late, 3.0 * coulomb) < 0.15,
            "seed {seed}: recursive {key} {late}, plant {} after the fault",
            3.0 * coulomb
        );
        assert!(
            batch < 0.85 * 3.0 * coulomb,
            "seed {seed}: the batch fit averages both halves, got {batch}"
        );
        let track = rec.track.as_ref().expect("track");
        let j = track.names.iter().position(|n| n == key).expect(key);
        let at_half = track.points[1].1[j];
        assert!(
            late > 2.0 * at_half,
            "seed {seed}: {key} {at_half} at half time, {late} at the end"
        );
        let change = track.change.as_ref().expect("halves fitted");
        assert!(change.z > 3.0, "seed {seed}: {change:?}");
    }
}

#[test]
fn the_halves_of_a_record_of_an_unchanged_plant_agree() {
    for seed in [4, 9] {
        let data = closed_loop(&axis(seed, 1.2, 5.0), seed, 16.0, false, Run::Track);
        let m = axis_model();
        let rec = fit(
            &m,
            &data,
            FitOptions {
                method: FitMethod::Recursive,
                ..FitOptions::default()
            },
        );
        let change = rec.track.and_then(|t| t.change).expect("halves fitted");
        assert!(change.z < 3.0, "seed {seed}: {change:?}");
    }
}

#[test]
fn output_error_free_run_recovers_a_solenoid_and_lowers_its_criterion() {
    let truth = [
        ("solenoid.mass_kg", 0.45),
        ("spring.stiffness_n_per_m", 1700.0),
        ("spring.pretension_n", 2.0),
        ("viscous.damping_pos_n_s_per_m", 22.0),
        ("viscous.damping_neg_n_s_per_m", 18.0),
    ];
    let seed = 6;
    let spec = plant(
        Family::Solenoid,
        &[EffectKind::Spring, EffectKind::Viscous],
        &truth,
        seed,
    );
    let data = closed_loop(&spec, seed, 12.0, false, Run::Track);
    let mut m = model(Family::Solenoid, &[EffectKind::Spring, EffectKind::Viscous]);
    // The drive's constants are known from the data sheet.
    for key in [
        "solenoid.current_time_constant_s",
        "solenoid.current_gain_a_per_v",
        "solenoid.force_constant_n_per_a",
    ] {
        m.spec.set_free(key, false).expect(key);
    }
    let oe = fit(
        &m,
        &data,
        FitOptions {
            method: FitMethod::OutputError,
            mode: Mode::FreeRun,
            ..FitOptions::default()
        },
    );
    assert_eq!(oe.criterion.0, Mode::FreeRun);
    // Least squares leaves the mass about half a percent off here (the filtered acceleration);
    // the simulated position pins every parameter far closer.
    assert!(
        oe.criterion.2 < 0.8 * oe.start,
        "free-run NRMSE {} at the end, {} at the least-squares start",
        oe.criterion.2,
        oe.start
    );
    for (key, v) in truth {
        let got = value(&oe, key);
        assert!(relative(got, v) < 0.003, "{key}: {got}, plant {v}");
    }
}

#[test]
fn output_error_k_step_recovers_an_integrating_axis_in_closed_loop() {
    for seed in [1, 7] {
        let data = closed_loop(&axis(seed, 1.2, 5.0), seed, 12.0, false, Run::Track);
        let m = axis_model();
        let oe = fit(
            &m,
            &data,
            FitOptions {
                method: FitMethod::OutputError,
                mode: Mode::KStep,
                k: 20,
                ..FitOptions::default()
            },
        );
        assert_eq!(oe.criterion.0, Mode::KStep);
        assert!(
            oe.criterion.2 < oe.start,
            "seed {seed}: {:?} from {}",
            oe.criterion,
            oe.start
        );
        for (key, v) in [
            ("linear_axis.mass_kg", 1.3),
            ("viscous.damping_pos_n_s_per_m", 5.0),
            ("coulomb.coulomb_pos_n", 1.2),
            ("coulomb.coulomb_neg_n", 1.08),
        ] {
            let got = value(&oe, key);
            assert!(
                relative(got, v) < 0.1,
                "seed {seed} {key}: {got}, plant {v}"
            );
        }
    }
}

#[test]
fn bad_method_settings_are_refused_with_the_flag_at_fault() {
    let data = closed_loop(&axis(1, 1.0, 4.0), 1, 4.0, false, Run::Track);
    let prep = prepare(&data, None);
    let m = model(Family::LinearAxis, &[EffectKind::Viscous]);
    let err = |opts: FitOptions| {
        fit_model(&m, &data, &prep, &opts, &|_, _| {})
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default()
    };
    let e = err(FitOptions {
        method: FitMethod::Recursive,
        forgetting: 1.5,
        ..FitOptions::default()
    });
    assert!(e.contains("--forgetting"), "{e}");
    let e = err(FitOptions {
        method: FitMethod::OutputError,
        mode: Mode::InverseDynamics,
        ..FitOptions::default()
    });
    assert!(e.contains("k_step or free_run"), "{e}");
}

#[test]
fn the_fit_command_writes_a_model_for_every_method() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let actuator = |args: &[&str]| lab_common::actuator(dir.path(), args);
    let plant = root.join("config/plants/solenoid.toml");
    let config = root.join("config/solenoid.toml");
    actuator(&[
        "sim",
        "--plant",
        plant.to_str().expect("path"),
        "--config",
        config.to_str().expect("path"),
        "--record",
        "run.csv",
        "--seconds",
        "6",
    ]);
    for (method, extra) in [
        ("least_squares", vec![]),
        ("recursive", vec!["--forgetting", "0.999"]),
        ("output_error", vec!["--mode", "free_run"]),
    ] {
        let out = format!("{method}.toml");
        let mut args = vec![
            "fit",
            "--data",
            "run.csv",
            "--family",
            "solenoid",
            "--with",
            "spring,viscous",
            "--method",
            method,
            "--out",
            &out,
            "--json",
        ];
        args.extend(extra);
        let json: serde_json::Value = serde_json::from_str(&actuator(&args)).expect("JSON");
        assert_eq!(json["method"], method);
        let (before, after) = (
            json["nrmse_before"].as_f64().expect("nrmse_before"),
            json["nrmse"].as_f64().expect("nrmse"),
        );
        assert!(after < 0.5 * before, "{method}: {before} -> {after}");
        assert_eq!(json["track"].is_null(), method != "recursive", "{json}");
        let written = Model::load(&dir.path().join(&out)).expect("the written model loads");
        // The header names each criterion once: the method's own and, where it is another,
        // the inverse-dynamics figure `compare` reports.
        let text = std::fs::read_to_string(dir.path().join(&out)).expect("written");
        let header = text.lines().next().expect("a header line");
        assert_eq!(
            header.matches("inverse_dynamics NRMSE").count(),
            1,
            "{method}: {header}"
        );
        let mass = written.spec.get("solenoid.mass_kg").expect("mass");
        assert!(relative(mass, 0.4956) < 0.05, "{method}: mass {mass}");
    }
}
