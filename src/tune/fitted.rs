//! A fitted model as `actuator fit` writes it: the model file with each estimated parameter's
//! 95 % interval in its header comments (`# name = value, 95 % interval [low, high]`).

use std::collections::BTreeMap;
use std::path::Path;

use crate::lab::Model;

/// The model and the intervals its file carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    pub model: Model,
    /// 95 % interval per qualified parameter name; a parameter without one was not estimated
    /// (fixed, kept or at a bound).
    pub intervals: BTreeMap<String, (f64, f64)>,
    /// File name, for messages.
    pub origin: String,
}

impl Fitted {
    pub fn load(path: &Path) -> anyhow::Result<Fitted> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("{origin}: cannot read: {e}"))?;
        Fitted::from_text(&text, &origin)
    }

    pub fn from_text(text: &str, origin: &str) -> anyhow::Result<Fitted> {
        let model = Model::from_toml(text, origin)?;
        let mut intervals = BTreeMap::new();
        for (n, line) in text.lines().enumerate() {
            let Some(rest) = line.strip_prefix('#') else {
                continue;
            };
            let Some((name, rest)) = rest.split_once(" = ") else {
                continue;
            };
            let Some((_, range)) = rest.split_once("95 % interval [") else {
                continue;
            };
            let name = name.trim();
            let parse = |s: &str| s.trim().parse::<f64>().ok().filter(|v| v.is_finite());
            let bounds = range
                .trim_end()
                .strip_suffix(']')
                .and_then(|r| r.split_once(','))
                .and_then(|(lo, hi)| Some((parse(lo)?, parse(hi)?)))
                .filter(|(lo, hi)| lo <= hi)
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "{origin}:{}: interval of {name} is not [low, high]: {line}",
                        n + 1
                    )
                })?;
            if model.spec.get(name).is_none() {
                anyhow::bail!(
                    "{origin}:{}: interval for {name}, which the model does not have",
                    n + 1
                );
            }
            intervals.insert(name.to_string(), bounds);
        }
        Ok(Fitted {
            model,
            intervals,
            origin: origin.to_string(),
        })
    }

    /// Value of a parameter of the model, if it has it.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.model.spec.get(name)
    }

    /// Half the interval's width relative to the value (`None` without an interval).
    pub fn relative_spread(&self, name: &str) -> Option<f64> {
        let (lo, hi) = *self.intervals.get(name)?;
        let v = self.get(name)?;
        Some(0.5 * (hi - lo) / v.abs().max(f64::MIN_POSITIVE))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FITTED: &str = "# Fitted by `actuator fit` on run.csv\n\
        # solenoid.mass_kg = 1.0e0, 95 % interval [9.0e-1, 1.2e0]\n\
        family = \"solenoid\"\n[solenoid]\nmass_kg = 1.0\n[spring]\nstiffness_n_per_m = 1000.0\n";

    #[test]
    fn reads_the_intervals_of_the_header() {
        let f = Fitted::from_text(FITTED, "f.toml").expect("reads");
        assert_eq!(f.intervals.get("solenoid.mass_kg"), Some(&(0.9, 1.2)));
        assert!((f.relative_spread("solenoid.mass_kg").expect("spread") - 0.15).abs() < 1e-12);
        assert_eq!(f.relative_spread("spring.stiffness_n_per_m"), None);
    }

    #[test]
    fn a_broken_interval_names_the_line() {
        let text = FITTED.replace("[9.0e-1, 1.2e0]", "[9.0e-1 1.2e0]");
        let err = Fitted::from_text(&text, "f.toml").expect_err("broken");
        assert!(err.to_string().contains("f.toml:2"), "{err}");
        let text = FITTED.replace("solenoid.mass_kg =", "coulomb.coulomb_pos_n =");
        let err = Fitted::from_text(&text, "f.toml").expect_err("unknown");
        assert!(err.to_string().contains("coulomb.coulomb_pos_n"), "{err}");
    }
}
