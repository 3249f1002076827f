//! The choice: designs over the free choices of [`super::tune`] (bandwidth, damping, the other
//! poles' speed, the friction compensation's share, the adaptation's speed), each predicted by
//! running the daemon's own node on the fitted model ([`super::predict`]); the best on the
//! objective, and the given configuration predicted the same way. A tuned configuration that
//! is not predicted better than the given one, at the estimate by a margin and at every corner
//! of the fitted intervals, is not chosen: the given one stays.
//!
//! The search, stage by stage (each from the best so far):
//! 1. bandwidth: the drive-limited design of [`super::tune`] and eight bandwidths from the
//!    sampling's limit `0.1 / T0` down to 8 % of it (damping 1, other poles 3x faster);
//! 2. around the best bandwidth: 0.85x and 1.18x, then damping 0.7 and 1.4;
//! 3. the other poles 2x and 5x faster;
//! 4. the friction compensation's share `alpha` 0.25, 0.5 and 1 (where the axis has one);
//! 5. the adaptation gain 0.3x and 3x (where the axis adapts);
//! 6. the given controller with the rest tuned (friction, observer, estimation).

use std::fmt;
use std::path::Path;

use toml_edit::Value;

use super::axis::{chosen_axis, tune, Goal, TuneOptions, Tuning};
use super::edit::Editor;
use super::fitted::Fitted;
use super::plant::design_parameters;
use super::predict::{plants, predict, Tour};
use crate::daemon::config::{
    AdaptiveFrictionSection, AxisConfig, Config, ControllerSection, FrictionCompensationSection,
};
use crate::lockstep::{SideBySide, TourFigures};
use crate::param_key;
use crate::physics::{Family, PlantSpec};

const CONTROLLER: &str = param_key!(AxisConfig, controller);
const FRICTION: &str = param_key!(AxisConfig, friction_compensation);
const ADAPTIVE: &str = param_key!(AxisConfig, adaptive_friction);

/// What the choice minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Objective {
    /// RMS following error over the tour.
    Rms,
    /// The slowest step's settling time (an unsettled step counts as its whole dwell).
    Settling,
    /// The largest overshoot, then the RMS error.
    Overshoot,
}

impl Objective {
    pub fn name(self) -> &'static str {
        match self {
            Objective::Rms => "rms",
            Objective::Settling => "settling",
            Objective::Overshoot => "overshoot",
        }
    }

    /// The figure minimised: smaller is better.
    pub fn score(self, f: &TourFigures, tour: &Tour) -> f64 {
        match self {
            Objective::Rms => f.rms_error,
            Objective::Settling => {
                f.worst_settling_s
                    .unwrap_or(0.0)
                    .max(if f.unsettled_steps > 0 {
                        tour.seconds
                    } else {
                        0.0
                    })
                    + tour.seconds * f.unsettled_steps as f64
            }
            // Overshoot in whole per mille first; the error breaks ties.
            Objective::Overshoot => (1e3 * f.worst_overshoot).round() + f.rms_error.min(0.999),
        }
    }
}

/// `--goal`: what `tune` chooses by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Aim {
    /// Search the design's free choices for the least of the objective on the tour.
    Search(Objective),
    /// The linear design of a given goal (`bandwidth=30,damping=0.9`) or, as `bandwidth`, the
    /// largest bandwidth whose linear prediction keeps the command within the drive's limits:
    /// one design, still predicted and held against the given configuration (on the RMS).
    Design(Goal),
}

impl Default for Aim {
    fn default() -> Self {
        Aim::Search(Objective::Rms)
    }
}

impl std::str::FromStr for Aim {
    type Err = String;

    /// `rms`, `settling`, `overshoot`, `bandwidth`, or a design goal `bandwidth=30,damping=0.9`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "" | "rms" => Ok(Aim::Search(Objective::Rms)),
            "settling" => Ok(Aim::Search(Objective::Settling)),
            "overshoot" => Ok(Aim::Search(Objective::Overshoot)),
            "bandwidth" => Ok(Aim::Design(Goal::default())),
            g if g.contains('=') => g.parse().map(Aim::Design),
            other => Err(format!(
                "--goal: {other:?} is none of rms, settling, overshoot, bandwidth or a design \
                 goal such as bandwidth=30,damping=0.9"
            )),
        }
    }
}

impl Aim {
    fn objective(self) -> Objective {
        match self {
            Aim::Search(o) => o,
            Aim::Design(_) => Objective::Rms,
        }
    }
}

