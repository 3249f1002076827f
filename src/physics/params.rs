//! Named parameters with units and bounds, shared by the plant families, the effects and the lab.

use super::family::{CommandUnit, Family};
use super::PhysicsError;

/// What a parameter measures. The key suffix and the unit follow from the family
/// (`_n` and N on a linear family, `_nm` and N·m on the rotary one); see
/// [`Family::suffix_and_unit`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Force (N) or torque (N·m).
    Force,
    /// Viscous coefficient (N·s/m or N·m·s/rad).
    Damping,
    /// Stiffness (N/m or N·m/rad).
    Stiffness,
    /// Position (m or rad).
    Position,
    /// Velocity (m/s or rad/s).
    Velocity,
    /// 1/m or 1/rad.
    PerPosition,
    /// 1/m² or 1/rad².
    PerPosition2,
    /// Time in s.
    Time,
    /// Dimensionless.
    Ratio,
    /// The unit of the family's command (V, N, duty, N·m).
    Command,
    /// Supply voltage (V) or pressure (Pa).
    Supply,
    /// A fixed unit; the base name already carries it.
    Named(&'static str),
}

/// Static description of a parameter: base name, quantity, bounds and default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamDef {
    /// Name without the unit suffix, e.g. `coulomb_pos`.
    pub base: &'static str,
    /// What it measures; gives the suffix and unit.
    pub quantity: Quantity,
    /// Lower bound.
    pub min: f64,
    /// True when the lower bound itself is excluded (`> min`).
    pub min_strict: bool,
    /// Upper bound.
    pub max: f64,
    /// Default value (a sensible starting point, also the lab's initial guess).
    pub default: f64,
    /// One-line meaning.
    pub doc: &'static str,
}

impl ParamDef {
    /// A parameter that must be >= 0.
    pub const fn non_negative(
        base: &'static str,
        quantity: Quantity,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamDef {
            base,
            quantity,
            min: 0.0,
            min_strict: false,
            max: f64::INFINITY,
            default,
            doc,
        }
    }
    /// A parameter that must be > 0.
    pub const fn positive(
        base: &'static str,
        quantity: Quantity,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamDef {
            base,
            quantity,
            min: 0.0,
            min_strict: true,
            max: f64::INFINITY,
            default,
            doc,
        }
    }
    /// A parameter with any finite value.
    pub const fn any(
        base: &'static str,
        quantity: Quantity,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamDef {
            base,
            quantity,
            min: f64::NEG_INFINITY,
            min_strict: false,
            max: f64::INFINITY,
            default,
            doc,
        }
    }
    /// A parameter in the closed range `[min, max]`.
    pub const fn range(
        base: &'static str,
        quantity: Quantity,
        min: f64,
        max: f64,
        default: f64,
        doc: &'static str,
    ) -> Self {
        ParamDef {
            base,
            quantity,
            min,
            min_strict: false,
            max,
            default,
            doc,
        }
    }

    /// The declaration of `base` among `defs` (a family's or an effect's `PARAMS`), for a
    /// constant: code outside the physics that reads a plant parameter names it through this,
    /// so a parameter renamed or dropped in its declaration fails the build instead of going
    /// missing when a model is read.
    pub const fn declared(defs: &'static [ParamDef], base: &str) -> ParamDef {
        let mut i = 0;
        while i < defs.len() {
            if crate::param::same(defs[i].base, base) {
                return defs[i];
            }
            i += 1;
        }
        panic!("the table declares no parameter of that name");
    }

    /// Full key in a plant file for a family, e.g. `coulomb_pos_n`.
    pub fn key(&self, family: Family, command: CommandUnit) -> String {
        let (suffix, _) = family.suffix_and_unit(self.quantity, command);
        format!("{}{}", self.base, suffix)
    }

    /// Unit for a family, e.g. `N`.
    pub fn unit(&self, family: Family, command: CommandUnit) -> &'static str {
        family.suffix_and_unit(self.quantity, command).1
    }

    /// `Err(rule)` when `value` breaks the bounds, e.g. "must be > 0, got -3".
    pub fn check(&self, value: f64) -> Result<(), String> {
        if !value.is_finite() {
            return Err(format!("must be a finite number, got {value}"));
        }
        let low_ok = if self.min_strict {
            value > self.min
        } else {
            value >= self.min
        };
        let high_ok = value <= self.max;
        if low_ok && high_ok {
            return Ok(());
        }
        let op = if self.min_strict { ">" } else { ">=" };
        let rule = match (self.min.is_finite(), self.max.is_finite()) {
            (true, true) => format!("must be in [{}, {}]", self.min, self.max),
            (true, false) => format!("must be {op} {}", self.min),
            (false, true) => format!("must be <= {}", self.max),
            (false, false) => "must be finite".to_string(),
        };
        Err(format!("{rule}, got {value}"))
    }
}

/// A parameter of a concrete model: its definition, key, value and whether the lab may fit it.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    /// Key in the plant file, e.g. `stiffness_n_per_m`.
    pub key: String,
    /// Unit, e.g. `N/m`.
    pub unit: &'static str,
    /// Bounds, default and meaning.
    pub def: ParamDef,
    /// Current value.
    pub value: f64,
    /// False when the lab must keep it fixed.
    pub free: bool,
}

impl Param {
    /// A parameter at its default value, free.
    pub fn from_def(def: ParamDef, family: Family, command: CommandUnit) -> Self {
        Param {
            key: def.key(family, command),
            unit: def.unit(family, command),
            def,
            value: def.default,
            free: true,
        }
    }
}

/// Set `value` of the parameter called `key` in `params`, checking its bounds.
pub(crate) fn set_checked(
    params: &mut [Param],
    key: &str,
    value: f64,
    origin: &str,
    table: &str,
) -> Result<(), PhysicsError> {
    let p = params
        .iter_mut()
        .find(|p| p.key == key)
        .ok_or_else(|| PhysicsError::Unknown {
            origin: format!("{origin}: [{table}]"),
            what: "key",
            name: key.to_string(),
            hint: String::new(),
        })?;
    p.def
        .check(value)
        .map_err(|rule| PhysicsError::invalid(origin, table, key, rule))?;
    p.value = value;
    Ok(())
}
