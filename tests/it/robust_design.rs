//! Robust design for the `motor_gear` plant file: synthesis checks, the sampled loop, the
//! controller file.

use std::path::Path;

use actuatord::control::robust::{
    sampled_loop_spectral_radius, DesignOptions, StateSpaceController, UncertainModel,
};
use actuatord::design::{design_robust, design_robust_with, write_controller_toml};
use nalgebra::Complex;

const PLANT: &str = "config/plants/motor_gear.toml";

/// The sixth-order design of the default weights: γ-iteration, Riccati checks, and the reduction
/// to the paper's order within 2 % of γ.
#[test]
fn motor_gear_design_meets_its_checks() {
    let d = design_robust_with(Path::new(PLANT), DesignOptions::default()).expect("design");
    eprintln!("{d}");
    let s = &d.synthesis;
    assert!(s.hinf.gamma_opt.is_finite() && s.hinf.gamma_opt > 0.0);
    assert!(s.hinf.gamma >= s.hinf.gamma_opt);
    // ‖T_zw‖∞ ≤ γ for the full central controller, verified by the Hamiltonian test and by an
    // independent frequency sweep.
    assert!(s.closed_loop_norm <= s.hinf.gamma * (1.0 + 1e-4));
    let cl = s.plant.close(&s.hinf.controller).expect("closed loop");
    assert!(cl.is_stable());
    let (sweep, _) = cl.peak_gain_sweep(1e-3, 1e5, 3000);
    assert!(
        sweep <= s.hinf.gamma * (1.0 + 1e-4),
        "sweep {sweep} > γ {}",
        s.hinf.gamma
    );
    assert!(
        sweep >= s.hinf.gamma_opt * (1.0 - 1e-3),
        "sweep {sweep} < γ_opt"
    );
    // Riccati checks.
    assert!(s.hinf.candidate.x.residual < 1e-8 && s.hinf.candidate.y.residual < 1e-8);
    assert!(s.hinf.candidate.x.closed_loop_abscissa < 0.0);
    assert!(s.hinf.candidate.rho_xy < s.hinf.gamma * s.hinf.gamma);
    // Reduced to the paper's order, the closed loop stays within 2 % of the γ bound.
    assert_eq!(s.controller.order(), 6);
    assert!(
        s.controller_closed_loop_norm <= s.hinf.gamma * 1.02,
        "{} vs γ {}",
        s.controller_closed_loop_norm,
        s.hinf.gamma
    );
    // The sampled loop is stable at the nominal model and at all represented vertices.
    assert!(s.nominal_discrete_stable);
    assert_eq!(s.vertices_stable.0, s.vertices_stable.1);
}

#[test]
fn sampled_loop_is_stable_over_the_ratio_range_and_half_the_contact_stiffness() {
    let d = design_robust(Path::new(PLANT)).expect("design");
    let m = &d.synthesis.model;
    let k = &d.synthesis.discrete;
    // Exact models at the ends and the middle of the ratio range h_0 … h_0 / cos 20°.
    for h in [
        m.params.ratio,
        m.ratio_mid,
        m.ratio_mid + m.ratio_half_range,
    ] {
        let mut p = m.params;
        p.ratio = h;
        p.varying_ratio = false;
        let exact = UncertainModel::new(p, Default::default()).expect("model");
        let r = sampled_loop_spectral_radius(&exact.nominal, k, 0.001).expect("loop");
        assert!(r < 1.0, "h = {h}: spectral radius {r}");
        // Contact stiffness and damping at 50 % and 150 % (δ1 = ∓0.5).
        for d1 in [-0.5, 0.5] {
            let pm = exact.perturbed(&[d1, 0.0]).expect("model");
            let r = sampled_loop_spectral_radius(&pm, k, 0.001).expect("loop");
            assert!(r < 1.0, "h = {h}, δ1 = {d1}: spectral radius {r}");
        }
    }
}

