//! linear_axis against closed forms: step and frequency response of `m y'' + d y' + c y = F`,
//! energy of the undamped oscillator, stick and breakaway, hysteresis loop width, input effects.

use actuatord::physics::{EffectKind, Family, Plant, PlantSpec};

const M: f64 = 2.0;
const C: f64 = 800.0;
const D: f64 = 8.0;

fn axis(effects: &[(EffectKind, &[(&str, f64)])]) -> Box<dyn Plant> {
    let mut spec = PlantSpec::new(Family::LinearAxis);
    spec.set("linear_axis.mass_kg", M).unwrap();
    spec.set("linear_axis.travel_min_m", -10.0).unwrap();
    spec.set("linear_axis.travel_max_m", 10.0).unwrap();
    spec.max_substep_s = 1e-4;
    for (kind, params) in effects {
        spec.add_effect(*kind).unwrap();
        for (key, v) in params.iter() {
            spec.set(&format!("{}.{}", kind.name(), key), *v).unwrap();
        }
    }
    spec.build().unwrap()
}

fn spring_damper() -> Vec<(EffectKind, &'static [(&'static str, f64)])> {
    vec![
        (
            EffectKind::Spring,
            &[("stiffness_n_per_m", C), ("pretension_n", 0.0)],
        ),
        (
            EffectKind::Viscous,
            &[("damping_pos_n_s_per_m", D), ("damping_neg_n_s_per_m", D)],
        ),
    ]
}

#[test]
fn step_response_matches_closed_form() {
    let mut p = axis(&spring_damper());
    let f = 10.0;
    let w0 = (C / M).sqrt();
    let zeta = D / (2.0 * (C * M).sqrt());
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let dt = 1e-3;
    let mut worst: f64 = 0.0;
    for k in 1..=2000 {
        p.step(f, dt);
        let t = k as f64 * dt;
        let y = f / C
            * (1.0
                - (-zeta * w0 * t).exp()
                    * ((wd * t).cos() + zeta / (1.0 - zeta * zeta).sqrt() * (wd * t).sin()));
        worst = worst.max((p.truth().position - y).abs());
    }
    assert!(worst < 1e-9 * f / C * 1e3, "max error {worst}");
}

#[test]
fn frequency_response_matches_closed_form() {
    for &w in &[5.0, 20.0, 40.0] {
        let mut p = axis(&spring_damper());
        let a = 5.0;
        let dt = 5e-4;
        let period = std::f64::consts::TAU / w;
        let settle = 3.0; // 1/(ζω0) = 0.5 s
        let n_total = ((settle + 10.0 * period) / dt) as usize;
        let (mut s_sin, mut s_cos, mut n) = (0.0, 0.0, 0.0);
        for k in 0..n_total {
            let t = k as f64 * dt;
            p.step(a * (w * (t + 0.5 * dt)).sin(), dt);
            let t_end = t + dt;
            if t_end > settle && t_end <= settle + 10.0 * period + 1e-9 {
                let y = p.truth().position;
                s_sin += y * (w * t_end).sin();
                s_cos += y * (w * t_end).cos();
                n += 1.0;
            }
        }
        let (b_sin, b_cos) = (2.0 * s_sin / n, 2.0 * s_cos / n);
        let amp = (b_sin * b_sin + b_cos * b_cos).sqrt();
        let phase = b_cos.atan2(b_sin);
        let re = C - M * w * w;
        let im = D * w;
        let amp_expected = a / (re * re + im * im).sqrt();
        let phase_expected = -(im.atan2(re));
        assert!(
            (amp / amp_expected - 1.0).abs() < 0.01,
            "ω {w}: amplitude {amp} expected {amp_expected}"
        );
        assert!(
            (phase - phase_expected).abs() < 0.02,
            "ω {w}: phase {phase} expected {phase_expected}"
        );
    }
}

