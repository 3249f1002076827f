//! `motor_gear`: DC motor, compliant shaft, gear and load (Bao et al. eq. 1-3):
//! `L_a I' = U - R_a I - K_e ω_m`, `J_m ω_m' = K_T I - τ_p`, `τ_p = K_p δ + C_p δ'`,
//! `δ' = ω_m - h ω_g`, `J_g ω_g' = h τ_p - τ_c`, `τ_c = K_g Δ + C_g Δ'` with `Δ = θ_g - θ_l`,
//! `J_l ω_l' = τ_c - τ_f - T_l`. With a torque input, `τ_m = u` replaces the armature.
//!
//! On top: `backlash` turns `τ_c` into the unilateral dead-zone contact of Bao et al. (contact ±
//! and gap regimes, switched at located events), `varying_ratio` makes `h = h_0 / cos θ_l`,
//! friction effects (`viscous`, `coulomb`, `stiction`, `stribeck`) act on the load with true
//! stick, `payload`, `spring` and `offset` load it, `hysteresis` acts on the motor torque.

use crate::physics::effects::{DelayLine, DryFriction, Effects};
use crate::physics::family::Family;
use crate::physics::fault::{Fault, FaultModifiers, FaultSet};
use crate::physics::integrator::{locate, rk4};
use crate::physics::params::{ParamDef, Quantity};
use crate::physics::sensor::Sensor;
use crate::physics::term::{LoadTerm, Signals};
use crate::physics::{Measurement, Plant};

const fn p(
    base: &'static str,
    unit: &'static str,
    min_strict: bool,
    default: f64,
    doc: &'static str,
) -> ParamDef {
    ParamDef {
        base,
        quantity: Quantity::Named(unit),
        min: 0.0,
        min_strict,
        max: f64::INFINITY,
        default,
        doc,
    }
}

/// Base parameters of the `[motor_gear]` table (reasons for the defaults in
/// `config/plants/motor_gear.toml`).
pub const PARAMS: &[ParamDef] = &[
    p(
        "resistance_ohm",
        "Ω",
        true,
        1.55,
        "R_a, armature resistance",
    ),
    p(
        "inductance_h",
        "H",
        true,
        0.0005,
        "L_a, armature inductance",
    ),
    p("back_emf_v_s_per_rad", "V·s/rad", false, 0.03, "K_e"),
    p("torque_constant_nm_per_a", "N·m/A", true, 0.03, "K_T"),
    p("motor_inertia_kg_m2", "kg·m²", true, 1e-6, "J_m"),
    p(
        "torsion_stiffness_nm_per_rad",
        "N·m/rad",
        true,
        50.0,
        "K_p, motor shaft",
    ),
    p(
        "torsion_damping_nm_s_per_rad",
        "N·m·s/rad",
        false,
        0.005,
        "C_p",
    ),
    p(
        "ratio",
        "1",
        true,
        20.0,
        "h_0, motor angle per gear output angle",
    ),
    p(
        "gear_inertia_kg_m2",
        "kg·m²",
        true,
        0.0003,
        "J_g, gear, screw and nut at the output",
    ),
    p(
        "contact_stiffness_nm_per_rad",
        "N·m/rad",
        true,
        500.0,
        "K_g, gear to load",
    ),
    p(
        "contact_damping_nm_s_per_rad",
        "N·m·s/rad",
        false,
        0.5,
        "C_g",
    ),
    p(
        "load_inertia_kg_m2",
        "kg·m²",
        true,
        0.0005,
        "J_l, fork lever",
    ),
    p("supply_voltage_v", "V", true, 24.0, "H-bridge supply"),
    ParamDef::any(
        "angle_min_rad",
        Quantity::Named("rad"),
        -1.2,
        "lower end stop of the load",
    ),
    ParamDef::any(
        "angle_max_rad",
        Quantity::Named("rad"),
        1.2,
        "upper end stop of the load",
    ),
];

// State indices.
const I: usize = 0;
const TM: usize = 1;
const WM: usize = 2;
const DELTA: usize = 3;
const TG: usize = 4;
const WG: usize = 5;
const TL: usize = 6;
const WL: usize = 7;

