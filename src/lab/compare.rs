//! Compare a model with measurements in one of three prediction modes, and say which.
//!
//! - `free_run`: the physics plant simulated on the measured command alone, from rest, shifted
//!   to the first measured position. Honest for stable plants in open loop; an integrating
//!   plant in closed loop drifts, so its free-run error says little.
//! - `k_step`: `k`-step-ahead prediction of the position from the measured state (filtered
//!   position and velocity at `k0`), with the model's acceleration from its balance of forces.
//! - `inverse_dynamics`: equation error of the balance of forces on filtered derivatives (force
//!   units), the standard for robot and machine-axis identification; works in closed loop.

use std::fmt;

use serde::Serialize;

use super::data::Dataset;
use super::model::Model;
use super::regress::{balance, fit_spec, IdFit};
use super::signals::{prepare, Prepared};
use crate::ident::{nrmse, rmse};

/// A prediction mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Simulate the physics plant on the measured command.
    FreeRun,
    /// Predict `k` samples ahead from the measured state.
    KStep,
    /// Equation error of the balance of forces.
    InverseDynamics,
}

impl Mode {
    /// Every mode, as the command line lists them.
    pub const ALL: [Mode; 3] = [Mode::FreeRun, Mode::KStep, Mode::InverseDynamics];

    /// The mode's name as printed and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Mode::FreeRun => "free_run",
            Mode::KStep => "k_step",
            Mode::InverseDynamics => "inverse_dynamics",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A model's prediction against a measured quantity.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// The mode the numbers come from.
    pub mode: Mode,
    /// What is compared, e.g. "position" or "drive force".
    pub quantity: String,
    /// Its unit.
    pub unit: String,
    /// Sample index of each value.
    pub index: Vec<usize>,
    /// Measured values.
    pub measured: Vec<f64>,
    /// Model values.
    pub predicted: Vec<f64>,
    /// Fit in percent, `100 (1 - NRMSE)`.
    pub fit: f64,
    /// RMSE over the standard deviation of the measured quantity.
    pub nrmse: f64,
    /// RMSE in `unit`.
    pub rmse: f64,
    /// A note on how the numbers were made.
    pub note: String,
}

impl Comparison {
    /// Residuals `measured - predicted`.
    pub fn residual(&self) -> Vec<f64> {
        self.measured
            .iter()
            .zip(&self.predicted)
            .map(|(m, p)| m - p)
            .collect()
    }

    fn from_series(
        mode: Mode,
        quantity: &str,
        unit: &str,
        index: Vec<usize>,
        measured: Vec<f64>,
        predicted: Vec<f64>,
        note: String,
    ) -> anyhow::Result<Comparison> {
        if measured.is_empty() {
            anyhow::bail!("{mode}: no samples to compare (is the actuator moving?)");
        }
        let score = PartScore::of(&measured, &predicted)?;
        Ok(Comparison {
            mode,
            quantity: quantity.to_string(),
            unit: unit.to_string(),
            fit: score.fit,
            nrmse: score.nrmse,
            rmse: score.rmse,
            index,
            measured,
            predicted,
            note,
        })
    }
}

/// Units of position and force of a model.
pub fn units(model: &Model) -> (&'static str, &'static str) {
    if model.spec.family.is_rotary() {
        ("rad", "N·m")
    } else {
        ("m", "N")
    }
}

/// Compare `model` with `data` in `mode`; `k` is the horizon of `k_step` in samples.
pub fn compare(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
    mode: Mode,
    k: usize,
) -> anyhow::Result<Comparison> {
    let (pos_unit, force_unit) = units(model);
    match mode {
        Mode::FreeRun => free_run(model, data, pos_unit),
        Mode::InverseDynamics => {
            let fit = balance(&model.spec, data, prep)?.evaluate();
            if let Some(why) = fit.degenerate() {
                anyhow::bail!(
                    "{}: the balance of model {}: {why}",
                    data.origin,
                    model.name
                );
            }
            id_comparison(&fit, force_unit, "model parameters as given")
        }
        Mode::KStep => k_step(model, data, prep, k.max(1), pos_unit),
    }
}