/// Least relative improvement of the objective at the estimate for a tuned configuration to
/// replace the given one: the fitted model is not the plant.
pub const REQUIRED_GAIN: f64 = 0.1;

/// One design tried.
#[derive(Debug, Clone, PartialEq)]
pub struct Tried {
    pub label: String,
    /// The prediction at the estimate, or why there is none (the design failed).
    pub outcome: Result<TourFigures, String>,
}

/// The outcome of the choice.
#[derive(Debug, Clone)]
pub struct Choice {
    pub objective: Objective,
    pub tour: Tour,
    /// The plants predicted on: the estimate and the corners of the design parameters'
    /// intervals.
    pub plants: usize,
    pub given: TourFigures,
    /// The given configuration's worst objective over the corners, with its figures.
    pub given_worst: TourFigures,
    /// The best design found, at the estimate and its worst over the corners.
    pub best: Option<(Tuning, String, TourFigures, TourFigures)>,
    /// Designs tried, in order.
    pub tried: Vec<Tried>,
    /// Whether the best design replaces the given configuration, and why (not).
    pub accepted: bool,
    pub reason: String,
    /// Length per metre (radian) and its unit, for the report.
    pub scale: (f64, &'static str),
}

impl Choice {
    /// The configuration text to write: the tuned one when accepted, otherwise the given.
    pub fn text<'a>(&'a self, given: &'a str) -> &'a str {
        match (&self.best, self.accepted) {
            (Some((t, ..)), true) => &t.text,
            _ => given,
        }
    }

    pub fn tuning(&self) -> Option<&Tuning> {
        match (&self.best, self.accepted) {
            (Some((t, ..)), true) => Some(t),
            _ => None,
        }
    }