/// Motion state of the load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Free,
    SlipPos,
    SlipNeg,
    Held,
}

/// Contact state of the backlash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Contact {
    /// No backlash effect: the coupling is a plain spring-damper.
    Rigid,
    /// Gear ahead of the load by the half gap, pushing positive.
    Pos,
    /// In the gap: no torque.
    Gap,
    /// Pushing negative.
    Neg,
}

#[derive(Debug, Clone, Copy)]
struct Consts {
    r: f64,
    l: f64,
    ke: f64,
    kt: f64,
    jm: f64,
    kp: f64,
    cp: f64,
    h0: f64,
    jg: f64,
    kg: f64,
    cg: f64,
    jl: f64,
    supply_v: f64,
    th_min: f64,
    th_max: f64,
    torque_input: bool,
}

/// The motor and gear plant.
#[derive(Debug, Clone)]
pub struct MotorGearPlant {
    c: Consts,
    nominal: Effects,
    fx: Effects,
    dry: DryFriction,
    half_gap: f64,
    x: [f64; 8],
    mode: Mode,
    contact: Contact,
    last_dir: f64,
    z: f64,
    t: f64,
    command: f64,
    max_h: f64,
    delay: DelayLine,
    sensor: Sensor,
    faults: FaultSet,
    mods: FaultModifiers,
    supply_ext: f64,
    /// Torques on the load the model declares itself.
    terms: Vec<LoadTerm>,
}

const MAX_EVENTS: usize = 16;
const JAM_TORQUE_NM: f64 = 1e6;

impl MotorGearPlant {
    /// A plant at rest, load at angle 0 (or the nearest stop), backlash centred.
    pub fn new(
        b: &[f64],
        torque_input: bool,
        effects: Effects,
        sensor: Sensor,
        faults: FaultSet,
        max_substep: f64,
        (th_min, th_max): (f64, f64),
    ) -> Self {
        let c = Consts {
            r: b[0],
            l: b[1],
            ke: b[2],
            kt: b[3],
            jm: b[4],
            kp: b[5],
            cp: b[6],
            h0: b[7],
            jg: b[8],
            kg: b[9],
            cg: b[10],
            jl: b[11],
            supply_v: b[12],
            th_min,
            th_max,
            torque_input,
        };
        let th0 = 0.0f64.clamp(th_min, th_max);
        let mut x = [0.0; 8];
        x[TL] = th0;
        x[TG] = th0;
        let mut plant = MotorGearPlant {
            c,
            nominal: effects,
            fx: effects,
            dry: DryFriction::default(),
            half_gap: 0.0,
            x,
            mode: Mode::Held,
            contact: if effects.backlash.is_some() {
                Contact::Gap
            } else {
                Contact::Rigid
            },
            last_dir: 1.0,
            z: 0.0,
            t: 0.0,
            command: 0.0,
            max_h: max_substep,
            delay: DelayLine::with_capacity(256),
            sensor,
            faults,
            mods: FaultModifiers::default(),
            supply_ext: 1.0,
            terms: Vec::new(),
        };
        plant.apply_faults();
        plant.settle(0.0);
        plant
    }

    /// The plant with the torques its model declares (`[[lab.term]]`) on the load.
    pub fn with_terms(mut self, terms: Vec<LoadTerm>) -> Self {
        self.terms = terms;
        self
    }

    fn apply_faults(&mut self) {
        let m = self.faults.modifiers(self.t);
        self.mods = m;
        let mut fx = self.nominal;
        if let Some(s) = fx.spring.as_mut() {
            s.stiffness *= m.stiffness;
            s.pretension *= m.pretension;
        }
        if let Some(v) = fx.viscous.as_mut() {
            v.damping_pos *= m.friction;
            v.damping_neg *= m.friction;
        }
        self.fx = fx;
        self.dry = DryFriction::from_effects(&fx, m.friction, m.jam * JAM_TORQUE_NM);
        let half_gap = fx.backlash.map_or(0.0, |b| b.half() * m.backlash);
        if half_gap != self.half_gap || self.t == 0.0 {
            self.half_gap = half_gap;
            if self.contact != Contact::Rigid {
                self.contact = self.contact_of(&self.x);
            }
        }
    }

