//! A geared axis behind a servo drive in torque mode, on records of the independent simulator
//! (tests/it/lab_indep/gear.rs): with `--command torque` a model whose drive constants are right
//! fits the drive torque, and the diagnosis names the effect hidden from it (Coulomb friction,
//! backlash) or none for a complete model. Without it the command is read as a voltage.
//!
//! `LAB_VERBOSE=1` prints every candidate.

use actuatord::lab::data::to_csv;
use actuatord::lab::diagnose::{diagnose, DiagnoseOptions};
use actuatord::lab::signals::prepare;
use actuatord::lab::{Command, Model};

use crate::lab_common;
use crate::lab_indep;
use lab_indep::gear::{Gear, GearHidden};

/// Seconds of record per case.
const LENGTH_S: f64 = 6.0;

fn compare_fit(dir: &std::path::Path, extra: &[&str]) -> f64 {
    let mut args = vec![
        "compare",
        "--json",
        "--data",
        "gear.csv",
        "--model",
        "gear.toml",
    ];
    args.extend_from_slice(extra);
    let out: serde_json::Value =
        serde_json::from_str(&lab_common::actuator(dir, &args)).expect("JSON");
    out["fit"].as_f64().expect("fit")
}

#[test]
fn a_torque_commanded_gear_fits_once_its_command_is_named() {
    for (hidden, seed) in [
        (None, 1),
        (None, 2),
        (None, 3),
        (Some(GearHidden::Backlash), 4),
        (Some(GearHidden::Backlash), 5),
    ] {
        let dir = tempfile::tempdir().expect("tempdir");
        let gear = Gear::draw(hidden, seed);
        std::fs::write(
            dir.path().join("gear.csv"),
            to_csv(&gear.simulate(seed, LENGTH_S)),
        )
        .expect("write CSV");
        std::fs::write(
            dir.path().join("gear.toml"),
            gear.model_file(&gear.complete_effects(), true),
        )
        .expect("write model");
        let as_voltage = compare_fit(dir.path(), &[]);
        let as_torque = compare_fit(dir.path(), &["--command", "torque"]);
        eprintln!(
            "{:?} seed {seed} dt {} ms: drive-torque fit read as a voltage {as_voltage:.1} %, \
             as a torque {as_torque:.1} %",
            gear.complete_effects(),
            gear.dt * 1e3
        );
        // The play makes the contact an impact: the drive side run on the sampled load angle
        // follows it less closely than a rigid contact.
        let least = if hidden.is_some() { 80.0 } else { 90.0 };
        assert!(as_torque >= least, "seed {seed}: {as_torque:.1} %");
        if seed == 1 {
            // The report reads the command the same way: its table gives the same fit.
            lab_common::actuator(
                dir.path(),
                &[
                    "report",
                    "--data",
                    "gear.csv",
                    "--model",
                    "gear.toml",
                    "--command",
                    "torque",
                    "--out",
                    "rep",
                ],
            );
            let html = std::fs::read_to_string(dir.path().join("rep/index.html")).expect("report");
            assert!(
                html.contains(&format!("<td>gear</td><td>{as_torque:.1}</td>")),
                "the report's fit is compare's"
            );
        }
        assert!(
            as_voltage < as_torque - 20.0,
            "seed {seed}: {as_voltage:.1} %"
        );
    }
    // A command the family does not take is refused with the families that do.
    let dir = tempfile::tempdir().expect("tempdir");
    let gear = Gear::draw(None, 1);
    std::fs::write(dir.path().join("gear.csv"), to_csv(&gear.simulate(1, 1.0))).expect("CSV");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args([
            "compare",
            "--data",
            "gear.csv",
            "--family",
            "motor_gear",
            "--command",
            "duty",
        ])
        .current_dir(dir.path())
        .output()
        .expect("actuator runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--command duty: not a command of motor_gear; pneumatic accept it")
            && err.contains("(motor_gear takes torque, voltage, current)"),
        "{err}"
    );
}

fn verdict(hidden: Option<GearHidden>, seed: u64) -> Option<String> {
    diagnosed(hidden, seed).verdict
}