#[test]
fn undamped_oscillator_keeps_its_energy() {
    let mut p = axis(&[(EffectKind::Spring, &[("stiffness_n_per_m", C)])]);
    // Push with 10 N for 10 ms, then let it swing.
    for _ in 0..10 {
        p.step(10.0, 1e-3);
    }
    let energy = |m: actuatord::physics::Measurement| {
        0.5 * M * m.velocity.powi(2) + 0.5 * C * m.position.powi(2)
    };
    let e0 = energy(p.truth());
    assert!(e0 > 0.0);
    // 200 periods of 0.314 s.
    let mut worst: f64 = 0.0;
    for _ in 0..63_000 {
        p.step(0.0, 1e-3);
        worst = worst.max((energy(p.truth()) / e0 - 1.0).abs());
    }
    assert!(worst < 1e-5, "relative energy drift {worst}");
}

fn friction_axis() -> Box<dyn Plant> {
    axis(&[
        (
            EffectKind::Coulomb,
            &[("coulomb_pos_n", 2.0), ("coulomb_neg_n", 2.0)],
        ),
        (
            EffectKind::Stiction,
            &[("breakaway_pos_n", 3.0), ("breakaway_neg_n", 3.0)],
        ),
    ])
}

#[test]
fn force_below_breakaway_does_not_move_it_above_does() {
    let mut p = friction_axis();
    for _ in 0..5000 {
        p.step(2.99, 1e-3);
    }
    assert_eq!(p.truth().position, 0.0);
    assert_eq!(p.truth().velocity, 0.0);
    for _ in 0..5000 {
        p.step(-2.99, 1e-3);
    }
    assert_eq!(p.truth().position, 0.0);
    // Above breakaway it slides against Coulomb friction: a = (3.5 - 2) / m.
    for _ in 0..100 {
        p.step(3.5, 1e-3);
    }
    let a = (3.5 - 2.0) / M;
    let t = 0.1;
    assert!((p.truth().velocity - a * t).abs() < 1e-9);
    assert!((p.truth().position - 0.5 * a * t * t).abs() < 1e-9);
}

#[test]
fn sliding_body_stops_and_sticks_without_creep_or_chatter() {
    let mut p = friction_axis();
    for _ in 0..200 {
        p.step(5.0, 1e-3);
    }
    // Remove the force: Coulomb friction stops it in v / (F_C / m).
    let v0 = p.truth().velocity;
    let y0 = p.truth().position;
    let decel = 2.0 / M;
    let stop_y = y0 + v0 * v0 / (2.0 * decel);
    for _ in 0..1000 {
        p.step(1.0, 1e-3);
        assert!(p.truth().velocity >= 0.0, "no reversal under friction");
    }
    // With 1 N applied it decelerates at (2 - 1)/m instead: recompute.
    let stop_y_1n = y0 + v0 * v0 / (2.0 * (2.0 - 1.0) / M);
    assert!(stop_y_1n > stop_y);
    let y_stop = p.truth().position;
    assert!((y_stop - stop_y_1n).abs() < 1e-9, "{y_stop} vs {stop_y_1n}");
    for _ in 0..10_000 {
        p.step(2.9, 1e-3);
        assert_eq!(p.truth().position, y_stop);
    }
}

#[test]
fn hysteresis_loop_width_equals_its_parameter() {
    let w = 1.5;
    let mut p = axis(&[
        (EffectKind::Spring, &[("stiffness_n_per_m", C)]),
        (
            EffectKind::Viscous,
            &[
                ("damping_pos_n_s_per_m", 80.0),
                ("damping_neg_n_s_per_m", 80.0),
            ],
        ),
        (EffectKind::Hysteresis, &[("width_n", w)]),
    ]);
    // Slow triangle 0 → 10 → -10 → 10 N, 0.5 N/s, and read y at F = 2 N on both branches.
    let dt = 1e-3;
    let rate = 0.5;
    let mut f: f64 = 0.0;
    let (mut up, mut down) = (None, None);
    let mut dir = 1.0;
    let mut legs = 0;
    while legs < 3 {
        let next = f + dir * rate * dt;
        p.step(next, dt);
        if legs == 2 && dir > 0.0 && f < 2.0 && next >= 2.0 {
            up = Some(p.truth().position);
        }
        if legs == 1 && dir < 0.0 && f > 2.0 && next <= 2.0 {
            down = Some(p.truth().position);
        }
        f = next;
        if f.abs() >= 10.0 {
            dir = -dir;
            legs += 1;
        }
    }
    let width = (down.unwrap() - up.unwrap()) * C;
    // At a finite rate the viscous force adds d·v on each branch, v = rate / c.
    let viscous_part = 2.0 * 80.0 * rate / C;
    assert!(
        (width - viscous_part - w).abs() < 1e-3 * w,
        "loop width {width}, parameter {w} + rate part {viscous_part}"
    );
}

