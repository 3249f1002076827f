//! A geared rotary axis behind a servo drive in torque mode, written for the lab's tests and
//! independent of `src/physics`: the motor and gear as one body referred to the gear output, a
//! compliant contact to the load (a spring-damper, with a play when the record has backlash), a
//! load with viscous and dry friction (Karnopp stick band), semi-implicit Euler on sub-steps of
//! 20 µs or less, and a PID loop on the measured load angle that commands the motor torque. The
//! constants (ratio, inertias, contact, friction, sample rate, sensor zero) are drawn per seed.
//! [`Gear::draw_voltage`] puts a DC motor's armature before the drive (`L i' = u - R i - K_E ω_m`,
//! torque `K_T i`, stepped exactly), commanded by its voltage.

use super::Draw;
use actuatord::lab::Dataset;

/// The effect hidden from the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GearHidden {
    Viscous,
    Coulomb,
    Backlash,
}

impl GearHidden {
    pub fn lab_name(self) -> &'static str {
        match self {
            GearHidden::Viscous => "viscous",
            GearHidden::Coulomb => "coulomb",
            GearHidden::Backlash => "backlash",
        }
    }
}

/// The true constants of one record.
#[derive(Debug, Clone)]
pub struct Gear {
    pub hidden: Option<GearHidden>,
    /// Sample period, s.
    pub dt: f64,
    /// Gear ratio (motor turns per load turn).
    pub ratio: f64,
    /// Rotor and gear-input inertia at the motor, kg·m².
    pub motor_inertia: f64,
    /// Gear-output inertia, kg·m².
    pub gear_inertia: f64,
    /// Contact between gear output and load: stiffness N·m/rad, damping N·m·s/rad.
    pub stiffness: f64,
    pub damping: f64,
    /// Full play of the contact, rad (0: none).
    pub play: f64,
    /// Load inertia, kg·m².
    pub load_inertia: f64,
    /// Viscous per direction (N·m·s/rad), Coulomb per direction (N·m).
    pub viscous: (f64, f64),
    pub coulomb: (f64, f64),
    /// Torque limit of the drive, N·m at the motor.
    pub torque_limit: f64,
    /// Angle the encoder reads at the load's physical zero, rad.
    pub sensor_zero: f64,
    pub quantum: f64,
    pub noise: f64,
    /// The armature, when the record's command is its voltage.
    pub armature: Option<Armature>,
}

/// A DC motor's armature: resistance Ω, inductance H, back-EMF V·s/rad, torque constant N·m/A,
/// supply V.
#[derive(Debug, Clone, Copy)]
pub struct Armature {
    pub resistance: f64,
    pub inductance: f64,
    pub back_emf: f64,
    pub torque_constant: f64,
    pub supply: f64,
}

impl Gear {
    /// Draw a record's constants. Viscous damping and Coulomb friction are always present; the
    /// play only when it is the hidden effect.
    pub fn draw(hidden: Option<GearHidden>, seed: u64) -> Gear {
        let mut g = Draw::new(seed ^ 0x6a09_e667_f3bc_c908);
        let dt = [5e-4, 1e-3, 2e-3][(g.next() * 3.0) as usize % 3];
        let ratio = g.log_range(12.0, 50.0);
        let motor_inertia = g.log_range(4e-6, 2e-5);
        let gear_inertia = g.log_range(4e-3, 2e-2);
        let load_inertia = g.log_range(5e-3, 4e-2);
        let drive_inertia = gear_inertia + ratio * ratio * motor_inertia;
        let reduced = drive_inertia * load_inertia / (drive_inertia + load_inertia);
        // Contact mode at 40-90 Hz, damped 10-30 %.
        let stiffness = reduced * (std::f64::consts::TAU * g.range(40.0, 90.0)).powi(2);
        let damping = 2.0 * g.range(0.1, 0.3) * (stiffness * reduced).sqrt();
        // A torque scale of the load: its inertia at the loop's accelerations (~10 rad/s²).
        let scale = 10.0 * (load_inertia + drive_inertia);
        let viscous0 = scale * g.range(0.3, 0.6) / 2.0;
        let coulomb0 = scale * g.range(0.15, 0.3);
        let viscous = (viscous0, viscous0 * g.range(0.8, 1.2));
        let coulomb = (coulomb0, coulomb0 * g.range(0.7, 1.3));
        let play = match hidden {
            Some(GearHidden::Backlash) => g.range(4e-3, 1e-2),
            _ => 0.0,
        };
        Gear {
            hidden,
            dt,
            ratio,
            motor_inertia,
            gear_inertia,
            stiffness,
            damping,
            play,
            load_inertia,
            viscous,
            coulomb,
            torque_limit: 6.0 * scale / ratio,
            sensor_zero: if g.coin() { g.range(-0.5, 0.5) } else { 0.0 },
            quantum: 2e-5,
            noise: 1e-5,
            armature: None,
        }
    }