/// A comparison from an inverse-dynamics fit.
pub fn id_comparison(fit: &IdFit, unit: &str, note: &str) -> anyhow::Result<Comparison> {
    let predicted: Vec<f64> = fit
        .target
        .iter()
        .zip(&fit.residual)
        .map(|(t, r)| t - r)
        .collect();
    Comparison::from_series(
        Mode::InverseDynamics,
        "drive force",
        unit,
        fit.index.clone(),
        fit.target.clone(),
        predicted,
        format!("{note}; moving samples only (standstill excluded)"),
    )
}

fn free_run(model: &Model, data: &Dataset, unit: &str) -> anyhow::Result<Comparison> {
    let n = data.len();
    let mut predicted = Vec::with_capacity(n);
    let segments = data.segments();
    let mut shifts = Vec::with_capacity(segments.len());
    // Each continuous stretch is simulated from rest, shifted to its first sample: nothing is
    // known of the plant across a gap.
    for r in &segments {
        let mut plant = model.spec.build_named(&model.name)?;
        let start = plant.truth().position;
        let shift = data.output[r.start] - start;
        shifts.push(shift);
        predicted.push(start + shift);
        for k in r.start + 1..r.end {
            if let Some(s) = &data.supply {
                plant.set_supply(s[k - 1]);
            }
            plant.step(data.input[k - 1], data.time[k] - data.time[k - 1]);
            predicted.push(plant.truth().position + shift);
        }
    }
    let note = match shifts.as_slice() {
        [one] => format!("simulated from rest, shifted by {one:.3e} {unit} to the first sample"),
        many => format!(
            "each of {} stretches simulated from rest, shifted to its first sample",
            many.len()
        ),
    };
    Comparison::from_series(
        Mode::FreeRun,
        "position",
        unit,
        (0..n).collect(),
        data.output.clone(),
        predicted,
        note,
    )
}

/// Acceleration of the model at the measured state, `a = -Σ_{j≠inertia} θ_j φ_j(k) / m`, for
/// every sample.
pub fn model_acceleration(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
) -> anyhow::Result<Vec<f64>> {
    super::predict::acceleration(&balance(&model.spec, data, prep)?)
        .ok_or_else(|| anyhow::anyhow!("k_step needs a mass > 0"))
}

fn k_step(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
    k: usize,
    unit: &str,
) -> anyhow::Result<Comparison> {
    let acc = model_acceleration(model, data, prep)?;
    let mut index = Vec::new();
    let mut predicted = Vec::new();
    let mut measured = Vec::new();
    for k0 in super::predict::starts(prep, k) {
        index.push(k0 + k);
        predicted.push(super::predict::ahead(prep, Some(&acc), k0, k));
        // Against the filtered position: the prediction is built from filtered signals, and
        // what the filter took out of the raw one no model predicts (an output-error fit
        // against it biased the mass by 12 %).
        measured.push(prep.y[k0 + k]);
    }
    Comparison::from_series(
        Mode::KStep,
        "position",
        unit,
        index,
        measured,
        predicted,
        format!(
            "{k}-step-ahead ({:.3} s) from the filtered measured state, against the filtered \
             measured position",
            k as f64 * prep.dt
        ),
    )
}

/// The mode used when the user asks for none: inverse dynamics wherever the family has it
/// (closed-loop data of integrating plants make free-run numbers meaningless), else free run.
pub fn default_mode(_model: &Model) -> Mode {
    // Every family has its balance of forces now (motor_gear through the transmitted torque of
    // `regress_gear`), and it is the one mode that does not drift in closed loop.
    Mode::InverseDynamics
}

/// Prepare a data set for a model (filter corner from the data unless given).
pub fn prepare_for(data: &Dataset, cutoff_hz: Option<f64>) -> Prepared {
    prepare(data, cutoff_hz)
}

/// Fit, NRMSE and RMSE of a model on some samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PartScore {
    /// Samples scored.
    pub samples: usize,
    /// Fit in percent, `100 (1 - NRMSE)`.
    pub fit: f64,
    /// RMSE over the standard deviation of the measured quantity on these samples.
    pub nrmse: f64,
    /// RMSE in the compared unit.
    pub rmse: f64,
}

