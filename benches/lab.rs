//! Speed of the model lab on long data sets: `actuator compare` on one million samples, phase by
//! phase (read the CSV, prepare the signals, compare, break the error down), and `diagnose` with
//! the whole catalogue on 100 000 samples (with the current recorded, and without it: the coil's
//! time constant identified), and `discover` adding two effects. Run with `cargo bench --bench lab`.
//!
//! The data are synthesised here: a solenoid with spring, viscous damping and Coulomb friction
//! in closed loop (PID on position, 1 kHz, sensor quantisation and noise, current recorded, a
//! slowly varying supply), written as CSV to a temporary directory. The model compared lacks the
//! friction.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};

use actuatord::lab::data::{load, to_csv};
use actuatord::lab::discover::discover;
use actuatord::lab::regimes::breakdown;
use actuatord::lab::signals::prepare;
use actuatord::lab::{compare, diagnose, Columns, Dataset, DiagnoseOptions, Mode, Model};
use actuatord::physics::{EffectKind, Family, PlantSpec};

const PERIOD_S: f64 = 1e-3;

/// The plant behind the data: solenoid with spring, viscous damping and Coulomb friction.
fn truth() -> PlantSpec {
    let mut spec = PlantSpec::new(Family::Solenoid);
    for kind in [EffectKind::Spring, EffectKind::Viscous, EffectKind::Coulomb] {
        spec.add_effect(kind).expect("solenoid effect");
    }
    spec.seed = 7;
    let set = |s: &mut PlantSpec, k: &str, v: f64| s.set(k, v).expect(k);
    set(&mut spec, "coulomb.coulomb_pos_n", 1.0);
    set(&mut spec, "coulomb.coulomb_neg_n", 1.0);
    set(&mut spec, "sensor.position_quantum_m", 1e-6);
    set(&mut spec, "sensor.position_noise_m", 5e-7);
    set(&mut spec, "sensor.current_quantum_a", 1e-3);
    set(&mut spec, "sensor.current_noise_a", 2e-3);
    spec
}

/// `n` samples of the plant under PID control following a sum of three sines.
fn closed_loop(n: usize) -> Dataset {
    let mut plant = truth().build().expect("plant builds");
    let (centre, amp, kp, ki, kd) = (0.012, 0.005, 3000.0, 30000.0, 60.0);
    let tau = std::f64::consts::TAU;
    let mut d = Dataset {
        origin: "synthetic".into(),
        time: Vec::with_capacity(n),
        input: Vec::with_capacity(n),
        output: Vec::with_capacity(n),
        supply: Some(Vec::with_capacity(n)),
        current: Some(Vec::with_capacity(n)),
    };
    let (mut integ, mut e_prev) = (0.0, 0.0);
    let mut y = plant.measure().position;
    for k in 0..n {
        let t = k as f64 * PERIOD_S;
        let r = centre
            + amp
                * (0.6 * (tau * 0.37 * t).sin()
                    + 0.3 * (tau * 0.91 * t + 1.0).sin()
                    + 0.1 * (tau * 1.73 * t + 2.0).sin());
        plant.set_supply(24.0 * (1.0 + 0.1 * (tau * 0.07 * t).sin()));
        let e = r - y;
        let deriv = (e - e_prev) / PERIOD_S;
        e_prev = e;
        let u_raw = kp * e + ki * integ + kd * deriv;
        let u = u_raw.clamp(0.0, 24.0);
        if u == u_raw {
            integ += e * PERIOD_S;
        }
        let m = plant.measure();
        d.time.push(t);
        d.input.push(u);
        d.output.push(m.position);
        if let Some(s) = d.supply.as_mut() {
            s.push(m.supply_voltage_v);
        }
        if let Some(c) = d.current.as_mut() {
            c.push(m.current_a);
        }
        plant.step(u, PERIOD_S);
        y = plant.measure().position;
    }
    d
}

fn write_csv(dir: &Path, name: &str, n: usize) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, to_csv(&closed_loop(n))).expect("write the bench data");
    path
}

fn model() -> Model {
    Model::from_names("solenoid", &["spring,viscous".into()]).expect("model")
}

fn lab(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let big = write_csv(dir.path(), "compare_1e6.csv", 1_000_000);
    let small = write_csv(dir.path(), "diagnose_1e5.csv", 100_000);
    let cols = Columns::default();
    let m = model();

    let mut g = c.benchmark_group("compare_1e6");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("total", |b| {
        b.iter(|| {
            let d = load(&big, &cols).expect("loads");
            let prep = prepare(&d, None);
            let cmp = compare(&m, &d, &prep, Mode::InverseDynamics, 10).expect("compares");
            black_box(breakdown(&cmp, &d, &prep))
        })
    });
    let d = load(&big, &cols).expect("loads");
    g.bench_function("read_csv", |b| {
        b.iter(|| black_box(load(&big, &cols).expect("loads")))
    });
    g.bench_function("prepare", |b| b.iter(|| black_box(prepare(&d, None))));
    let prep = prepare(&d, None);
    g.bench_function("compare", |b| {
        b.iter(|| black_box(compare(&m, &d, &prep, Mode::InverseDynamics, 10).expect("compares")))
    });
    let cmp = compare(&m, &d, &prep, Mode::InverseDynamics, 10).expect("compares");
    g.bench_function("breakdown", |b| {
        b.iter(|| black_box(breakdown(&cmp, &d, &prep)))
    });
    g.finish();

    let mut g = c.benchmark_group("diagnose_1e5");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    let d = load(&small, &cols).expect("loads");
    let prep = prepare(&d, None);
    let opts = DiagnoseOptions::default();
    g.bench_function("whole_catalogue", |b| {
        b.iter(|| black_box(diagnose(&m, &d, &prep, &opts, &|_, _, _| {}).expect("diagnoses")))
    });
    // Without the current the coil's time constant is identified (once on the model, profiled
    // per candidate), and the effects before the coil join the catalogue.
    let mut bare = d.clone();
    bare.current = None;
    let prep_bare = prepare(&bare, None);
    g.bench_function("whole_catalogue_drive_identified", |b| {
        b.iter(|| {
            black_box(diagnose(&m, &bare, &prep_bare, &opts, &|_, _, _| {}).expect("diagnoses"))
        })
    });
    // Two effects missing (viscous damping, Coulomb friction): three diagnoses and the fits.
    let spring = Model::from_names("solenoid", &["spring".into()]).expect("model");
    g.bench_function("discover_two_steps", |b| {
        b.iter(|| black_box(discover(&spring, &d, &prep, &opts, &|_, _| {}).expect("discovers")))
    });
    g.finish();
}

criterion_group!(benches, lab);
criterion_main!(benches);
