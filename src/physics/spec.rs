//! Plant descriptions: a family, its base parameters, a list of effects with their parameters,
//! the sensor, a seed and scheduled faults. Read from TOML plant files or assembled in code (the
//! lab), then [`PlantSpec::build`] makes the plant.

use std::fmt::Write as _;

use super::effects::{EffectDef, EffectKind, Effects, SupplyGain};
use super::families::body::{BodyParams, BodyPlant};
use super::families::{linear_axis, motor_gear, pneumatic, solenoid};
use super::family::{CommandUnit, Family};
use super::fault::{FaultSet, ScheduledFault};
use super::params::{set_checked, Param, ParamDef};
use super::sensor::{Sensor, SensorSpec, SENSOR_PARAMS};
use super::term::TermSpec;
use super::{PhysicsError, Plant};

/// One effect of a model, with its parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct EffectSpec {
    /// Which effect.
    pub kind: EffectKind,
    /// Its parameters, in the effect's order.
    pub params: Vec<Param>,
}

/// A complete plant description.
#[derive(Debug, Clone, PartialEq)]
pub struct PlantSpec {
    /// The family.
    pub family: Family,
    /// Unit of the command (fixed by the family, except linear_axis and motor_gear).
    pub command: CommandUnit,
    /// Base parameters of the family (the `[<family>]` table).
    pub base: Vec<Param>,
    /// Effects, at most one of each kind.
    pub effects: Vec<EffectSpec>,
    /// Sensor parameters (the `[sensor]` table).
    pub sensor: Vec<Param>,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Largest integration sub-step in s.
    pub max_substep_s: f64,
    /// Faults the plant injects into itself at the given times.
    pub faults: Vec<ScheduledFault>,
    /// Forces the model declares itself (a model file's `[[lab.term]]`); those marked as
    /// candidates are not part of the plant.
    pub terms: Vec<TermSpec>,
}

/// Base parameter definitions of a family.
pub fn base_params(family: Family) -> &'static [ParamDef] {
    match family {
        Family::LinearAxis => linear_axis::PARAMS,
        Family::Solenoid => solenoid::PARAMS,
        Family::Pneumatic => pneumatic::PARAMS,
        Family::MotorGear => motor_gear::PARAMS,
    }
}

fn default_command(family: Family) -> CommandUnit {
    match family {
        Family::LinearAxis => CommandUnit::Newton,
        Family::Solenoid | Family::MotorGear => CommandUnit::Volt,
        Family::Pneumatic => CommandUnit::Duty,
    }
}

/// Default largest sub-step per family, about a tenth of its fastest time constant.
fn default_substep(family: Family) -> f64 {
    match family {
        // T_I = 8.6 ms and 1/ω0 = 17 ms: 0.5 ms (T_I / 17) keeps RK4 accurate to far below the
        // sensor resolution; impacts and stick-slip are located as events anyway.
        Family::Solenoid => 5e-4,
        Family::LinearAxis => 1e-4,
        // τ = 2 ms.
        Family::Pneumatic => 2.5e-4,
        // L_a / R_a = 0.32 ms and the shaft's torsion mode near 11000 rad/s on the light rotor
        // (config/plants/motor_gear.toml): h |λ| = 0.28.
        Family::MotorGear => 2.5e-5,
    }
}

fn table_of(params: &[Param]) -> impl Iterator<Item = (&str, f64)> {
    params.iter().map(|p| (p.key.as_str(), p.value))
}

impl PlantSpec {
    /// A family with default base and sensor parameters and no effects.
    pub fn new(family: Family) -> Self {
        let command = default_command(family);
        PlantSpec {
            family,
            command,
            base: base_params(family)
                .iter()
                .map(|d| Param::from_def(*d, family, command))
                .collect(),
            effects: Vec::new(),
            sensor: SENSOR_PARAMS
                .iter()
                .map(|d| Param::from_def(*d, family, command))
                .collect(),
            seed: 0,
            max_substep_s: default_substep(family),
            faults: Vec::new(),
            terms: Vec::new(),
        }
    }