impl PartScore {
    /// Scores of `predicted` against `measured`.
    pub fn of(measured: &[f64], predicted: &[f64]) -> anyhow::Result<PartScore> {
        let nrmse = nrmse(measured, predicted)?;
        Ok(PartScore {
            samples: measured.len(),
            // The same as `ident::fit_percent`, without computing the NRMSE twice.
            fit: 100.0 * (1.0 - nrmse),
            nrmse,
            rmse: rmse(measured, predicted)?,
        })
    }
}

/// Held-out validation: the model's free parameters refitted on the first part of the data
/// only, then compared on that part (training) and on the rest (held out).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Holdout {
    /// Fraction of the samples held out, the last ones.
    pub fraction: f64,
    /// First held-out sample and its time in s.
    pub split_sample: usize,
    /// Time of the first held-out sample in s.
    pub split_time_s: f64,
    /// Scores on the training part.
    pub training: PartScore,
    /// Scores on the held-out part.
    pub held_out: PartScore,
    /// The free parameters as refitted on the training part (empty when not refitted).
    pub parameters: Vec<(String, f64)>,
    /// How the parameters were obtained.
    pub note: String,
}

/// Split the scores of `c` at sample `split`: the samples before it and from it on.
pub fn split_scores(c: &Comparison, split: usize) -> anyhow::Result<(PartScore, PartScore)> {
    let cut = c.index.partition_point(|&k| k < split);
    if c.index[cut..].iter().any(|&k| k < split) {
        anyhow::bail!("{}: samples out of order, cannot split them", c.mode);
    }
    let part = |r: std::ops::Range<usize>, what: &str| {
        if r.is_empty() {
            anyhow::bail!(
                "{}: no samples to compare in the {what} part (is the actuator moving there?)",
                c.mode
            );
        }
        PartScore::of(&c.measured[r.clone()], &c.predicted[r])
    };
    Ok((
        part(0..cut, "training")?,
        part(cut..c.index.len(), "held-out")?,
    ))
}

