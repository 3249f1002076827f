//! The adaptive friction compensation against a stick-slip plant written for this test,
//! independent of `src/physics`: its own Karnopp integrator (a stick band around zero speed in
//! which the body holds any net force up to the breakaway force), the coil's lag by its exact
//! exponential step, a return spring with pretension, and constants drawn per seed around a
//! solenoid of Isermann & Raab's size. The loop is the one `config/solenoid.toml` ships, read
//! through the daemon's configuration loader: the paper's PIDT1 at 2.5 ms with the project's
//! `AdaptiveFriction` and `ArrivalRelief` on top, fed the way the axis feeds it (the
//! controller's memory takes its own share of the command, not the compensation).
//!
//! The script is the demo's friction phase: small steps 10.0 <-> 10.2 mm once a second at
//! nominal friction (Coulomb 0.45-0.65 N, about the reference plant's 0.55 N), then the friction
//! raised threefold. What is checked: the arrival relief (`ArrivalRelief`, on the controller's
//! stored output) lowers the steady error after the rise on every seed where breakaway is up to
//! 1.2 times Coulomb, 2.7 times on the mean over the seeds after every friction effect tripled
//! and 2.5 times after the dry friction alone, and there it brings the steps' steady error back
//! to nominal on the mean over the seeds (the demo's `friction_x3`); where breakaway is up to 1.6
//! times Coulomb it is 1.6 times better on the mean after every friction effect tripled and as
//! good within two quanta after the dry friction alone.

use actuatord::control::{
    AdaptiveFriction, AdaptiveFrictionConfig, ArrivalRelief, ArrivalReliefConfig,
    DiscreteController,
};
use actuatord::daemon::Config;

/// xorshift64*, its own generator (not the physics').
#[derive(Debug, Clone)]
struct Draw(u64);

