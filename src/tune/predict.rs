//! The prediction of a configuration on a fitted model: the daemon's own node (controller,
//! anti-windup, friction compensation and its adaptation, dither, schedule, supervision) runs
//! the tour in lock step against the fitted plant, and the run's figures are what `tune`
//! chooses by. The margins of a linear design say nothing about saturation, stick-slip or the
//! adaptation; this run sees them as the daemon will.

use std::path::Path;

use serde::Deserialize;

use super::fitted::Fitted;
use crate::daemon::config::{Config, SetpointStep};
use crate::lockstep::{LockStep, TourFigures};
use crate::physics::{Fault, FaultKind, PlantSpec, ScheduledFault};

/// The set-points a configuration is judged on: the axis' own `[[axis.setpoints]]` or a tour
/// file (`--tour`).
#[derive(Debug, Clone, PartialEq)]
pub struct Tour {
    pub initial_setpoint_m: f64,
    pub setpoints: Vec<SetpointStep>,
    /// Length of the run from the start, s.
    pub seconds: f64,
}

/// A tour file: the axis' keys, and the run's length.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TourFile {
    initial_setpoint_m: f64,
    setpoints: Vec<TourStep>,
    seconds: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TourStep {
    at_s: f64,
    position_m: f64,
}

/// The run's default length: the last step's time and the longest dwell of the tour after it
/// (at least one second), so the last step is judged as long as the others.
fn default_seconds(setpoints: &[SetpointStep]) -> f64 {
    let dwell = setpoints
        .windows(2)
        .map(|w| w[1].at_s - w[0].at_s)
        .fold(1.0, f64::max);
    setpoints.last().map_or(0.0, |s| s.at_s) + dwell
}

impl Tour {
    /// The axis' configured tour.
    pub fn of(config: &Config, axis: usize) -> anyhow::Result<Tour> {
        let a = config
            .axis
            .get(axis)
            .ok_or_else(|| anyhow::anyhow!("no axis #{axis}"))?;
        Ok(Tour {
            initial_setpoint_m: a.initial_setpoint_m,
            setpoints: a.setpoints.clone(),
            seconds: default_seconds(&a.setpoints),
        })
    }

    /// A tour file: `initial_setpoint_m`, `[[setpoints]]` with `at_s` and `position_m`, and
    /// optionally `seconds`.
    pub fn load(path: &Path) -> anyhow::Result<Tour> {
        let name = path.display();
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("{name}: cannot read: {e}"))?;
        let file: TourFile = toml::from_str(&text).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
        let mut last = 0.0;
        for (j, s) in file.setpoints.iter().enumerate() {
            anyhow::ensure!(
                s.at_s.is_finite() && s.at_s >= last && s.position_m.is_finite(),
                "{name}: setpoints #{}: at_s must be finite, >= 0 and not earlier than the one \
                 before, position_m finite (got at_s = {}, position_m = {})",
                j + 1,
                s.at_s,
                s.position_m
            );
            last = s.at_s;
        }
        anyhow::ensure!(
            !file.setpoints.is_empty(),
            "{name}: a tour needs at least one [[setpoints]]"
        );
        let setpoints: Vec<SetpointStep> = file
            .setpoints
            .iter()
            .map(|s| SetpointStep {
                at_s: s.at_s,
                position_m: s.position_m,
            })
            .collect();
        let seconds = file.seconds.unwrap_or_else(|| default_seconds(&setpoints));
        anyhow::ensure!(
            seconds.is_finite() && seconds > last,
            "{name}: seconds = {seconds} must come after the last step at {last} s"
        );
        Ok(Tour {
            initial_setpoint_m: file.initial_setpoint_m,
            setpoints,
            seconds,
        })
    }

    /// The tour a design of axis `axis` is judged on: `given` (`--tour FILE`) or the axis' own
    /// set-points; an axis without any is refused, naming the file.
    pub fn resolve(
        given: Option<Tour>,
        config: &Config,
        axis: usize,
        config_path: &Path,
    ) -> anyhow::Result<Tour> {
        let tour = match given {
            Some(t) => t,
            None => Tour::of(config, axis)?,
        };
        anyhow::ensure!(
            !tour.setpoints.is_empty(),
            "{}: axis {:?} has no [[axis.setpoints]] to judge a design on: give a tour (--tour \
             FILE)",
            config_path.display(),
            config.axis.get(axis).map_or("", |a| a.name.as_str())
        );
        Ok(tour)
    }

    /// `config` reduced to axis `axis` running this tour: what the lock step runs.
    pub fn apply(&self, config: &Config, axis: usize) -> anyhow::Result<Config> {
        let mut c = config.clone();
        anyhow::ensure!(axis < c.axis.len(), "no axis #{axis}");
        let mut a = c.axis.swap_remove(axis);
        a.initial_setpoint_m = self.initial_setpoint_m;
        a.setpoints = self.setpoints.clone();
        c.axis = vec![a];
        Ok(c)
    }
}

/// A fitted plant as the bench runs it: the model, and the supply it runs at as a share of the
/// model's own (a schedule's supply point).
#[derive(Debug, Clone)]
pub struct BenchPlant {
    pub spec: PlantSpec,
    pub supply_share: f64,
}

