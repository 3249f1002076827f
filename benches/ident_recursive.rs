//! Per-step cost of the recursive identification pieces run in the control cycle
//! (compare with Isermann & Raab 1993, Table 3). Run with `cargo bench --bench ident_recursive`.

use std::hint::black_box;
use std::time::Instant;

use actuatord::ident::{
    ArxOrder, CovarianceGuard, DirectionalRegressor, DirectionalSelection, Dsfi, DsfiConfig,
    RecursiveEstimator, Rls, RlsConfig, StateVariableFilter,
};

const STEPS: usize = 2_000_000;

fn report(name: &str, start: Instant) {
    let ns = start.elapsed().as_secs_f64() * 1e9 / STEPS as f64;
    println!("{name:<40} {ns:>8.1} ns/step");
}

fn signal(k: usize) -> f64 {
    (k as f64 * 0.013).sin() + 0.3 * (k as f64 * 0.071).cos()
}

fn estimator<E: RecursiveEstimator>(name: &str, mut est: E, n: usize) {
    let mut psi = vec![0.0; n];
    let start = Instant::now();
    for k in 0..STEPS {
        for (j, p) in psi.iter_mut().enumerate() {
            *p = signal(k + 7 * j);
        }
        let y = psi.iter().sum::<f64>();
        let _ = black_box(est.step(black_box(&psi), black_box(y)));
    }
    report(name, start);
}

fn main() {
    for n in [2, 3, 5] {
        let rls = Rls::new(
            n,
            RlsConfig {
                forgetting: 0.975,
                initial_covariance: 1e3,
                guard: CovarianceGuard::None,
            },
        )
        .expect("valid config");
        estimator(&format!("rls n={n}"), rls, n);
        let dsfi = Dsfi::new(
            n,
            DsfiConfig {
                forgetting: 0.975,
                ..DsfiConfig::default()
            },
        )
        .expect("valid config");
        estimator(&format!("dsfi n={n} (information floor)"), dsfi, n);
        let dsfi = Dsfi::new(
            n,
            DsfiConfig {
                forgetting: 0.975,
                information_floor: None,
                ..DsfiConfig::default()
            },
        )
        .expect("valid config");
        estimator(&format!("dsfi n={n} (no floor)"), dsfi, n);
    }
    let mut svf = StateVariableFilter::new(4, 3, 50.0, 1e-3).expect("valid filter");
    let start = Instant::now();
    for k in 0..STEPS {
        black_box(svf.step(black_box(signal(k))));
    }
    report("state-variable filter K=4, 3 derivatives", start);
    let order = ArxOrder {
        na: 2,
        nb: 2,
        delay: 0,
    };
    let mut sel = DirectionalRegressor::new(DirectionalSelection::new(order)).expect("valid");
    let start = Instant::now();
    for k in 0..STEPS {
        black_box(sel.push(black_box(signal(k)), black_box(signal(k + 3))));
    }
    report("directional regressor na=nb=2", start);
}
