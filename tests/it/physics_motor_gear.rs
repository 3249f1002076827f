//! motor_gear (Bao et al.): motor steady state, backlash lost motion and free regime, friction.

use actuatord::physics::{load_spec, EffectKind, Family, Plant, PlantSpec};
use std::path::Path;

fn file_spec() -> PlantSpec {
    load_spec(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/plants/motor_gear.toml"
    )))
    .unwrap()
}

#[test]
fn default_plant_runs_and_follows_the_voltage_sign() {
    let mut p = file_spec().build().unwrap();
    assert_eq!(p.family(), Family::MotorGear);
    for _ in 0..200 {
        p.step(6.0, 1e-3);
    }
    let y = p.truth().position;
    assert!(y > 0.0, "{y}");
    for _ in 0..400 {
        p.step(-6.0, 1e-3);
    }
    assert!(p.truth().position < y);
    assert!(p.truth().current_a.abs() > 0.0);
    assert_eq!(p.truth().supply_voltage_v, 24.0);
}

#[test]
fn steady_speed_matches_the_motor_equations() {
    // No backlash, viscous load only: K_T (U - K_e h ω_l) / R · h = d ω_l.
    let mut s = PlantSpec::new(Family::MotorGear);
    s.set("motor_gear.angle_min_rad", -100.0).unwrap();
    s.set("motor_gear.angle_max_rad", 100.0).unwrap();
    s.add_effect(EffectKind::Viscous).unwrap();
    s.set("viscous.damping_pos_nm_s_per_rad", 0.5).unwrap();
    s.set("viscous.damping_neg_nm_s_per_rad", 0.5).unwrap();
    let h = s.get("motor_gear.ratio").unwrap();
    let mut p = s.build().unwrap();
    let (u, kt, ke, r, d) = (12.0, 0.03, 0.03, 1.55, 0.5);
    for _ in 0..1000 {
        p.step(u, 1e-3);
    }
    let w = kt * h * u / (r * d + kt * ke * h * h);
    assert!(
        (p.truth().velocity - w).abs() < 1e-6 * w,
        "{} vs {w}",
        p.truth().velocity
    );
    let i = d * w / (kt * h);
    assert!((p.truth().current_a - i).abs() < 1e-6);
}

fn backlash_plant(gap: f64) -> Box<dyn Plant> {
    let mut s = PlantSpec::new(Family::MotorGear);
    s.set_command(actuatord::physics::CommandUnit::NewtonMetre)
        .unwrap();
    // A stiff contact so that its elastic deflection (torque / K_g) is negligible.
    s.set("motor_gear.contact_stiffness_nm_per_rad", 1e5)
        .unwrap();
    s.set("motor_gear.contact_damping_nm_s_per_rad", 20.0)
        .unwrap();
    s.max_substep_s = 1e-5;
    s.add_effect(EffectKind::Backlash).unwrap();
    s.set("backlash.gap_rad", gap).unwrap();
    s.add_effect(EffectKind::Coulomb).unwrap();
    s.set("coulomb.coulomb_pos_nm", 0.4).unwrap();
    s.set("coulomb.coulomb_neg_nm", 0.4).unwrap();
    s.add_effect(EffectKind::Stiction).unwrap();
    s.set("stiction.breakaway_pos_nm", 0.5).unwrap();
    s.set("stiction.breakaway_neg_nm", 0.5).unwrap();
    s.add_effect(EffectKind::Viscous).unwrap();
    s.set("viscous.damping_pos_nm_s_per_rad", 0.5).unwrap();
    s.set("viscous.damping_neg_nm_s_per_rad", 0.5).unwrap();
    s.build().unwrap()
}

#[test]
fn load_does_not_move_until_the_gap_is_taken_up() {
    let gap = 0.01;
    let mut p = backlash_plant(gap);
    // Motor torque 0.01 N·m, slow: the gear crosses the half gap before anything else happens.
    let mut took_up = false;
    for _ in 0..20_000 {
        p.step(0.01, 1e-4);
        let (g, l) = (p.drive_position(), p.truth().position);
        if !took_up && g - l < 0.5 * gap - 1e-9 {
            assert_eq!(l, 0.0, "load moved in the gap");
        } else {
            took_up = true;
        }
    }
    assert!(took_up);
    assert!(p.truth().position > 0.0, "load pushed once in contact");
}

#[test]
fn lost_motion_at_a_reversal_equals_the_gap() {
    for gap in [0.004, 0.01] {
        let mut p = backlash_plant(gap);
        // Push positive at a steady speed, record Δ = θ_g - θ_l.
        for _ in 0..5000 {
            p.step(0.02, 1e-4);
        }
        let d_pos = p.drive_position() - p.truth().position;
        let l_before = p.truth().position;
        // Reverse: the load stays exactly where it stopped while the gear crosses the gap.
        let mut crossing = true;
        let mut max_still = 0.0f64;
        for _ in 0..20_000 {
            p.step(-0.02, 1e-4);
            let l = p.truth().position;
            let d = p.drive_position() - l;
            if crossing && d > -0.5 * gap + 1e-9 && p.truth().velocity == 0.0 {
                max_still = max_still.max((l - l_before).abs());
            } else {
                crossing = false;
            }
        }
        assert!(!crossing, "never came into negative contact");
        let d_neg = p.drive_position() - p.truth().position;
        // Elastic deflection in contact: (F_C + d ω) / K_g on each side, below 1e-5 rad.
        let lost = d_pos - d_neg;
        assert!((lost - gap).abs() < 2e-5, "gap {gap}: lost motion {lost}");
        // Once stopped, the load did not creep while the gear crossed the gap: at most the
        // coasting distance after separation, v² / (2 F_C / J) with v = 0.02 / 0.5 rad/s.
        assert!(
            max_still < 0.04f64.powi(2) / (2.0 * 0.4 / 0.01) + 1e-9,
            "{max_still}"
        );
    }
}

