//! One rigid body on a line, `m y'' = F_drive + F_spring + F_load + F_bias - F_viscous - F_dry`,
//! between two end stops, shared by `linear_axis`, `solenoid` and `pneumatic`. The families differ
//! only in their [`Drive`]: the power stage, an optional internal state (the coil current) and the
//! drive force.
//!
//! Modes and events. The body is either `Free` (no dry friction: velocity is continuous),
//! `Slip(±)` (sliding with the dry friction of that direction) or `Held` (velocity exactly zero,
//! position fixed: stuck by dry friction or pressed against an end stop). Inside a mode the
//! dynamics are smooth and integrated with RK4; a sign change of an event function ends the
//! segment at the located instant: velocity reversal while sliding, reaching an end stop, or the
//! net force crossing the breakaway level while held. At rest the mode is chosen from the net
//! force, so a body below breakaway stays exactly where it is (no creep) and a reversal does not
//! chatter.

use crate::physics::effects::{DelayLine, DryFriction, Effects, SupplyGain};
use crate::physics::family::Family;
use crate::physics::fault::{Fault, FaultModifiers, FaultSet};
use crate::physics::integrator::{locate, rk4};
use crate::physics::sensor::Sensor;
use crate::physics::term::{LoadTerm, Signals};
use crate::physics::{Measurement, Plant};

/// The part of a linear family that makes the force.
pub trait Drive: Copy + Send + std::fmt::Debug + 'static {
    /// Which family this drive makes.
    const FAMILY: Family;
    /// Power stage: command (after saturation and dead zone) to drive signal (V, N or m/s).
    /// `supply_ratio` is the supply over its nominal value, `gain` the fault factor F4.
    fn power(&self, u: f64, supply_ratio: f64, supply_gain: Option<SupplyGain>, gain: f64) -> f64;
    /// Rate of the internal state `x[2]` (coil current), 0 when there is none.
    fn aux_rate(&self, p: f64, x: &[f64; 3]) -> f64;
    /// Drive force for signal `p` in state `x = [y, v, aux]`.
    fn force(&self, p: f64, x: &[f64; 3]) -> f64;
    /// Current reported by the sensor (A), 0 when the family has none.
    fn current(&self, x: &[f64; 3]) -> f64;
    /// (supply voltage V, supply pressure Pa) for a supply ratio.
    fn supply(&self, ratio: f64) -> (f64, f64);
    /// Supply ratio for an absolute supply value (V or Pa).
    fn supply_ratio_of(&self, value: f64) -> f64;
}

/// Motion state of the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// No dry friction, velocity continuous.
    Free,
    /// Sliding positive.
    SlipPos,
    /// Sliding negative.
    SlipNeg,
    /// Velocity exactly zero: stuck or against a stop.
    Held,
}

/// Mechanical constants of the body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyParams {
    /// Moving mass (kg).
    pub mass: f64,
    /// Lower end stop (m).
    pub y_min: f64,
    /// Upper end stop (m).
    pub y_max: f64,
    /// Initial position (m).
    pub y0: f64,
    /// Largest integration sub-step (s).
    pub max_substep: f64,
    /// Dry friction level that stands for a seized body (N).
    pub jam_force: f64,
}

/// A linear plant: one body, one drive, its effects, its sensor and its faults.
#[derive(Debug, Clone)]
pub struct BodyPlant<D: Drive> {
    drive: D,
    body: BodyParams,
    nominal: Effects,
    fx: Effects,
    dry: DryFriction,
    x: [f64; 3],
    mode: Mode,
    last_dir: f64,
    z: f64,
    t: f64,
    command: f64,
    delay: DelayLine,
    sensor: Sensor,
    faults: FaultSet,
    mods: FaultModifiers,
    supply_ext: f64,
    /// Forces the model declares itself.
    terms: Vec<LoadTerm>,
}

const MAX_EVENTS: usize = 12;

impl<D: Drive> BodyPlant<D> {
    /// A plant at rest at `body.y0`.
    pub fn new(
        drive: D,
        body: BodyParams,
        effects: Effects,
        sensor: Sensor,
        faults: FaultSet,
    ) -> Self {
        let mut p = BodyPlant {
            drive,
            body,
            nominal: effects,
            fx: effects,
            dry: DryFriction::default(),
            x: [body.y0.clamp(body.y_min, body.y_max), 0.0, 0.0],
            mode: Mode::Held,
            last_dir: 1.0,
            z: 0.0,
            t: 0.0,
            command: 0.0,
            delay: DelayLine::with_capacity(256),
            sensor,
            faults,
            mods: FaultModifiers::default(),
            supply_ext: 1.0,
            terms: Vec::new(),
        };
        p.apply_faults();
        p.z = p.drive_force(&p.x, 0.0);
        p.settle(0.0);
        p
    }