    pub fn tuning_mut(&mut self) -> Option<&mut Tuning> {
        match (&mut self.best, self.accepted) {
            (Some((t, ..)), true) => Some(t),
            _ => None,
        }
    }
}

/// Edit values of one axis of a tuned configuration: each a change noted with its origin, in
/// place of an earlier change of the same key.
fn edited(
    tuning: &Tuning,
    axis: usize,
    edits: &[(&str, &str, Value)],
    origin: &str,
) -> anyhow::Result<Tuning> {
    let doc: toml_edit::DocumentMut = tuning.text.parse()?;
    let mut ed = Editor::new(doc, axis);
    for (section, key, value) in edits {
        ed.set(section, key, value.clone(), origin);
    }
    let mut t = tuning.clone();
    t.text = ed.doc.to_string();
    let new: Vec<String> = ed.changes.iter().map(|c| c.key.clone()).collect();
    t.changes.retain(|c| !new.contains(&c.key));
    t.changes.extend(ed.changes);
    Ok(t)
}

fn f64_value(v: f64) -> Value {
    Value::from(super::edit::round_sig(v, 6))
}

fn list_value(v: &[f64]) -> Value {
    Value::Array(
        v.iter()
            .map(|x| super::edit::round_sig(*x, 10))
            .collect::<toml_edit::Array>(),
    )
}

/// Predictions of one configuration over several plants.
fn predict_all(
    config: &Config,
    axis: usize,
    plants: &[PlantSpec],
    tour: &Tour,
) -> anyhow::Result<Vec<TourFigures>> {
    plants
        .iter()
        .map(|p| predict(config, axis, p, tour))
        .collect()
}

/// Choose the configuration for axis `options.axis` of `config_text` on the fitted model: the
/// search of the module's documentation (one design for [`Aim::Design`]), each design predicted
/// on the tour, the given configuration predicted the same way.
pub fn choose(
    fitted: &Fitted,
    config_text: &str,
    config_path: &Path,
    options: &TuneOptions,
    aim: Aim,
    tour: Option<Tour>,
) -> anyhow::Result<Choice> {
    let cfg_name = config_path.display().to_string();
    let config = Config::from_toml(config_text, config_path)?;
    let (axis, a) = chosen_axis(&config, options, &cfg_name)?;
    let tour = match tour {
        Some(t) => t,
        None => Tour::of(&config, axis)?,
    };
    anyhow::ensure!(
        !tour.setpoints.is_empty(),
        "{cfg_name}: axis {:?} has no [[axis.setpoints]] to judge a design on: give a tour \
         (--tour FILE)",
        a.name
    );
    let objective = aim.objective();
    let family = fitted.model.spec.family;
    let names: Vec<String> = design_parameters(family)
        .iter()
        .map(|k| k.name(family))
        .collect();
    let plants = plants(fitted, &names);
    let estimate = &plants[..1];
    let tour_seconds = tour.clone();
    let score = |f: &TourFigures| objective.score(f, &tour_seconds);

    let given_all = predict_all(&config, axis, &plants, &tour)
        .map_err(|e| anyhow::anyhow!("{cfg_name} on {}: {e}", fitted.origin))?;
    let given = given_all[0];

    let mut tried: Vec<Tried> = Vec::new();
    // (tuning, label, prediction at the estimate)
    let mut best: Option<(Tuning, String, TourFigures)> = None;
    let period = config.cycle.period_s;
    let consider = |tuning: anyhow::Result<Tuning>,
                    label: String,
                    best: &mut Option<(Tuning, String, TourFigures)>,
                    tried: &mut Vec<Tried>| {
        let outcome = tuning.and_then(|t| {
            let c = Config::from_toml(&t.text, config_path)?;
            let f = predict_all(&c, axis, estimate, &tour)?[0];
            Ok((t, f))
        });
        match outcome {
            Ok((t, f)) => {
                tried.push(Tried {
                    label: label.clone(),
                    outcome: Ok(f),
                });
                let better = f.faults <= given.faults
                    && best.as_ref().is_none_or(|(_, _, b)| score(&f) < score(b));
                if better {
                    *best = Some((t, label, f));
                }
            }
            Err(e) => tried.push(Tried {
                label,
                outcome: Err(format!("{e:#}")),
            }),
        }
    };
    let searching = matches!(aim, Aim::Search(_));
    let design = |goal: Goal| {
        tune(
            fitted,
            config_text,
            config_path,
            &TuneOptions {
                goal,
                ..options.clone()
            },
        )
        .map(|mut t| {
            if searching && goal.bandwidth_rad_s.is_some() {
                t.bandwidth_reason =
                    "the search's, by the tour predicted on the fitted model".to_string();
            }
            t
        })
    };
    let label_of = |g: &Goal, w: f64| {
        format!(
            "{w:.1} rad/s, damping {}, other poles {}x faster",
            g.damping, g.fast
        )
    };

    match aim {
        Aim::Design(goal) => {
            let t = design(goal);
            let label = match &t {
                Ok(t) => label_of(&goal, t.bandwidth_rad_s),
                Err(_) => "the design goal".to_string(),
            };
            consider(t, label, &mut best, &mut tried);
        }
        Aim::Search(_) => {
            // 1. Bandwidth.
            let base = Goal::default();
            let t = design(base);
            let label = match &t {
                Ok(t) => format!(
                    "{} (the drive-limited design)",
                    label_of(&base, t.bandwidth_rad_s)
                ),
                Err(_) => "the drive-limited design".to_string(),
            };
            consider(t, label, &mut best, &mut tried);
            let w_max = 0.1 / period;
            for share in [1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.12, 0.08] {
                let g = Goal {
                    bandwidth_rad_s: Some(w_max * share),
                    ..base
                };
                consider(
                    design(g),
                    label_of(&g, w_max * share),
                    &mut best,
                    &mut tried,
                );
            }
            // 2. Around the best bandwidth, then its damping; 3. the other poles.
            let current = |best: &Option<(Tuning, String, TourFigures)>| {
                best.as_ref().map(|(t, ..)| Goal {
                    bandwidth_rad_s: Some(t.bandwidth_rad_s),
                    ..t.goal
                })
            };
            type Step = fn(Goal) -> Goal;
            let stages: [&[Step]; 3] = [
                &[
                    |g| Goal {
                        bandwidth_rad_s: g.bandwidth_rad_s.map(|w| w * 0.85),
                        ..g
                    },
                    |g| Goal {
                        bandwidth_rad_s: g.bandwidth_rad_s.map(|w| w * 1.18),
                        ..g
                    },
                ],
                &[
                    |g| Goal { damping: 0.7, ..g },
                    |g| Goal { damping: 1.4, ..g },
                ],
                &[|g| Goal { fast: 2.0, ..g }, |g| Goal { fast: 5.0, ..g }],
            ];
            for stage in stages {
                let Some(from) = current(&best) else { break };
                for step in stage {
                    let g = step(from);
                    let w = g.bandwidth_rad_s.unwrap_or(0.0);
                    if w > w_max * 1.0001 {
                        continue;
                    }
                    consider(design(g), label_of(&g, w), &mut best, &mut tried);
                }
            }
            // 4. The friction compensation's share; 5. the adaptation's speed.
            if let Some((t, label, _)) = best.clone() {
                let tuned = Config::from_toml(&t.text, config_path)?;
                let ta = &tuned.axis[axis];
                if let Some(fc) = &ta.friction_compensation {
                    for alpha in [0.25, 0.5, 1.0] {
                        if (alpha - fc.alpha).abs() < 1e-9 {
                            continue;
                        }
                        let e = edited(
                            &t,
                            axis,
                            &[(
                                FRICTION,
                                param_key!(FrictionCompensationSection, alpha),
                                f64_value(alpha),
                            )],
                            "the search: the friction compensation's share with the least \
                             predicted error",
                        );
                        consider(e, format!("{label}, alpha {alpha}"), &mut best, &mut tried);
                    }
                }
            }
            if let Some((t, label, _)) = best.clone() {
                let tuned = Config::from_toml(&t.text, config_path)?;
                if let Some(ad) = &tuned.axis[axis].adaptive_friction {
                    for factor in [0.3, 3.0] {
                        let e = edited(
                            &t,
                            axis,
                            &[(
                                ADAPTIVE,
                                param_key!(AdaptiveFrictionSection, adaptation_gain_per_m_s),
                                f64_value(ad.adaptation_gain_per_m_s * factor),
                            )],
                            "the search: the adaptation's speed with the least predicted error",
                        );
                        consider(
                            e,
                            format!("{label}, adaptation gain x{factor}"),
                            &mut best,
                            &mut tried,
                        );
                    }
                }
            }
            // 6. The given controller with the rest tuned.
            if let Some((t, ..)) = best.clone() {
                let mut edits = vec![
                    (
                        CONTROLLER,
                        param_key!(ControllerSection, q_per_m),
                        list_value(&a.controller.q_per_m),
                    ),
                    (
                        CONTROLLER,
                        param_key!(ControllerSection, p),
                        list_value(&a.controller.p),
                    ),
                ];
                if let Some(ad) = &a.adaptive_friction {
                    edits.push((
                        ADAPTIVE,
                        param_key!(AdaptiveFrictionSection, model_time_constant_s),
                        f64_value(ad.model_time_constant_s),
                    ));
                }
                let e = edited(
                    &t,
                    axis,
                    &edits,
                    "the given controller: no design predicted better with the rest tuned",
                );
                consider(
                    e,
                    "the given controller, the rest tuned".to_string(),
                    &mut best,
                    &mut tried,
                );
            }
        }
    }

    let scale = match family {
        Family::MotorGear => (1e6, "µrad"),
        _ => (1e6, "µm"),
    };
    // Without any design the model or the configuration cannot be designed from (intervals too
    // wide, a command the design does not know): the first design's reason says why.
    let Some((tuning, label, at_estimate)) = best else {
        if tried.iter().all(|t| t.outcome.is_err()) {
            let first = tried
                .iter()
                .find_map(|t| t.outcome.as_ref().err())
                .cloned()
                .unwrap_or_default();
            anyhow::bail!("{first}");
        }
        return Ok(Choice {
            objective,
            tour,
            plants: plants.len(),
            given,
            given_worst: worst(&given_all, &score),
            best: None,
            tried,
            accepted: false,
            reason: format!(
                "every design is predicted to latch more faults than the given configuration \
                 ({}): the given configuration stays",
                given.faults
            ),
            scale,
        });
    };
    // The best over the corners, each against the given at the same corner.
    let tuned_config = Config::from_toml(&tuning.text, config_path)?;
    let tuned_all = predict_all(&tuned_config, axis, &plants, &tour)?;
    let gain = 1.0 - score(&at_estimate) / score(&given).max(f64::MIN_POSITIVE);
    let corner_worse = tuned_all
        .iter()
        .zip(&given_all)
        .skip(1)
        .position(|(t, g)| score(t) > score(g) || t.faults > g.faults);
    let name = objective.name();
    let (accepted, reason) =
        if gain < REQUIRED_GAIN {
            (
                false,
                format!(
                "the best design ({label}) is predicted {} on the {name} objective than the given \
                 configuration ({:+.1} %; at least {:.0} % better is asked, the fitted model is \
                 not the plant): the given configuration stays",
                if gain < 0.0 { "worse" } else { "only a little better" },
                -100.0 * gain,
                100.0 * REQUIRED_GAIN
            ),
            )
        } else if let Some(k) = corner_worse {
            (
                false,
                format!(
                "the best design ({label}) is predicted {:.0} % better at the estimate but worse \
                 than the given configuration at corner {} of {} of the fitted intervals: the \
                 given configuration stays",
                100.0 * gain,
                k + 1,
                plants.len() - 1
            ),
            )
        } else {
            (
                true,
                format!(
                    "{label}: predicted {:.0} % better than the given configuration on the {name} \
                 objective, and not worse at any of the {} corners of the fitted intervals",
                    100.0 * gain,
                    plants.len() - 1
                ),
            )
        };
    Ok(Choice {
        objective,
        tour,
        plants: plants.len(),
        given,
        given_worst: worst(&given_all, &score),
        best: Some((tuning, label, at_estimate, worst(&tuned_all, &score))),
        tried,
        accepted,
        reason,
        scale,
    })
}

fn worst(all: &[TourFigures], score: &dyn Fn(&TourFigures) -> f64) -> TourFigures {
    all.iter()
        .copied()
        .max_by(|a, b| score(a).total_cmp(&score(b)))
        .unwrap_or(all[0])
}

impl fmt::Display for Choice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (s, u) = self.scale;
        writeln!(
            f,
            "predicted by running the daemon's node in lock step on the fitted model over the \
             tour ({} set-point changes, {:.1} s), at the estimate and at {} corners of the fitted \
             intervals; objective: {}",
            self.tour.setpoints.len(),
            self.tour.seconds,
            self.plants - 1,
            self.objective.name()
        )?;
        writeln!(f, "designs tried:")?;
        for t in &self.tried {
            match &t.outcome {
                Ok(x) => writeln!(
                    f,
                    "  {:<64} RMS {:>9.1} {u}, overshoot {:>5.1} %, faults {}",
                    t.label,
                    x.rms_error * s,
                    100.0 * x.worst_overshoot,
                    x.faults
                )?,
                Err(e) => writeln!(f, "  {:<64} not designed: {e}", t.label)?,
            }
        }
        let mut runs = vec![
            ("given", &self.given),
            ("given, worst corner", &self.given_worst),
        ];
        if let Some((_, _, at, worst)) = &self.best {
            runs.push(("tuned", at));
            runs.push(("tuned, worst corner", worst));
        }
        writeln!(f, "predicted on the tour:")?;
        write!(
            f,
            "{}",
            SideBySide {
                runs,
                scale: s,
                unit: u
            }
        )?;
        writeln!(f, "{}", self.reason)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goals_parse_and_name_what_is_wrong() {
        assert_eq!("".parse::<Aim>(), Ok(Aim::Search(Objective::Rms)));
        assert_eq!(
            "settling".parse::<Aim>(),
            Ok(Aim::Search(Objective::Settling))
        );
        assert_eq!("bandwidth".parse::<Aim>(), Ok(Aim::Design(Goal::default())));
        match "bandwidth=30,damping=0.9".parse::<Aim>() {
            Ok(Aim::Design(g)) => {
                assert_eq!(g.bandwidth_rad_s, Some(30.0));
                assert_eq!(g.damping, 0.9);
            }
            other => panic!("{other:?}"),
        }
        let err = "fastest".parse::<Aim>().expect_err("unknown");
        assert!(err.contains("fastest") && err.contains("settling"), "{err}");
    }

    #[test]
    fn an_unsettled_step_scores_worse_than_any_settled_one() {
        let tour = Tour {
            initial_setpoint_m: 0.0,
            setpoints: Vec::new(),
            seconds: 5.0,
        };
        let settled = TourFigures {
            rms_error: 1e-3,
            worst_settling_s: Some(0.9),
            unsettled_steps: 0,
            worst_overshoot: 0.0,
            steady_error: 0.0,
            saturation_s: 0.0,
            faults: 0,
            steps: 2,
        };
        let unsettled = TourFigures {
            worst_settling_s: Some(0.1),
            unsettled_steps: 1,
            ..settled
        };
        let o = Objective::Settling;
        assert!(o.score(&unsettled, &tour) > o.score(&settled, &tour));
        let over = TourFigures {
            worst_overshoot: 0.05,
            rms_error: 1e-6,
            ..settled
        };
        assert!(
            Objective::Overshoot.score(&over, &tour) > Objective::Overshoot.score(&settled, &tour)
        );
    }
}