impl From<PlantSpec> for BenchPlant {
    fn from(spec: PlantSpec) -> Self {
        BenchPlant {
            spec,
            supply_share: 1.0,
        }
    }
}

/// Run `config`'s axis `axis` over the tour against `plant`; the figures of the run.
pub fn predict(
    config: &Config,
    axis: usize,
    plant: &BenchPlant,
    tour: &Tour,
) -> anyhow::Result<TourFigures> {
    let c = tour.apply(config, axis)?;
    // The supply from the start: the plant's supply scaled as `sim --fault supply_xK@0s` does.
    let faults = if plant.supply_share == 1.0 {
        Vec::new()
    } else {
        vec![ScheduledFault {
            at_s: 0.0,
            fault: Fault {
                kind: FaultKind::Supply(plant.supply_share),
                ramp_s: 0.0,
            },
        }]
    };
    let mut rig = LockStep::new(&c, plant.spec.build()?, faults)?;
    let mut records = Vec::with_capacity((tour.seconds / c.cycle.period_s) as usize + 1);
    rig.run(tour.seconds, &mut |s| records.push(s.record));
    TourFigures::of(&records, &c.axis[0])
        .ok_or_else(|| anyhow::anyhow!("the tour has no record after its first step"))
}

/// The fitted plant at its estimate and at the corners of the intervals of `names` (the
/// estimate first). A corner past a parameter's physical range (an interval of a small damping
/// reaching below zero) is taken at the range's edge, or at the estimate where the edge itself
/// is excluded.
pub fn plants(fitted: &Fitted, names: &[String]) -> Vec<BenchPlant> {
    let mut out = vec![BenchPlant::from(fitted.model.spec.clone())];
    for corner in super::plant::corners(fitted, names) {
        let mut spec = fitted.model.spec.clone();
        for (n, v) in &corner {
            if spec.set(n, *v).is_ok() {
                continue;
            }
            let edge = spec
                .params()
                .into_iter()
                .find(|(q, _)| q == n)
                .map(|(_, p)| v.clamp(p.def.min, p.def.max));
            if let Some(edge) = edge {
                // Excluded edges keep the estimate.
                let _ = spec.set(n, edge);
            }
        }
        out.push(spec.into());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::Family;

    fn reference() -> Config {
        let b = crate::defaults::config(Family::Solenoid);
        Config::from_toml(b.text, Path::new(b.path)).expect("reference configuration")
    }

    #[test]
    fn the_configured_tour_is_judged_one_dwell_past_its_last_step() {
        let tour = Tour::of(&reference(), 0).expect("tour");
        // config/solenoid.toml: steps at 1, 2, 3 and 4 s.
        assert_eq!(tour.setpoints.len(), 4);
        assert!((tour.seconds - 5.0).abs() < 1e-12, "{}", tour.seconds);
    }

    #[test]
    fn a_tour_file_is_read_and_a_broken_one_named() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("tour.toml");
        std::fs::write(
            &path,
            "initial_setpoint_m = 0.002\n[[setpoints]]\nat_s = 0.5\nposition_m = 0.004\n\
             [[setpoints]]\nat_s = 2.5\nposition_m = 0.003\n",
        )
        .expect("written");
        let tour = Tour::load(&path).expect("tour");
        assert_eq!(tour.setpoints.len(), 2);
        assert!((tour.seconds - 4.5).abs() < 1e-12, "{}", tour.seconds);
        std::fs::write(
            &path,
            "initial_setpoint_m = 0.0\n[[setpoints]]\nat_s = 2.0\nposition_m = 0.004\n\
             [[setpoints]]\nat_s = 1.0\nposition_m = 0.003\n",
        )
        .expect("written");
        let err = Tour::load(&path).expect_err("backwards").to_string();
        assert!(
            err.contains("tour.toml") && err.contains("setpoints #2"),
            "{err}"
        );
    }

    #[test]
    fn the_prediction_on_the_reference_plant_is_the_reference_run() {
        // The reference configuration on its own plant settles every step of its tour.
        let config = reference();
        let b = crate::defaults::plant(Family::Solenoid);
        let plant = PlantSpec::from_toml(b.text, b.path).expect("plant");
        let tour = Tour::of(&config, 0).expect("tour");
        let plant = BenchPlant::from(plant);
        let f = predict(&config, 0, &plant, &tour).expect("prediction");
        assert_eq!(f.steps, 4);
        assert_eq!(f.faults, 0);
        // The 0.2 mm step ends in stick-slip some 20 µm off (the paper's 25-50 µm), outside
        // a band of 5 % of it; the others settle.
        assert!(f.unsettled_steps <= 1, "{f:?}");
        // A PIDT1 at 400 Hz on a 25 mm drive: the 15 mm step takes a few hundred ms.
        let settling = f.worst_settling_s.expect("settled");
        assert!(settling > 0.02 && settling < 0.8, "{f:?}");
        // Slower by a factor of ten in the controller's gain, the same tour tracks worse.
        let mut slow = config.clone();
        for q in &mut slow.axis[0].controller.q_per_m {
            *q *= 0.1;
        }
        let g = predict(&slow, 0, &plant, &tour).expect("prediction");
        assert!(g.rms_error > 1.5 * f.rms_error, "{g:?} against {f:?}");
    }
}
