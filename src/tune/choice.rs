//! Judging designs by prediction: every design and the given configuration run the tour on the
//! same fitted plants ([`Bench`]); the best design on the objective is chosen
//! ([`Searcher`]), and it replaces the given configuration only when it is predicted at least
//! [`REQUIRED_GAIN`] better at the estimate and not worse on any plant of the bench (each supply
//! point, each corner of the fitted intervals).

use std::fmt;
use std::path::PathBuf;

use super::axis::Tuning;
use super::pneumatic::PneumaticTuning;
use super::predict::{predict, BenchPlant, Tour};
use crate::daemon::config::Config;
use crate::lockstep::{SideBySide, TourFigures};

/// Least relative improvement of the objective at the estimate for a tuned configuration to
/// replace the given one: the fitted model is not the plant.
pub const REQUIRED_GAIN: f64 = 0.1;

/// What the choice minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Objective {
    /// RMS following error over the tour.
    Rms,
    /// The slowest step's settling time (an unsettled step counts as its whole dwell).
    Settling,
    /// The largest overshoot, then the RMS error.
    Overshoot,
    /// The error held at the end of each dwell (mean over the steps).
    Steady,
}

impl Objective {
    pub fn name(self) -> &'static str {
        match self {
            Objective::Rms => "rms",
            Objective::Settling => "settling",
            Objective::Overshoot => "overshoot",
            Objective::Steady => "steady",
        }
    }

    /// The figure minimised: smaller is better.
    pub fn score(self, f: &TourFigures, tour: &Tour) -> f64 {
        match self {
            Objective::Rms => f.rms_error,
            Objective::Settling => {
                let unsettled = f.unsettled_steps as f64;
                f.worst_settling_s
                    .unwrap_or(0.0)
                    .max(tour.seconds * unsettled.min(1.0))
                    + tour.seconds * unsettled
            }
            // Overshoot in whole per mille first; the error breaks ties.
            Objective::Overshoot => (1e3 * f.worst_overshoot).round() + f.rms_error.min(0.999),
            Objective::Steady => f.steady_error,
        }
    }
}

/// A tuning whose configuration text can be predicted.
pub trait Tuned: Clone {
    fn text(&self) -> &str;
}

impl Tuned for Tuning {
    fn text(&self) -> &str {
        &self.text
    }
}

impl Tuned for PneumaticTuning {
    fn text(&self) -> &str {
        &self.text
    }
}

/// What every design is judged on.
#[derive(Debug, Clone)]
pub struct Bench {
    pub config_path: PathBuf,
    pub axis: usize,
    pub tour: Tour,
    pub objective: Objective,
    /// The fitted plants: first the estimate (one, or one per supply point of a schedule), then
    /// the corners of the fitted intervals.
    pub plants: Vec<BenchPlant>,
    /// How many of `plants` are the estimate.
    pub estimate: usize,
    /// Length per metre (radian) and its unit, for the report.
    pub scale: (f64, &'static str),
}

impl Bench {
    /// The configuration run on the first `upto` plants.
    pub fn predict(&self, config: &Config, upto: usize) -> anyhow::Result<Vec<TourFigures>> {
        self.plants[..upto.min(self.plants.len())]
            .iter()
            .map(|p| predict(config, self.axis, p, &self.tour))
            .collect()
    }

    pub fn score(&self, f: &TourFigures) -> f64 {
        self.objective.score(f, &self.tour)
    }

    /// The objective over the estimate: the mean over its plants.
    pub fn score_estimate(&self, figures: &[TourFigures]) -> f64 {
        let n = self.estimate.min(figures.len()).max(1);
        figures.iter().take(n).map(|f| self.score(f)).sum::<f64>() / n as f64
    }

    fn faults(&self, figures: &[TourFigures]) -> usize {
        figures.iter().take(self.estimate).map(|f| f.faults).sum()
    }

