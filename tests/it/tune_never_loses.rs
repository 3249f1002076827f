//! `actuator tune` chooses by running the daemon's node on the fitted model, and never writes a
//! configuration that tracks worse than the one it was given. The loop as a user runs it: the
//! reference configuration records a plant foreign to it (`sim --record`), `fit`, `tune`, and
//! `sim --record` again with what `tune` wrote; the achieved figures against those `tune`
//! predicted.
//!
//! The plants are not the reference plants scaled by one factor: `tests/data/tune/*.toml` were
//! written for this test (other masses, friction levels split by direction, stick-slip, drive
//! constants), and the sweep draws every parameter with its own factor.

use crate::common::paths::root;
use std::path::{Path, PathBuf};

use actuatord::physics::{Family, PlantSpec};

use crate::lab_common;

/// `actuator ARGS` in `dir`; its standard output and standard error. It must succeed.
fn actuator(dir: &Path, args: &[&str]) -> (String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("actuator runs");
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    );
    assert!(
        out.status.success(),
        "actuator {}: {stdout}{stderr}",
        args.join(" ")
    );
    (stdout, stderr)
}

/// The predicted RMS following errors of `tune`'s side-by-side table: given, given at its worst
/// corner, and (when a design was found) tuned and tuned at its worst corner.
fn predicted_rms(stdout: &str) -> Vec<f64> {
    stdout
        .lines()
        .find(|l| l.trim_start().starts_with("RMS following error/"))
        .map(|l| {
            l.split_whitespace()
                .skip(3)
                .filter_map(|v| v.parse().ok())
                .collect()
        })
        .unwrap_or_else(|| panic!("no predicted figures in: {stdout}"))
}

struct Loop {
    /// Achieved with the reference configuration and with what `tune` wrote.
    before: f64,
    after: f64,
    /// Predicted for the given and (if any) the tuned configuration, at the estimate.
    predicted_given: f64,
    predicted_tuned: Option<f64>,
    accepted: bool,
}

/// The effects the user fits: the plant's own. (Without `stiction` on the linear axis, whose
/// foreign plant holds at a breakaway above its Coulomb level, the negative Coulomb level of the
/// fit is asked below zero, and `fit` refuses to write it.)
fn with(family: Family) -> &'static str {
    match family {
        Family::MotorGear => "viscous,coulomb,payload,backlash",
        Family::LinearAxis => "spring,viscous,coulomb,stiction",
        _ => "spring,viscous,coulomb",
    }
}

/// The user's loop on `plant` with the family's reference configuration, over its tour (five
/// seconds: the tour's last step at 4 s and one dwell).
fn user_loop(dir: &Path, family: Family, plant: &Path) -> Result<Loop, String> {
    let name = family.name();
    let config = root().join(format!("config/{name}.toml"));
    let p = |p: &Path| p.display().to_string();
    let sim = |config: &Path, csv: &str| {
        let (_, stderr) = actuator(
            dir,
            &[
                "sim",
                "--family",
                name,
                "--plant",
                &p(plant),
                "--config",
                &p(config),
                "--record",
                csv,
                "--seconds",
                "5",
            ],
        );
        lab_common::reported_rms(&stderr)
    };
    let before = sim(&config, "before.csv");
    let fit = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args([
            "fit",
            "--data",
            "before.csv",
            "--family",
            name,
            "--with",
            with(family),
            "--out",
            "fitted.toml",
        ])
        .current_dir(dir)
        .output()
        .expect("actuator runs");
    if !fit.status.success() {
        // A fit that holds a parameter past its bound (the plant's Stribeck dip asks for a
        // negative damping of a model without it) writes no model, and there is nothing to tune.
        let stderr = String::from_utf8_lossy(&fit.stderr).to_string();
        assert!(
            stderr.contains("is held at its bound") && !dir.join("fitted.toml").exists(),
            "fit failed otherwise: {stderr}"
        );
        return Err(format!("fit: {stderr}"));
    }
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args([
            "tune",
            "--model",
            "fitted.toml",
            "--config",
            &p(&config),
            "--out",
            "tuned.toml",
        ])
        .current_dir(dir)
        .output()
        .expect("actuator runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    if !out.status.success() {
        // A refusal (a fit too loose to design from) writes nothing, and says why.
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(
            !dir.join("tuned.toml").exists(),
            "a refusal wrote a file: {stderr}"
        );
        return Err(stderr);
    }
    let accepted = !stdout.contains("(the given configuration, unchanged)");
    let tuned_text = std::fs::read_to_string(dir.join("tuned.toml")).expect("tuned.toml");
    if !accepted {
        let given = std::fs::read_to_string(&config).expect("configuration");
        assert_eq!(tuned_text, given, "kept means unchanged");
    }
    let after = sim(&dir.join("tuned.toml"), "after.csv");
    let predicted = predicted_rms(&stdout);
    Ok(Loop {
        before,
        after,
        predicted_given: predicted[0],
        predicted_tuned: predicted.get(2).copied(),
        accepted,
    })
}