    fn contact_of(&self, x: &[f64; 8]) -> Contact {
        let d = x[TG] - x[TL];
        if d >= self.half_gap {
            Contact::Pos
        } else if d <= -self.half_gap {
            Contact::Neg
        } else {
            Contact::Gap
        }
    }

    #[inline]
    fn supply_ratio(&self) -> f64 {
        self.supply_ext * self.mods.supply
    }

    #[inline]
    fn direction(&self) -> f64 {
        if self.x[WM] > 0.0 {
            1.0
        } else if self.x[WM] < 0.0 {
            -1.0
        } else {
            self.last_dir
        }
    }

    /// Power stage output: armature voltage (V) or motor torque (N·m).
    fn signal(&mut self, t: f64) -> f64 {
        let mut u = self.command;
        if let Some(d) = self.fx.dead_time {
            u = self.delay.at(t - d.delay);
        }
        if let Some(s) = self.fx.saturation {
            u = s.apply(u);
        }
        if let Some(d) = self.fx.deadzone {
            u = d.apply(u);
        }
        let ratio = self.supply_ratio();
        let mut p = if self.c.torque_input {
            u
        } else {
            match self.fx.supply_gain {
                Some(s) => u.clamp(-self.c.supply_v, self.c.supply_v) * s.factor(ratio),
                None => {
                    let lim = self.c.supply_v * ratio;
                    u.clamp(-lim, lim)
                }
            }
        };
        p *= self.mods.drive_gain;
        if let Some(a) = self.fx.direction_asymmetry {
            p *= a.gain(self.direction());
        }
        p
    }

    #[inline(always)]
    fn motor_torque(&self, x: &[f64; 8], p: f64) -> f64 {
        if self.c.torque_input {
            p
        } else {
            self.c.kt * x[I]
        }
    }

    #[inline(always)]
    fn ratio(&self, x: &[f64; 8]) -> f64 {
        match self.fx.varying_ratio {
            Some(v) => self.c.h0 * v.factor(x[TL]),
            None => self.c.h0,
        }
    }

    /// Torque from the gear to the load.
    #[inline(always)]
    fn coupling(&self, x: &[f64; 8], contact: Contact) -> f64 {
        let d = x[TG] - x[TL];
        let dd = x[WG] - x[WL];
        match contact {
            Contact::Rigid => self.c.kg * d + self.c.cg * dd,
            Contact::Gap => 0.0,
            Contact::Pos => (self.c.kg * (d - self.half_gap) + self.c.cg * dd).max(0.0),
            Contact::Neg => (self.c.kg * (d + self.half_gap) + self.c.cg * dd).min(0.0),
        }
    }

    /// Torque on the load from everything except its friction and its stops.
    #[inline(always)]
    fn load_torque(&self, x: &[f64; 8], contact: Contact) -> f64 {
        let th = x[TL];
        let mut f = self.coupling(x, contact);
        // Spring, payload, offset and any other torque on the load.
        self.fx.add_load_forces(th, x[WL], &mut f);
        if !self.terms.is_empty() {
            let s = Signals {
                y: th,
                v: x[WL],
                u: self.command,
                supply: self.c.supply_v * self.supply_ratio(),
                t: self.t,
            };
            f += self.terms.iter().map(|t| t.force(&s)).sum::<f64>();
        }
        f
    }