#[test]
fn dead_time_delays_the_force_exactly() {
    let td = 0.0123;
    let mut p = axis(&[(EffectKind::DeadTime, &[("delay_s", td)])]);
    let dt = 1e-3;
    for k in 1..=100 {
        p.step(4.0, dt);
        let t = k as f64 * dt;
        let expected = if t > td {
            0.5 * 4.0 / M * (t - td).powi(2)
        } else {
            0.0
        };
        assert!((p.truth().position - expected).abs() < 1e-12, "t {t}");
    }
}

#[test]
fn input_effects_shape_the_force() {
    // Free mass: the acceleration shows the force that reached it.
    let accel = |effects: &[(EffectKind, &[(&str, f64)])], u: f64| {
        let mut p = axis(effects);
        p.step(u, 0.01);
        2.0 * p.truth().position / 0.01f64.powi(2) * M
    };
    let sat: &[(&str, f64)] = &[("min_n", -3.0), ("max_n", 5.0)];
    assert!((accel(&[(EffectKind::Saturation, sat)], 9.0) - 5.0).abs() < 1e-9);
    assert!((accel(&[(EffectKind::Saturation, sat)], -9.0) + 3.0).abs() < 1e-9);
    let dz: &[(&str, f64)] = &[("threshold_n", 1.0)];
    assert!(accel(&[(EffectKind::Deadzone, dz)], 0.9).abs() < 1e-12);
    assert!((accel(&[(EffectKind::Deadzone, dz)], 3.0) - 2.0).abs() < 1e-9);
    let asym: &[(&str, f64)] = &[("gain_pos", 1.0), ("gain_neg", 0.5)];
    assert!((accel(&[(EffectKind::DirectionAsymmetry, asym)], 4.0) - 4.0).abs() < 1e-9);
    let off: &[(&str, f64)] = &[("bias_n", -1.5)];
    assert!((accel(&[(EffectKind::Offset, off)], 4.0) - 2.5).abs() < 1e-9);
}

#[test]
fn direction_asymmetry_gives_speed_per_direction() {
    let mut p = axis(&[
        (
            EffectKind::Viscous,
            &[
                ("damping_pos_n_s_per_m", 10.0),
                ("damping_neg_n_s_per_m", 10.0),
            ],
        ),
        (
            EffectKind::DirectionAsymmetry,
            &[("gain_pos", 1.0), ("gain_neg", 0.5)],
        ),
    ]);
    for _ in 0..5000 {
        p.step(5.0, 1e-3);
    }
    assert!((p.truth().velocity - 0.5).abs() < 1e-6);
    for _ in 0..5000 {
        p.step(-5.0, 1e-3);
    }
    assert!((p.truth().velocity + 0.25).abs() < 1e-6);
}

#[test]
fn stribeck_steady_speed_solves_the_friction_law() {
    let (fc, ex, vs, d) = (2.0, 1.0, 0.05, 20.0);
    let mut p = axis(&[
        (
            EffectKind::Coulomb,
            &[("coulomb_pos_n", fc), ("coulomb_neg_n", fc)],
        ),
        (
            EffectKind::Stribeck,
            &[
                ("excess_pos_n", ex),
                ("excess_neg_n", ex),
                ("velocity_pos_m_per_s", vs),
                ("velocity_neg_m_per_s", vs),
            ],
        ),
        (
            EffectKind::Viscous,
            &[("damping_pos_n_s_per_m", d), ("damping_neg_n_s_per_m", d)],
        ),
    ]);
    let f = 4.0;
    for _ in 0..20_000 {
        p.step(f, 1e-3);
    }
    // F = F_C + ex e^(-v/vs) + d v, solved by bisection.
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..100 {
        let v = 0.5 * (lo + hi);
        if fc + ex * (-v / vs).exp() + d * v < f {
            lo = v;
        } else {
            hi = v;
        }
    }
    assert!(
        (p.truth().velocity - lo).abs() < 1e-6,
        "{} vs {lo}",
        p.truth().velocity
    );
    // Static level F_C + excess = 3 N: 2.9 N does not start it.
    let mut q = axis(&[
        (
            EffectKind::Coulomb,
            &[("coulomb_pos_n", fc), ("coulomb_neg_n", fc)],
        ),
        (
            EffectKind::Stribeck,
            &[("excess_pos_n", ex), ("excess_neg_n", ex)],
        ),
    ]);
    for _ in 0..1000 {
        q.step(2.9, 1e-3);
    }
    assert_eq!(q.truth().position, 0.0);
}

