//! Solenoid family against hand-computable physics and the paper's identified model.

use actuatord::physics::{load_spec, EffectKind, Fault, Plant, PlantSpec};
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

fn spec() -> PlantSpec {
    load_spec(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/plants/solenoid.toml"
    )))
    .unwrap()
}

fn plant() -> Box<dyn Plant> {
    spec().build().unwrap()
}

fn hold(p: &mut dyn Plant, u: f64, seconds: f64) {
    for _ in 0..(seconds / 0.0025).round() as usize {
        p.step(u, 0.0025);
    }
}

/// The plant's own parameters, read from its file: the checks below hold the simulated physics
/// against hand-computed values, and the paper's figures against the plant's parameters.
struct Solenoid {
    /// K_I K_Mag, N/V.
    k: f64,
    /// Spring stiffness c, N/m.
    c: f64,
    /// Spring pretension F_0, N.
    f0: f64,
    /// Breakaway force F_S, N.
    fs: f64,
    m: f64,
    d: f64,
    ti: f64,
    ki: f64,
    km: f64,
}

static P: std::sync::LazyLock<Solenoid> = std::sync::LazyLock::new(|| {
    let s = spec();
    let get = |name: &str| s.get(name).unwrap_or_else(|| panic!("{name} in the plant"));
    let (ki, km) = (
        get("solenoid.current_gain_a_per_v"),
        get("solenoid.force_constant_n_per_a"),
    );
    Solenoid {
        k: ki * km,
        c: get("spring.stiffness_n_per_m"),
        f0: get("spring.pretension_n"),
        fs: get("stiction.breakaway_pos_n"),
        m: get("solenoid.mass_kg"),
        d: get("viscous.damping_pos_n_s_per_m"),
        ti: get("solenoid.current_time_constant_s"),
        ki,
        km,
    }
});

#[test]
fn rests_on_its_stop_below_the_pretension_threshold() {
    let mut p = plant();
    hold(p.as_mut(), 0.0, 1.0);
    assert_eq!(p.truth().position, 0.0);
    // (F_0 + F_S) / K = 3.83 N / 1.63 N/V = 2.35 V: just below, nothing moves.
    hold(p.as_mut(), 2.3, 2.0);
    assert_eq!(p.truth().position, 0.0);
    assert_eq!(p.truth().velocity, 0.0);
    hold(p.as_mut(), 2.4, 2.0);
    assert!(p.truth().position > 0.0);
    assert!((p.time_s() - 5.0).abs() < 1e-9);
}

#[test]
fn static_gain_matches_paper_within_the_friction_band() {
    for u in [6.0, 12.0, 20.0] {
        let mut p = plant();
        hold(p.as_mut(), u, 3.0);
        let y = p.truth().position;
        let expected = (P.k * u - P.f0) / P.c;
        assert!(
            (y - expected).abs() <= P.fs / P.c + 1e-7,
            "U {u}: y {y} expected {expected} ± {}",
            P.fs / P.c
        );
        // DC gain 0.987 mm/V (G+).
        assert!((P.k / P.c * 1000.0 - 0.987).abs() < 0.002);
    }
}

#[test]
fn breakaway_happens_exactly_at_the_stiction_level() {
    // Held at y, the net force without friction is f0 = K U - F_0 - c y; it breaks loose when
    // K U' - F_0 - c y leaves [-F_S, F_S].
    let mut p = plant();
    hold(p.as_mut(), 10.0, 3.0);
    let y = p.truth().position;
    assert_eq!(p.truth().velocity, 0.0);
    let f0 = P.k * 10.0 - P.f0 - P.c * y;
    assert!(f0.abs() <= P.fs + 1e-9);
    let u_up = 10.0 + (P.fs - f0) / P.k;
    hold(p.as_mut(), u_up - 0.002, 2.0);
    assert_eq!(p.truth().position, y, "held below breakaway");
    let u_down = 10.0 - (P.fs + f0) / P.k;
    hold(p.as_mut(), u_down + 0.002, 2.0);
    assert_eq!(p.truth().position, y, "held below breakaway, other side");
    hold(p.as_mut(), u_up + 0.01, 2.0);
    assert!(p.truth().position > y, "moves above breakaway");
}

/// Linear third-order model without dry friction:
/// `T_I I' + I = K_I U`, `m y'' + d y' + c y = K_Mag I - F_0`, integrated exactly by the
/// matrix exponential.
#[test]
fn linear_response_matches_the_paper_model() {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    s.set("viscous.damping_neg_n_s_per_m", 20.0).unwrap();
    let mut p = s.build().unwrap();
    // Operating point 8 V (y = 6.08 mm), then a 4 V step.
    hold(p.as_mut(), 8.0, 3.0);
    let (m, d, ti, ki, km) = (P.m, P.d, P.ti, P.ki, P.km);
    let a = Matrix3::new(0.0, 1.0, 0.0, -P.c / m, -d / m, km / m, 0.0, 0.0, -1.0 / ti);
    let y_ss = |u: f64| (P.k * u - P.f0) / P.c;
    let x0 = Vector3::new(y_ss(8.0), 0.0, ki * 8.0);
    let x_ss = Vector3::new(y_ss(12.0), 0.0, ki * 12.0);
    assert!((p.truth().position - x0[0]).abs() < 1e-9);
    let mut worst: f64 = 0.0;
    for k in 1..=200 {
        p.step(12.0, 0.0025);
        let t = k as f64 * 0.0025;
        let x = x_ss + (a * t).exp() * (x0 - x_ss);
        worst = worst.max((p.truth().position - x[0]).abs());
        assert!((p.truth().current_a - x[2]).abs() < 1e-7);
    }
    assert!(worst < 1e-8, "max deviation {worst} m");
    // The model's poles are the paper's G+: s + 116.4 and s² + 40.4 s + 3329.4.
    assert!((1.0 / ti - 116.4).abs() < 0.1);
    assert!((d / m - 40.4).abs() < 0.05);
    assert!((P.c / m - 3329.4).abs() < 1.0);
}