    fn config(&self, text: &str) -> anyhow::Result<Config> {
        Ok(Config::from_toml(text, &self.config_path)?)
    }
}

/// One design tried.
#[derive(Debug, Clone, PartialEq)]
pub struct Tried {
    pub label: String,
    /// The prediction on the estimate's plants, or why there is none (the design failed).
    pub outcome: Result<Vec<TourFigures>, String>,
}

/// The designs tried so far and the best of them.
pub struct Searcher<'b, T> {
    bench: &'b Bench,
    /// The given configuration on the estimate's plants.
    given: Vec<TourFigures>,
    best: Option<(T, String, Vec<TourFigures>)>,
    tried: Vec<Tried>,
}

impl<'b, T: Tuned> Searcher<'b, T> {
    pub fn new(bench: &'b Bench, given: &Config) -> anyhow::Result<Self> {
        Ok(Searcher {
            bench,
            given: bench.predict(given, bench.estimate)?,
            best: None,
            tried: Vec::new(),
        })
    }

    /// Predict a design on the estimate; it becomes the best when its objective is less and it
    /// latches no more faults than the given configuration.
    pub fn consider(&mut self, design: anyhow::Result<T>, label: String) {
        let b = self.bench;
        let outcome = design.and_then(|t| {
            let c = b.config(t.text())?;
            let f = b.predict(&c, b.estimate)?;
            Ok((t, f))
        });
        match outcome {
            Ok((t, f)) => {
                self.tried.push(Tried {
                    label: label.clone(),
                    outcome: Ok(f.clone()),
                });
                let better = b.faults(&f) <= b.faults(&self.given)
                    && self
                        .best
                        .as_ref()
                        .is_none_or(|(_, _, x)| b.score_estimate(&f) < b.score_estimate(x));
                if better {
                    self.best = Some((t, label, f));
                }
            }
            Err(e) => self.tried.push(Tried {
                label,
                outcome: Err(format!("{e:#}")),
            }),
        }
    }

    /// The best design so far and its label.
    pub fn best(&self) -> Option<(&T, &str)> {
        self.best.as_ref().map(|(t, l, _)| (t, l.as_str()))
    }

    /// The choice: the best design against the given configuration on every plant of the
    /// bench. Without any design (each one failed), the first failure's reason is the error.
    pub fn finish(self, given: &Config) -> anyhow::Result<Choice<T>> {
        let b = self.bench;
        let given_all = b.predict(given, b.plants.len())?;
        let given_worst = worst(b, &given_all);
        let Some((tuning, label, at_estimate)) = self.best else {
            if self.tried.iter().all(|t| t.outcome.is_err()) {
                let first = self
                    .tried
                    .iter()
                    .find_map(|t| t.outcome.as_ref().err())
                    .cloned()
                    .unwrap_or_default();
                anyhow::bail!("{first}");
            }
            return Ok(Choice {
                bench: b.clone(),
                given: given_all[0],
                given_worst,
                best: None,
                tried: self.tried,
                accepted: false,
                reason: format!(
                    "every design is predicted to latch more faults than the given \
                     configuration ({}): the given configuration stays",
                    b.faults(&given_all)
                ),
            });
        };
        let tuned_all = b.predict(&b.config(tuning.text())?, b.plants.len())?;
        let gain = 1.0
            - b.score_estimate(&at_estimate) / b.score_estimate(&given_all).max(f64::MIN_POSITIVE);
        let worse_on = tuned_all
            .iter()
            .zip(&given_all)
            .position(|(t, g)| b.score(t) > b.score(g) || t.faults > g.faults);
        let name = b.objective.name();
        let others = b.plants.len() - 1;
        let (accepted, reason) = if gain < REQUIRED_GAIN {
            (
                false,
                format!(
                    "the best design ({label}) is predicted {} on the {name} objective than the \
                     given configuration ({:+.1} %; at least {:.0} % better is asked, the fitted \
                     model is not the plant): the given configuration stays",
                    if gain < 0.0 {
                        "worse"
                    } else {
                        "only a little better"
                    },
                    -100.0 * gain,
                    100.0 * REQUIRED_GAIN
                ),
            )
        } else if let Some(k) = worse_on {
            (
                false,
                format!(
                    "the best design ({label}) is predicted {:.0} % better at the estimate but \
                     worse than the given configuration on plant {} of {} (the estimate's first, \
                     then each supply point and corner of the fitted intervals): the given \
                     configuration stays",
                    100.0 * gain,
                    k + 1,
                    b.plants.len()
                ),
            )
        } else {
            (
                true,
                format!(
                    "{label}: predicted {:.0} % better than the given configuration on the \
                     {name} objective, and not worse on any of the {others} other plants (supply \
                     points and corners of the fitted intervals)",
                    100.0 * gain,
                ),
            )
        };
        Ok(Choice {
            bench: b.clone(),
            given: given_all[0],
            given_worst,
            best: Some((tuning, label, at_estimate[0], worst(b, &tuned_all))),
            tried: self.tried,
            accepted,
            reason,
        })
    }
}