fn foreign(family: Family) -> Loop {
    let dir = tempfile::tempdir().expect("tempdir");
    let plant = root().join(format!("tests/data/tune/{}_foreign.toml", family.name()));
    let l = user_loop(dir.path(), family, &plant)
        .unwrap_or_else(|e| panic!("{}: tune refused: {e}", family.name()));
    println!(
        "{}: reference {:.1} -> tuned {:.1} ({:.2}x); predicted given {:.1}, tuned {:?}",
        family.name(),
        l.before,
        l.after,
        l.before / l.after,
        l.predicted_given,
        l.predicted_tuned
    );
    assert!(
        l.accepted,
        "{}: tune kept the given configuration",
        family.name()
    );
    assert!(
        l.after <= 0.5 * l.before,
        "{}: tuned {} against the reference's {}",
        family.name(),
        l.after,
        l.before
    );
    let predicted = l.predicted_tuned.expect("a tuned prediction");
    assert!(
        (predicted - l.after).abs() <= 0.3 * l.after,
        "{}: predicted {predicted}, achieved {}",
        family.name(),
        l.after
    );
    l
}

#[test]
fn a_foreign_solenoid_is_tuned_to_half_the_error_as_predicted() {
    foreign(Family::Solenoid);
}

#[test]
fn a_foreign_linear_axis_is_tuned_to_half_the_error_as_predicted() {
    foreign(Family::LinearAxis);
}

#[test]
fn a_foreign_geared_drive_is_tuned_to_half_the_error_as_predicted() {
    foreign(Family::MotorGear);
}

/// Multiply `name` of `spec` by a factor drawn from `lo..hi`.
fn scale(spec: &mut PlantSpec, draw: &mut lab_common::Lcg, name: &str, lo: f64, hi: f64) {
    let v = spec.get(name).unwrap_or_else(|| panic!("{name}"));
    spec.set(name, v * draw.range(lo, hi))
        .unwrap_or_else(|e| panic!("{name}: {e}"));
}

/// Coulomb friction per direction drawn from `level` times 1 to `up_to`, the breakaway 1.1 to
/// 1.6 times above it (stick-slip), in newtons.
fn dry_friction(s: &mut PlantSpec, d: &mut lab_common::Lcg, level: f64, up_to: f64) {
    for dir in ["pos", "neg"] {
        let c = level * d.range(1.0, up_to);
        s.set(&format!("coulomb.coulomb_{dir}_n"), c)
            .expect("coulomb");
        s.set(
            &format!("stiction.breakaway_{dir}_n"),
            c * d.range(1.1, 1.6),
        )
        .expect("stiction");
    }
}

