//! H∞ synthesis against problems with known answers.

use actuatord::control::robust::{
    hinf_controller, hinf_feasible, hinfsyn, GeneralizedPlant, HinfOptions, Ss,
};
use nalgebra::DMatrix;

/// `ẋ = a x + w1 + u`, `z = [x; u]`, `y = x + w2`.
fn scalar_plant(a: f64) -> GeneralizedPlant {
    let sys = Ss::new(
        DMatrix::from_element(1, 1, a),
        DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 1.0]),
        DMatrix::from_row_slice(3, 1, &[1.0, 0.0, 1.0]),
        DMatrix::from_row_slice(3, 3, &[0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]),
    )
    .expect("valid");
    GeneralizedPlant::new(sys, 1, 1).expect("partition")
}

/// For the scalar plant the Riccati equations are quadratics with the stabilising roots
/// `X = Y = 1 / (√(a² + 1 - γ⁻²) - a)` (real and positive for `γ > 1/√(1 + a²)`, and `γ > 1` if
/// `a > 0`); `X` falls with γ and `γ_opt` is where `XY = γ²`, i.e. `X(γ) = γ`. Found here by
/// scalar bisection, independently of the matrix code.
fn scalar_gamma_opt(a: f64) -> f64 {
    let x = |g: f64| 1.0 / ((a * a + 1.0 - 1.0 / (g * g)).sqrt() - a);
    let start = if a > 0.0 {
        1.0
    } else {
        1.0 / (1.0 + a * a).sqrt()
    };
    let (mut lo, mut hi) = (start * (1.0 + 1e-12), 100.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if x(mid) < mid {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[test]
fn integrator_problem_has_gamma_opt_sqrt2() {
    // a = 0: X = 1/√(1 - γ⁻²), and XY < γ² ⇔ γ > √2 exactly.
    let p = scalar_plant(0.0);
    let sol = hinfsyn(
        &p,
        &HinfOptions {
            gamma_rel_tol: 1e-7,
            margin: 1.01,
            ..HinfOptions::default()
        },
    )
    .expect("feasible");
    let exact = 2f64.sqrt();
    assert!(
        (sol.gamma_opt / exact - 1.0).abs() < 1e-6,
        "γ_opt {} vs √2",
        sol.gamma_opt
    );
    let cl = p.close(&sol.controller).expect("closed loop");
    assert!(cl.is_stable());
    let norm = cl.hinf_norm(1e-9);
    assert!(
        norm <= sol.gamma * (1.0 + 1e-6),
        "‖T‖ {norm} > γ {}",
        sol.gamma
    );
    // No controller beats γ_opt.
    assert!(norm >= exact * (1.0 - 1e-6), "‖T‖ {norm} below γ_opt");
    assert!(sol.candidate.x.residual < 1e-10 && sol.candidate.y.residual < 1e-10);
}

#[test]
fn unstable_scalar_problem_matches_the_scalar_riccati_answer() {
    for a in [1.0f64, -1.0, 3.0] {
        // X(γ) = γ ⇔ √(a² + 1 - γ⁻²) = a + 1/γ ⇔ γ² - 2aγ - 2 = 0: γ_opt = a + √(a² + 2)
        // (√3 + 1, √3 - 1, 3 + √11), checked against the scalar bisection.
        let exact = a + (a * a + 2.0).sqrt();
        assert!((scalar_gamma_opt(a) / exact - 1.0).abs() < 1e-12, "a={a}");
        let p = scalar_plant(a);
        let sol = hinfsyn(
            &p,
            &HinfOptions {
                gamma_rel_tol: 1e-7,
                margin: 1.02,
                ..HinfOptions::default()
            },
        )
        .expect("feasible");
        assert!(
            (sol.gamma_opt / exact - 1.0).abs() < 1e-5,
            "a={a}: γ_opt {} vs {exact}",
            sol.gamma_opt
        );
        let cl = p.close(&sol.controller).expect("closed loop");
        let norm = cl.hinf_norm(1e-9);
        assert!(cl.is_stable(), "a={a}");
        assert!(
            norm <= sol.gamma * (1.0 + 1e-6),
            "a={a}: {norm} > {}",
            sol.gamma
        );
        assert!(
            norm >= exact * (1.0 - 1e-6),
            "a={a}: {norm} < γ_opt {exact}"
        );
    }
}

/// Mixed sensitivity `min ‖[W1 S; W2 K S]‖∞` for `G = 200 / ((10s + 1)(0.05s + 1)²)`
/// (Skogestad & Postlethwaite's disturbance example), `W1 = ω_b / (s + ω_b ε)`, `W2 = k_u`.
fn mixed_sensitivity_plant(wb: f64, eps: f64, ku: f64) -> GeneralizedPlant {
    // G in controllable form: states of (10s+1)(0.05s+1)² = 0.025 s³ + 1.0025 s² + 10.1 s + 1.
    let den = [0.025, 1.0025, 10.1, 1.0];
    let (a2, a1, a0) = (den[1] / den[0], den[2] / den[0], den[3] / den[0]);
    let k = 200.0 / den[0];
    // States [g1, g2, g3, x_w]; inputs [r, u]; outputs [z1, z2, y = r - G u].
    let a = DMatrix::from_row_slice(
        4,
        4,
        &[
            0.0,
            1.0,
            0.0,
            0.0, //
            0.0,
            0.0,
            1.0,
            0.0, //
            -a0,
            -a1,
            -a2,
            0.0, //
            -k,
            0.0,
            0.0,
            -eps * wb,
        ],
    );
    let b = DMatrix::from_row_slice(4, 2, &[0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0]);
    let c = DMatrix::from_row_slice(
        3,
        4,
        &[0.0, 0.0, 0.0, wb, 0.0, 0.0, 0.0, 0.0, -k, 0.0, 0.0, 0.0],
    );
    let d = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 0.0, ku, 1.0, 0.0]);
    GeneralizedPlant::new(Ss::new(a, b, c, d).expect("valid"), 1, 1).expect("partition")
}

#[test]
fn mixed_sensitivity_gamma_is_verified_by_the_closed_loop_norm() {
    let p = mixed_sensitivity_plant(10.0, 1e-4, 1.0);
    let opts = HinfOptions {
        gamma_rel_tol: 1e-6,
        margin: 1.01,
        ..HinfOptions::default()
    };
    let sol = hinfsyn(&p, &opts).expect("feasible");
    // Just below γ_opt the conditions fail, just above they hold.
    assert!(hinf_feasible(&p, sol.gamma_opt * (1.0 - 1e-4)).is_err());
    assert!(hinf_feasible(&p, sol.gamma_opt * (1.0 + 1e-4)).is_ok());
    let cl = p.close(&sol.controller).expect("closed loop");
    assert!(cl.is_stable());
    let hamiltonian = cl.hinf_norm(1e-9);
    let (sweep, _) = cl.peak_gain_sweep(1e-3, 1e4, 2000);
    assert!(
        (hamiltonian / sweep - 1.0).abs() < 1e-5,
        "{hamiltonian} vs {sweep}"
    );
    assert!(
        sweep <= sol.gamma * (1.0 + 1e-6),
        "{sweep} > γ {}",
        sol.gamma
    );
    assert!(
        sweep >= sol.gamma_opt * (1.0 - 1e-4),
        "{sweep} < γ_opt {}",
        sol.gamma_opt
    );
    // Central controller at a larger γ is still within its bound.
    let (k, c) = hinf_controller(&p, 2.0 * sol.gamma_opt).expect("feasible");
    assert!(c.rho_xy < c.gamma * c.gamma);
    let n2 = p.close(&k).expect("closed loop").hinf_norm(1e-9);
    assert!(n2 <= 2.0 * sol.gamma_opt * (1.0 + 1e-6));
    eprintln!(
        "mixed sensitivity: γ_opt = {:.6}, ‖T‖∞ at 1.01 γ_opt = {:.6} (sweep {:.6})",
        sol.gamma_opt, hamiltonian, sweep
    );
}