#[test]
fn stops_at_the_pulled_in_end_stop() {
    let mut s = spec();
    s.set("spring.pretension_n", 0.0).unwrap();
    s.set("spring.stiffness_n_per_m", 1000.0).unwrap();
    let mut p = s.build().unwrap();
    hold(p.as_mut(), 24.0, 2.0);
    assert_eq!(p.truth().position, 0.025);
    assert_eq!(p.truth().velocity, 0.0);
}

fn static_position(fault: Option<&str>, u: f64) -> f64 {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    let mut p = s.build().unwrap();
    if let Some(f) = fault {
        p.inject(f.parse::<Fault>().unwrap());
    }
    hold(p.as_mut(), u, 4.0);
    p.truth().position
}

#[test]
fn the_four_paper_faults_change_the_statics_as_the_model_says() {
    let u = 12.0;
    let tol = 1e-9;
    // F1: pretension 1.5 × 3 N.
    assert!(
        (static_position(Some("spring_pretension_x1.5"), u) - (P.k * u - 1.5 * P.f0) / P.c).abs()
            < tol
    );
    // F2: 1650 → 1200 N/m.
    let k2 = 1200.0 / P.c;
    assert!(
        (static_position(Some(&format!("spring_x{k2}")), u) - (P.k * u - P.f0) / 1200.0).abs()
            < tol
    );
    // F4: current loop gain halved.
    assert!(
        (static_position(Some("current_gain_x0.5"), u) - (0.5 * P.k * u - P.f0) / P.c).abs() < tol
    );
    // Supply halved, PWM duty computed for 24 V (supply_gain exponent 1): half the voltage.
    assert!((static_position(Some("supply_x0.5"), u) - (0.5 * P.k * u - P.f0) / P.c).abs() < tol);
    assert!((static_position(None, u) - (P.k * u - P.f0) / P.c).abs() < tol);
}

#[test]
fn friction_fault_widens_the_band_and_jamming_locks() {
    // F3: friction × 3 raises the voltage needed to leave the rest stop by 2 F_S / K.
    let mut p = plant();
    p.inject("friction_x3".parse().unwrap());
    hold(p.as_mut(), (P.f0 + 3.0 * P.fs) / P.k - 0.02, 2.0);
    assert_eq!(p.truth().position, 0.0);
    hold(p.as_mut(), (P.f0 + 3.0 * P.fs) / P.k + 0.05, 2.0);
    assert!(p.truth().position > 0.0);
    let mut q = plant();
    hold(q.as_mut(), 10.0, 2.0);
    let y = q.truth().position;
    q.inject("jamming".parse().unwrap());
    hold(q.as_mut(), 24.0, 2.0);
    assert_eq!(q.truth().position, y);
    hold(q.as_mut(), 0.0, 2.0);
    assert_eq!(q.truth().position, y);
}

#[test]
fn a_drifting_fault_grows_linearly() {
    let mut s = spec();
    s.remove_effect(EffectKind::Coulomb);
    s.remove_effect(EffectKind::Stiction);
    s.faults.push("current_gain_x0.5~20s@1s".parse().unwrap());
    let mut p = s.build().unwrap();
    // Quasi-static: at t = 11 s the gain is 0.75.
    hold(p.as_mut(), 12.0, 11.0);
    // A ramp through a first-order-like lag is followed with a delay equal to the sum of the
    // time constants, T_I + d / c, plus half a step because faults are updated per step.
    let rate = -0.5 / 20.0 * P.k * 12.0 / P.c;
    let lag = P.ti + P.d / P.c + 0.5 * 0.0025;
    let expected = (0.75 * P.k * 12.0 - P.f0) / P.c - rate * lag;
    assert!(
        (p.truth().position - expected).abs() < 1e-6,
        "{}",
        p.truth().position
    );
}

#[test]
fn sensor_quantises_and_is_deterministic() {
    let mut a = plant();
    let mut b = plant();
    for _ in 0..400 {
        a.step(10.0, 0.0025);
        b.step(10.0, 0.0025);
        let (ma, mb) = (a.measure(), b.measure());
        assert_eq!(ma, mb);
        let q = ma.position / 1e-6;
        assert!((q - q.round()).abs() < 1e-6);
        assert!((ma.position - a.truth().position).abs() < 6e-6);
        assert!((ma.supply_voltage_v - 24.0).abs() < 0.2);
    }
}

#[test]
fn sensor_faults() {
    let mut p = plant();
    hold(p.as_mut(), 10.0, 1.0);
    let before = p.measure().position;
    p.inject("sensor_offset_0.001".parse().unwrap());
    let m = p.measure().position;
    assert!((m - before - 0.001).abs() < 5e-6);
    p.inject("sensor_stuck".parse().unwrap());
    let stuck = p.measure().position;
    hold(p.as_mut(), 20.0, 1.0);
    assert_eq!(p.measure().position, stuck);
    let mut q = plant();
    hold(q.as_mut(), 10.0, 1.0);
    q.inject("sensor_noise_x100".parse().unwrap());
    let y = q.truth().position;
    let n = 2000;
    let var: f64 = (0..n)
        .map(|_| (q.measure().position - y).powi(2))
        .sum::<f64>()
        / n as f64;
    // σ = 100 × 0.5 µm = 50 µm.
    assert!((var.sqrt() - 50e-6).abs() < 5e-6, "σ {}", var.sqrt());
}