    /// [`Gear::draw`] behind an armature commanded by its voltage: `L_a / R_a` of 0.5-5 ms, a
    /// torque constant of 0.02-0.1 N·m/A, a back-EMF within 10 % of it, and a resistance that
    /// gives the drive's torque limit at 60-80 % of a 24 V supply.
    pub fn draw_voltage(hidden: Option<GearHidden>, seed: u64) -> Gear {
        let mut gear = Gear::draw(hidden, seed);
        let mut g = Draw::new(seed ^ 0xbb67_ae85_84ca_a73b);
        let supply = 24.0;
        let torque_constant = g.log_range(0.02, 0.1);
        let resistance = g.range(0.6, 0.8) * supply * torque_constant / gear.torque_limit;
        gear.armature = Some(Armature {
            resistance,
            inductance: g.log_range(5e-4, 5e-3) * resistance,
            back_emf: torque_constant * g.range(0.9, 1.1),
            torque_constant,
            supply,
        });
        gear
    }

    /// Effects of the lab's complete model of this plant.
    pub fn complete_effects(&self) -> Vec<&'static str> {
        let mut v = vec!["viscous", "coulomb"];
        if self.play > 0.0 {
            v.push("backlash");
        }
        v
    }

    /// A model file as a user writes it from the data sheet: the drive constants declared and
    /// fixed, the load's constants free, the effects `with`; the load's constants at their true
    /// values when `right`, at rough guesses otherwise. No `command` key: the family's default (a
    /// voltage) unless `--command` says otherwise.
    pub fn model_file(&self, with: &[&str], right: bool) -> String {
        let pick = |truth: f64, guess: f64| if right { truth } else { guess };
        let mut s = format!(
            "family = \"motor_gear\"\n\n[motor_gear]\nratio = {}\nmotor_inertia_kg_m2 = {:e}\n\
             gear_inertia_kg_m2 = {:e}\ncontact_stiffness_nm_per_rad = {}\n\
             contact_damping_nm_s_per_rad = {}\nload_inertia_kg_m2 = {}\n\
             angle_min_rad = -3.0\nangle_max_rad = 3.0\n{}",
            self.ratio,
            self.motor_inertia,
            self.gear_inertia,
            self.stiffness,
            self.damping,
            pick(self.load_inertia, 0.01),
            // The data sheet's armature, but for its inductance (the family's default, free).
            self.armature.map_or(String::new(), |a| format!(
                "resistance_ohm = {}\nback_emf_v_s_per_rad = {}\ntorque_constant_nm_per_a = {}\n\
                 supply_voltage_v = {}\n",
                a.resistance, a.back_emf, a.torque_constant, a.supply
            ))
        );
        if self.armature.is_some() {
            s = s.replacen(
                "family = \"motor_gear\"\n",
                "family = \"motor_gear\"\ncommand = \"voltage\"\n",
                1,
            );
        }
        for e in with {
            s.push_str(&match *e {
                "viscous" => format!(
                    "\n[viscous]\ndamping_pos_nm_s_per_rad = {}\ndamping_neg_nm_s_per_rad = {}\n",
                    pick(self.viscous.0, 0.05),
                    pick(self.viscous.1, 0.05)
                ),
                "coulomb" => format!(
                    "\n[coulomb]\ncoulomb_pos_nm = {}\ncoulomb_neg_nm = {}\n",
                    pick(self.coulomb.0, 0.1),
                    pick(self.coulomb.1, 0.1)
                ),
                "backlash" => format!("\n[backlash]\ngap_rad = {}\n", pick(self.play, 0.005)),
                other => panic!("no model text for {other}"),
            });
        }
        s.push_str(
            "\n[lab]\nfixed = [\"motor_gear.ratio\", \"motor_gear.motor_inertia_kg_m2\", \
             \"motor_gear.gear_inertia_kg_m2\", \"motor_gear.contact_stiffness_nm_per_rad\", \
             \"motor_gear.contact_damping_nm_s_per_rad\"",
        );
        if self.armature.is_some() {
            s.push_str(
                ", \"motor_gear.resistance_ohm\", \"motor_gear.back_emf_v_s_per_rad\", \
                 \"motor_gear.torque_constant_nm_per_a\", \"motor_gear.supply_voltage_v\"",
            );
        }
        s.push_str("]\n");
        s
    }

    /// Simulate the closed loop; the record as the lab reads it, `u` the motor torque (N·m).
    pub fn simulate(&self, seed: u64, length_s: f64) -> Dataset {
        self.simulate_with_contact(seed, length_s).0
    }

    /// [`Gear::simulate`] and the torque the contact transmits to the load at each sample.
    pub fn simulate_with_contact(&self, seed: u64, length_s: f64) -> (Dataset, Vec<f64>) {
        let mut g = Draw::new(seed.wrapping_add(0x9e37));
        let samples = (length_s / self.dt) as usize;
        let sub = (self.dt / 2e-5).round().max(1.0) as usize;
        let h = self.dt / sub as f64;
        let waves: Vec<(f64, f64, f64)> = (0..3)
            .map(|i| {
                (
                    g.range(0.2, 0.6) * (1.0 + 0.8 * i as f64),
                    g.range(0.4, 1.0),
                    g.range(0.0, std::f64::consts::TAU),
                )
            })
            .collect();
        let norm: f64 = waves.iter().map(|w| w.1).sum();
        let amp = 0.5;
        let drive_inertia = self.gear_inertia + self.ratio * self.ratio * self.motor_inertia;
        // PID in motor torque: proportional and integral on the load angle, the damping on the
        // motor encoder's speed (referred to the gear output), as a servo drive's speed loop
        // gives it: the drive stays damped while it crosses a play, where the load angle says
        // nothing. Bandwidth 4 Hz on the whole inertia.
        let w = std::f64::consts::TAU * 4.0;
        let m = (drive_inertia + self.load_inertia) / self.ratio;
        let (kp, ki, kd) = (m * w * w, m * w * w * w / 5.0, 1.6 * m * w);
        let mut d = Dataset {
            origin: format!("gear-{:?}-seed{seed}", self.hidden),
            time: Vec::with_capacity(samples),
            input: Vec::with_capacity(samples),
            output: Vec::with_capacity(samples),
            supply: None,
            current: None,
        };
        let (mut th_d, mut w_d, mut th_l, mut w_l) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let mut integ = 0.0;
        let mut current = 0.0;
        let measure = |x: f64, g: &mut Draw| {
            let y = x + self.sensor_zero + self.noise * g.gauss();
            (y / self.quantum).round() * self.quantum
        };
        let mut y = measure(th_l, &mut g);
        let mut transmitted = Vec::with_capacity(samples);
        let band = 1e-4;
        for k in 0..samples {
            let time = k as f64 * self.dt;
            let shape = waves
                .iter()
                .map(|(f, a, p)| a * (std::f64::consts::TAU * f * time + p).sin())
                .sum::<f64>()
                / norm;
            let e = amp * shape + self.sensor_zero - y;
            let rate = amp
                * waves
                    .iter()
                    .map(|(f, a, p)| {
                        a * std::f64::consts::TAU * f * (std::f64::consts::TAU * f * time + p).cos()
                    })
                    .sum::<f64>()
                / norm;
            let raw = kp * e + ki * integ + kd * (rate - w_d);
            let torque = raw.clamp(-self.torque_limit, self.torque_limit);
            // A voltage-mode amplifier: the torque's voltage and the back-EMF the motor
            // encoder's speed predicts, within the supply.
            let u = match self.armature {
                Some(a) => (torque * a.resistance / a.torque_constant
                    + a.back_emf * self.ratio * w_d)
                    .clamp(-a.supply, a.supply),
                None => torque,
            };
            if torque == raw {
                integ += e * self.dt;
            }
            d.time.push(time);
            d.input.push(u);
            d.output.push(y);
            transmitted.push(self.contact(th_d - th_l, w_d - w_l));
            for _ in 0..sub {
                let contact = self.contact(th_d - th_l, w_d - w_l);
                let motor_torque = match self.armature {
                    Some(a) => {
                        // The armature's first-order lag toward its steady current, exact
                        // over the sub-step at the speed it starts with.
                        let steady = (u - a.back_emf * self.ratio * w_d) / a.resistance;
                        let decay = (-h * a.resistance / a.inductance).exp();
                        current = steady + (current - steady) * decay;
                        a.torque_constant * current
                    }
                    None => u,
                };
                // Drive side: the motor torque through the ratio against the contact.
                w_d += h * (self.ratio * motor_torque - contact) / drive_inertia;
                th_d += h * w_d;
                // Load side: the contact against viscous and dry friction.
                let visc = if w_l > 0.0 {
                    self.viscous.0
                } else {
                    self.viscous.1
                } * w_l;
                let outer = contact - visc;
                let a = if w_l.abs() < band {
                    let dir = outer.signum();
                    let hold = if dir > 0.0 {
                        self.coulomb.0
                    } else {
                        self.coulomb.1
                    };
                    if outer.abs() <= hold {
                        w_l = 0.0;
                        0.0
                    } else {
                        (outer - dir * hold) / self.load_inertia
                    }
                } else {
                    let c = if w_l > 0.0 {
                        self.coulomb.0
                    } else {
                        self.coulomb.1
                    };
                    (outer - w_l.signum() * c) / self.load_inertia
                };
                let w_new = w_l + h * a;
                w_l = if w_l != 0.0 && w_new.signum() != w_l.signum() && w_l.abs() < 50.0 * band {
                    0.0
                } else {
                    w_new
                };
                th_l += h * w_l;
            }
            y = measure(th_l, &mut g);
        }
        (d, transmitted)
    }

    /// Torque through the contact at a twist (gear output ahead of the load) and its rate: a
    /// spring-damper outside the play, nothing inside it, and it can only push.
    fn contact(&self, twist: f64, rate: f64) -> f64 {
        let half = 0.5 * self.play;
        if twist > half {
            (self.stiffness * (twist - half) + self.damping * rate).max(0.0)
        } else if twist < -half {
            (self.stiffness * (twist + half) + self.damping * rate).min(0.0)
        } else {
            0.0
        }
    }
}
