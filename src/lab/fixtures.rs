//! Records for the lab's unit tests: a force-commanded linear axis of the physics plants under a
//! sum of sines, sampled at 1 kHz.

use super::data::Dataset;
use crate::physics::{CommandUnit, EffectKind, Family, Fault, PlantSpec};

/// A linear axis commanded in N with `effects`, its sensor noise `noise_m` drawn from `seed`.
pub fn force_axis(effects: &[EffectKind], seed: u64, noise_m: f64) -> PlantSpec {
    let mut spec = PlantSpec::new(Family::LinearAxis);
    spec.set_command(CommandUnit::Newton)
        .expect("force command");
    for &kind in effects {
        spec.add_effect(kind).expect("linear_axis effect");
    }
    spec.seed = seed;
    spec.set("sensor.position_noise_m", noise_m).expect("noise");
    spec
}

/// `n` samples at 1 kHz of `spec` under `Σ A sin(2π f t + φ)` for each `(A, f, φ)` of `sines`,
/// with `fault` injected at its time in s.
pub fn under_sines(
    spec: &PlantSpec,
    n: usize,
    sines: &[(f64, f64, f64)],
    fault: Option<(f64, Fault)>,
) -> Dataset {
    let dt = 1e-3;
    let mut plant = spec.build().expect("plant builds");
    let mut d = Dataset {
        origin: "axis".into(),
        time: Vec::with_capacity(n),
        input: Vec::with_capacity(n),
        output: Vec::with_capacity(n),
        supply: None,
        current: None,
    };
    for k in 0..n {
        let t = k as f64 * dt;
        if let Some((at, f)) = fault {
            if (t - at).abs() < 0.5 * dt {
                plant.inject(f);
            }
        }
        let u: f64 = sines
            .iter()
            .map(|(a, f, p)| a * (std::f64::consts::TAU * f * t + p).sin())
            .sum();
        d.time.push(t);
        d.input.push(u);
        d.output.push(plant.measure().position);
        plant.step(u, dt);
    }
    d
}
