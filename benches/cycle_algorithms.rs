//! Computation time per sample of each algorithm the daemon's cycle runs, and of one whole axis
//! cycle, like Isermann & Raab (1993), Table 3 (there on an 8-bit 12 MHz microcontroller: PIDT1
//! 0.48 ms, + feed-forward friction compensation 0.55 ms, + adaptive friction compensation
//! 2.11 ms, fault detection by state estimation 2.73 ms, parameter-adaptive control 7.68 ms).
//!
//! Group `table3` adds the pieces up the way the paper's rows do; group `algorithm` times each
//! piece alone. Every call gets the next sample of a slowly varying signal, so the estimators and
//! the supervision see moving data and take their ordinary paths.
//! Run with `cargo bench --bench cycle_algorithms` (add `-- --quick` for a short run).

use std::hint::black_box;
use std::path::Path;
use std::sync::LazyLock;

use actuatord::canopen::NmtState;
use actuatord::control::*;
use actuatord::daemon::axis::Axis;
use actuatord::daemon::Config;
use actuatord::device::SensorPdo;
use actuatord::ident::{
    ArxOrder, DirectionalRegressor, DirectionalSelection, Dsfi, DsfiConfig, RecursiveEstimator,
    Rls, RlsConfig, StateVariableFilter,
};
use actuatord::supervise::*;
use criterion::{criterion_group, criterion_main, Criterion};

/// The solenoid's sampling time, s (400 Hz).
const T0: f64 = 0.0025;

/// Samples of the input signals, computed once so the timings do not include `sin`.
const SAMPLES: usize = 8192;

struct Signals {
    position: Vec<f64>,
    setpoint: Vec<f64>,
}

static SIGNALS: LazyLock<Signals> = LazyLock::new(|| {
    let t = |k: usize| k as f64 * T0;
    Signals {
        // 5 mm ± 2 mm, two frequencies, as a tour of the stroke.
        position: (0..SAMPLES)
            .map(|k| 0.005 + 0.002 * (7.0 * t(k)).sin() + 0.001 * (23.0 * t(k)).sin())
            .collect(),
        // Steps between 4 and 6 mm every second.
        setpoint: (0..SAMPLES)
            .map(|k| if (k / 400) % 2 == 0 { 0.004 } else { 0.006 })
            .collect(),
    }
});

/// Position of sample `k`, m.
fn position(k: u64) -> f64 {
    SIGNALS.position[k as usize % SAMPLES]
}

/// Set-point of sample `k`, m.
fn setpoint(k: u64) -> f64 {
    SIGNALS.setpoint[k as usize % SAMPLES]
}

/// A command that goes with the position, V.
fn command(k: u64) -> f64 {
    6.0 + 1000.0 * (position(k) - 0.005)
}

fn pidt1() -> DiscreteController {
    DiscreteController::pidt1([2231.0, -4204.0, 2000.0], 0.616, 0.0, 24.0).expect("valid PIDT1")
}

fn friction_ff() -> FrictionFeedForward {
    FrictionFeedForward::from_forces(0.8, 0.2, 0.2, 1.63, 3e-6)
}

fn adaptive_friction() -> AdaptiveFriction {
    AdaptiveFriction::new(AdaptiveFrictionConfig {
        period_s: T0,
        params: actuatord::control::AdaptiveFrictionSection {
            model_time_constant_s: 0.03,
            adaptation_gain_per_m_s: 2000.0,
            compensation_max: 0.4,
            error_deadband_m: 3e-6,
            model_deadband_m: 10e-6,
            settled_band_m: 20e-6,
            step_max_m: 1e-3,
        },
        initial_pos: 0.098,
        initial_neg: 0.098,
    })
    .expect("valid adaptive friction")
}

fn correction() -> NonlinearCorrection {
    NonlinearCorrection::new(NonlinearCorrectionConfig {
        pole_m: 0.026,
        c0: 1.53,
        c1_per_m: -30.0,
        c2_per_m2: 0.0,
        reference_position_m: 0.0,
        min_gain_ratio: 0.2,
        output_min: 0.0,
        output_max: 24.0,
    })
    .expect("valid correction")
}

fn observer() -> DisturbanceObserver {
    DisturbanceObserver::new(actuatord::bench::paper::solenoid_observer_config())
        .expect("valid observer")
}

