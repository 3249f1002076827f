//! Per-step cost of the recursive identification pieces run in the control cycle
//! (compare with Isermann & Raab 1993, Table 3). Run with `cargo bench --bench ident_recursive`
//! (add `-- --quick` for a short run).

use std::hint::black_box;
use std::sync::LazyLock;

use actuatord::ident::{
    ArxOrder, CovarianceGuard, DirectionalRegressor, DirectionalSelection, Dsfi, DsfiConfig,
    RecursiveEstimator, Rls, RlsConfig, StateVariableFilter,
};
use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion};

/// Samples of the input signal, computed once so the timings do not include `sin`.
const SAMPLES: usize = 8192;

static SIGNAL: LazyLock<Vec<f64>> = LazyLock::new(|| {
    (0..SAMPLES)
        .map(|k| (k as f64 * 0.013).sin() + 0.3 * (k as f64 * 0.071).cos())
        .collect()
});

fn signal(k: usize) -> f64 {
    SIGNAL[k % SAMPLES]
}

/// One estimator step per call on a regressor of `n` entries whose output is their sum.
fn estimator<E: RecursiveEstimator>(
    g: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    mut est: E,
    n: usize,
) {
    let mut psi = vec![0.0; n];
    let mut k = 0usize;
    g.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            for (j, p) in psi.iter_mut().enumerate() {
                *p = signal(k + 7 * j);
            }
            let y = psi.iter().sum::<f64>();
            black_box(est.step(black_box(&psi), black_box(y)).ok())
        })
    });
}

fn recursive_estimators(c: &mut Criterion) {
    let mut g = c.benchmark_group("ident_recursive");
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
        estimator(&mut g, &format!("rls n={n}"), rls, n);
        let dsfi = Dsfi::new(
            n,
            DsfiConfig {
                forgetting: 0.975,
                ..DsfiConfig::default()
            },
        )
        .expect("valid config");
        estimator(&mut g, &format!("dsfi n={n} (information floor)"), dsfi, n);
        let dsfi = Dsfi::new(
            n,
            DsfiConfig {
                forgetting: 0.975,
                information_floor: None,
                ..DsfiConfig::default()
            },
        )
        .expect("valid config");
        estimator(&mut g, &format!("dsfi n={n} (no floor)"), dsfi, n);
    }
    let mut svf = StateVariableFilter::new(4, 3, 50.0, 1e-3).expect("valid filter");
    let mut k = 0usize;
    g.bench_function("state-variable filter K=4, 3 derivatives", |b| {
        b.iter(|| {
            k += 1;
            black_box(svf.step(black_box(signal(k)))[3])
        })
    });
    let order = ArxOrder {
        na: 2,
        nb: 2,
        delay: 0,
    };
    let mut sel = DirectionalRegressor::new(DirectionalSelection::new(order)).expect("valid");
    g.bench_function("directional regressor na=nb=2", |b| {
        b.iter(|| {
            k += 1;
            black_box(
                sel.push(black_box(signal(k)), black_box(signal(k + 3)))
                    .map(|(_, p)| p[0]),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, recursive_estimators);
criterion_main!(benches);