    /// Change the command unit (linear_axis: N or V; motor_gear: V or N·m). Renames the keys
    /// of command-valued parameters.
    pub fn set_command(&mut self, command: CommandUnit) -> Result<(), PhysicsError> {
        let ok = matches!(
            (self.family, command),
            (Family::LinearAxis, CommandUnit::Newton | CommandUnit::Volt)
                | (
                    Family::MotorGear,
                    CommandUnit::Volt | CommandUnit::NewtonMetre
                )
                | (Family::Solenoid, CommandUnit::Volt)
                | (Family::Pneumatic, CommandUnit::Duty)
        );
        if !ok {
            return Err(PhysicsError::invalid(
                self.family.name(),
                "",
                "command",
                format!("{command:?} is not a command of {}", self.family),
            ));
        }
        self.command = command;
        let (family, cmd) = (self.family, command);
        for p in self
            .base
            .iter_mut()
            .chain(self.sensor.iter_mut())
            .chain(self.effects.iter_mut().flat_map(|e| e.params.iter_mut()))
        {
            p.key = p.def.key(family, cmd);
            p.unit = p.def.unit(family, cmd);
        }
        Ok(())
    }

    /// Add an effect with default parameters (replacing one of the same kind).
    pub fn add_effect(&mut self, kind: EffectKind) -> Result<&mut EffectSpec, PhysicsError> {
        if !kind.supported_by(self.family) {
            return Err(PhysicsError::Unknown {
                origin: self.family.name().to_string(),
                what: "effect for this family",
                name: kind.name().to_string(),
                hint: format!(", expected one of {}", EffectKind::names_for(self.family)),
            });
        }
        self.effects.retain(|e| e.kind != kind);
        let params = kind
            .params()
            .iter()
            .map(|d| Param::from_def(*d, self.family, self.command))
            .collect();
        self.effects.push(EffectSpec { kind, params });
        let last = self.effects.len() - 1;
        Ok(&mut self.effects[last])
    }

    /// Builder form of [`PlantSpec::add_effect`].
    pub fn with_effect(mut self, kind: EffectKind) -> Result<Self, PhysicsError> {
        self.add_effect(kind)?;
        Ok(self)
    }

    /// Remove an effect.
    pub fn remove_effect(&mut self, kind: EffectKind) {
        self.effects.retain(|e| e.kind != kind);
    }