/// A plant of `family` foreign to its reference configuration: the reference plant with each
/// parameter drawn on its own.
fn draw_plant(family: Family, seed: u64) -> PlantSpec {
    let b = actuatord::defaults::plant(family);
    let mut spec = PlantSpec::from_toml(b.text, b.path).expect("reference plant");
    let mut d = lab_common::Lcg(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ family as u64);
    spec.seed = seed;
    let s = &mut spec;
    match family {
        Family::Solenoid => {
            scale(s, &mut d, "solenoid.mass_kg", 1.0, 3.5);
            scale(s, &mut d, "solenoid.current_gain_a_per_v", 0.8, 1.6);
            scale(s, &mut d, "spring.stiffness_n_per_m", 0.6, 1.4);
            scale(s, &mut d, "spring.pretension_n", 0.5, 2.0);
            scale(s, &mut d, "viscous.damping_pos_n_s_per_m", 0.7, 2.0);
            scale(s, &mut d, "viscous.damping_neg_n_s_per_m", 0.7, 2.0);
            dry_friction(s, &mut d, 0.55, 4.0);
        }
        Family::LinearAxis => {
            scale(s, &mut d, "linear_axis.mass_kg", 1.0, 4.0);
            scale(s, &mut d, "linear_axis.force_gain_n_per_v", 0.6, 1.3);
            scale(s, &mut d, "spring.stiffness_n_per_m", 0.4, 1.5);
            scale(s, &mut d, "viscous.damping_pos_n_s_per_m", 0.7, 2.0);
            scale(s, &mut d, "viscous.damping_neg_n_s_per_m", 0.7, 2.0);
            dry_friction(s, &mut d, 2.0, 3.0);
        }
        Family::MotorGear => {
            scale(s, &mut d, "motor_gear.load_inertia_kg_m2", 1.0, 4.0);
            scale(s, &mut d, "motor_gear.gear_inertia_kg_m2", 0.7, 1.5);
            scale(s, &mut d, "payload.max_load_nm", 0.5, 2.0);
            scale(s, &mut d, "viscous.damping_pos_nm_s_per_rad", 0.5, 2.5);
            scale(s, &mut d, "viscous.damping_neg_nm_s_per_rad", 0.5, 2.5);
            for dir in ["pos", "neg"] {
                let c = 0.4 * d.range(0.8, 2.5);
                s.set(&format!("coulomb.coulomb_{dir}_nm"), c)
                    .expect("coulomb");
                let excess = c * d.range(0.5, 1.5);
                s.set(&format!("stribeck.excess_{dir}_nm"), excess)
                    .expect("stribeck");
                s.set(
                    &format!("stiction.breakaway_{dir}_nm"),
                    (c + excess) * d.range(1.05, 1.4),
                )
                .expect("stiction");
            }
        }
        Family::Pneumatic => unreachable!("the pneumatic schedule is not searched"),
    }
    spec
}

/// Draws per family in the sweep: `TUNE_SWEEP=N` for another count.
fn sweep_count() -> u64 {
    std::env::var("TUNE_SWEEP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20)
}

fn sweep(family: Family) {
    let n = sweep_count();
    assert!(n > 0, "TUNE_SWEEP=0 sweeps nothing");
    let (mut kept, mut refused, mut gains) = (0, 0, Vec::new());
    for seed in 1..=n {
        let dir = tempfile::tempdir().expect("tempdir");
        let plant: PathBuf = dir.path().join("plant.toml");
        std::fs::write(&plant, draw_plant(family, seed).to_toml()).expect("plant written");
        let l = match user_loop(dir.path(), family, &plant) {
            Ok(l) => l,
            Err(why) => {
                println!("{} seed {seed}: refused: {}", family.name(), why.trim());
                refused += 1;
                continue;
            }
        };
        println!(
            "{} seed {seed}: reference {:.1} -> {} {:.1} (predicted given {:.1}, tuned {:?})",
            family.name(),
            l.before,
            if l.accepted { "tuned" } else { "kept" },
            l.after,
            l.predicted_given,
            l.predicted_tuned
        );
        assert!(
            l.after <= l.before,
            "{} seed {seed}: tune wrote a configuration that tracks worse: {} against the \
             given's {}",
            family.name(),
            l.after,
            l.before
        );
        if l.accepted {
            gains.push(l.before / l.after);
        } else {
            kept += 1;
        }
    }
    gains.sort_by(f64::total_cmp);
    println!(
        "{}: {n} plants, {} tuned (improvement {:.2}x to {:.2}x), {kept} kept, {refused} refused",
        family.name(),
        gains.len(),
        gains.first().copied().unwrap_or(1.0),
        gains.last().copied().unwrap_or(1.0)
    );
    // A sweep that refuses most plants says nothing about what tune writes (a refusal is
    // right where a 5 s record leaves a design parameter's interval wider than --max-spread).
    assert!(
        2 * refused <= n,
        "{}: {refused} of {n} refused",
        family.name()
    );
}

#[test]
fn tune_never_writes_a_worse_solenoid_configuration() {
    sweep(Family::Solenoid);
}

#[test]
fn tune_never_writes_a_worse_linear_axis_configuration() {
    sweep(Family::LinearAxis);
}

#[test]
fn tune_never_writes_a_worse_geared_drive_configuration() {
    sweep(Family::MotorGear);
}