fn parameter_estimator() -> ParameterEstimator {
    ParameterEstimator::new(ParameterEstimatorConfig {
        period_s: T0,
        filter_omega_rad_s: 150.0,
        forgetting: 0.999,
        mass_kg: 0.4956,
        nominal_current_time_constant_s: 0.00859,
        moving_speed_m_per_s: 1e-3,
        min_moving_samples: 8,
        disturbed_moving_samples: 8,
    })
    .expect("valid estimator")
}

fn schedule_point(supply: f64, k: f64) -> SchedulePoint {
    SchedulePoint {
        supply,
        params: vec![k, 0.7 * k],
    }
}

/// `u = G_c(q) e + extra(e, w, y)`, with the controller's anti-windup as in the daemon.
fn pidt1_with(c: &mut DiscreteController, k: u64, extra: f64) -> f64 {
    let e = setpoint(k) - position(k);
    let (lo, hi) = c.limits();
    let u = (c.propose(e) + extra).clamp(lo, hi);
    c.commit(e, u - extra);
    u
}

/// The solenoid axis of `config/solenoid.toml` (adaptive friction, observer, parameter
/// estimation, limits) with its node operational, fed a position that follows the set-point like
/// the closed loop does, so the supervision stays quiet and every stage takes its ordinary path.
struct AxisRun {
    axis: Axis,
    k: u64,
    position: f64,
}

impl AxisRun {
    fn new() -> Self {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
        let text = std::fs::read_to_string(&path).expect("config/solenoid.toml readable");
        let config = Config::from_toml(&text, &path).expect("config/solenoid.toml valid");
        let axis = Axis::new(&config.axis[0], config.cycle.period_s).expect("axis builds");
        let mut run = Self {
            axis,
            k: 0,
            position: setpoint(0),
        };
        // Past the configured set-point schedule, the observer's warm-up and learning.
        for _ in 0..8000 {
            run.cycle();
        }
        let step = run.step();
        assert!(
            !step.model.machine.fail_safe && step.supervision.latched.is_empty(),
            "the bench's axis must run healthy: {step:?}"
        );
        run
    }

    fn step(&mut self) -> actuatord::daemon::axis::AxisStep {
        self.k += 1;
        let now = self.k as f64 * T0;
        let w = setpoint(self.k);
        // y(k) = y(k-1) + (T0 / T) (w - y(k-1)), T = 30 ms, plus a ripple of a few µm.
        self.position += T0 / 0.03 * (w - self.position);
        self.axis.set_setpoint(w);
        self.axis.on_heartbeat(NmtState::Operational, now);
        self.axis.begin_cycle();
        self.axis.on_sensor(SensorPdo {
            position: self.position + 0.001 * (position(self.k) - 0.005),
            current_a: 0.6,
            supply_voltage_v: 24.0,
        });
        self.axis.step(now)
    }

    fn cycle(&mut self) -> f64 {
        self.step().command
    }
}

fn table3(c: &mut Criterion) {
    let mut g = c.benchmark_group("table3");
    let mut k = 0u64;
    let mut pid = pidt1();
    g.bench_function("PIDT1", |b| {
        b.iter(|| {
            k += 1;
            black_box(pidt1_with(&mut pid, black_box(k), 0.0))
        })
    });
    let mut pid = pidt1();
    let ff = friction_ff();
    g.bench_function("PIDT1 + feed-forward friction compensation", |b| {
        b.iter(|| {
            k += 1;
            let comp = ff.compensation(black_box(setpoint(k) - position(k)));
            black_box(pidt1_with(&mut pid, k, comp))
        })
    });
    let mut pid = pidt1();
    let mut af = adaptive_friction();
    g.bench_function("PIDT1 + adaptive friction compensation", |b| {
        b.iter(|| {
            k += 1;
            let comp = af.step(black_box(setpoint(k)), position(k)).compensation;
            black_box(pidt1_with(&mut pid, k, comp))
        })
    });
    let mut pid = pidt1();
    let mut obs = observer();
    g.bench_function("PIDT1 + fault detection by state estimation", |b| {
        b.iter(|| {
            k += 1;
            let u = pidt1_with(&mut pid, black_box(k), 0.0);
            black_box(obs.step(position(k), u));
            u
        })
    });
    let mut pid = pidt1();
    let mut est = parameter_estimator();
    g.bench_function("PIDT1 + fault detection by parameter estimation", |b| {
        b.iter(|| {
            k += 1;
            let u = pidt1_with(&mut pid, black_box(k), 0.0);
            est.step(position(k), u);
            u
        })
    });
    let mut ad = PneumaticAdaptive::new(&PneumaticAdaptiveConfig::membrane_drive(
        0.02,
        vec![schedule_point(60_000.0, 0.03)],
        1e-7,
        true,
    ))
    .expect("valid pneumatic adaptive");
    let mut y_pn = 0.008;
    g.bench_function(
        "parameter-adaptive control (pneumatic, DSFI per direction)",
        |b| {
            b.iter(|| {
                k += 1;
                let w = if (k / 50) % 2 == 0 { 0.008 } else { 0.0085 };
                let out = ad.step(black_box(w), y_pn, 60_000.0);
                // The integrating drive, K_I = 30 mm/s, so the estimator sees a real response.
                y_pn += 0.03 * 0.02 * out.duty;
                out.duty
            })
        },
    );
    let mut pid = pidt1();
    let mut af = adaptive_friction();
    let mut nl = correction();
    let mut obs = observer();
    g.bench_function(
        "nonlinear control + fault detection by state estimation",
        |b| {
            b.iter(|| {
                k += 1;
                let (w, y) = (black_box(setpoint(k)), position(k));
                let e = w - y;
                let comp = af.step(w, y).compensation;
                let u_c = pid.propose(e);
                let u_corr = nl.step(u_c, y);
                let u = (u_corr + comp).clamp(0.0, 24.0);
                pid.commit(e, u - comp);
                black_box(obs.step(y, u));
                u
            })
        },
    );
    let mut axis = AxisRun::new();
    g.bench_function("whole axis cycle (config/solenoid.toml)", |b| {
        b.iter(|| black_box(axis.cycle()))
    });
    g.finish();
}

