//! The user's loop in one call: diagnose, add the effect named, refit, and again, until no
//! candidate is significant (or the error is not of the catalogue, or the record cannot decide
//! between candidates). Each rung of the ladder keeps the error before and after, the
//! held-out drop and the evidence that named it.

use serde::Serialize;

use super::collapse::refused;
use super::data::Dataset;
use super::diagnose::{diagnose, DiagnoseOptions};
use super::methods::held_at_bound_in;
use super::model::Model;
use super::predict::Prediction;
use super::regress::fit_spec;
use super::signals::Prepared;
use super::structure::Structure;

/// At most this many effects are added: a ladder longer than the catalogue's families allow
/// would be fitting noise, and each rung costs a whole diagnosis.
pub const MAX_STEPS: usize = 6;

/// One rung: the effect added and what it did.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Effect added.
    pub effect: String,
    /// NRMSE of the model before it (diagnosis criterion, free parameters refitted).
    pub nrmse_before: f64,
    /// NRMSE with it added and refitted, over the spread of the start's force to explain (the
    /// reference of every rung).
    pub nrmse: f64,
    /// Relative NRMSE drop on the held-out samples.
    pub holdout_improvement: f64,
    /// `BIC_with - BIC_before`.
    pub delta_bic: f64,
    /// The model after this rung, fitted on the training part, predicting the held-out
    /// motion ([`super::predict`]).
    pub prediction: Option<Prediction>,
    /// The effect's signature in the residual before it was added.
    pub evidence: String,
    /// A parameter this rung's fit held at a bound the record asks it to pass, and what was
    /// asked ([`super::methods::held_at_bound`]).
    pub held_at_bound: Option<String>,
    /// The model after this rung, fitted.
    #[serde(skip)]
    pub model: Model,
}

/// The ladder and the final model.
#[derive(Debug, Clone)]
pub struct Discovery {
    /// The model as given, fitted: the foot of the ladder.
    pub start: Model,
    /// NRMSE of the model as given (refitted).
    pub nrmse_base: f64,
    /// Effects added, in order.
    pub steps: Vec<Step>,
    /// NRMSE of the final model (refitted).
    pub nrmse_final: f64,
    /// The final model, fitted.
    pub model: Model,
    /// The final model, fitted on the training part, predicting the held-out motion: the last
    /// rung's, or the start's.
    pub prediction: Option<Prediction>,
    /// True when the loop stopped because nothing more was significant (not at [`MAX_STEPS`]).
    pub converged: bool,
    /// A rung the diagnosis named whose refit collapsed (see [`super::collapse`]): the effect
    /// and why it was not taken.
    pub refused: Option<(String, String)>,
    /// Structure the last diagnosis found in the residual that no candidate explains: the
    /// ladder stops there, as no effect of the catalogue is the answer.
    pub unexplained: Vec<Structure>,
    /// Candidates the last diagnosis could not tell apart, and the record that would: the
    /// ladder stops there rather than pick one by a hair ([`super::undecided`]).
    pub undecided: Vec<String>,
    pub separating_record: Option<String>,
    /// Why the final model cannot be written: a parameter its fit held at a bound the record
    /// asks it to pass ([`super::methods::held_at_bound`]).
    pub held_at_bound: Option<String>,
}

