//! Physics: plant families built from physical effects, pure maths, no I/O.
//!
//! # Shape
//!
//! - [`effects`]: one file per effect (`viscous`, `coulomb`, `stiction`, `stribeck`, `spring`,
//!   `position_stiffness`, `backlash`, `hysteresis`, `direction_asymmetry`, `deadzone`,
//!   `supply_gain`, `supply_friction`, `dead_time`, `saturation`, `payload`, `offset`,
//!   `varying_ratio`), each a small
//!   `Copy` struct with its equation, its parameters (name, quantity, bounds, default) and the
//!   function the families call. [`effects::EffectKind`] is the registry of names.
//! - [`families`]: `linear_axis`, `solenoid`, `pneumatic` share one rigid body with end stops and
//!   differ in their drive; `motor_gear` is the motor / torsion spring / gear / load chain of
//!   Bao et al. A family is the minimal physics; every effect is optional.
//! - [`integrator`]: RK4 sub-steps with event location. The command is held over a step
//!   (zero-order hold); a step is split into sub-steps of at most `max_substep_s`; inside a
//!   sub-step the dynamics of the current mode (sliding ±, held, free; backlash contact ± or gap)
//!   are smooth, and a mode change happens at the located instant of its event.
//! - [`fault`]: faults with abrupt or drifting onset; [`sensor`]: quantisation, noise, offset,
//!   stuck; [`rng`]: a seeded generator, so a plant is deterministic for its seed.
//! - [`spec`]: [`PlantSpec`], the description of a plant, read from a TOML plant file
//!   (`config/plants/*.toml`) or assembled in code.
//!
//! # For the lab
//!
//! A model is a [`PlantSpec`]: `family` + `effects: Vec<EffectSpec>` + parameters, each a
//! [`Param`] with key, unit, bounds, value and a `free` flag. Parameters are addressed by
//! qualified names (`solenoid.mass_kg`, `spring.stiffness_n_per_m`); the free ones form a vector
//! ([`PlantSpec::free_names`], [`PlantSpec::free_values`], [`PlantSpec::set_free_values`],
//! [`PlantSpec::free_bounds`]). [`PlantSpec::build`] gives a `Box<dyn Plant>`; the per-sample
//! call is the only dynamic dispatch: inside, each family is a concrete generic type whose effects
//! are `Option` fields of plain structs, so a sub-step has no allocation and no indirect call.
//!
//! # Units and signs
//!
//! SI everywhere. Linear families: position in m, positive as the family states (solenoid:
//! 0 at the spring's rest stop, positive pulled in). `motor_gear`: load angle in rad. Forces and
//! torques act towards positive positions when positive.

pub mod effects;
pub mod error;
pub mod families;
pub mod family;
pub mod fault;
pub mod integrator;
pub mod params;
pub mod rng;
pub mod sensor;
pub mod spec;
pub mod term;

pub use effects::{EffectDef, EffectKind, Effects};
pub use error::PhysicsError;
pub use family::{CommandUnit, Family};
pub use fault::{Fault, FaultKind, FaultModifiers, FaultSet, ScheduledFault};
pub use params::{Param, ParamDef, Quantity};
pub use sensor::SensorSpec;
pub use spec::{EffectSpec, PlantSpec};

/// What the actuator's sensors report, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Measurement {
    /// m for linear families, rad (load angle) for motor_gear.
    pub position: f64,
    /// m/s or rad/s (true velocity, for recording and tests).
    pub velocity: f64,
    /// Coil / armature current; 0 where the family has none.
    pub current_a: f64,
    /// 0 where not applicable.
    pub supply_voltage_v: f64,
    /// Absolute pressure, 0 where not applicable.
    pub supply_pressure_pa: f64,
}

/// A simulated actuator.
pub trait Plant: Send {
    /// Advance by dt_s with the actuator command held (zero-order hold). Command unit per family:
    /// solenoid and motor_gear: terminal voltage in V (clipped to what the supply allows: the
    /// solenoid's PWM stage gives 0..supply, the motor's H-bridge -supply..+supply);
    /// pneumatic: signed valve duty in [-1, 1] (negative opens V1 to the low pressure and moves
    /// down, positive opens V2 to atmosphere and moves up);
    /// linear_axis: force in N, or voltage times a gain if the plant file says so.
    fn step(&mut self, command: f64, dt_s: f64);
    /// Sensor reading now (with sensor model: noise, quantisation, offset, stuck).
    fn measure(&mut self) -> Measurement;
    /// True physical state for tests (no sensor model).
    fn truth(&self) -> Measurement;
    /// Start a fault now (abrupt) or as a drift (see [`Fault`]).
    fn inject(&mut self, fault: Fault);
    /// The plant's family.
    fn family(&self) -> Family;
    /// Simulated time in s since construction.
    fn time_s(&self) -> f64;
    /// Set the actual supply (V, or absolute Pa for pneumatic), e.g. a manifold pressure that
    /// varies; faults of the supply act on top of it. All four families implement it; the
    /// default (for plants without a supply) ignores the value.
    fn set_supply(&mut self, value: f64) {
        let _ = value;
    }
    /// True position of the drive side of the transmission (gear output angle for motor_gear,
    /// the same as `truth().position` where there is no transmission): shows backlash.
    fn drive_position(&self) -> f64 {
        self.truth().position
    }
    /// Mechanical energy stored in the moving bodies and the springs of the transmission, in J
    /// (for energy-balance checks); `None` where a family does not report it.
    fn energy_j(&self) -> Option<f64> {
        None
    }
    /// Run `commands`, one step of `dt_s` each, appending the sensor reading after each step.
    fn simulate(&mut self, commands: &[f64], dt_s: f64, out: &mut Vec<Measurement>) {
        out.reserve(commands.len());
        for &u in commands {
            self.step(u, dt_s);
            out.push(self.measure());
        }
    }
}

/// Build a plant from a TOML plant file. Errors name the file, the key and the rule broken, e.g.
/// "config/plants/solenoid.toml: [spring] stiffness_n_per_m must be > 0, got -3".
pub fn load_plant(path: &std::path::Path) -> Result<Box<dyn Plant>, PhysicsError> {
    load_spec(path)?.build_named(&path.display().to_string())
}

/// Read a plant file into a [`PlantSpec`] (for the lab, to change effects or parameters).
pub fn load_spec(path: &std::path::Path) -> Result<PlantSpec, PhysicsError> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| PhysicsError::Io {
        origin: origin.clone(),
        error,
    })?;
    PlantSpec::from_toml(&text, &origin)
}

/// Build a plant from TOML text; `origin` names it in error messages.
pub fn plant_from_str(toml_text: &str, origin: &str) -> Result<Box<dyn Plant>, PhysicsError> {
    PlantSpec::from_toml(toml_text, origin)?.build_named(origin)
}