#[test]
fn payload_spring_and_offset_set_the_equilibrium() {
    let mut p = axis(&[
        (
            EffectKind::Spring,
            &[("stiffness_n_per_m", C), ("pretension_n", 1.0)],
        ),
        (
            EffectKind::Viscous,
            &[
                ("damping_pos_n_s_per_m", 80.0),
                ("damping_neg_n_s_per_m", 80.0),
            ],
        ),
        (
            EffectKind::Payload,
            &[("max_load_n", 20.0), ("full_scale_m", 0.1)],
        ),
        (EffectKind::Offset, &[("bias_n", 2.0)]),
    ]);
    for _ in 0..20_000 {
        p.step(30.0, 1e-3);
    }
    // 30 + 2 - 1 - c y - 200 y = 0.
    let y = 31.0 / (C + 200.0);
    assert!((p.truth().position - y).abs() < 1e-9);
}

#[test]
fn end_stops_hold_the_body() {
    let mut spec = PlantSpec::new(Family::LinearAxis);
    spec.set("linear_axis.travel_max_m", 0.05).unwrap();
    let mut p = spec.build().unwrap();
    for _ in 0..2000 {
        p.step(10.0, 1e-3);
        assert!(p.truth().position <= 0.05);
    }
    assert_eq!(p.truth().position, 0.05);
    assert_eq!(p.truth().velocity, 0.0);
    p.step(-10.0, 0.1);
    assert!((p.truth().position - (0.05 - 0.5 * 10.0 * 0.01)).abs() < 1e-9);
}

#[test]
fn voltage_command_uses_force_gain_and_supply_limit() {
    let mut spec = PlantSpec::new(Family::LinearAxis);
    spec.set_command(actuatord::physics::CommandUnit::Volt)
        .unwrap();
    spec.set("linear_axis.force_gain_n_per_v", 2.0).unwrap();
    let mut p = spec.build().unwrap();
    p.step(100.0, 0.01); // clipped to 24 V → 48 N on 1 kg
    assert!((p.truth().position - 0.5 * 48.0 * 1e-4).abs() < 1e-12);
    assert_eq!(p.truth().supply_voltage_v, 24.0);
}

#[test]
fn supply_friction_scales_the_breakaway_with_the_supply() {
    // Coulomb 1 N at the nominal 24 V supply, in proportion to it (κ_f = 1); a 1.5 N push.
    let effects: Vec<(EffectKind, &[(&str, f64)])> = vec![
        (
            EffectKind::Coulomb,
            &[("coulomb_pos_n", 1.0), ("coulomb_neg_n", 1.0)],
        ),
        (EffectKind::SupplyFriction, &[("exponent", 1.0)]),
    ];
    let travelled = |supply_v: f64| {
        let mut p = axis(&effects);
        p.set_supply(supply_v);
        let start = p.truth().position;
        for _ in 0..500 {
            p.step(1.5, 1e-3);
        }
        p.truth().position - start
    };
    // Nominal: 0.5 N net for 0.5 s accelerates the 2 kg body, y = a t² / 2.
    let nominal = travelled(24.0);
    let expected = 0.5 / M * 0.5 * 0.5 * 0.5;
    assert!((nominal - expected).abs() < 1e-3 * expected, "{nominal}");
    // Double supply: 2 N of friction holds the 1.5 N push.
    assert_eq!(travelled(48.0), 0.0);
    // Half supply: 0.5 N of friction, 1 N net.
    let half = travelled(12.0);
    assert!((half - 2.0 * expected).abs() < 1e-3 * expected, "{half}");
}
