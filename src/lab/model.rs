//! Models: a plant family plus effects with parameter values, bounds and free/fixed flags, read
//! from a model file (`config/models/*.toml`) or assembled from `--family F --with a,b`.
//!
//! A model file is a plant file (see `config/plants/`) with an optional `[lab]` table:
//! `fixed = ["solenoid.mass_kg", ...]` lists the parameters the lab keeps fixed (all others are
//! free and refitted).

use std::path::Path;

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
            for (key, value) in lab {
                match key.as_str() {
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
                    other => anyhow::bail!("{origin}: [lab] unknown key '{other}', expected fixed"),
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
