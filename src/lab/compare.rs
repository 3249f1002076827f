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

use super::data::Dataset;
use super::model::Model;
use super::regress::{balance, IdFit};
use super::signals::{prepare, Prepared};
use crate::ident::{fit_percent, nrmse, rmse};

/// A prediction mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
#[value(rename_all = "snake_case")]
pub enum Mode {
    /// Simulate the physics plant on the measured command.
    FreeRun,
    /// Predict `k` samples ahead from the measured state.
    KStep,
    /// Equation error of the balance of forces.
    InverseDynamics,
}

impl Mode {
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
        Ok(Comparison {
            mode,
            quantity: quantity.to_string(),
            unit: unit.to_string(),
            fit: fit_percent(&measured, &predicted)?,
            nrmse: nrmse(&measured, &predicted)?,
            rmse: rmse(&measured, &predicted)?,
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
    let mut plant = model.spec.build_named(&model.name)?;
    let n = data.len();
    let mut predicted = Vec::with_capacity(n);
    let start = plant.truth().position;
    let shift = data.output[0] - start;
    predicted.push(start + shift);
    for k in 1..n {
        if let Some(s) = &data.supply {
            plant.set_supply(s[k - 1]);
        }
        plant.step(data.input[k - 1], data.time[k] - data.time[k - 1]);
        predicted.push(plant.truth().position + shift);
    }
    Comparison::from_series(
        Mode::FreeRun,
        "position",
        unit,
        (0..n).collect(),
        data.output.clone(),
        predicted,
        format!("simulated from rest, shifted by {shift:.3e} {unit} to the first sample"),
    )
}

/// Acceleration of the model at the measured state, `a = -Σ_{j≠inertia} θ_j φ_j(k) / m`, for
/// every sample.
pub fn model_acceleration(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
) -> anyhow::Result<Vec<f64>> {
    let bal = balance(&model.spec, data, prep)?;
    let mass = bal.terms[0].value;
    if mass.is_nan() || mass <= 0.0 {
        anyhow::bail!("k_step needs a mass > 0");
    }
    let n = prep.y.len();
    let mut acc = vec![0.0; n];
    for t in &bal.terms[1..] {
        for (a, c) in acc.iter_mut().zip(&t.col) {
            *a -= t.value * c / mass;
        }
    }
    Ok(acc)
}

fn k_step(
    model: &Model,
    data: &Dataset,
    prep: &Prepared,
    k: usize,
    unit: &str,
) -> anyhow::Result<Comparison> {
    let acc = model_acceleration(model, data, prep)?;
    let n = prep.y.len();
    let dt = prep.dt;
    let edge = prep.valid.iter().position(|v| *v).unwrap_or(0).min(n / 4);
    let mut index = Vec::new();
    let mut predicted = Vec::new();
    let mut measured = Vec::new();
    let mut k0 = edge;
    while k0 + k < n.saturating_sub(edge) {
        // y(k0+K) = y(k0) + K T v(k0) + T² Σ_i (K - i - ½) a(k0+i)
        let mut y = prep.y[k0] + k as f64 * dt * prep.v[k0];
        for i in 0..k {
            y += dt * dt * (k as f64 - i as f64 - 0.5) * acc[k0 + i];
        }
        index.push(k0 + k);
        predicted.push(y);
        measured.push(data.output[k0 + k]);
        k0 += 1;
    }
    Comparison::from_series(
        Mode::KStep,
        "position",
        unit,
        index,
        measured,
        predicted,
        format!(
            "{k}-step-ahead ({:.3} s) from the filtered measured state",
            k as f64 * dt
        ),
    )
}

/// The mode used when the user asks for none: inverse dynamics wherever the family has it
/// (closed-loop data of integrating plants make free-run numbers meaningless), else free run.
pub fn default_mode(model: &Model) -> Mode {
    if model.spec.family == crate::physics::Family::MotorGear {
        Mode::FreeRun
    } else {
        Mode::InverseDynamics
    }
}

/// Prepare a data set for a model (filter corner from the data unless given).
pub fn prepare_for(data: &Dataset, cutoff_hz: Option<f64>) -> Prepared {
    prepare(data, cutoff_hz)
}