/// Held-out validation of `model` on `data` in `mode`: the last `fraction` of the samples are
/// held out, the free parameters are refitted by inverse-dynamics regression (as `actuator fit`
/// does) on the samples before them, and the refitted model is scored on both parts. A family
/// without an inverse-dynamics form keeps its parameters as given.
pub fn holdout(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
    mode: Mode,
    k: usize,
    fraction: f64,
) -> anyhow::Result<Holdout> {
    if !(fraction > 0.0 && fraction < 1.0) {
        anyhow::bail!("--holdout must be a fraction between 0 and 1 (exclusive), got {fraction}");
    }
    let n = data.len();
    let split = (((1.0 - fraction) * n as f64).round() as usize).clamp(1, n.saturating_sub(1));
    let training_index = balance(&model.spec, data, prep).map(|b| {
        b.index
            .into_iter()
            .filter(|&i| i < split)
            .collect::<Vec<_>>()
    });
    let (fitted, parameters, note) =
        match training_index.and_then(|idx| fit_spec(&model.spec, data, prep, Some(&idx))) {
            Ok((spec, fit)) => {
                let parameters = fit
                    .names
                    .iter()
                    .zip(&fit.values)
                    .zip(&fit.intervals)
                    .filter(|(_, ci)| ci.is_some())
                    .map(|((name, v), _)| (name.clone(), *v))
                    .chain(fit.nonlinear.iter().cloned())
                    .collect();
                let fitted = Model {
                    name: model.name.clone(),
                    spec,
                };
                let note = format!(
                    "free parameters refitted (inverse dynamics) on the first {:.0} % of the \
                     samples only",
                    100.0 * (1.0 - fraction)
                );
                (fitted, parameters, note)
            }
            Err(e) => (
                model.clone(),
                Vec::new(),
                format!("parameters as given (no refit: {e})"),
            ),
        };
    let c = compare(&fitted, data, prep, mode, k)?;
    let (training, held_out) = split_scores(&c, split)?;
    Ok(Holdout {
        fraction,
        split_sample: split,
        split_time_s: data.time[split],
        training,
        held_out,
        parameters,
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::fixtures;
    use crate::lab::signals::prepare;
    use crate::physics::{EffectKind, Fault, PlantSpec};

    /// A linear axis with spring, viscous damping and Coulomb friction driven by a force in N.
    fn axis() -> PlantSpec {
        fixtures::force_axis(
            &[EffectKind::Spring, EffectKind::Viscous, EffectKind::Coulomb],
            3,
            1e-6,
        )
    }

    /// 40 s at 1 kHz of the axis under a sum of sines of force, with `fault` from `fault_at_s`.
    fn measured(spec: &PlantSpec, fault: Option<(f64, Fault)>) -> Dataset {
        fixtures::under_sines(spec, 40_000, &[(60.0, 0.7, 0.0), (25.0, 2.3, 1.0)], fault)
    }

    fn model() -> Model {
        let mut spec = axis();
        // Start the fit away from the truth.
        for (name, v) in [
            ("coulomb.coulomb_pos_n", 0.5),
            ("coulomb.coulomb_neg_n", 0.5),
            ("viscous.damping_pos_n_s_per_m", 5.0),
            ("viscous.damping_neg_n_s_per_m", 5.0),
        ] {
            spec.set(name, v).expect(name);
        }
        Model {
            name: "axis".into(),
            spec,
        }
    }

    #[test]
    fn holdout_scores_a_consistent_plant_alike_on_both_parts() {
        let d = measured(&axis(), None);
        let prep = prepare(&d, None);
        let m = model();
        let h = holdout(&m, &d, &prep, Mode::InverseDynamics, 10, 0.3).expect("validates");
        assert_eq!(h.split_sample, 28_000);
        assert!((h.split_time_s - 28.0).abs() < 1e-9);
        // Every compared sample is in exactly one part.
        let as_given = compare(&m, &d, &prep, Mode::InverseDynamics, 10).expect("compares");
        assert_eq!(
            h.training.samples + h.held_out.samples,
            as_given.index.len()
        );
        assert!(h.training.samples > 2 * h.held_out.samples);
        // The refit explains both parts; the as-given model (friction too low) does not.
        assert!(h.training.nrmse < 0.1, "{h:?}");
        assert!(h.held_out.nrmse < 0.1, "{h:?}");
        assert!(
            as_given.nrmse > 2.0 * h.held_out.nrmse,
            "{}",
            as_given.nrmse
        );
        assert!((h.training.fit - 100.0 * (1.0 - h.training.nrmse)).abs() < 1e-9);
        let coulomb = h
            .parameters
            .iter()
            .find(|(n, _)| n == "coulomb.coulomb_pos_n")
            .map(|(_, v)| *v)
            .expect("Coulomb friction refitted");
        let truth = axis().get("coulomb.coulomb_pos_n").expect("known");
        assert!(
            (coulomb - truth).abs() < 0.15 * truth,
            "{coulomb} vs {truth}"
        );
    }

    #[test]
    fn holdout_exposes_a_plant_that_changed_in_the_held_out_part() {
        let friction_x3: Fault = "friction_x3".parse().expect("fault");
        let d = measured(&axis(), Some((32.0, friction_x3)));
        let prep = prepare(&d, None);
        let h = holdout(&model(), &d, &prep, Mode::InverseDynamics, 10, 0.3).expect("validates");
        assert!(h.training.nrmse < 0.1, "{h:?}");
        assert!(h.held_out.nrmse > 3.0 * h.training.nrmse, "{h:?}");
    }

    #[test]
    fn holdout_fraction_must_be_inside_zero_one() {
        let d = measured(&axis(), None);
        let prep = prepare(&d, None);
        for f in [0.0, 1.0, -0.2, f64::NAN] {
            let err = holdout(&model(), &d, &prep, Mode::InverseDynamics, 10, f).unwrap_err();
            assert!(err.to_string().contains("--holdout"), "{err}");
        }
    }
}