fn diagnosed(hidden: Option<GearHidden>, seed: u64) -> actuatord::lab::diagnose::Diagnosis {
    let gear = Gear::draw(hidden, seed);
    let mut data = gear.simulate(seed, LENGTH_S);
    let with: Vec<&str> = gear
        .complete_effects()
        .into_iter()
        .filter(|e| Some(*e) != hidden.map(GearHidden::lab_name))
        .collect();
    let mut model = Model::from_toml(&gear.model_file(&with, false), "gear.toml").expect("model");
    Command::Torque
        .apply(&mut model.spec, &mut data)
        .expect("motor_gear takes a torque");
    let prep = prepare(&data, None);
    let dg = diagnose(
        &model,
        &data,
        &prep,
        &DiagnoseOptions::default(),
        &|_, _, _| {},
    )
    .expect("diagnosis runs");
    if std::env::var("LAB_VERBOSE").is_ok() {
        eprintln!("  {gear:?}");
    }
    lab_common::print_candidates(&dg);
    eprintln!(
        "gear {:<12} seed {seed} dt {:.1} ms{}: NRMSE {:.4}, verdict {}",
        hidden.map_or("(complete)", GearHidden::lab_name),
        gear.dt * 1e3,
        if gear.sensor_zero != 0.0 {
            ", zero offset"
        } else {
            ""
        },
        dg.nrmse_base,
        dg.verdict.as_deref().unwrap_or("none")
    );
    if !dg.unconfirmed.is_empty() {
        eprintln!("  unconfirmed: {:?}", dg.unconfirmed);
    }
    dg
}

/// Where the record does not confirm the play (seeds 2 and 3: it cuts the error by 22 % and
/// 15 % on the whole record, and leaves the held-out part 37 % and 45 % worse), the diagnosis
/// says so rather than a bare `none`: the play is named or reported as suggested and not
/// confirmed. A complete model is never told of an effect it does not miss.
#[test]
fn a_play_the_record_does_not_confirm_is_reported_as_suggested() {
    for seed in [2, 3] {
        let dg = diagnosed(Some(GearHidden::Backlash), seed);
        let named = dg.verdict.as_deref() == Some("backlash");
        let suggested =
            dg.verdict.is_none() && dg.unconfirmed.first().map(String::as_str) == Some("backlash");
        assert!(
            named || suggested,
            "seed {seed}: verdict {:?}, unconfirmed {:?}",
            dg.verdict,
            dg.unconfirmed
        );
    }
    for seed in [1, 2] {
        let dg = diagnosed(None, seed);
        assert_eq!(dg.verdict, None, "seed {seed}");
        assert!(
            dg.unconfirmed.is_empty(),
            "seed {seed}: {:?}",
            dg.unconfirmed
        );
    }
}

#[test]
fn a_torque_commanded_gear_is_diagnosed() {
    let mut wrong = Vec::new();
    for (hidden, seeds) in [
        (None, [1, 2]),
        (Some(GearHidden::Coulomb), [3, 4]),
        (Some(GearHidden::Backlash), [5, 6]),
    ] {
        for seed in seeds {
            let got = verdict(hidden, seed);
            if got.as_deref() != hidden.map(GearHidden::lab_name) {
                wrong.push((hidden, seed, got));
            }
        }
    }
    assert!(wrong.is_empty(), "wrong verdicts: {wrong:?}");
}

/// Every case on seeds 1-6 (`LAB_SEEDS=...` for others): the figures of docs/lab.md.
#[test]
#[ignore = "sweep over seeds; run with scripts/lab-sweeps"]
fn torque_commanded_gear_sweep() {
    let seeds = lab_common::sweep_seeds(1..=6);
    let mut wrong = Vec::new();
    for hidden in [
        None,
        Some(GearHidden::Coulomb),
        Some(GearHidden::Viscous),
        Some(GearHidden::Backlash),
    ] {
        let mut right = 0;
        for &seed in &seeds {
            let got = verdict(hidden, seed);
            if got.as_deref() == hidden.map(GearHidden::lab_name) {
                right += 1;
            } else {
                wrong.push((hidden, seed, got));
            }
        }
        eprintln!(
            "right/total {}: {right}/{}",
            hidden.map_or("(complete)", GearHidden::lab_name),
            seeds.len()
        );
    }
    assert!(wrong.is_empty(), "wrong verdicts: {wrong:?}");
}

