//! Shared by the lab tests: closed-loop records of the physics plants with sensor noise and
//! quantisation, a small deterministic generator for parameter variation, and the `actuator`
//! command run as a user runs it.
#![allow(dead_code)]

use std::path::Path;

use actuatord::lab::Dataset;
use actuatord::physics::{Family, Fault, PlantSpec};

/// Run `actuator ARGS` in `dir` as a user would; it must succeed. Returns its standard output.
pub fn actuator<S: AsRef<str>>(dir: &Path, args: &[S]) -> String {
    let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(&args)
        .current_dir(dir)
        .output()
        .expect("actuator runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "actuator {}: {}{}",
        args.join(" "),
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Run `actuator ARGS` in `dir`; it must fail. Returns its standard error.
pub fn actuator_fails(dir: &Path, args: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_actuator"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("actuator runs");
    assert!(
        !out.status.success(),
        "actuator {} succeeded",
        args.join(" ")
    );
    String::from_utf8_lossy(&out.stderr).to_string()
}

/// The RMS following error `actuator sim --record` reports on its standard error, in µm (µrad
/// for a gear).
pub fn reported_rms(stderr: &str) -> f64 {
    stderr
        .split("RMS following error ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no tracking figure in: {stderr}"))
}

/// The seeds of a sweep: `LAB_SEEDS=1,2,3` when set, `default` otherwise. A list with an entry
/// that is not a seed, or none, is refused: a sweep over nothing proves nothing.
pub fn sweep_seeds(default: std::ops::RangeInclusive<u64>) -> Vec<u64> {
    let Ok(text) = std::env::var("LAB_SEEDS") else {
        return default.collect();
    };
    let seeds: Vec<u64> = text
        .split(',')
        .map(|x| {
            x.trim()
                .parse()
                .unwrap_or_else(|_| panic!("LAB_SEEDS={text:?}: {x:?} is not a seed"))
        })
        .collect();
    assert!(!seeds.is_empty(), "LAB_SEEDS={text:?} names no seed");
    seeds
}

/// Every candidate of a diagnosis, one line each, when `LAB_VERBOSE` is set.
pub fn print_candidates(dg: &actuatord::lab::diagnose::Diagnosis) {
    if std::env::var("LAB_VERBOSE").is_err() {
        return;
    }
    if let Some(p) = &dg.base_prediction {
        eprintln!("    base: prediction skill {:.3}", p.skill);
    }
    for c in &dg.candidates {
        eprintln!(
            "    {:<20} NRMSE {:.4} drop {:+.3} held-out {:+.3} predicted {:+.3} skill {:.3} ΔBIC {:9.1} {} | {} | {:?}",
            c.effect,
            c.nrmse,
            c.improvement,
            c.holdout_improvement,
            c.prediction_improvement.unwrap_or(f64::NAN),
            c.prediction.map_or(f64::NAN, |p| p.skill),
            c.delta_bic,
            if c.significant { "*" } else { " " },
            c.evidence,
            c.parameters
        );
    }
    for r in &dg.rivals {
        eprintln!("    undecided against {}: z = {:?}", r.effect, r.z);
    }
}

/// A small deterministic generator for parameter variation.
pub struct Lcg(pub u64);
impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// Sensor noise and quantisation of a closed-loop record.
pub fn sensor(spec: &mut PlantSpec, seed: u64) {
    spec.seed = seed;
    let (q, noise) = match spec.family {
        Family::Pneumatic | Family::Solenoid => (1e-6, 5e-7),
        _ => (1e-5, 5e-6),
    };
    // An axis encoder of 2^19 counts per turn on the load of motor_gear.
    let unit = if spec.family == Family::MotorGear {
        "rad"
    } else {
        "m"
    };
    spec.set(&format!("sensor.position_quantum_{unit}"), q)
        .expect("quantum");
    spec.set(&format!("sensor.position_noise_{unit}"), noise)
        .expect("noise");
    if matches!(spec.family, Family::Solenoid | Family::MotorGear) {
        spec.set("sensor.current_quantum_a", 1e-3).expect("iq");
        spec.set("sensor.current_noise_a", 2e-3).expect("in");
    }
}

/// How the record is made.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum Run {
    /// Closed loop (PID on position) following a smooth random reference.
    Track,
    /// The same, with a reference that rests at its peaks: the actuator stops and starts.
    Dwell,
    /// A breakaway experiment: the drive swings slowly in open loop (with a small dither), so the
    /// actuator rests while the force builds up and breaks away at each reversal.
    Breakaway,
}

/// The supply during a record.
#[derive(Clone, Copy, PartialEq, Debug)]
pub enum Supply {
    /// The plant's nominal supply, not recorded.
    Nominal,
    /// A slow swing around the nominal supply, recorded.
    Varying,
    /// Held at this value (V, or Pa absolute for pneumatic), recorded.
    Held(f64),
}

/// Record the plant; the supply varies slowly when `vary_supply`.
pub fn closed_loop(
    spec: &PlantSpec,
    seed: u64,
    seconds: f64,
    vary_supply: bool,
    run: Run,
) -> Dataset {
    let supply = if vary_supply {
        Supply::Varying
    } else {
        Supply::Nominal
    };
    closed_loop_with_fault(spec, seed, seconds, supply, run, None)
}

