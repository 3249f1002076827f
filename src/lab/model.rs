//! Models: a plant family plus effects with parameter values, bounds and free/fixed flags, read
//! from a model file (`config/models/*.toml`) or assembled from `--family F --with a,b`.
//!
//! A model file is a plant file (see `config/plants/`) with an optional `[lab]` table:
//! `fixed = ["solenoid.mass_kg", ...]` lists the parameters the lab keeps fixed (all others are
//! free and refitted).

use std::path::Path;

use crate::physics::spec::number;
use crate::physics::term::{TermParam, TermSpec};
use crate::physics::{EffectKind, Family, PlantSpec};

/// A model under test.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Name for messages and reports (file name or `family+effects`).
    pub name: String,
    /// The plant description with its free/fixed flags.
    pub spec: PlantSpec,
}

impl Model {
    /// A family with the given effects at default parameters, every parameter free.
    pub fn from_family(family: Family, effects: &[EffectKind]) -> anyhow::Result<Model> {
        let mut spec = PlantSpec::new(family);
        for &e in effects {
            spec.add_effect(e)?;
        }
        let mut name = family.name().to_string();
        for e in effects {
            name.push('+');
            name.push_str(e.name());
        }
        Ok(Model { name, spec })
    }

    /// Parse `--family` and `--with a,b` (effect names as in the physics catalogue).
    pub fn from_names(family: &str, with: &[String]) -> anyhow::Result<Model> {
        let family: Family = family.parse()?;
        let mut effects = Vec::new();
        for w in with.iter().flat_map(|s| s.split(',')).map(str::trim) {
            if w.is_empty() {
                continue;
            }
            let kind = EffectKind::from_name(w).ok_or_else(|| {
                anyhow::anyhow!(
                    "--with: unknown effect '{w}', expected one of {}",
                    EffectKind::names_for(family)
                )
            })?;
            effects.push(kind);
        }
        Model::from_family(family, &effects)
    }

    /// Read a model file.
    pub fn load(path: &Path) -> anyhow::Result<Model> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
        let mut model = Model::from_toml(&text, &origin)?;
        model.name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or(&origin)
            .to_string();
        Ok(model)
    }

    /// Parse model-file text; `origin` prefixes errors.
    pub fn from_toml(text: &str, origin: &str) -> anyhow::Result<Model> {
        let mut table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| anyhow::anyhow!("{origin}: {}", e.message()))?;
        let lab = table.remove("lab");
        let plant_text = toml::to_string(&table).map_err(|e| anyhow::anyhow!("{origin}: {e}"))?;
        let mut spec = PlantSpec::from_toml(&plant_text, origin)?;
        if let Some(lab) = lab {
            let lab = lab
                .as_table()
                .ok_or_else(|| anyhow::anyhow!("{origin}: [lab] must be a table"))?;
            // Terms first: `fixed` may name their parameters.
            if let Some(terms) = lab.get("term") {
                let list = terms.as_array().ok_or_else(|| {
                    anyhow::anyhow!("{origin}: [lab] term must be a list of [[lab.term]] tables")
                })?;
                for (i, item) in list.iter().enumerate() {
                    spec.add_term(term_from_toml(item, i, origin)?, origin)?;
                }
            }
            for (key, value) in lab {
                match key.as_str() {
                    "term" => {}
                    "fixed" => {
                        let list = value.as_array().ok_or_else(|| {
                            anyhow::anyhow!("{origin}: [lab] fixed must be a list of names")
                        })?;
                        for item in list {
                            let name = item.as_str().ok_or_else(|| {
                                anyhow::anyhow!(
                                    "{origin}: [lab] fixed: expected a string, got {item}"
                                )
                            })?;
                            spec.set_free(name, false).map_err(|_| {
                                anyhow::anyhow!(
                                    "{origin}: [lab] fixed: unknown parameter '{name}', expected \
                                     one of {}",
                                    spec.params()
                                        .iter()
                                        .map(|(n, _)| n.as_str())
                                        .collect::<Vec<_>>()
                                        .join(", ")
                                )
                            })?;
                        }
                    }
                    other => {
                        anyhow::bail!(
                            "{origin}: [lab] unknown key '{other}', expected fixed or term"
                        )
                    }
                }
            }
        }
        let name = format!(
            "{}{}",
            spec.family,
            spec.effect_names()
                .iter()
                .map(|e| format!("+{e}"))
                .collect::<String>()
        );
        Ok(Model { name, spec })
    }

    /// Model-file text that [`Model::from_toml`] reads back (fixed parameters in `[lab]`).
    pub fn to_toml(&self) -> String {
        let mut s = self.spec.to_toml();
        let fixed: Vec<String> = self
            .spec
            .params()
            .into_iter()
            .filter(|(n, p)| !p.free && !n.starts_with("sensor."))
            .map(|(n, _)| format!("\"{n}\""))
            .collect();
        s.push_str("\n[lab]\n");
        s.push_str(&format!("fixed = [{}]\n", fixed.join(", ")));
        for t in &self.spec.terms {
            s.push_str(&t.to_toml());
        }
        s
    }

    /// True when the model contains `kind`.
    pub fn has(&self, kind: EffectKind) -> bool {
        self.spec.effects.iter().any(|e| e.kind == kind)
    }

    /// Effects present.
    pub fn effects(&self) -> Vec<EffectKind> {
        self.spec.effects.iter().map(|e| e.kind).collect()
    }

    /// Free flag of a parameter (false when unknown).
    pub fn is_free(&self, qualified: &str) -> bool {
        self.spec
            .params()
            .iter()
            .any(|(n, p)| n == qualified && p.free)
    }

    /// Value of a parameter (NaN when unknown, which no caller asks for).
    pub fn value(&self, qualified: &str) -> f64 {
        self.spec.get(qualified).unwrap_or(f64::NAN)
    }
}