    #[inline(always)]
    fn deriv(&self, x: &[f64; 8], p: f64, z: f64, mode: Mode, contact: Contact) -> [f64; 8] {
        let c = &self.c;
        let di = if c.torque_input {
            0.0
        } else {
            (p - c.r * x[I] - c.ke * x[WM]) / c.l
        };
        let mut tm = self.motor_torque(x, p);
        if let Some(hy) = self.fx.hysteresis {
            tm = hy.play(z, tm);
        }
        let h = self.ratio(x);
        let ddelta = x[WM] - h * x[WG];
        let tp = c.kp * x[DELTA] + c.cp * ddelta;
        let tc = self.coupling(x, contact);
        let (dtl, dwl) = match mode {
            Mode::Held => (0.0, 0.0),
            _ => {
                let wl = x[WL];
                let mut f = self.load_torque(x, contact);
                if let Some(v) = self.fx.viscous {
                    f += v.force(wl);
                }
                match mode {
                    Mode::SlipPos => f -= self.dry.sliding(1.0, wl),
                    Mode::SlipNeg => f += self.dry.sliding(-1.0, wl),
                    _ => {}
                }
                (wl, f / c.jl)
            }
        };
        [
            di,
            x[WM],
            (tm - tp) / c.jm,
            ddelta,
            x[WG],
            (h * tp - tc) / c.jg,
            dtl,
            dwl,
        ]
    }

    fn moving(&self, dir: f64) -> Mode {
        if !self.dry.present {
            Mode::Free
        } else if dir > 0.0 {
            Mode::SlipPos
        } else {
            Mode::SlipNeg
        }
    }

    fn settle(&mut self, _p: f64) {
        self.x[WL] = 0.0;
        let f = self.load_torque(&self.x, self.contact);
        let at_low = self.x[TL] <= self.c.th_min;
        let at_high = self.x[TL] >= self.c.th_max;
        self.mode = if f > self.dry.break_pos && !at_high {
            self.moving(1.0)
        } else if f < -self.dry.break_neg && !at_low {
            self.moving(-1.0)
        } else {
            Mode::Held
        };
    }

    /// Event functions, positive while nothing happens:
    /// [lower stop, upper stop, reversal, breakaway, backlash a, backlash b].
    #[inline]
    fn events(&self, x: &[f64; 8], mode: Mode, contact: Contact) -> [f64; 6] {
        let inf = f64::INFINITY;
        let mut e = [inf; 6];
        match mode {
            Mode::Held => {
                let f = self.load_torque(x, contact);
                let up = if x[TL] >= self.c.th_max {
                    inf
                } else {
                    self.dry.break_pos - f
                };
                let down = if x[TL] <= self.c.th_min {
                    inf
                } else {
                    f + self.dry.break_neg
                };
                e[3] = up.min(down);
            }
            _ => {
                e[0] = x[TL] - self.c.th_min;
                e[1] = self.c.th_max - x[TL];
                e[2] = match mode {
                    Mode::SlipPos => x[WL],
                    Mode::SlipNeg => -x[WL],
                    _ => inf,
                };
            }
        }
        let d = x[TG] - x[TL];
        match contact {
            Contact::Rigid => {}
            Contact::Gap => {
                e[4] = self.half_gap - d;
                e[5] = d + self.half_gap;
            }
            Contact::Pos => e[4] = d - self.half_gap,
            Contact::Neg => e[5] = -self.half_gap - d,
        }
        e
    }

    fn commit_hysteresis(&mut self, p: f64) {
        if let Some(h) = self.fx.hysteresis {
            self.z = h.play(self.z, self.motor_torque(&self.x, p));
        }
    }

