//! The search of a pneumatic axis: its supply schedule tuned ([`super::tune_pneumatic`]) for
//! the closed-loop pole the configuration gives its slower direction and for the poles 0.1 to
//! 0.7, each predicted by running the daemon's node on the fitted model at every supply point
//! of the schedule (the mean of the objective over them is what is minimised) and judged
//! against the given configuration as [`super::choice`] says, also at the corners of the drive
//! gains' intervals.

use std::path::Path;

use super::axis::{chosen_axis, TuneOptions};
use super::choice::{Bench, Choice, Objective, Searcher};
use super::fitted::Fitted;
use super::keys::PNEUMATIC_SUPPLY;
use super::pneumatic::{tune_pneumatic_at, PneumaticTuning, DRIVE_GAINS};
use super::predict::{plants, BenchPlant, Tour};
use crate::daemon::config::Config;
use crate::physics::Family;

/// Closed-loop poles of the slower direction the search tries beside the configuration's.
pub const POLES: [f64; 7] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7];

/// Choose the schedule of the pneumatic axis `options.axis` of `config_text` on the fitted model.
pub fn choose_pneumatic(
    fitted: &Fitted,
    config_text: &str,
    config_path: &Path,
    options: &TuneOptions,
    objective: Objective,
    tour: Option<Tour>,
) -> anyhow::Result<Choice<PneumaticTuning>> {
    let cfg_name = config_path.display().to_string();
    let config = Config::from_toml(config_text, config_path)?;
    let (axis, a) = chosen_axis(&config, options, &cfg_name)?;
    let tour = Tour::resolve(tour, &config, axis, config_path)?;
    // The estimate at every supply point the schedule names (the model's own supply without
    // one), then the corners of the drive gains' intervals at the model's supply.
    let supply = fitted
        .get(&PNEUMATIC_SUPPLY.name(Family::Pneumatic))
        .filter(|p| *p > 0.0)
        .ok_or_else(|| anyhow::anyhow!("{}: no supply pressure", fitted.origin))?;
    let points = a
        .schedule
        .as_ref()
        .and_then(|s| s.supply_pressure_pa.clone())
        .unwrap_or_default();
    let names: Vec<String> = DRIVE_GAINS
        .iter()
        .map(|k| k.name(Family::Pneumatic))
        .collect();
    let mut all = plants(fitted, &names);
    let corners = all.split_off(1);
    let mut estimate: Vec<BenchPlant> = points
        .iter()
        .map(|p| BenchPlant {
            spec: fitted.model.spec.clone(),
            supply_share: p / supply,
        })
        .collect();
    if estimate.is_empty() {
        estimate = all;
    }
    let n = estimate.len();
    estimate.extend(corners);
    let bench = Bench {
        config_path: config_path.to_path_buf(),
        axis,
        tour,
        objective,
        plants: estimate,
        estimate: n,
        scale: (1e6, "µm"),
    };
    let mut s = Searcher::new(&bench, &config)
        .map_err(|e| anyhow::anyhow!("{cfg_name} on {}: {e}", fitted.origin))?;
    let design = |pole| tune_pneumatic_at(fitted, config_text, config_path, options, pole);
    s.consider(
        design(None),
        "the configuration's closed-loop pole for the fitted drive".to_string(),
    );
    for z in POLES {
        s.consider(
            design(Some(z)),
            format!("closed-loop pole {z} (slower direction)"),
        );
    }
    s.finish(&config)
}
