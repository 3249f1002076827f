//! Pneumatic membrane drive: speed = gain × duty at each supply pressure (paper's integrator).

use actuatord::physics::{load_spec, EffectKind, PlantSpec};
use std::path::Path;

fn spec() -> PlantSpec {
    load_spec(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/plants/pneumatic.toml"
    )))
    .unwrap()
}

/// The plant's own parameters, read from its file, so that the hand-computed expectations
/// below follow the plant and the paper's figures are held against what the plant uses.
struct Pneumatic {
    atm: f64,
    p_nom: f64,
    kappa: f64,
    gain_down: f64,
    gain_up: f64,
    coulomb: f64,
    breakaway: f64,
    mass: f64,
    tau: f64,
}

static P: std::sync::LazyLock<Pneumatic> = std::sync::LazyLock::new(|| {
    let s = spec();
    let get = |name: &str| s.get(name).unwrap_or_else(|| panic!("{name} in the plant"));
    Pneumatic {
        atm: get("pneumatic.atmosphere_pa"),
        p_nom: get("pneumatic.supply_pressure_pa"),
        kappa: get("supply_gain.exponent"),
        gain_down: get("pneumatic.gain_down_m_per_s"),
        gain_up: get("pneumatic.gain_up_m_per_s"),
        coulomb: get("coulomb.coulomb_neg_n"),
        breakaway: get("stiction.breakaway_neg_n"),
        mass: get("pneumatic.mass_kg"),
        tau: get("pneumatic.velocity_time_constant_s"),
    }
});

fn gain_at(p_l: f64, k_nom: f64) -> f64 {
    k_nom * ((P.atm - p_l) / (P.atm - P.p_nom)).powf(P.kappa)
}

#[test]
fn speed_is_gain_times_duty_at_each_supply_pressure() {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    for p_l in [40_000.0, 60_000.0, 80_000.0] {
        for duty in [-1.0, -0.4, 0.3, 1.0] {
            let mut p = s.build().unwrap();
            p.set_supply(p_l);
            // 20 ms = 10 τ: the speed has settled; mid-stroke start, 20 mm / 50 mm/s = 0.4 s.
            for _ in 0..3 {
                p.step(duty, 0.01);
            }
            let k = if duty < 0.0 { P.gain_down } else { P.gain_up };
            let v = gain_at(p_l, k) * duty;
            assert!(
                (p.truth().velocity - v).abs() < 1e-4 * v.abs(),
                "P_L {p_l} duty {duty}: v {} expected {v}",
                p.truth().velocity
            );
            assert!((p.truth().supply_pressure_pa - p_l).abs() < 1e-6);
        }
    }
    // The paper's band, held against the plant's parameters: full speed 12 mm/s at 800 mbar
    // and 50 mm/s at 400 mbar (the faster, venting direction).
    for (p_l, paper) in [(80_000.0, 0.012), (40_000.0, 0.050)] {
        let v = gain_at(p_l, P.gain_down);
        assert!(
            (v - paper).abs() < 0.05 * paper,
            "P_L {p_l}: the plant's {v} m/s, the paper's {paper}"
        );
    }
}

#[test]
fn integrates_like_the_paper_model_at_t0() {
    // Y(k) = Y(k-1) + K_I T0 U(k-1) once the 2 ms lag is over.
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    let mut p = s.build().unwrap();
    let t0 = 0.02;
    p.step(0.5, t0);
    let y1 = p.truth().position;
    p.step(0.5, t0);
    let y2 = p.truth().position;
    assert!(((y2 - y1) - P.gain_up * 0.5 * t0).abs() < 1e-9);
}

#[test]
fn small_duty_does_not_move_the_membrane_against_stiction() {
    let mut p = spec().build().unwrap();
    let y0 = p.truth().position;
    // Breakaway 0.15 N over m/τ = 100 N·s/m: 1.5 mm/s, duty 0.05 down (30 mm/s full); just
    // below that duty the membrane stays.
    let breakaway_duty = P.breakaway / (P.mass / P.tau) / P.gain_down;
    assert!((breakaway_duty - 0.05).abs() < 1e-9, "{breakaway_duty}");
    for _ in 0..100 {
        p.step(-0.9 * breakaway_duty, 0.02);
    }
    assert_eq!(p.truth().position, y0);
    for _ in 0..10 {
        p.step(-0.2, 0.02);
    }
    assert!(p.truth().position < y0);
    // Sliding speed: duty·K_I - F_C / (m/τ).
    let v = -0.2 * P.gain_down + P.coulomb / (P.mass / P.tau);
    assert!((p.truth().velocity - v).abs() < 1e-6);
}

#[test]
fn supply_fault_slows_it_down() {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    let mut p = s.build().unwrap();
    p.inject("supply_x0.5".parse().unwrap());
    p.step(1.0, 0.05);
    assert!((p.truth().velocity - P.gain_up * 0.5f64.powf(P.kappa)).abs() < 1e-7);
    // Available pressure difference halved: P_L halfway to atmosphere.
    let p_l = P.atm - 0.5 * (P.atm - P.p_nom);
    assert!((p.truth().supply_pressure_pa - p_l).abs() < 1e-6);
}

#[test]
fn each_valve_follows_its_own_supply_law() {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    // The positive command's law flat over the supply (κ + Δκ = 0), the negative one's as before.
    s.set("supply_gain.exponent_pos_shift", -P.kappa)
        .expect("the shift is a parameter of supply_gain");
    for p_l in [40_000.0, 80_000.0] {
        for duty in [-0.5, 0.5] {
            let mut p = s.build().expect("builds");
            p.set_supply(p_l);
            for _ in 0..3 {
                p.step(duty, 0.01);
            }
            let v = if duty < 0.0 {
                gain_at(p_l, P.gain_down) * duty
            } else {
                P.gain_up * duty
            };
            assert!(
                (p.truth().velocity - v).abs() < 1e-4 * v.abs(),
                "P_L {p_l} duty {duty}: v {} expected {v}",
                p.truth().velocity
            );
        }
    }
}

#[test]
fn a_law_per_direction_is_refused_on_a_pwm_drive_naming_the_key() {
    let mut s = PlantSpec::new(actuatord::physics::Family::LinearAxis);
    s.add_effect(EffectKind::SupplyGain)
        .expect("linear_axis takes supply_gain");
    s.set("supply_gain.exponent_pos_shift", 0.5)
        .expect("in range");
    let err = s
        .build_named("axis.toml")
        .err()
        .expect("refused")
        .to_string();
    assert!(
        err.contains("axis.toml") && err.contains("exponent_pos_shift"),
        "{err}"
    );
}
