//! A model's parameters as the lab's regression reads them: named in code once as a [`Key`]
//! (the family's table or an effect's, and the name without its unit suffix), resolved against
//! a model to a [`Handle`] with its qualified name, value, freedom and bounds. A key the model
//! does not have is an error that names the key, the model's family and the line of the lab
//! that asked, never a silent 0.

use std::panic::Location;

use crate::physics::{EffectKind, PlantSpec};

/// Which table of a model a parameter sits in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Table {
    /// The family's own table (`[linear_axis]`, `[solenoid]`, ...).
    Family,
    /// An effect's table.
    Effect(EffectKind),
}

/// A parameter named in code: its table and its base name, without the unit suffix the family
/// gives it (`breakaway_pos` is `breakaway_pos_n` on a linear family, `breakaway_pos_nm` on
/// `motor_gear`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Key {
    /// The table.
    pub table: Table,
    /// The base name, as the parameter's `ParamDef` declares it.
    pub base: &'static str,
}

impl Key {
    /// A parameter of the family's table, e.g. `Key::family("mass_kg")`.
    pub const fn family(base: &'static str) -> Key {
        Key {
            table: Table::Family,
            base,
        }
    }

    /// A parameter of an effect, e.g. `Key::effect(EffectKind::Stiction, "breakaway_pos")`.
    pub const fn effect(kind: EffectKind, base: &'static str) -> Key {
        Key {
            table: Table::Effect(kind),
            base,
        }
    }

    /// Look the parameter up in `spec`. An unknown name, or an effect the model does not have,
    /// is an error naming the key and the place in the lab that asked for it.
    #[track_caller]
    pub fn resolve(self, spec: &PlantSpec) -> anyhow::Result<Handle> {
        let asked = Location::caller();
        let (table, list) = match self.table {
            Table::Family => (spec.family.name(), Some(&spec.base)),
            Table::Effect(kind) => (
                kind.name(),
                spec.effects
                    .iter()
                    .find(|e| e.kind == kind)
                    .map(|e| &e.params),
            ),
        };
        let Some(list) = list else {
            anyhow::bail!(
                "the {} model has no effect '{table}' for its parameter '{table}.{}' \
                 (asked at {}:{})",
                spec.family,
                self.base,
                asked.file(),
                asked.line()
            );
        };
        let Some(p) = list.iter().find(|p| p.def.base == self.base) else {
            let known: Vec<&str> = list.iter().map(|p| p.def.base).collect();
            anyhow::bail!(
                "the {} model has no parameter '{table}.{}' ({table} has {}; asked at {}:{})",
                spec.family,
                self.base,
                known.join(", "),
                asked.file(),
                asked.line()
            );
        };
        Ok(Handle {
            name: format!("{table}.{}", p.key),
            value: p.value,
            free: p.free,
            bounds: (p.def.min, p.def.max),
            min_strict: p.def.min_strict,
        })
    }

    /// The parameter's value in `spec` (see [`Key::resolve`]).
    #[track_caller]
    pub fn value(self, spec: &PlantSpec) -> anyhow::Result<f64> {
        Ok(self.resolve(spec)?.value)
    }

    /// Its qualified name in `spec` (the unit suffix follows the family and the command), e.g.
    /// `stiction.breakaway_pos_n`.
    #[track_caller]
    pub fn name(self, spec: &PlantSpec) -> anyhow::Result<String> {
        Ok(self.resolve(spec)?.name)
    }
}

/// One parameter of one model, resolved from its [`Key`].
#[derive(Debug, Clone, PartialEq)]
pub struct Handle {
    /// Qualified name with the unit suffix, e.g. `coulomb.coulomb_pos_n`.
    pub name: String,
    /// Value in the model.
    pub value: f64,
    /// True when the lab may fit it.
    pub free: bool,
    /// Bounds `(min, max)`.
    pub bounds: (f64, f64),
    /// True when the lower bound itself is excluded.
    pub min_strict: bool,
}

/// Look a parameter up by its qualified name (`table.key` with the unit suffix), as names
/// arrive from a grid or a fit; an unknown name is an error naming it and the place that asked.
#[track_caller]
pub fn by_name(spec: &PlantSpec, qualified: &str) -> anyhow::Result<Handle> {
    let asked = Location::caller();
    let Some((name, p)) = spec.params().into_iter().find(|(n, _)| n == qualified) else {
        anyhow::bail!(
            "the {} model has no parameter '{qualified}' (asked at {}:{})",
            spec.family,
            asked.file(),
            asked.line()
        );
    };
    Ok(Handle {
        name,
        value: p.value,
        free: p.free,
        bounds: (p.def.min, p.def.max),
        min_strict: p.def.min_strict,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::Family;

    #[test]
    fn a_misspelled_parameter_is_refused_by_name_and_place() {
        let spec = PlantSpec::new(Family::LinearAxis)
            .with_effect(EffectKind::Stiction)
            .expect("stiction");
        let good = Key::effect(EffectKind::Stiction, "breakaway_pos")
            .resolve(&spec)
            .expect("declared");
        assert_eq!(good.name, "stiction.breakaway_pos_n");
        assert_eq!(
            Some(good.value),
            spec.get("stiction.breakaway_pos_n"),
            "the handle reads the model's value"
        );
        let err = Key::effect(EffectKind::Stiction, "breakaway_pox")
            .resolve(&spec)
            .expect_err("a misspelled name is an error, not 0");
        let text = err.to_string();
        assert!(text.contains("'stiction.breakaway_pox'"), "{text}");
        assert!(text.contains("breakaway_pos, breakaway_neg"), "{text}");
        assert!(text.contains("src/lab/params.rs"), "{text}");
        let err = Key::family("mass_kgg")
            .value(&spec)
            .expect_err("the family's table too");
        assert!(err.to_string().contains("'linear_axis.mass_kgg'"), "{err}");
        let err = by_name(&spec, "stiction.breakaway_pos_nm").expect_err("wrong unit");
        assert!(
            err.to_string().contains("'stiction.breakaway_pos_nm'"),
            "{err}"
        );
    }

    #[test]
    fn an_absent_effect_is_an_error_too() {
        let spec = PlantSpec::new(Family::Solenoid);
        let err = Key::effect(EffectKind::Coulomb, "coulomb_pos")
            .resolve(&spec)
            .expect_err("no coulomb in the model");
        assert!(err.to_string().contains("no effect 'coulomb'"), "{err}");
    }

    #[test]
    fn the_suffix_follows_the_family_and_command() {
        let spec = PlantSpec::new(Family::MotorGear)
            .with_effect(EffectKind::Coulomb)
            .expect("coulomb");
        let h = Key::effect(EffectKind::Coulomb, "coulomb_neg")
            .resolve(&spec)
            .expect("declared");
        assert_eq!(h.name, "coulomb.coulomb_neg_nm");
        assert!(h.free);
        assert_eq!(h.bounds.0, 0.0);
    }
}