fn worst(b: &Bench, all: &[TourFigures]) -> TourFigures {
    all.iter()
        .copied()
        .max_by(|x, y| b.score(x).total_cmp(&b.score(y)))
        .unwrap_or(all[0])
}

/// The outcome of the choice.
#[derive(Debug, Clone)]
pub struct Choice<T> {
    pub bench: Bench,
    /// The given configuration on the first plant of the estimate, and at its worst plant.
    pub given: TourFigures,
    pub given_worst: TourFigures,
    /// The best design found: its label, on the first plant of the estimate and at its worst.
    pub best: Option<(T, String, TourFigures, TourFigures)>,
    /// Designs tried, in order.
    pub tried: Vec<Tried>,
    /// Whether the best design replaces the given configuration, and why (not).
    pub accepted: bool,
    pub reason: String,
}

impl<T: Tuned> Choice<T> {
    /// The configuration text to write: the tuned one when accepted, otherwise the given.
    pub fn text<'a>(&'a self, given: &'a str) -> &'a str {
        self.tuning().map_or(given, Tuned::text)
    }

    pub fn tuning(&self) -> Option<&T> {
        match (&self.best, self.accepted) {
            (Some((t, ..)), true) => Some(t),
            _ => None,
        }
    }

    pub fn tuning_mut(&mut self) -> Option<&mut T> {
        match (&mut self.best, self.accepted) {
            (Some((t, ..)), true) => Some(t),
            _ => None,
        }
    }
}

impl<T> fmt::Display for Choice<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let b = &self.bench;
        let (s, u) = b.scale;
        let corners = b.plants.len() - b.estimate;
        writeln!(
            f,
            "predicted by running the daemon's node in lock step on the fitted model over the \
             tour ({} set-point changes, {:.1} s), at the estimate{} and at {corners} corners of \
             the fitted intervals; objective: {}",
            b.tour.setpoints.len(),
            b.tour.seconds,
            if b.estimate > 1 {
                format!(" (at {} supply points)", b.estimate)
            } else {
                String::new()
            },
            b.objective.name()
        )?;
        writeln!(f, "designs tried:")?;
        for t in &self.tried {
            match &t.outcome {
                Ok(x) if b.estimate > 1 => writeln!(
                    f,
                    "  {:<64} RMS {:>9.1} {u}, steady {:.1} {u} (means over the supply points), \
                     faults {}",
                    t.label,
                    x.iter().map(|y| y.rms_error).sum::<f64>() * s / x.len() as f64,
                    x.iter().map(|y| y.steady_error).sum::<f64>() * s / x.len() as f64,
                    x.iter().map(|y| y.faults).sum::<usize>()
                )?,
                Ok(x) => writeln!(
                    f,
                    "  {:<64} RMS {:>9.1} {u}, overshoot {:>5.1} %, steady {:.1} {u}, faults {}",
                    t.label,
                    x[0].rms_error * s,
                    100.0 * x[0].worst_overshoot,
                    x[0].steady_error * s,
                    x[0].faults
                )?,
                Err(e) => writeln!(f, "  {:<64} not designed: {e}", t.label)?,
            }
        }
        let mut runs = vec![
            ("given", &self.given),
            ("given, worst plant", &self.given_worst),
        ];
        if let Some((_, _, at, worst)) = &self.best {
            runs.push(("tuned", at));
            runs.push(("tuned, worst plant", worst));
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