#[test]
fn backlash_growth_fault_doubles_the_lost_motion() {
    let gap = 0.004;
    let mut p = backlash_plant(gap);
    p.inject("backlash_x2".parse().unwrap());
    for _ in 0..5000 {
        p.step(0.02, 1e-4);
    }
    let d_pos = p.drive_position() - p.truth().position;
    for _ in 0..20_000 {
        p.step(-0.02, 1e-4);
    }
    let d_neg = p.drive_position() - p.truth().position;
    assert!(((d_pos - d_neg) - 2.0 * gap).abs() < 2e-5);
}

#[test]
fn load_held_by_stiction_stays_put_in_the_gap_and_moves_under_its_own_load() {
    // With a payload and no friction, the free load in the gap swings under its own load only.
    let mut s = PlantSpec::new(Family::MotorGear);
    s.set_command(actuatord::physics::CommandUnit::NewtonMetre)
        .unwrap();
    s.add_effect(EffectKind::Backlash).unwrap();
    s.set("backlash.gap_rad", 0.2).unwrap();
    s.add_effect(EffectKind::Offset).unwrap();
    s.set("offset.bias_nm", -0.05).unwrap();
    s.set("motor_gear.load_inertia_kg_m2", 0.01).unwrap();
    let mut p = s.build().unwrap();
    // Zero motor torque; the load (J_l = 0.01) accelerates at -5 rad/s² until it meets the gear.
    let dt = 1e-3;
    for k in 1..=50 {
        p.step(0.0, dt);
        let t = k as f64 * dt;
        let expected = -0.5 * 5.0 * t * t;
        assert!((p.truth().position - expected).abs() < 1e-9, "t {t}");
        assert_eq!(p.drive_position(), 0.0);
    }
}

#[test]
fn varying_ratio_raises_the_ratio_with_angle() {
    // Steady speed with viscous load only at h = h0 / cos θ: compare near 0 and near 0.8 rad.
    let mut s = PlantSpec::new(Family::MotorGear);
    s.set("motor_gear.angle_min_rad", -1.4).unwrap();
    s.set("motor_gear.angle_max_rad", 1.4).unwrap();
    s.add_effect(EffectKind::VaryingRatio).unwrap();
    s.add_effect(EffectKind::Viscous).unwrap();
    s.set("viscous.damping_pos_nm_s_per_rad", 0.5).unwrap();
    let h0 = s.get("motor_gear.ratio").unwrap();
    let mut p = s.build().unwrap();
    let (u, kt, ke, r, d) = (2.0, 0.03, 0.03, 1.55, 0.5);
    let speed = |h: f64| kt * h * u / (r * d + kt * ke * h * h);
    let mut checked = 0;
    for _ in 0..20_000 {
        p.step(u, 1e-4);
        let th = p.truth().position;
        if (th - 0.8).abs() < 0.002 {
            let h = h0 / th.cos();
            // Quasi-steady: ω changes slowly compared with the motor time constants.
            assert!((p.truth().velocity / speed(h) - 1.0).abs() < 0.02);
            checked += 1;
        }
    }
    assert!(checked > 0);
}

#[test]
fn backlash_impacts_neither_create_nor_lose_energy_without_damping() {
    let mut s = PlantSpec::new(Family::MotorGear);
    s.set_command(actuatord::physics::CommandUnit::NewtonMetre)
        .unwrap();
    s.set("motor_gear.torsion_damping_nm_s_per_rad", 0.0)
        .unwrap();
    s.set("motor_gear.contact_damping_nm_s_per_rad", 0.0)
        .unwrap();
    s.set("motor_gear.angle_min_rad", -100.0).unwrap();
    s.set("motor_gear.angle_max_rad", 100.0).unwrap();
    s.add_effect(EffectKind::Backlash).unwrap();
    s.set("backlash.gap_rad", 0.01).unwrap();
    // The undamped shaft mode of the light rotor (near 11000 rad/s) is integrated with a
    // sub-step short enough (h |λ| = 0.055) that RK4's own loss stays far below the bound, so
    // the balance measures the impacts.
    s.max_substep_s = 5e-6;
    let mut p = s.build().unwrap();
    // Kick the motor for 5 ms, then let gear and load rattle through the gap.
    for _ in 0..5 {
        p.step(0.05, 1e-3);
    }
    let e0 = p.energy_j().unwrap();
    assert!(e0 > 0.0);
    let mut contacts = 0;
    let mut in_gap = true;
    let mut worst: f64 = 0.0;
    for _ in 0..20_000 {
        p.step(0.0, 1e-4);
        let d = p.drive_position() - p.truth().position;
        let gap_now = d.abs() < 0.005;
        if in_gap && !gap_now {
            contacts += 1;
        }
        in_gap = gap_now;
        worst = worst.max((p.energy_j().unwrap() / e0 - 1.0).abs());
    }
    assert!(contacts > 10, "only {contacts} contacts");
    assert!(worst < 1e-4, "relative energy error {worst}");
}