/// One `[[lab.term]]` table (the `index`-th): `name`, `force` (an expression over `y`, `v`, `u`,
/// `supply`, `t`, `pi` and its parameters), `params` (each `[min, max]`, or `{ min, max, value }`)
/// and `candidate` (default false: the term is part of the model).
fn term_from_toml(item: &toml::Value, index: usize, origin: &str) -> anyhow::Result<TermSpec> {
    let at = format!("{origin}: [[lab.term]] #{}", index + 1);
    let table = item
        .as_table()
        .ok_or_else(|| anyhow::anyhow!("{at}: must be a table"))?;
    let name = table
        .get("name")
        .and_then(toml::Value::as_str)
        .ok_or_else(|| anyhow::anyhow!("{at}: name must be a string"))?;
    let at = format!("{origin}: [[lab.term]] '{name}'");
    let force = table
        .get("force")
        .and_then(toml::Value::as_str)
        .ok_or_else(|| anyhow::anyhow!("{at}: force must be a string (an expression)"))?;
    let candidate = match table.get("candidate") {
        None => false,
        Some(v) => v
            .as_bool()
            .ok_or_else(|| anyhow::anyhow!("{at}: candidate must be true or false"))?,
    };
    for key in table.keys() {
        if !matches!(key.as_str(), "name" | "force" | "params" | "candidate") {
            anyhow::bail!("{at}: unknown key '{key}', expected name, force, params or candidate");
        }
    }
    let mut params = Vec::new();
    if let Some(list) = table.get("params") {
        let list = list
            .as_table()
            .ok_or_else(|| anyhow::anyhow!("{at}: params must be a table of name = [min, max]"))?;
        for (pname, v) in list {
            let bad = || {
                anyhow::anyhow!(
                    "{at}: params.{pname} must be [min, max] or {{ min, max, value }}, got {v}"
                )
            };
            let (min, max, value) = match v {
                toml::Value::Array(a) if a.len() == 2 => {
                    let lo = number(&a[0]).ok_or_else(bad)?;
                    let hi = number(&a[1]).ok_or_else(bad)?;
                    (lo, hi, 0.5 * (lo + hi))
                }
                toml::Value::Table(t) => {
                    let get = |k: &str| t.get(k).and_then(number);
                    let lo = get("min").ok_or_else(bad)?;
                    let hi = get("max").ok_or_else(bad)?;
                    (lo, hi, get("value").unwrap_or(0.5 * (lo + hi)))
                }
                _ => return Err(bad()),
            };
            params.push(TermParam {
                name: pname.clone(),
                min,
                max,
                value,
            });
        }
    }
    Ok(TermSpec::new(name, force, &params, candidate, origin)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_file_round_trip_keeps_fixed_flags() {
        let mut m = Model::from_names("solenoid", &["spring,coulomb".into()]).expect("model");
        m.spec.set_free("solenoid.mass_kg", false).expect("known");
        let text = m.to_toml();
        let back = Model::from_toml(&text, "m.toml").expect("reads back");
        assert!(!back.is_free("solenoid.mass_kg"));
        assert!(back.is_free("coulomb.coulomb_pos_n"));
        assert!(back.has(EffectKind::Spring));
    }

    #[test]
    fn every_example_model_loads() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("config/models");
        let mut seen = 0;
        for entry in std::fs::read_dir(&dir).expect("config/models exists") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "toml") {
                let m = Model::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                assert!(!m.effects().is_empty(), "{}", path.display());
                seen += 1;
            }
        }
        assert!(seen >= 4, "found {seen} models");
    }

    #[test]
    fn a_declared_term_is_read_written_and_read_back() {
        let text = "family = \"linear_axis\"\n[viscous]\n\n[lab]\nfixed = [\"cogging.pitch\"]\n\
                    [[lab.term]]\nname = \"cogging\"\n\
                    force = \"a*sin(2*pi*y/pitch) + b*cos(2*pi*y/pitch)\"\n\
                    params = { a = [-50, 50], b = [-50, 50], pitch = { min = 0.001, max = 0.05, value = 0.02 } }\n";
        let m = Model::from_toml(text, "m.toml").expect("reads");
        assert!(!m.is_free("cogging.pitch"));
        assert!(m.is_free("cogging.a"));
        assert_eq!(m.value("cogging.pitch"), 0.02);
        let back = Model::from_toml(&m.to_toml(), "back.toml").expect("reads back");
        assert_eq!(back.spec.terms, m.spec.terms);
        assert!(!back.is_free("cogging.pitch"));
        let err = Model::from_toml(
            "family = \"linear_axis\"\n[lab]\n[[lab.term]]\nname = \"c\"\nforce = \"a*y\"\nparams = { a = \"x\" }\n",
            "m.toml",
        )
        .unwrap_err();
        assert!(err.to_string().contains("params.a"), "{err}");
        let err = Model::from_toml(
            "family = \"linear_axis\"\n[lab]\n[[lab.term]]\nname = \"spring\"\nforce = \"a*y\"\nparams = { a = [0, 1] }\n",
            "m.toml",
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .starts_with("m.toml: [lab.term 'spring'] name"),
            "{err}"
        );
    }

    #[test]
    fn errors_name_the_key() {
        let err = Model::from_toml(
            "family = \"solenoid\"\n[lab]\nfixed = [\"solenoid.bogus\"]\n",
            "m.toml",
        )
        .unwrap_err();
        assert!(err.to_string().contains("solenoid.bogus"), "{err}");
        let err = Model::from_names("solenoid", &["backlash".into()]).unwrap_err();
        assert!(err.to_string().contains("backlash"), "{err}");
    }
}