fn algorithm(c: &mut Criterion) {
    let mut g = c.benchmark_group("algorithm");
    let mut k = 0u64;

    let mut pid = pidt1();
    g.bench_function("general discrete controller (PIDT1)", |b| {
        b.iter(|| {
            k += 1;
            black_box(pid.step(black_box(setpoint(k) - position(k))))
        })
    });
    let mut sf = StateFeedback::new(&[2000.0, 40.0, 5.0, 1000.0], 2500.0, 0.0, 24.0)
        .expect("valid state feedback");
    g.bench_function("state feedback (4 states)", |b| {
        b.iter(|| {
            k += 1;
            let y = position(k);
            black_box(sf.step(black_box(&[y, 0.01, 0.6, 1e-4]), setpoint(k)))
        })
    });
    let ff = friction_ff();
    g.bench_function("friction feed-forward", |b| {
        b.iter(|| {
            k += 1;
            black_box(ff.compensation(black_box(setpoint(k) - position(k))))
        })
    });
    let mut dither = Dither::new(DitherConfig {
        period_s: T0,
        amplitude: 0.2,
        frequency_hz: 50.0,
        adapt: true,
        amplitude_min: 0.0,
        amplitude_max: 1.0,
        frequency_min_hz: 20.0,
        frequency_max_hz: 200.0,
        amplitude_rate_per_s: 1.0,
        frequency_rate_per_s: 1.0,
        error_tolerance_m: 20e-6,
        ripple_moving_m: 1e-6,
        ripple_max_m: 10e-6,
        ripple_time_constant_s: 0.02,
    })
    .expect("valid dither");
    g.bench_function("dither (self-adapting)", |b| {
        b.iter(|| {
            k += 1;
            black_box(dither.step(black_box(setpoint(k)), position(k)))
        })
    });
    let mut af = adaptive_friction();
    g.bench_function("adaptive friction compensation", |b| {
        b.iter(|| {
            k += 1;
            black_box(af.step(black_box(setpoint(k)), position(k)))
        })
    });
    let mut sched = GainSchedule::new(&[
        schedule_point(40_000.0, 0.05),
        schedule_point(60_000.0, 0.03),
        schedule_point(80_000.0, 0.012),
    ])
    .expect("valid schedule");
    g.bench_function("scheduling interpolation (3 points, 2 parameters)", |b| {
        b.iter(|| {
            k += 1;
            let supply = 40_000.0 + (k % 40_000) as f64;
            black_box(sched.step(black_box(supply))[0])
        })
    });
    let mut nl = correction();
    g.bench_function("nonlinear correction", |b| {
        b.iter(|| {
            k += 1;
            black_box(nl.step(black_box(command(k)), position(k)))
        })
    });
    let mut table = LearnedTable::new(LearnedTableConfig {
        position_edges_m: vec![0.0, 0.005, 0.01, 0.015, 0.02, 0.025],
        load_edges_n: vec![-10.0, 0.0, 10.0],
        supply_edges: vec![40_000.0, 60_000.0, 80_000.0],
        param_names: vec!["q01_per_m".into(), "q02_per_m".into()],
        averaging_count: 10,
        min_count: 1,
    })
    .expect("valid table");
    let op = |k: u64| OperatingPoint {
        position_m: position(k),
        load_n: 2000.0 * (position(k) - 0.005),
        supply: 50_000.0 + (k % 20_000) as f64,
    };
    g.bench_function("learned table learn", |b| {
        b.iter(|| {
            k += 1;
            black_box(table.learn(black_box(&op(k)), &[500.0, 600.0]))
        })
    });
    g.bench_function("learned table lookup", |b| {
        b.iter(|| {
            k += 1;
            black_box(table.lookup(black_box(&op(k))).map(|p| p[0]))
        })
    });
    // The parameter estimator's size: θ of Y''' + a2 Y'' + a1 Y' + a0 Y = b0 U + C_0 + C_F sign.
    let mut rls = Rls::new(
        6,
        RlsConfig {
            forgetting: 0.999,
            ..RlsConfig::default()
        },
    )
    .expect("valid RLS");
    let regressor = |k: u64| {
        let mut psi = [0.0; 6];
        for (j, p) in psi.iter_mut().enumerate() {
            *p = position(k + 7 * j as u64) * 100.0;
        }
        psi[5] = 1.0;
        psi
    };
    g.bench_function("RLS n=6", |b| {
        b.iter(|| {
            k += 1;
            let psi = regressor(k);
            black_box(rls.step(black_box(&psi), psi.iter().sum()).ok())
        })
    });
    let mut dsfi = Dsfi::new(
        6,
        DsfiConfig {
            forgetting: 0.999,
            ..DsfiConfig::default()
        },
    )
    .expect("valid DSFI");
    g.bench_function("DSFI n=6", |b| {
        b.iter(|| {
            k += 1;
            let psi = regressor(k);
            black_box(dsfi.step(black_box(&psi), psi.iter().sum()).ok())
        })
    });
    let mut dir = DirectionalRegressor::new(DirectionalSelection::new(ArxOrder {
        na: 3,
        nb: 3,
        delay: 0,
    }))
    .expect("valid selection");
    g.bench_function("directional regressor na=nb=3", |b| {
        b.iter(|| {
            k += 1;
            black_box(
                dir.push(black_box(position(k)), command(k))
                    .map(|(_, p)| p[0]),
            )
        })
    });
    let mut svf = StateVariableFilter::new(4, 3, 150.0, T0).expect("valid filter");
    g.bench_function("state-variable filter 4th order, 3 derivatives", |b| {
        b.iter(|| {
            k += 1;
            black_box(svf.step(black_box(position(k)))[3])
        })
    });
    let mut obs = observer();
    g.bench_function("disturbance observer", |b| {
        b.iter(|| {
            k += 1;
            black_box(obs.step(black_box(position(k)), command(k)))
        })
    });
    let mut est = parameter_estimator();
    g.bench_function("parameter estimator step", |b| {
        b.iter(|| {
            k += 1;
            est.step(black_box(position(k)), command(k));
        })
    });
    let mut machine = FaultMachine::new(&FaultMachineConfig::default()).expect("valid machine");
    g.bench_function("fault machine", |b| {
        b.iter(|| {
            k += 1;
            let mut present = SupervisedFaults::default();
            if k % 100 == 0 {
                present.insert(SupervisedFault::EstimatorImplausible);
            }
            black_box(machine.step(black_box(present)))
        })
    });
    let band = |low, high| {
        Some(Band {
            low,
            high,
            persistence_cycles: 3,
        })
    };
    let mut limits = LimitSupervisor::new(Limits {
        following_error: band(-2e-3, 2e-3),
        position: band(-0.0005, 0.0255),
        current_a: band(-3.0, 3.0),
        supply_voltage_v: band(18.0, 32.0),
        supply_pressure_pa: None,
        sensor_timeout_cycles: 8,
        heartbeat_timeout_s: Some(0.5),
    });
    g.bench_function("limit supervisor", |b| {
        b.iter(|| {
            k += 1;
            black_box(limits.step(black_box(&SupervisionInput {
                setpoint: setpoint(k),
                position: position(k),
                current_a: 0.6,
                supply_voltage_v: 24.0,
                sensor_fresh: true,
                node_operational: true,
                ..Default::default()
            })))
        })
    });
    g.finish();
}

criterion_group!(benches, table3, algorithm);
criterion_main!(benches);
