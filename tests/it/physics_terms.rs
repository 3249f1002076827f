//! Forces a model declares itself (`[[lab.term]]`) act in the plant as the catalogue's do: a term
//! written as a spring moves every family exactly as the spring effect does, and a force periodic
//! in time drives a damped mass to the closed-form amplitude.

use actuatord::physics::term::{TermParam, TermSpec};
use actuatord::physics::{EffectKind, Family, Plant, PlantSpec};

fn param(name: &str, value: f64) -> TermParam {
    TermParam {
        name: name.into(),
        min: value - 1e4,
        max: value + 1e4,
        value,
    }
}

fn run(spec: &PlantSpec, command: &dyn Fn(f64) -> f64, seconds: f64) -> Vec<f64> {
    let mut plant: Box<dyn Plant> = spec.build().expect("builds");
    let dt = 1e-3;
    (0..(seconds / dt) as usize)
        .map(|k| {
            plant.step(command(k as f64 * dt), dt);
            plant.truth().position
        })
        .collect()
}

#[test]
fn a_term_written_as_a_spring_moves_every_family_as_the_spring_does() {
    for (family, command, stiffness, pretension) in [
        (Family::LinearAxis, 40.0, 800.0, 5.0),
        (Family::Solenoid, 12.0, 2000.0, 1.0),
        (Family::Pneumatic, 0.3, 3000.0, 10.0),
        (Family::MotorGear, 6.0, 2.0, 0.1),
    ] {
        let base = PlantSpec::new(family);
        let c_key = format!(
            "spring.{}",
            EffectKind::Spring.params()[0].key(family, base.command)
        );
        let f_key = format!(
            "spring.{}",
            EffectKind::Spring.params()[1].key(family, base.command)
        );
        let mut with_effect = base
            .clone()
            .with_effect(EffectKind::Spring)
            .expect("spring");
        with_effect.set(&c_key, stiffness).expect("stiffness");
        with_effect.set(&f_key, pretension).expect("pretension");
        let mut with_term = base.clone();
        with_term
            .add_term(
                TermSpec::new(
                    "my_spring",
                    "-(f0 + c*y)",
                    &[param("c", stiffness), param("f0", pretension)],
                    false,
                    "test",
                )
                .expect("term"),
                "test",
            )
            .expect("declared");
        let u = |t: f64| {
            if (t * 2.0).fract() < 0.5 {
                command
            } else {
                -command
            }
        };
        let a = run(&with_effect, &u, 2.0);
        let b = run(&with_term, &u, 2.0);
        let span = a.iter().fold(0.0f64, |m, y| m.max(y.abs()));
        assert!(span > 0.0, "{family}: no motion");
        let worst = a
            .iter()
            .zip(&b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            worst <= 1e-9 * span.max(1e-6),
            "{family}: differs by {worst} of {span}"
        );
        // A candidate term is declared but does not act.
        let mut candidate = with_term.clone();
        candidate.terms[0].candidate = true;
        let c = run(&candidate, &u, 2.0);
        let apart = a
            .iter()
            .zip(&c)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(apart > 1e-6 * span, "{family}: the candidate term acted");
    }
}

#[test]
fn a_force_periodic_in_time_drives_a_damped_mass_to_the_closed_form_amplitude() {
    // m y'' + d y' = F sin(ω t): the velocity settles to the amplitude F / sqrt(d² + (m ω)²).
    let (m, d, f, period) = (2.0, 40.0, 10.0, 0.25);
    let mut spec = PlantSpec::new(Family::LinearAxis)
        .with_effect(EffectKind::Viscous)
        .expect("viscous");
    spec.set("linear_axis.mass_kg", m).expect("mass");
    spec.set("linear_axis.travel_min_m", -10.0).expect("min");
    spec.set("linear_axis.travel_max_m", 10.0).expect("max");
    spec.set("viscous.damping_pos_n_s_per_m", d).expect("d+");
    spec.set("viscous.damping_neg_n_s_per_m", d).expect("d-");
    spec.add_term(
        TermSpec::new(
            "shaker",
            "amp * sin(2*pi*t/period)",
            &[param("amp", f), param("period", period)],
            false,
            "test",
        )
        .expect("term"),
        "test",
    )
    .expect("declared");
    let mut plant = spec.build().expect("builds");
    let dt = 1e-4;
    let mut peak = 0.0f64;
    for k in 0..(4.0 / dt) as usize {
        plant.step(0.0, dt);
        if k as f64 * dt > 2.0 {
            peak = peak.max(plant.truth().velocity.abs());
        }
    }
    let w = 2.0 * std::f64::consts::PI / period;
    let want = f / (d * d + (m * w).powi(2)).sqrt();
    assert!(
        (peak - want).abs() < 0.01 * want,
        "velocity amplitude {peak} vs {want}"
    );
}