    fn substep(&mut self, h: f64, t0: f64) {
        let mut done = 0.0;
        for _ in 0..MAX_EVENTS {
            let rem = h - done;
            if rem <= h * 1e-12 {
                return;
            }
            let p = self.signal(t0 + done);
            let (mode, contact, z, x0) = (self.mode, self.contact, self.z, self.x);
            let f = |x: &[f64; 8]| self.deriv(x, p, z, mode, contact);
            let x1 = rk4(&x0, rem, f);
            let e1 = self.events(&x1, mode, contact);
            if e1.iter().all(|&g| g > 0.0) {
                self.x = x1;
                self.commit_hysteresis(p);
                if self.x[WM] != 0.0 {
                    self.last_dir = self.x[WM].signum();
                }
                return;
            }
            let mut e0 = self.events(&x0, mode, contact);
            for g in e0.iter_mut() {
                if *g == 0.0 {
                    *g = f64::MIN_POSITIVE;
                }
            }
            let mut first = (rem, usize::MAX);
            for i in 0..6 {
                if e1[i] <= 0.0 {
                    let tau = locate(
                        |t| self.events(&rk4(&x0, t, f), mode, contact)[i],
                        rem,
                        e0[i],
                        e1[i],
                    );
                    if first.1 == usize::MAX || tau < first.0 {
                        first = (tau, i);
                    }
                }
            }
            let (tau, which) = first;
            self.x = if tau > 0.0 { rk4(&x0, tau, f) } else { x0 };
            self.commit_hysteresis(p);
            done += tau;
            match which {
                0 | 1 => {
                    self.x[TL] = if which == 0 {
                        self.c.th_min
                    } else {
                        self.c.th_max
                    };
                    self.settle(p);
                }
                2 => self.settle(p),
                3 => {
                    let f = self.load_torque(&self.x, self.contact);
                    let dir = if f > 0.0 { 1.0 } else { -1.0 };
                    self.mode = self.moving(dir);
                    self.x[WL] = 0.0;
                }
                _ => {
                    self.contact = match (self.contact, which) {
                        (Contact::Gap, 4) => Contact::Pos,
                        (Contact::Gap, _) => Contact::Neg,
                        _ => Contact::Gap,
                    };
                    // A held load may be pushed loose (or a sliding one is unaffected).
                    if self.mode == Mode::Held {
                        self.settle(p);
                    }
                }
            }
        }
    }

    fn truth_now(&self) -> Measurement {
        Measurement {
            position: self.x[TL],
            velocity: self.x[WL],
            current_a: if self.c.torque_input { 0.0 } else { self.x[I] },
            supply_voltage_v: if self.c.torque_input {
                0.0
            } else {
                self.c.supply_v * self.supply_ratio()
            },
            supply_pressure_pa: 0.0,
        }
    }

    /// Motor angle (rad), for tests and recording.
    pub fn motor_angle(&self) -> f64 {
        self.x[TM]
    }

    /// Gear output angle (rad), the drive side of the backlash.
    pub fn gear_angle(&self) -> f64 {
        self.x[TG]
    }
}

impl Plant for MotorGearPlant {
    fn step(&mut self, command: f64, dt_s: f64) {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return;
        }
        let command = if command.is_finite() { command } else { 0.0 };
        if self.faults.update(self.t) {
            self.apply_faults();
        }
        if self.fx.dead_time.is_some() {
            self.delay.push(self.t, command);
        }
        self.command = command;
        let n = (dt_s / self.max_h).ceil().max(1.0);
        let h = dt_s / n;
        let t_start = self.t;
        for k in 0..n as usize {
            self.substep(h, t_start + k as f64 * h);
        }
        self.t = t_start + dt_s;
    }

    fn measure(&mut self) -> Measurement {
        let truth = self.truth_now();
        self.sensor.read(truth, &self.mods)
    }

    fn truth(&self) -> Measurement {
        self.truth_now()
    }

    fn inject(&mut self, fault: Fault) {
        self.faults.inject(fault, self.t);
        self.apply_faults();
    }

    fn family(&self) -> Family {
        Family::MotorGear
    }

    fn time_s(&self) -> f64 {
        self.t
    }

    fn set_supply(&mut self, value: f64) {
        if value.is_finite() {
            self.supply_ext = (value / self.c.supply_v).max(0.0);
        }
    }

    fn drive_position(&self) -> f64 {
        self.x[TG]
    }

    /// `½ J_m ω_m² + ½ J_g ω_g² + ½ J_l ω_l² + ½ K_p δ² + ½ K_g (|Δ| - b)²` (contact spring only
    /// when in contact).
    fn energy_j(&self) -> Option<f64> {
        let (c, x) = (&self.c, &self.x);
        let d = x[TG] - x[TL];
        let defl = match self.contact {
            Contact::Rigid => d,
            _ => (d.abs() - self.half_gap).max(0.0),
        };
        Some(
            0.5 * (c.jm * x[WM] * x[WM] + c.jg * x[WG] * x[WG] + c.jl * x[WL] * x[WL])
                + 0.5 * c.kp * x[DELTA] * x[DELTA]
                + 0.5 * c.kg * defl * defl,
        )
    }
}