/// The project's own gear plant (`src/physics`) in torque mode with backlash, under the same
/// kind of loop: the diagnosis names backlash, and says none once the model has it. The drive is
/// the family's own light gear (`config/plants/motor_gear.toml`), whose load moves in short
/// hops between stops; the lab's balance takes them sample by sample (`regress_gear::in_motion`).
#[test]
fn the_physics_gear_in_torque_mode_with_backlash_is_diagnosed_as_backlash() {
    use actuatord::physics::{CommandUnit, EffectKind, Family, PlantSpec};
    let mut spec = PlantSpec::new(Family::MotorGear);
    spec.set_command(CommandUnit::NewtonMetre).expect("torque");
    for e in [
        EffectKind::Viscous,
        EffectKind::Coulomb,
        EffectKind::Backlash,
    ] {
        spec.add_effect(e).expect("effect");
    }
    spec.set("backlash.gap_rad", 0.008).expect("gap");
    lab_common::sensor(&mut spec, 3);
    let mut plant = spec.build().expect("plant");
    let (dt, n) = (1e-3, 8000);
    let h = spec.get("motor_gear.ratio").expect("ratio");
    let inertia = ["gear_inertia_kg_m2", "load_inertia_kg_m2"]
        .iter()
        .map(|k| spec.get(&format!("motor_gear.{k}")).expect("inertia"))
        .sum::<f64>()
        + h * h * spec.get("motor_gear.motor_inertia_kg_m2").expect("J_m");
    let (w, m) = (std::f64::consts::TAU * 4.0, inertia / h);
    let (kp, ki, kd) = (m * w * w, m * w * w * w / 5.0, 1.6 * m * w);
    let mut data = actuatord::lab::Dataset {
        origin: "physics gear".into(),
        time: Vec::new(),
        input: Vec::new(),
        output: Vec::new(),
        supply: None,
        current: None,
    };
    let (mut integ, mut gear_prev) = (0.0, plant.drive_position());
    for k in 0..n {
        let t = k as f64 * dt;
        let (r, r_rate) = (
            0.4 * (std::f64::consts::TAU * 0.7 * t).sin()
                + 0.2 * (std::f64::consts::TAU * 1.9 * t).sin(),
            0.4 * std::f64::consts::TAU * 0.7 * (std::f64::consts::TAU * 0.7 * t).cos()
                + 0.2 * std::f64::consts::TAU * 1.9 * (std::f64::consts::TAU * 1.9 * t).cos(),
        );
        let y = plant.measure().position;
        let gear = plant.drive_position();
        let gear_speed = (gear - gear_prev) / dt;
        gear_prev = gear;
        let e = r - y;
        integ += e * dt;
        let u = kp * e + ki * integ + kd * (r_rate - gear_speed);
        data.time.push(t);
        data.input.push(u);
        data.output.push(y);
        plant.step(u, dt);
    }
    for (with, want) in [
        ("viscous,coulomb", Some("backlash")),
        ("viscous,coulomb,backlash", None),
    ] {
        let mut d = data.clone();
        let mut model = Model::from_names("motor_gear", &[with.to_string()]).expect("model");
        // The drive constants as the plant's data sheet gives them.
        for (name, p) in spec.params() {
            if name.starts_with("motor_gear.") && name != "motor_gear.load_inertia_kg_m2" {
                model.spec.set(&name, p.value).expect("same family");
                model.spec.set_free(&name, false).expect("known");
            }
        }
        Command::Torque
            .apply(&mut model.spec, &mut d)
            .expect("motor_gear takes a torque");
        let prep = prepare(&d, None);
        let dg = diagnose(
            &model,
            &d,
            &prep,
            &DiagnoseOptions::default(),
            &|_, _, _| {},
        )
        .expect("diagnosis runs");
        eprintln!(
            "physics gear, torque mode, model {with}: NRMSE {:.4}, verdict {}",
            dg.nrmse_base,
            dg.verdict.as_deref().unwrap_or("none")
        );
        lab_common::print_candidates(&dg);
        assert_eq!(
            dg.verdict.as_deref(),
            want,
            "model {with}: {:?}",
            dg.undecided
        );
    }
}