/// Run the loop from `model`. `progress(step, effect)` is called as rungs are added.
pub fn discover(
    model: &Model,
    data: &Dataset,
    d: &Prepared,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(usize, &str) + Sync),
) -> anyhow::Result<Discovery> {
    let mut current = model.clone();
    let mut steps: Vec<Step> = Vec::new();
    let mut nrmse_base = None;
    let (start, start_fit) = fit_spec(&model.spec, data, d, None)?;
    if let Some(why) = refused(
        &model.spec,
        &start,
        start_fit.nrmse,
        None,
        Some(&start_fit),
        data,
        d,
    )? {
        anyhow::bail!(
            "{}: the model as given does not fit this record: {why}",
            data.origin
        );
    }
    let start = Model {
        name: model.name.clone(),
        spec: start,
    };
    loop {
        let dg = diagnose(&current, data, d, opts, &|_, _, _| {})?;
        nrmse_base.get_or_insert(dg.nrmse_base);
        let next = dg.verdict.as_ref().and_then(|v| {
            dg.candidates
                .iter()
                .find(|c| &c.effect == v)
                .map(|c| (v.clone(), c.clone()))
        });
        // The final figure is the last rung's (or the start's) own refit: the same number the
        // ladder shows.
        let finish = |steps: Vec<Step>, refused, converged| {
            let (model, nrmse_final, prediction, held_at_bound) = match steps.last() {
                Some(s) => (
                    s.model.clone(),
                    s.nrmse,
                    s.prediction,
                    s.held_at_bound.clone(),
                ),
                None => (
                    start.clone(),
                    start_fit.nrmse,
                    dg.base_prediction,
                    held_at_bound_in(&model.spec, &start_fit),
                ),
            };
            Ok(Discovery {
                start: start.clone(),
                nrmse_base: nrmse_base.unwrap_or(dg.nrmse_base),
                steps,
                nrmse_final,
                model,
                prediction,
                converged,
                refused,
                unexplained: if dg.unexplained {
                    dg.residual_map.structures.clone()
                } else {
                    Vec::new()
                },
                undecided: dg.undecided.clone(),
                separating_record: dg.separating_record.clone(),
                held_at_bound,
            })
        };
        let Some((effect, c)) = next.filter(|_| steps.len() < MAX_STEPS) else {
            let converged = dg.verdict.is_none() && dg.undecided.is_empty();
            return finish(steps, None, converged);
        };
        let addition = super::diagnose::Addition::named(&current.spec, &effect)
            .map_err(|e| anyhow::anyhow!("the diagnosis named it: {e}"))?;
        progress(steps.len() + 1, &effect);
        let mut with = current.spec.clone();
        addition.add_to(&mut with)?;
        // As the diagnosis judged it: a body parameter that ran to its bound held.
        for name in &c.held {
            if let Some(v) = current.spec.get(name) {
                with.set(name, v)?;
                with.set_free(name, false)?;
            }
        }
        let (spec, fit) = fit_spec(&with, data, d, None)?;
        if let Some(why) = refused(
            &with,
            &spec,
            fit.nrmse,
            Some(&current.spec),
            Some(&fit),
            data,
            d,
        )? {
            return finish(steps, Some((effect, why)), false);
        }
        steps.push(Step {
            effect: effect.clone(),
            nrmse_before: steps.last().map_or(start_fit.nrmse, |s: &Step| s.nrmse),
            // On the start's reference, as every rung: an effect that reshapes the drive (a dead
            // zone) moves its own target, and over that its figure could rise while its
            // residual fell.
            nrmse: fit.nrmse_on(start_fit.reference()),
            holdout_improvement: c.holdout_improvement,
            delta_bic: c.delta_bic,
            prediction: c.prediction,
            evidence: c.evidence.clone(),
            held_at_bound: held_at_bound_in(&with, &fit),
            model: Model {
                name: format!("{}+{effect}", current.name),
                spec,
            },
        });
        current = steps[steps.len() - 1].model.clone();
    }
}

impl Discovery {
    /// Why the ladder stopped, in a sentence that starts with what it added (the text of
    /// `discover` and of the report's ladder).
    pub fn stopped_because(&self) -> String {
        let n = self.steps.len();
        if !self.unexplained.is_empty() {
            format!("{n} added, then stopped at structure no effect of the catalogue explains")
        } else if self.refused.is_some() {
            format!("{n} added, then stopped at a collapsed fit")
        } else if !self.undecided.is_empty() {
            format!(
                "{n} added, then stopped: the record cannot decide between {} ({})",
                self.undecided.join(", "),
                self.separating_record.as_deref().unwrap_or_default()
            )
        } else if n == 0 {
            "nothing added: no candidate improves the model significantly".to_string()
        } else if self.converged {
            format!("{n} added, then nothing more is significant")
        } else {
            format!("stopped after {n} steps (at most {MAX_STEPS})")
        }
    }

    /// The JSON of `discover --json`: `{"nrmse_base", "steps": [{"effect", "nrmse",
    /// "evidence", ...}], "with", "nrmse_final", ...}`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "nrmse_base": self.nrmse_base,
            "steps": self.steps,
            "with": self.model.effects().iter().map(|e| e.name()).collect::<Vec<_>>(),
            "nrmse_final": self.nrmse_final,
            "prediction": self.prediction,
            "converged": self.converged,
            "unexplained": self.unexplained,
            "undecided": (!self.undecided.is_empty()).then(|| serde_json::json!({
                "effects": self.undecided,
                "separated_by": self.separating_record,
            })),
            "refused": self.refused.as_ref().map(|(effect, why)| serde_json::json!({
                "effect": effect, "why": why})),
            "held_at_bound": self.held_at_bound,
        })
    }
}
