//! The drive from the data, on records of the independent simulator (tests/lab_indep) whose
//! drive constants are drawn per seed: the lab finds them without being told, says where a
//! declared value is contradicted, and its significance test follows the error.

use actuatord::lab::diagnose::{diagnose, DiagnoseOptions};
use actuatord::lab::drive::identify;
use actuatord::lab::signals::prepare;
use actuatord::lab::Model;

use crate::lab_indep;
use lab_indep::{simulate_for, Hidden, Plant, Truth};

/// A solenoid record without its current, and the first seeds that draw one.
fn solenoid_without_current(count: usize) -> Vec<(u64, Truth)> {
    (1..40)
        .map(|seed| (seed, Truth::draw(Plant::Solenoid, None, seed)))
        .filter(|(_, t)| !t.record_current)
        .take(count)
        .collect()
}

#[test]
fn coil_time_constant_found_and_a_wrong_declared_one_named() {
    for (seed, truth) in solenoid_without_current(1) {
        let data = simulate_for(&truth, seed, 0.5);
        let prep = prepare(&data, None);
        let mut model = Model::from_names(
            "solenoid",
            &["spring".into(), "viscous".into(), "coulomb".into()],
        )
        .expect("model");
        let found = identify(&model.spec, &data, &prep).expect("identified");
        let tau = found
            .iter()
            .find(|c| c.name == "solenoid.current_time_constant_s")
            .expect("the coil's time constant");
        // Over 16 records (docs/lab.md) within -38 % .. +60 % of the truth: the coil's lag
        // trades with the damping and the spring's phase on closed-loop records. On this record
        // (seed 3: truth 7.20 ms) the fit gives 6.90 ms, -4 %, where the family's default it
        // starts from, 8.59 ms, is +19 % off: within 10 % of the truth, and at most half the
        // default's error (measured 0.21 of it), so a fit that stays at its start fails.
        let err = (tau.value - truth.coil_tau).abs() / truth.coil_tau;
        let default_err = (tau.declared - truth.coil_tau).abs() / truth.coil_tau;
        println!(
            "seed {seed}: coil time constant {:.3} ms, truth {:.3} ms, default {:.3} ms",
            tau.value * 1e3,
            truth.coil_tau * 1e3,
            tau.declared * 1e3
        );
        assert!(
            err < 0.1 && err <= 0.5 * default_err,
            "seed {seed}: coil time constant {} against {}, the default {} (dt {})",
            tau.value,
            truth.coil_tau,
            tau.declared,
            truth.dt
        );
        assert!(tau.low <= tau.value && tau.value <= tau.high);
        assert!(!tau.contradicted(), "not declared: nothing to contradict");
        // Declared at three times the truth: named, with both figures.
        model
            .spec
            .set("solenoid.current_time_constant_s", 3.0 * truth.coil_tau)
            .expect("in bounds");
        model
            .spec
            .set_free("solenoid.current_time_constant_s", false)
            .expect("known");
        let found = identify(&model.spec, &data, &prep).expect("identified");
        let tau = &found[0];
        assert!(tau.contradicted(), "{}", tau.sentence());
        let text = tau.sentence();
        assert!(
            text.starts_with("coil time constant") && text.contains("declared, the data say"),
            "{text}"
        );
    }
}

#[test]
fn pneumatic_valve_speeds_per_direction_found() {
    for seed in [1u64] {
        let truth = Truth::draw(Plant::Pneumatic, Some(Hidden::Coulomb), seed);
        let data = simulate_for(&truth, seed, 0.5);
        let prep = prepare(&data, None);
        let model = Model::from_names("pneumatic", &["coulomb".into()]).expect("model");
        let found = identify(&model.spec, &data, &prep).expect("identified");
        for (name, want) in [
            ("pneumatic.gain_down_m_per_s", truth.k_down),
            ("pneumatic.gain_up_m_per_s", truth.k_up),
            ("pneumatic.velocity_time_constant_s", truth.chamber_tau),
        ] {
            let c = found.iter().find(|c| c.name == name).expect(name);
            // Over 7 records (docs/lab.md) the speeds come out 8-20 % low, the lag within 20 %.
            // On seed 1 the fit is off by 10 % (down), 11 % (up) and 15 % (lag), where the
            // family's defaults it starts from are off by 23 %, 33 % and 79 %: within 20 %, and
            // at most half the default's error (measured 0.43, 0.34, 0.19 of it), so a fit that
            // stays at its start fails.
            let err = (c.value - want).abs() / want;
            let default_err = (c.declared - want).abs() / want;
            println!(
                "seed {seed}: {name} {:.3e} against {want:.3e}, the default {:.3e}",
                c.value, c.declared
            );
            assert!(
                err < 0.2 && err <= 0.5 * default_err,
                "seed {seed}: {name} {} against {want}, the default {}",
                c.value,
                c.declared
            );
        }
    }
}

/// A candidate that does not cut the error is not favoured by the penalised criterion, on every
/// family; the one that does is significant (the pneumatic balance once gave every candidate a
/// large ΔBIC of one sign, from a base fitted in other units than the candidates).
#[test]
fn significance_follows_the_error_on_every_family() {
    for (plant, hidden) in [
        (Plant::ServoAxis, Hidden::Coulomb),
        (Plant::Solenoid, Hidden::Coulomb),
        (Plant::Pneumatic, Hidden::Coulomb),
    ] {
        let seed = 2;
        let truth = Truth::draw(plant, Some(hidden), seed);
        let data = simulate_for(&truth, seed, 0.5);
        let prep = prepare(&data, None);
        let with: Vec<String> = truth
            .base_effects()
            .into_iter()
            .filter(|e| *e != hidden.lab_name())
            .map(String::from)
            .collect();
        let mut model = Model::from_names(truth.family(), &with).expect("model");
        if plant == Plant::Pneumatic {
            // Valve speeds declared and the mass free: the residual's unit (the coupling m/τ)
            // moves with the fitted mass.
            for (k, v) in [
                ("pneumatic.gain_down_m_per_s", truth.k_down),
                ("pneumatic.gain_up_m_per_s", truth.k_up),
            ] {
                model.spec.set(k, v).expect("in bounds");
                model.spec.set_free(k, false).expect("known");
            }
        }
        let dg = diagnose(
            &model,
            &data,
            &prep,
            &DiagnoseOptions::default(),
            &|_, _, _| {},
        )
        .expect("diagnosis");
        for c in &dg.candidates {
            if c.improvement <= 0.0 {
                assert!(
                    c.delta_bic > 0.0 && !c.significant,
                    "{plant:?}: {} drops nothing and has ΔBIC {}",
                    c.effect,
                    c.delta_bic
                );
            }
            if c.improvement > 0.05 && c.holdout_improvement > 0.05 {
                assert!(c.delta_bic < 0.0, "{plant:?}: {} cuts the error", c.effect);
            }
        }
        assert_eq!(dg.verdict.as_deref(), Some("coulomb"), "{plant:?}");
    }
}