/// [`closed_loop`] with a fault injected into the plant at a time (s).
pub fn closed_loop_with_fault(
    spec: &PlantSpec,
    seed: u64,
    seconds: f64,
    supply_kind: Supply,
    run: Run,
    fault: Option<(f64, Fault)>,
) -> Dataset {
    let dwell = run == Run::Dwell;
    let dt = 1e-3;
    let n = (seconds / dt) as usize;
    let mut plant = spec.build().expect("plant builds");
    let mut g = Lcg(seed ^ 0x9e37_79b9);
    let (centre, amp, kp, ki, kd, u_min, u_max, u0) = match spec.family {
        Family::LinearAxis => (0.0, 0.12, 900.0, 3000.0, 50.0, -100.0, 100.0, 0.0),
        Family::Solenoid => (0.012, 0.005, 3000.0, 30000.0, 60.0, 0.0, 24.0, 0.0),
        Family::Pneumatic => (0.010, 0.006, 150.0, 0.0, 1.0, -1.0, 1.0, 0.0),
        // Load angle in rad, armature voltage in V; swings of ±0.7 rad make 1/cos θ visible.
        Family::MotorGear => (0.0, 0.7, 60.0, 150.0, 1.5, -24.0, 24.0, 0.0),
    };
    let freqs: Vec<(f64, f64, f64)> = (0..3)
        .map(|i| {
            (
                g.range(0.2, 0.9) * (1.0 + i as f64 * 0.7),
                g.range(0.5, 1.0),
                g.range(0.0, std::f64::consts::TAU),
            )
        })
        .collect();
    let norm: f64 = freqs.iter().map(|f| f.1).sum();
    let mut d = Dataset {
        origin: format!("{}-seed{seed}", spec.family),
        time: Vec::with_capacity(n),
        input: Vec::with_capacity(n),
        output: Vec::with_capacity(n),
        supply: (supply_kind != Supply::Nominal).then(|| Vec::with_capacity(n)),
        current: matches!(spec.family, Family::Solenoid | Family::MotorGear)
            .then(|| Vec::with_capacity(n)),
    };
    let nominal = match spec.family {
        Family::Pneumatic => 60_000.0,
        _ => 24.0,
    };
    let (mut integ, mut e_prev) = (0.0, 0.0);
    let mut y = plant.measure().position;
    for k in 0..n {
        let t = k as f64 * dt;
        if let Some((at, f)) = fault {
            if k == (at / dt).round() as usize {
                plant.inject(f);
            }
        }
        let shape = freqs
            .iter()
            .map(|(f, a, p)| a * (2.0 * std::f64::consts::PI * f * t + p).sin())
            .sum::<f64>()
            / norm;
        let r = centre
            + amp
                * if dwell {
                    // Rests at the peaks, left and reached with a smooth start: x / (1 + x⁸)^⅛.
                    let x = 2.5 * shape;
                    x / (1.0 + x.powi(8)).powf(0.125)
                } else {
                    shape
                };
        let supply = if spec.family == Family::Pneumatic {
            // Low pressure between 40 and 80 kPa absolute.
            nominal + 20_000.0 * (2.0 * std::f64::consts::PI * 0.07 * t).sin()
        } else {
            nominal * (1.0 + 0.2 * (2.0 * std::f64::consts::PI * 0.07 * t).sin())
        };
        match supply_kind {
            Supply::Nominal => {}
            Supply::Varying => plant.set_supply(supply),
            Supply::Held(s) => plant.set_supply(s),
        }
        let e = r - y;
        let deriv = (e - e_prev) / dt;
        e_prev = e;
        let u_raw = u0 + kp * e + ki * integ + kd * deriv;
        let u = if run == Run::Breakaway {
            // Slow swings of the drive, their amplitude varied, well above the breakaway level.
            let (amp, f) = match spec.family {
                Family::MotorGear => (2.0, 0.7),
                _ => (3.0, 0.4),
            };
            // A small dither reverses the drive while moving too, as in friction experiments.
            let tau = 2.0 * std::f64::consts::PI;
            // A weak pull to the centre keeps asymmetric friction from walking the load into a
            // stop.
            let centring = match spec.family {
                Family::MotorGear => 4.0,
                _ => 10.0,
            };
            amp * (1.0 + 0.25 * (tau * 0.11 * t).sin()) * (tau * f * t).sin()
                + 0.1 * amp * (tau * 6.0 * t).sin()
                - centring * (y - centre)
        } else {
            u_raw.clamp(u_min, u_max)
        };
        if u == u_raw {
            integ += e * dt;
        }
        let m = plant.measure();
        d.time.push(t);
        d.input.push(u);
        d.output.push(m.position);
        if let Some(s) = d.supply.as_mut() {
            s.push(if spec.family == Family::Pneumatic {
                m.supply_pressure_pa
            } else {
                m.supply_voltage_v
            });
        }
        if let Some(c) = d.current.as_mut() {
            c.push(m.current_a);
        }
        plant.step(u, dt);
        y = plant.measure().position;
    }
    d
}