    /// Names of the effects present.
    pub fn effect_names(&self) -> Vec<&'static str> {
        self.effects.iter().map(|e| e.kind.name()).collect()
    }

    /// All parameters with qualified names `table.key`, e.g. `spring.stiffness_n_per_m`,
    /// `solenoid.mass_kg`, `sensor.position_noise_m`.
    pub fn params(&self) -> Vec<(String, &Param)> {
        let fam = self.family.name();
        let mut out: Vec<(String, &Param)> = self
            .base
            .iter()
            .map(|p| (format!("{fam}.{}", p.key), p))
            .collect();
        for e in &self.effects {
            for p in &e.params {
                out.push((format!("{}.{}", e.kind.name(), p.key), p));
            }
        }
        for p in &self.sensor {
            out.push((format!("sensor.{}", p.key), p));
        }
        for t in self.active_terms() {
            for p in &t.params {
                out.push((format!("{}.{}", t.name, p.key), p));
            }
        }
        out
    }

    /// The declared terms that act in the plant (not candidates).
    pub fn active_terms(&self) -> impl Iterator<Item = &TermSpec> {
        self.terms.iter().filter(|t| !t.candidate)
    }

    /// The declared term called `name`.
    pub fn term(&self, name: &str) -> Option<&TermSpec> {
        self.terms.iter().find(|t| t.name == name)
    }

    /// Make the declared candidate term `name` part of the model.
    pub fn activate_term(&mut self, name: &str) -> Result<(), PhysicsError> {
        let fam = self.family.name().to_string();
        let t = self
            .terms
            .iter_mut()
            .find(|t| t.name == name)
            .ok_or_else(|| PhysicsError::Unknown {
                origin: fam,
                what: "term",
                name: name.to_string(),
                hint: String::new(),
            })?;
        t.candidate = false;
        Ok(())
    }

    /// Declare a term (replacing one of the same name); `origin` names the model in errors.
    pub fn add_term(&mut self, term: TermSpec, origin: &str) -> Result<(), PhysicsError> {
        let clash = term.name == self.family.name()
            || term.name == "sensor"
            || EffectKind::from_name(&term.name).is_some();
        if clash {
            return Err(PhysicsError::invalid(
                origin,
                &format!("lab.term '{}'", term.name),
                "name",
                "is the name of a family, an effect of the catalogue or the sensor; choose another",
            ));
        }
        self.terms.retain(|t| t.name != term.name);
        self.terms.push(term);
        Ok(())
    }

    fn param_mut(&mut self, qualified: &str) -> Result<(String, &mut Param), PhysicsError> {
        let (table, key) = qualified.split_once('.').unwrap_or(("", qualified));
        let fam = self.family.name();
        let list: Option<&mut Vec<Param>> = if table == fam {
            Some(&mut self.base)
        } else if table == "sensor" {
            Some(&mut self.sensor)
        } else if let Some(t) = self.terms.iter_mut().find(|t| t.name == table) {
            Some(&mut t.params)
        } else {
            self.effects
                .iter_mut()
                .find(|e| e.kind.name() == table)
                .map(|e| &mut e.params)
        };
        let unknown = || PhysicsError::Unknown {
            origin: fam.to_string(),
            what: "parameter",
            name: qualified.to_string(),
            hint: String::new(),
        };
        let list = list.ok_or_else(unknown)?;
        let p = list.iter_mut().find(|p| p.key == key).ok_or_else(unknown)?;
        Ok((table.to_string(), p))
    }

    /// Value of a parameter by qualified name.
    pub fn get(&self, qualified: &str) -> Option<f64> {
        self.params()
            .into_iter()
            .find(|(n, _)| n == qualified)
            .map(|(_, p)| p.value)
    }

    /// Set a parameter by qualified name, checking its bounds.
    pub fn set(&mut self, qualified: &str, value: f64) -> Result<(), PhysicsError> {
        let (table, p) = self.param_mut(qualified)?;
        p.def
            .check(value)
            .map_err(|rule| PhysicsError::invalid("", &table, &p.key, rule))?;
        p.value = value;
        Ok(())
    }

    /// Mark a parameter as free (fitted by the lab) or fixed.
    pub fn set_free(&mut self, qualified: &str, free: bool) -> Result<(), PhysicsError> {
        self.param_mut(qualified)?.1.free = free;
        Ok(())
    }

    /// Mark every parameter fixed.
    pub fn fix_all(&mut self) {
        for p in self
            .base
            .iter_mut()
            .chain(self.sensor.iter_mut())
            .chain(self.effects.iter_mut().flat_map(|e| e.params.iter_mut()))
            .chain(self.terms.iter_mut().flat_map(|t| t.params.iter_mut()))
        {
            p.free = false;
        }
    }

    fn free_iter(&self) -> impl Iterator<Item = &Param> {
        self.base
            .iter()
            .chain(self.effects.iter().flat_map(|e| e.params.iter()))
            .chain(self.active_terms().flat_map(|t| t.params.iter()))
            .filter(|p| p.free)
    }

    fn free_iter_mut(&mut self) -> impl Iterator<Item = &mut Param> {
        self.base
            .iter_mut()
            .chain(self.effects.iter_mut().flat_map(|e| e.params.iter_mut()))
            .chain(
                self.terms
                    .iter_mut()
                    .filter(|t| !t.candidate)
                    .flat_map(|t| t.params.iter_mut()),
            )
            .filter(|p| p.free)
    }

    /// Qualified names of the free parameters (sensor parameters are never free), in vector order.
    pub fn free_names(&self) -> Vec<String> {
        self.params()
            .into_iter()
            .filter(|(n, p)| p.free && !n.starts_with("sensor."))
            .map(|(n, _)| n)
            .collect()
    }

    /// The free parameter vector.
    pub fn free_values(&self) -> Vec<f64> {
        self.free_iter().map(|p| p.value).collect()
    }

    /// Bounds `(min, max)` of the free parameters (a strict bound is reported as the bound).
    pub fn free_bounds(&self) -> Vec<(f64, f64)> {
        self.free_iter().map(|p| (p.def.min, p.def.max)).collect()
    }

    /// Set the free parameter vector, checking length and bounds.
    pub fn set_free_values(&mut self, values: &[f64]) -> Result<(), PhysicsError> {
        let n = self.free_iter().count();
        if values.len() != n {
            return Err(PhysicsError::VectorLength {
                expected: n,
                got: values.len(),
            });
        }
        for (p, &v) in self.free_iter_mut().zip(values) {
            p.def
                .check(v)
                .map_err(|rule| PhysicsError::invalid("", "", &p.key, rule))?;
            p.value = v;
        }
        Ok(())
    }

    fn effects_struct(&self, origin: &str) -> Result<Effects, PhysicsError> {
        let mut fx = Effects::default();
        for e in &self.effects {
            let values: Vec<f64> = e.params.iter().map(|p| p.value).collect();
            for p in &e.params {
                p.def
                    .check(p.value)
                    .map_err(|rule| PhysicsError::invalid(origin, e.kind.name(), &p.key, rule))?;
            }
            e.kind.check(&values).map_err(|(i, rule)| {
                PhysicsError::invalid(origin, e.kind.name(), &e.params[i].key, rule)
            })?;
            fx.set(e.kind, &values);
        }
        Ok(fx)
    }

    fn values(
        &self,
        params: &[Param],
        table: &str,
        origin: &str,
    ) -> Result<Vec<f64>, PhysicsError> {
        params
            .iter()
            .map(|p| {
                p.def
                    .check(p.value)
                    .map(|_| p.value)
                    .map_err(|rule| PhysicsError::invalid(origin, table, &p.key, rule))
            })
            .collect()
    }

    /// Make the plant.
    pub fn build(&self) -> Result<Box<dyn Plant>, PhysicsError> {
        self.build_named("plant")
    }

    /// Make the plant; `origin` names the description in error messages.
    pub fn build_named(&self, origin: &str) -> Result<Box<dyn Plant>, PhysicsError> {
        let fam = self.family.name();
        if !(self.max_substep_s > 0.0 && self.max_substep_s.is_finite()) {
            return Err(PhysicsError::invalid(
                origin,
                "",
                "max_substep_s",
                format!("must be > 0, got {}", self.max_substep_s),
            ));
        }
        for e in &self.effects {
            if !e.kind.supported_by(self.family) {
                return Err(PhysicsError::Unknown {
                    origin: origin.to_string(),
                    what: "effect for this family",
                    name: e.kind.name().to_string(),
                    hint: format!(", expected one of {}", EffectKind::names_for(self.family)),
                });
            }
        }
        let b = self.values(&self.base, fam, origin)?;
        let fx = self.effects_struct(origin)?;
        if let Some(sg) = fx.supply_gain {
            // A PWM stage scales both directions of the command alike; only the pneumatic drive
            // has two valves, each with its own law.
            if sg.exponent_pos_shift != 0.0 && self.family != Family::Pneumatic {
                let def = &<SupplyGain as EffectDef>::PARAMS[1];
                return Err(PhysicsError::invalid(
                    origin,
                    <SupplyGain as EffectDef>::NAME,
                    def.base,
                    format!(
                        "a law per direction is the pneumatic drive's (two valves); a {fam} \
                         drive's gain follows the supply alike in both directions: leave it 0, \
                         got {}",
                        sg.exponent_pos_shift
                    ),
                ));
            }
        }
        let s = self.values(&self.sensor, "sensor", origin)?;
        let sensor = Sensor::new(SensorSpec::from_values(&s), self.seed);
        let faults = FaultSet::with_schedule(self.faults.clone());
        let stops = |lo: usize, hi: usize| -> Result<(f64, f64), PhysicsError> {
            if b[hi] <= b[lo] {
                return Err(PhysicsError::invalid(
                    origin,
                    fam,
                    &self.base[hi].key,
                    format!("must be > {} ({}), got {}", self.base[lo].key, b[lo], b[hi]),
                ));
            }
            Ok((b[lo], b[hi]))
        };
        let terms: Vec<_> = self.active_terms().map(TermSpec::load).collect();
        let body = |mass: f64, (y_min, y_max): (f64, f64), jam: f64| BodyParams {
            mass,
            y_min,
            y_max,
            y0: 0.0f64.clamp(y_min, y_max),
            max_substep: self.max_substep_s,
            jam_force: jam,
        };
        Ok(match self.family {
            Family::Solenoid => Box::new(
                BodyPlant::new(
                    solenoid::SolenoidDrive::from_values(&b),
                    body(b[0], stops(4, 5)?, 1e6),
                    fx,
                    sensor,
                    faults,
                )
                .with_terms(terms),
            ),
            Family::LinearAxis => Box::new(
                BodyPlant::new(
                    linear_axis::AxisDrive::from_values(&b, self.command == CommandUnit::Volt),
                    body(b[0], stops(2, 3)?, 1e7),
                    fx,
                    sensor,
                    faults,
                )
                .with_terms(terms),
            ),
            Family::Pneumatic => {
                let (lo, hi) = stops(4, 5)?;
                let mut bp = body(b[0], (lo, hi), 1e6);
                // The membrane rests at mid-stroke when nothing drives it.
                bp.y0 = 0.5 * (lo + hi);
                Box::new(
                    BodyPlant::new(
                        pneumatic::ValveDrive::from_values(&b),
                        bp,
                        fx,
                        sensor,
                        faults,
                    )
                    .with_terms(terms),
                )
            }
            Family::MotorGear => Box::new(
                motor_gear::MotorGearPlant::new(
                    &b,
                    self.command == CommandUnit::NewtonMetre,
                    fx,
                    sensor,
                    faults,
                    self.max_substep_s,
                    stops(13, 14)?,
                )
                .with_terms(terms),
            ),
        })
    }

    /// Read a plant description from TOML text; `origin` (usually the file name) prefixes errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, PhysicsError> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| PhysicsError::Toml {
                origin: origin.to_string(),
                message: e.message().to_string(),
            })?;
        let bad = |key: &str, rule: String| PhysicsError::invalid(origin, "", key, rule);
        let family: Family = match table.get("family") {
            Some(toml::Value::String(s)) => s.parse().map_err(|_| PhysicsError::Unknown {
                origin: origin.to_string(),
                what: "family",
                name: s.clone(),
                hint: ", expected one of linear_axis, solenoid, pneumatic, motor_gear".to_string(),
            })?,
            Some(other) => return Err(bad("family", format!("must be a string, got {other}"))),
            None => return Err(bad("family", "is missing".to_string())),
        };
        let mut spec = PlantSpec::new(family);
        if let Some(v) = table.get("command") {
            let unit = match v.as_str() {
                Some("force") => CommandUnit::Newton,
                Some("voltage") => CommandUnit::Volt,
                Some("torque") => CommandUnit::NewtonMetre,
                Some("duty") => CommandUnit::Duty,
                _ => {
                    return Err(bad(
                        "command",
                        format!("must be \"force\", \"voltage\", \"torque\" or \"duty\", got {v}"),
                    ))
                }
            };
            spec.set_command(unit)
                .map_err(|_| bad("command", format!("{v} is not a command of {family}")))?;
        }
        for (key, value) in &table {
            match key.as_str() {
                "family" | "command" => {}
                "seed" => match value.as_integer() {
                    Some(s) if s >= 0 => spec.seed = s as u64,
                    _ => return Err(bad("seed", format!("must be an integer >= 0, got {value}"))),
                },
                "max_substep_s" => match number(value) {
                    Some(h) if h > 0.0 && h.is_finite() => spec.max_substep_s = h,
                    _ => return Err(bad("max_substep_s", format!("must be > 0, got {value}"))),
                },
                "faults" => {
                    let list = value
                        .as_array()
                        .ok_or_else(|| bad("faults", "must be a list of strings".to_string()))?;
                    for item in list {
                        let s = item.as_str().ok_or_else(|| {
                            bad("faults", format!("must hold strings, got {item}"))
                        })?;
                        let f: ScheduledFault =
                            s.parse().map_err(|e| bad("faults", format!("{e}")))?;
                        spec.faults.push(f);
                    }
                }
                name => {
                    let sub = value.as_table().ok_or_else(|| PhysicsError::Unknown {
                        origin: origin.to_string(),
                        what: "key",
                        name: name.to_string(),
                        hint: ", expected family, command, seed, max_substep_s, faults or a table"
                            .to_string(),
                    })?;
                    spec.read_table(name, sub, origin)?;
                }
            }
        }
        // Cross-parameter rules and bounds, with the file name in the message.
        spec.effects_struct(origin)?;
        Ok(spec)
    }

    fn read_table(
        &mut self,
        name: &str,
        sub: &toml::Table,
        origin: &str,
    ) -> Result<(), PhysicsError> {
        let family = self.family;
        let params: &mut Vec<Param> = if name == family.name() {
            &mut self.base
        } else if name == "sensor" {
            &mut self.sensor
        } else {
            let kind = EffectKind::from_name(name).ok_or_else(|| PhysicsError::Unknown {
                origin: origin.to_string(),
                what: "table",
                name: name.to_string(),
                hint: format!(
                    ", expected [{family}], [sensor] or an effect: {}",
                    EffectKind::names_for(family)
                ),
            })?;
            if let Some(toml::Value::Boolean(false)) = sub.get("enabled") {
                return Ok(());
            }
            if !kind.supported_by(family) {
                return Err(PhysicsError::Unknown {
                    origin: origin.to_string(),
                    what: "effect for this family",
                    name: name.to_string(),
                    hint: format!(", expected one of {}", EffectKind::names_for(family)),
                });
            }
            &mut self.add_effect(kind)?.params
        };
        for (key, value) in sub {
            if key == "enabled" {
                if value.as_bool().is_none() {
                    return Err(PhysicsError::invalid(
                        origin,
                        name,
                        key,
                        format!("must be true or false, got {value}"),
                    ));
                }
                continue;
            }
            if !params.iter().any(|p| &p.key == key) {
                let known: Vec<&str> = params.iter().map(|p| p.key.as_str()).collect();
                return Err(PhysicsError::Unknown {
                    origin: format!("{origin}: [{name}]"),
                    what: "key",
                    name: key.clone(),
                    hint: format!(", expected one of {}", known.join(", ")),
                });
            }
            let v = number(value).ok_or_else(|| {
                PhysicsError::invalid(origin, name, key, format!("must be a number, got {value}"))
            })?;
            set_checked(params, key, v, origin, name)?;
        }
        Ok(())
    }

    /// Write the description as a plant file that [`PlantSpec::from_toml`] reads back.
    pub fn to_toml(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "family = \"{}\"", self.family);
        let cmd = match self.command {
            CommandUnit::Newton => "force",
            CommandUnit::Volt => "voltage",
            CommandUnit::Duty => "duty",
            CommandUnit::NewtonMetre => "torque",
        };
        let _ = writeln!(s, "command = \"{cmd}\"");
        let _ = writeln!(s, "seed = {}", self.seed);
        let _ = writeln!(s, "max_substep_s = {:?}", self.max_substep_s);
        if !self.faults.is_empty() {
            let list: Vec<String> = self.faults.iter().map(|f| format!("\"{f}\"")).collect();
            let _ = writeln!(s, "faults = [{}]", list.join(", "));
        }
        let mut section = |name: &str, params: &[Param]| {
            let _ = writeln!(s, "\n[{name}]");
            for (k, v) in table_of(params) {
                let _ = writeln!(s, "{k} = {v:?}");
            }
        };
        section(self.family.name(), &self.base);
        section("sensor", &self.sensor);
        for e in &self.effects {
            section(e.kind.name(), &e.params);
        }
        s
    }
}

/// A TOML number, integer or float.
pub(crate) fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}