    /// The plant with the forces its model declares (`[[lab.term]]`) on the body.
    pub fn with_terms(mut self, terms: Vec<LoadTerm>) -> Self {
        self.terms = terms;
        self.z = self.drive_force(&self.x, 0.0);
        self.settle(0.0);
        self
    }

    /// The signals a declared term sees in state `x`: the command and the supply held over the
    /// step, the time at its start.
    fn term_signals(&self, x: &[f64; 3]) -> Signals {
        let (volt, pascal) = self.drive.supply(self.supply_ratio());
        Signals {
            y: x[0],
            v: x[1],
            u: self.command,
            supply: if D::FAMILY == Family::Pneumatic {
                pascal
            } else {
                volt
            },
            t: self.t,
        }
    }

    /// Recompute the effective effects from the nominal ones and the fault modifiers.
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
        let supply = fx
            .supply_friction
            .map_or(1.0, |s| s.factor(self.supply_ratio()));
        self.dry = DryFriction::from_effects(&fx, m.friction * supply, m.jam * self.body.jam_force);
    }

    #[inline]
    fn supply_ratio(&self) -> f64 {
        self.supply_ext * self.mods.supply
    }

    #[inline]
    fn direction(&self) -> f64 {
        match self.mode {
            Mode::SlipPos => 1.0,
            Mode::SlipNeg => -1.0,
            Mode::Free if self.x[1] > 0.0 => 1.0,
            Mode::Free if self.x[1] < 0.0 => -1.0,
            _ => self.last_dir,
        }
    }

    /// Drive signal for the segment starting at `t`.
    #[inline]
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
        let mut p = self.drive.power(
            u,
            self.supply_ratio(),
            self.fx.supply_gain,
            self.mods.drive_gain,
        );
        if let Some(a) = self.fx.direction_asymmetry {
            p *= a.gain(self.direction());
        }
        p
    }

    /// Drive force before hysteresis.
    #[inline(always)]
    fn drive_force(&self, x: &[f64; 3], p: f64) -> f64 {
        let f = self.drive.force(p, x);
        match self.fx.position_stiffness {
            Some(ps) => f * ps.factor(x[0]),
            None => f,
        }
    }

    /// All forces except friction and stop reactions.
    #[inline(always)]
    fn net_force(&self, x: &[f64; 3], p: f64, z: f64) -> f64 {
        let y = x[0];
        let mut f = self.drive_force(x, p);
        if let Some(h) = self.fx.hysteresis {
            f = h.play(z, f);
        }
        // Spring, payload, offset and any other force on the body.
        self.fx.add_load_forces(y, x[1], &mut f);
        if !self.terms.is_empty() {
            let s = self.term_signals(x);
            f += self.terms.iter().map(|t| t.force(&s)).sum::<f64>();
        }
        f
    }

    #[inline(always)]
    fn deriv(&self, x: &[f64; 3], p: f64, z: f64, mode: Mode) -> [f64; 3] {
        let da = self.drive.aux_rate(p, x);
        let v = x[1];
        let mut f = match mode {
            Mode::Held => return [0.0, 0.0, da],
            _ => self.net_force(x, p, z),
        };
        if let Some(vi) = self.fx.viscous {
            f += vi.force(v);
        }
        match mode {
            Mode::SlipPos => f -= self.dry.sliding(1.0, v),
            Mode::SlipNeg => f += self.dry.sliding(-1.0, v),
            _ => {}
        }
        [v, f / self.body.mass, da]
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

    /// With the velocity at zero, choose between staying held and starting to move.
    fn settle(&mut self, p: f64) {
        self.x[1] = 0.0;
        let f = self.net_force(&self.x, p, self.z);
        let at_low = self.x[0] <= self.body.y_min;
        let at_high = self.x[0] >= self.body.y_max;
        self.mode = if f > self.dry.break_pos && !at_high {
            self.last_dir = 1.0;
            self.moving(1.0)
        } else if f < -self.dry.break_neg && !at_low {
            self.last_dir = -1.0;
            self.moving(-1.0)
        } else {
            Mode::Held
        };
    }

    /// How far a held body is from breaking away (positive while held), per direction.
    #[inline]
    fn hold_margin(&self, x: &[f64; 3], p: f64, z: f64) -> f64 {
        let f = self.net_force(x, p, z);
        let up = if x[0] >= self.body.y_max {
            f64::INFINITY
        } else {
            self.dry.break_pos - f
        };
        let down = if x[0] <= self.body.y_min {
            f64::INFINITY
        } else {
            f + self.dry.break_neg
        };
        up.min(down)
    }

    /// Event functions while moving: (lower stop, upper stop, velocity reversal).
    #[inline]
    fn moving_events(&self, x: &[f64; 3], mode: Mode) -> [f64; 3] {
        let rev = match mode {
            Mode::SlipPos => x[1],
            Mode::SlipNeg => -x[1],
            _ => f64::INFINITY,
        };
        [x[0] - self.body.y_min, self.body.y_max - x[0], rev]
    }

    fn commit_hysteresis(&mut self, p: f64) {
        if let Some(h) = self.fx.hysteresis {
            self.z = h.play(self.z, self.drive_force(&self.x, p));
        }
    }

    /// Advance one sub-step of length `h` starting at time `t0`.
    fn substep(&mut self, h: f64, t0: f64) {
        let mut done = 0.0;
        for _ in 0..MAX_EVENTS {
            let rem = h - done;
            if rem <= h * 1e-12 {
                return;
            }
            let p = self.signal(t0 + done);
            let (mode, z, x0) = (self.mode, self.z, self.x);
            let x1 = rk4(&x0, rem, |x| self.deriv(x, p, z, mode));
            if mode == Mode::Held {
                let m1 = self.hold_margin(&x1, p, z);
                if m1 >= 0.0 {
                    self.x = x1;
                    self.commit_hysteresis(p);
                    return;
                }
                let m0 = self.hold_margin(&x0, p, z);
                let tau = locate(
                    |t| self.hold_margin(&rk4(&x0, t, |x| self.deriv(x, p, z, mode)), p, z),
                    rem,
                    m0,
                    m1,
                );
                self.x = if tau > 0.0 {
                    rk4(&x0, tau, |x| self.deriv(x, p, z, mode))
                } else {
                    x0
                };
                self.commit_hysteresis(p);
                // Break away: force the direction the margin was lost in.
                let f = self.net_force(&self.x, p, self.z);
                let dir = if f > 0.0 { 1.0 } else { -1.0 };
                self.mode = self.moving(dir);
                self.last_dir = dir;
                self.x[1] = 0.0;
                done += tau;
                continue;
            }
            let e1 = self.moving_events(&x1, mode);
            if e1.iter().all(|&g| g > 0.0) {
                self.x = x1;
                self.commit_hysteresis(p);
                if mode == Mode::Free {
                    if self.x[1] > 0.0 {
                        self.last_dir = 1.0;
                    } else if self.x[1] < 0.0 {
                        self.last_dir = -1.0;
                    }
                }
                return;
            }
            let mut e0 = self.moving_events(&x0, mode);
            // Starting from a stop or from rest, the function grows from exactly zero.
            for g in e0.iter_mut() {
                if *g == 0.0 {
                    *g = f64::MIN_POSITIVE;
                }
            }
            let mut first = (rem, usize::MAX);
            for i in 0..3 {
                if e1[i] <= 0.0 {
                    let tau = locate(
                        |t| {
                            self.moving_events(&rk4(&x0, t, |x| self.deriv(x, p, z, mode)), mode)[i]
                        },
                        rem,
                        e0[i],
                        e1[i],
                    );
                    if tau < first.0 || first.1 == usize::MAX {
                        first = (tau, i);
                    }
                }
            }
            let (tau, which) = first;
            self.x = if tau > 0.0 {
                rk4(&x0, tau, |x| self.deriv(x, p, z, mode))
            } else {
                x0
            };
            self.commit_hysteresis(p);
            match which {
                0 => self.x[0] = self.body.y_min,
                1 => self.x[0] = self.body.y_max,
                _ => {}
            }
            self.x[0] = self.x[0].clamp(self.body.y_min, self.body.y_max);
            self.settle(p);
            done += tau;
        }
    }

    fn truth_now(&self) -> Measurement {
        let (v, pa) = self.drive.supply(self.supply_ratio());
        Measurement {
            position: self.x[0],
            velocity: self.x[1],
            current_a: self.drive.current(&self.x),
            supply_voltage_v: v,
            supply_pressure_pa: pa,
        }
    }

    /// Current motion mode (for tests and diagnostics).
    pub fn mode(&self) -> Mode {
        self.mode
    }
}

impl<D: Drive> Plant for BodyPlant<D> {
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
        let n = (dt_s / self.body.max_substep).ceil().max(1.0);
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
        D::FAMILY
    }

    fn time_s(&self) -> f64 {
        self.t
    }

    fn set_supply(&mut self, value: f64) {
        if value.is_finite() {
            self.supply_ext = self.drive.supply_ratio_of(value).max(0.0);
            if self.fx.supply_friction.is_some() {
                // The dry friction levels follow the supply.
                self.apply_faults();
            }
        }
    }

    /// `½ m v² + F_0 y + ½ c y²` (kinetic plus spring energy).
    fn energy_j(&self) -> Option<f64> {
        let (y, v) = (self.x[0], self.x[1]);
        let spring = self
            .fx
            .spring
            .map_or(0.0, |s| s.pretension * y + 0.5 * s.stiffness * y * y);
        Some(0.5 * self.body.mass * v * v + spring)
    }
}