#[test]
fn perturbation_structure_reproduces_the_regimes() {
    let spec = actuatord::physics::load_spec(Path::new(PLANT)).expect("plant file");
    let params = actuatord::control::robust::MotorGearParams::from_spec(&spec).expect("params");
    let m = UncertainModel::new(params, Default::default()).expect("model");
    assert_eq!(m.perturbations.len(), 3);
    // δ1 = -1 removes the contact: the load (θ_l, ω_l) decouples, so the transfer from voltage
    // to load angle vanishes.
    let gap = m.perturbed(&[-1.0, 0.0, 0.0]).expect("model");
    let g = gap.eval(Complex::new(0.0, 10.0)).expect("response")[(0, 0)];
    assert!(g.norm() < 1e-12, "{g}");
    // In contact the low-frequency gain is the rigid chain's: |P(jω)| ≈ (h K_T / R_a) /
    // ((b + h² K_T K_e / R_a) ω) well below the mechanical corner, the viscous friction b beside
    // the back-EMF's damping (a fifth of it on this gear).
    let w = 0.01;
    let p = m.nominal.eval(Complex::new(0.0, w)).expect("response")[(0, 0)].norm();
    let h = m.ratio_mid;
    let drive = h * params.torque_constant_nm_per_a / params.resistance_ohm;
    let b = 0.5 * (params.viscous_pos_nm_s_per_rad + params.viscous_neg_nm_s_per_rad);
    let rigid = drive / ((b + drive * h * params.back_emf_v_s_per_rad) * w);
    assert!((p / rigid - 1.0).abs() < 0.1, "{p} vs {rigid}");
    // Each factorisation L_i R_i reproduces E⁻¹A_i.
    for pert in &m.perturbations {
        assert!((&pert.l * &pert.r - &pert.a).norm() < 1e-9 * pert.a.norm());
    }
}

#[test]
fn controller_file_round_trips_and_steps_like_the_discrete_system() {
    let d = design_robust(Path::new(PLANT)).expect("design");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("controller.toml");
    write_controller_toml(&d, &path).expect("write");
    let mut k = StateSpaceController::load(&path).expect("load");
    assert_eq!(k.order(), d.synthesis.discrete.order());
    assert_eq!(k.period_s(), 0.001);
    // Impulse response of the loaded controller against the matrices of the design.
    let sys = &d.synthesis.discrete;
    let mut x = nalgebra::DVector::<f64>::zeros(sys.order());
    for step in 0..50 {
        let e = if step == 0 { 1e-3 } else { 0.0 };
        let u_ref = (&sys.c * &x)[(0, 0)] + sys.d[(0, 0)] * e;
        x = &sys.a * &x + &sys.b * e;
        let u = k.step(e);
        assert!(
            (u - u_ref).abs() < 1e-9 * (1.0 + u_ref.abs()),
            "step {step}: {u} vs {u_ref}"
        );
    }
    // A broken file is reported with its name.
    std::fs::write(&path, "[controller]\nkind = \"state_space\"\n").expect("write");
    let err = StateSpaceController::load(&path).expect_err("incomplete file");
    assert!(err.to_string().contains("controller.toml"), "{err}");
}

#[test]
fn prewarped_design_discretises_at_the_prewarp_frequency() {
    let opts = DesignOptions {
        prewarp_rad_s: Some(60.0),
        ..DesignOptions::default()
    };
    let d = design_robust_with(Path::new(PLANT), opts).expect("design");
    let s = &d.synthesis;
    let kc = s.controller.eval(Complex::new(0.0, 60.0)).expect("ok")[(0, 0)];
    let z = Complex::new(0.0, 60.0 * 0.001).exp();
    let kd = s.discrete.eval(z).expect("ok")[(0, 0)];
    assert!((kc - kd).norm() < 1e-9 * kc.norm());
}

#[test]
fn other_families_are_refused_with_the_file_name() {
    let err = design_robust(Path::new("config/plants/solenoid.toml")).expect_err("not motor_gear");
    let msg = err.to_string();
    assert!(
        msg.contains("solenoid.toml") && msg.contains("motor_gear"),
        "{msg}"
    );
}