impl Draw {
    fn new(seed: u64) -> Self {
        Draw(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// A solenoid armature with dry friction: `m y'' = K_M I - c y - F_0 - d y' - F_f`,
/// `T_I I' + I = K_I U`, `F_f` by Karnopp's model.
#[derive(Debug, Clone)]
struct StickSlip {
    mass_kg: f64,
    spring_n_per_m: f64,
    pretension_n: f64,
    damping_n_s_per_m: f64,
    coil_time_constant_s: f64,
    coil_gain_a_per_v: f64,
    force_constant_n_per_a: f64,
    coulomb_n: f64,
    breakaway_n: f64,
    /// Below this speed the body counts as standing.
    stick_speed_m_per_s: f64,
    y: f64,
    v: f64,
    i: f64,
    noise: Draw,
}

impl StickSlip {
    /// Constants drawn per seed; breakaway over Coulomb friction in `stiction_ratio`.
    fn drawn(seed: u64, stiction_ratio: (f64, f64)) -> Self {
        let mut d = Draw::new(seed);
        let coulomb_n = d.range(0.45, 0.65);
        Self {
            mass_kg: d.range(0.4, 0.6),
            spring_n_per_m: d.range(1500.0, 1800.0),
            pretension_n: d.range(2.0, 4.0),
            damping_n_s_per_m: d.range(15.0, 28.0),
            coil_time_constant_s: d.range(0.006, 0.012),
            coil_gain_a_per_v: 0.1,
            force_constant_n_per_a: d.range(15.0, 17.5),
            coulomb_n,
            breakaway_n: coulomb_n * d.range(stiction_ratio.0, stiction_ratio.1),
            stick_speed_m_per_s: 1e-5,
            y: 0.0,
            v: 0.0,
            i: 0.0,
            noise: Draw::new(seed ^ 0x5eed),
        }
    }

    /// Coil voltage that holds the armature at `y` without friction.
    fn holding_voltage(&self, y: f64) -> f64 {
        (self.spring_n_per_m * y + self.pretension_n)
            / (self.coil_gain_a_per_v * self.force_constant_n_per_a)
    }

    /// Start at rest at `y` with the holding current.
    fn rest_at(&mut self, y: f64) {
        self.y = y;
        self.v = 0.0;
        self.i = self.coil_gain_a_per_v * self.holding_voltage(y);
    }

    /// Advance `dt` with coil voltage `u`, semi-implicit Euler on 50 µs sub-steps.
    fn advance(&mut self, u: f64, dt: f64) {
        let n = (dt / 50e-6).ceil().max(1.0) as usize;
        let h = dt / n as f64;
        let i_end = self.coil_gain_a_per_v * u;
        let decay = (-h / self.coil_time_constant_s).exp();
        for _ in 0..n {
            self.i = i_end + (self.i - i_end) * decay;
            let drive = self.force_constant_n_per_a * self.i
                - self.spring_n_per_m * self.y
                - self.pretension_n
                - self.damping_n_s_per_m * self.v;
            if self.v.abs() < self.stick_speed_m_per_s {
                if drive.abs() <= self.breakaway_n {
                    self.v = 0.0;
                    continue;
                }
                let a = (drive - self.coulomb_n * drive.signum()) / self.mass_kg;
                self.v += a * h;
            } else {
                let before = self.v;
                let a = (drive - self.coulomb_n * before.signum()) / self.mass_kg;
                self.v += a * h;
                // Friction can stop the body, never reverse it.
                if self.v.signum() != before.signum() {
                    self.v = 0.0;
                }
            }
            self.y += self.v * h;
        }
    }

    /// The position sensor: 1 µm quantum, 0.3 µm noise.
    fn measure(&mut self) -> f64 {
        let noise = 0.6e-6 * (self.noise.next() + self.noise.next() + self.noise.next() - 1.5);
        ((self.y + noise) / 1e-6).round() * 1e-6
    }
}

const PERIOD_S: f64 = 0.0025;
const QUANTUM_M: f64 = 1e-6;

/// The loop of `config/solenoid.toml` as the daemon reads it: its PIDT1, its adaptive friction
/// compensation starting from the feed-forward `α F_C / K`, and its arrival relief.
struct Shipped {
    controller: DiscreteController,
    adaptive_friction: AdaptiveFrictionConfig,
    relief: ArrivalReliefConfig,
}

fn shipped_solenoid() -> Shipped {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
    let config = Config::load(&path).expect("shipped solenoid configuration");
    let axis = &config.axis[0];
    // The plant is stepped at this test's period; the configuration must run at the same one.
    assert_eq!(config.cycle.period_s, PERIOD_S, "{}", path.display());
    let c = &axis.controller;
    Shipped {
        controller: DiscreteController::new(&c.p, &c.q_per_m, c.output_min, c.output_max)
            .expect("valid controller"),
        adaptive_friction: axis
            .adaptive_friction_config(PERIOD_S)
            .expect("[axis.adaptive_friction]"),
        relief: axis
            .friction_compensation
            .as_ref()
            .and_then(|f| f.arrival_relief(PERIOD_S))
            .expect("arrival relief in [axis.friction_compensation]"),
    }
}

/// What rises threefold at the rise.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Rise {
    /// Every friction effect, viscous included, as the demo's `friction_x3`.
    AllFriction,
    /// Coulomb and breakaway friction only.
    DryFriction,
}

/// Steady errors (|mean of w - y| over each step's last 200 ms), m.
#[derive(Debug, Clone, Copy)]
struct Figures {
    /// Mean of the nominal steps (after two that start the loop).
    nominal_m: f64,
    /// The first step after the rise.
    first_after_rise_m: f64,
    /// Mean of the last two steps.
    adapted_m: f64,
}

/// The demo's friction phase on the plant of `seed`, with or without the arrival relief.
fn run(seed: u64, stiction_ratio: (f64, f64), rise: Rise, with_relief: bool) -> Figures {
    let mut plant = StickSlip::drawn(seed, stiction_ratio);
    // The shipped configuration's values, not the drawn plant's.
    let shipped = shipped_solenoid();
    let mut law =
        AdaptiveFriction::new(shipped.adaptive_friction).expect("valid adaptive friction");
    let mut relief = ArrivalRelief::new(shipped.relief).expect("valid arrival relief");
    let mut pid = shipped.controller;
    let start = 0.010;
    plant.rest_at(start);
    pid.preset(plant.holding_voltage(start));

    let nominal_steps = 6;
    let risen_steps = 8;
    let cycles_per_step = (1.0 / PERIOD_S).round() as usize;
    let tail = (0.2 / PERIOD_S).round() as usize;
    let mut errors = Vec::new();
    for s in 0..nominal_steps + risen_steps {
        if s == nominal_steps {
            plant.coulomb_n *= 3.0;
            plant.breakaway_n *= 3.0;
            if rise == Rise::AllFriction {
                plant.damping_n_s_per_m *= 3.0;
            }
        }
        let w = if s % 2 == 0 { 0.0102 } else { 0.0100 };
        let mut sum = 0.0;
        for k in 0..cycles_per_step {
            let y = plant.measure();
            let e = w - y;
            // As the axis: compensation added to the command, the relief to the controller's
            // stored output, the controller fed back its own share.
            let comp = law.step(w, y).compensation;
            if with_relief {
                pid.shift_output(relief.step(w, y).relief);
            }
            let u = (pid.propose(e) + comp).clamp(0.0, 24.0);
            pid.commit(e, u - comp);
            plant.advance(u, PERIOD_S);
            if k >= cycles_per_step - tail {
                sum += e;
            }
        }
        errors.push((sum / tail as f64).abs());
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    Figures {
        nominal_m: mean(&errors[2..nominal_steps]),
        first_after_rise_m: errors[nominal_steps],
        adapted_m: mean(&errors[errors.len() - 2..]),
    }
}

const SEEDS: std::ops::RangeInclusive<u64> = 1..=8;

/// Per seed: (without, with) the relief.
fn compare(stiction_ratio: (f64, f64), rise: Rise) -> Vec<(Figures, Figures)> {
    SEEDS
        .map(|seed| {
            let without = run(seed, stiction_ratio, rise, false);
            let with = run(seed, stiction_ratio, rise, true);
            println!(
                "seed {seed}: without: nominal {:.1} µm, first after x3 {:.1} µm, adapted {:.1} µm; with: nominal {:.1} µm, first after x3 {:.1} µm, adapted {:.1} µm",
                without.nominal_m * 1e6,
                without.first_after_rise_m * 1e6,
                without.adapted_m * 1e6,
                with.nominal_m * 1e6,
                with.first_after_rise_m * 1e6,
                with.adapted_m * 1e6,
            );
            (without, with)
        })
        .collect()
}

/// Mean over the seeds of one figure.
fn mean_of(runs: &[(Figures, Figures)], f: fn(&(Figures, Figures)) -> f64) -> f64 {
    runs.iter().map(f).sum::<f64>() / runs.len() as f64
}

/// After the rise, better with the relief than without on every seed, and at least twice as good
/// on the mean over the seeds (measured 2.7x after every friction effect tripled, 5.7 against
/// 2.1 µm; 2.5x after the dry friction alone, 14.1 against 5.5 µm; per seed at least 1.5x): a
/// relief that does nothing is as good, not better. The nominal steps (the relief learning from
/// nothing) within a quantum on the mean over the seeds: with high stiction a step that stalls or
/// slips decides the next one's start, and single seeds go either way.
fn assert_better(runs: &[(Figures, Figures)]) {
    for (seed, (without, with)) in SEEDS.zip(runs) {
        assert!(
            with.adapted_m < without.adapted_m,
            "seed {seed}: {with:?} vs {without:?}"
        );
    }
    let (with, without) = (
        mean_of(runs, |r| r.1.adapted_m),
        mean_of(runs, |r| r.0.adapted_m),
    );
    println!(
        "adapted {:.2} µm with the relief, {:.2} without ({:.2}x)",
        with * 1e6,
        without * 1e6,
        without / with
    );
    assert!(2.0 * with <= without, "{with} vs {without}");
    assert!(mean_of(runs, |r| r.1.nominal_m) <= mean_of(runs, |r| r.0.nominal_m) + QUANTUM_M);
}

#[test]
fn every_friction_effect_x3_the_relief_brings_the_steady_error_back_to_nominal() {
    let runs = compare((1.05, 1.2), Rise::AllFriction);
    assert_better(&runs);
    // Without the relief the loop ends well above its nominal error (2.0x on the mean of seeds
    // 1-8 with the reference friction).
    let without_adapted = mean_of(&runs, |r| r.0.adapted_m);
    let without_nominal = mean_of(&runs, |r| r.0.nominal_m);
    assert!(
        without_adapted > 1.5 * without_nominal,
        "{without_adapted} vs {without_nominal}"
    );
    // With it, back to nominal on the mean over the seeds (2.1 against 2.5 µm), and no seed far
    // off: at a nominal error of one or two sensor quanta a single stick-slip end decides the
    // ratio (seed 2: 2.9 µm against 1.3).
    let with_adapted = mean_of(&runs, |r| r.1.adapted_m);
    let with_nominal = mean_of(&runs, |r| r.1.nominal_m);
    assert!(
        with_adapted <= with_nominal + QUANTUM_M,
        "{with_adapted} vs {with_nominal}"
    );
    for (seed, (_, with)) in SEEDS.zip(&runs) {
        assert!(
            with.adapted_m <= 3.0 * with.nominal_m + QUANTUM_M,
            "seed {seed}: {with:?}"
        );
    }
}

#[test]
fn dry_friction_x3_the_relief_is_better() {
    assert_better(&compare((1.05, 1.2), Rise::DryFriction));
}

/// Breakaway up to 1.6 times the Coulomb force (the reference plant's 1.51): the step's end is
/// decided by where a slip stops, and single seeds go either way. On the mean over the seeds
/// the relief is 1.57 times better after every friction effect tripled (20.7 against 32.4 µm),
/// asserted as at least 1.4 times, which a relief that does nothing is not; with the dry
/// friction alone tripled it claims no gain, only as good within two sensor quanta (42.4 against
/// 40.5 µm); on the nominal steps, where it learns from nothing, it costs a little (13.6 against
/// 11.4 µm), which this test prints and does not judge.
#[test]
fn high_stiction_x3_the_relief_is_better_on_the_mean() {
    for rise in [Rise::AllFriction, Rise::DryFriction] {
        let runs = compare((1.2, 1.6), rise);
        let (with, without) = (
            mean_of(&runs, |r| r.1.adapted_m),
            mean_of(&runs, |r| r.0.adapted_m),
        );
        println!(
            "{rise:?}: adapted {:.1} µm with the relief, {:.1} without; nominal {:.1} / {:.1} µm",
            with * 1e6,
            without * 1e6,
            mean_of(&runs, |r| r.1.nominal_m) * 1e6,
            mean_of(&runs, |r| r.0.nominal_m) * 1e6
        );
        match rise {
            Rise::AllFriction => assert!(1.4 * with <= without, "{rise:?}: {with} vs {without}"),
            Rise::DryFriction => {
                assert!(
                    with < without + 2.0 * QUANTUM_M,
                    "{rise:?}: {with} vs {without}"
                )
            }
        }
    }
}
