//! The search of an electromechanical axis: designs over the free choices of [`super::tune`]
//! (bandwidth, damping, the other poles' speed, the friction compensation's share, the
//! adaptation's speed), each predicted by running the daemon's own node on the fitted model and
//! judged against the given configuration as [`super::choice`] says.
//!
//! The search, stage by stage (each from the best so far):
//! 1. bandwidth: the drive-limited design of [`super::tune`] and eight bandwidths from the
//!    sampling's limit `0.1 / T0` down to 8 % of it (damping 1, other poles 3x faster);
//! 2. around the best bandwidth: 0.85x and 1.18x, then damping 0.7 and 1.4;
//! 3. the other poles 2x and 5x faster;
//! 4. the friction compensation's share `alpha` 0.25, 0.5 and 1 (where the axis has one);
//! 5. the adaptation gain 0.3x and 3x (where the axis adapts);
//! 6. the given controller with the rest tuned (friction, observer, estimation).

use std::path::Path;

use toml_edit::Value;

use super::axis::{chosen_axis, tune, Goal, TuneOptions, Tuning};
use super::choice::{Bench, Choice, Objective, Searcher};
use super::edit::Editor;
use super::fitted::Fitted;
use super::plant::design_parameters;
use super::predict::{plants, Tour};
use crate::daemon::config::{
    AdaptiveFrictionSection, AxisConfig, Config, ControllerSection, FrictionCompensationSection,
};
use crate::param_key;
use crate::physics::Family;

const CONTROLLER: &str = param_key!(AxisConfig, controller);
const FRICTION: &str = param_key!(AxisConfig, friction_compensation);
const ADAPTIVE: &str = param_key!(AxisConfig, adaptive_friction);

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

    /// `rms`, `settling`, `overshoot`, `steady`, `bandwidth`, or a design goal
    /// `bandwidth=30,damping=0.9`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "" | "rms" => Ok(Aim::Search(Objective::Rms)),
            "settling" => Ok(Aim::Search(Objective::Settling)),
            "overshoot" => Ok(Aim::Search(Objective::Overshoot)),
            "steady" => Ok(Aim::Search(Objective::Steady)),
            "bandwidth" => Ok(Aim::Design(Goal::default())),
            g if g.contains('=') => g.parse().map(Aim::Design),
            other => Err(format!(
                "--goal: {other:?} is none of rms, settling, overshoot, steady, bandwidth or a \
                 design goal such as bandwidth=30,damping=0.9"
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

/// The bench of an electromechanical axis: the tour, and the fitted plant at its estimate and
/// at the corners of the design parameters' intervals.
pub fn bench(
    fitted: &Fitted,
    config: &Config,
    config_path: &Path,
    axis: usize,
    objective: Objective,
    tour: Option<Tour>,
) -> anyhow::Result<Bench> {
    let tour = Tour::resolve(tour, config, axis, config_path)?;
    let family = fitted.model.spec.family;
    let names: Vec<String> = design_parameters(family)
        .iter()
        .map(|k| k.name(family))
        .collect();
    Ok(Bench {
        config_path: config_path.to_path_buf(),
        axis,
        tour,
        objective,
        plants: plants(fitted, &names),
        estimate: 1,
        scale: match family {
            Family::MotorGear => (1e6, "µrad"),
            _ => (1e6, "µm"),
        },
    })
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
) -> anyhow::Result<Choice<Tuning>> {
    let cfg_name = config_path.display().to_string();
    let config = Config::from_toml(config_text, config_path)?;
    let (axis, a) = chosen_axis(&config, options, &cfg_name)?;
    let bench = bench(fitted, &config, config_path, axis, aim.objective(), tour)?;
    let mut s = Searcher::new(&bench, &config)
        .map_err(|e| anyhow::anyhow!("{cfg_name} on {}: {e}", fitted.origin))?;
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
    let labelled = |t: &anyhow::Result<Tuning>, g: &Goal, what: &str| match t {
        Ok(t) => format!("{}{what}", label_of(g, t.bandwidth_rad_s)),
        Err(_) => format!("the design{what}"),
    };

    if let Aim::Design(goal) = aim {
        let t = design(goal);
        let label = labelled(&t, &goal, "");
        s.consider(t, label);
        return s.finish(&config);
    }
    // 1. Bandwidth.
    let base = Goal::default();
    let t = design(base);
    let label = labelled(&t, &base, " (the drive-limited design)");
    s.consider(t, label);
    let w_max = 0.1 / config.cycle.period_s;
    for share in [1.0, 0.7, 0.5, 0.35, 0.25, 0.18, 0.12, 0.08] {
        let g = Goal {
            bandwidth_rad_s: Some(w_max * share),
            ..base
        };
        s.consider(design(g), label_of(&g, w_max * share));
    }
    // 2. Around the best bandwidth, then its damping; 3. the other poles.
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
        let Some(from) = s.best().map(|(t, _)| Goal {
            bandwidth_rad_s: Some(t.bandwidth_rad_s),
            ..t.goal
        }) else {
            break;
        };
        for step in stage {
            let g = step(from);
            let w = g.bandwidth_rad_s.unwrap_or(0.0);
            if w > w_max * 1.0001 {
                continue;
            }
            s.consider(design(g), label_of(&g, w));
        }
    }
    // 4. The friction compensation's share; 5. the adaptation's speed.
    if let Some((t, label)) = s.best().map(|(t, l)| (t.clone(), l.to_string())) {
        let tuned = Config::from_toml(&t.text, config_path)?;
        if let Some(fc) = &tuned.axis[axis].friction_compensation {
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
                    "the search: the friction compensation's share with the least predicted \
                     error",
                );
                s.consider(e, format!("{label}, alpha {alpha}"));
            }
        }
    }
    if let Some((t, label)) = s.best().map(|(t, l)| (t.clone(), l.to_string())) {
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
                s.consider(e, format!("{label}, adaptation gain x{factor}"));
            }
        }
    }
    // 6. The given controller with the rest tuned.
    if let Some(t) = s.best().map(|(t, _)| t.clone()) {
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
        s.consider(e, "the given controller, the rest tuned".to_string());
    }
    s.finish(&config)
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
}
