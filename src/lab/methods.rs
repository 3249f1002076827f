//! The identification methods of `actuator fit`, all on the same model and data:
//!
//! - `least_squares` (default): the balance of forces fitted in one batch, with bounds and the
//!   grid search of the nonlinear parameters ([`super::regress::fit_spec`]).
//! - `recursive`: the same regression run sample by sample in time order through the
//!   square-root recursive estimator the daemon's supervision uses, with a forgetting factor:
//!   what an online estimator would have seen, and whether the parameters drift over the record.
//! - `output_error`: Levenberg–Marquardt on the position the model predicts, `k` samples ahead
//!   from the measured state (works in closed loop) or simulated free from the start, starting
//!   from the least-squares estimate. The equation error weighs the noise of a twice
//!   differentiated position; the output error compares positions, as a user reads a model.

use std::ops::ControlFlow;

use serde::Serialize;

use super::compare::{compare, id_comparison, units, Mode};
use super::data::Dataset;
use super::model::Model;
use super::regress::{apply_fit, balance, fit_spec, set_nonlinear, IdFit, PNEUMATIC_COMPLIANCE};
use super::signals::Prepared;
use crate::ident::stats::student_t_quantile;
use crate::ident::{
    minimize_with_progress, Bounds, Dsfi, DsfiConfig, LmOptions, RecursiveEstimator,
};
use crate::physics::PlantSpec;

/// How `actuator fit` identifies the parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FitMethod {
    /// Batch least squares on the balance of forces (inverse dynamics).
    LeastSquares,
    /// Recursive least squares on the balance of forces, in time order, with forgetting.
    Recursive,
    /// Output error: the predicted position (k-step or free run) fitted by Levenberg–Marquardt.
    OutputError,
}

impl FitMethod {
    /// Every method, as the command line lists them.
    pub const ALL: [FitMethod; 3] = [
        FitMethod::LeastSquares,
        FitMethod::Recursive,
        FitMethod::OutputError,
    ];

    /// The name as printed and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            FitMethod::LeastSquares => "least_squares",
            FitMethod::Recursive => "recursive",
            FitMethod::OutputError => "output_error",
        }
    }
}

/// Settings of [`fit_model`].
#[derive(Debug, Clone, Copy)]
pub struct FitOptions {
    /// The method.
    pub method: FitMethod,
    /// Forgetting factor λ of `recursive`, in (0, 1]; the memory is about `1/(1-λ)` samples.
    pub forgetting: f64,
    /// Criterion of `output_error`: [`Mode::KStep`] or [`Mode::FreeRun`].
    pub mode: Mode,
    /// Horizon of the k-step prediction, samples.
    pub k: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            method: FitMethod::LeastSquares,
            forgetting: 1.0,
            mode: Mode::KStep,
            k: 10,
        }
    }
}

/// What became of a parameter in the fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Estimated, with a confidence interval.
    Estimated,
    /// Estimated, but ended on a bound of the parameter.
    AtBound,
    /// Free, but not separable from the other terms on these data: kept at its value.
    Kept,
    /// Fixed by the model.
    Fixed,
    /// Found by the grid search of the least-squares fit; its interval is the profile's over
    /// the grid, conditional on the other grid parameters.
    Grid,
}

/// One parameter of the fitted model.
#[derive(Debug, Clone, Serialize)]
pub struct FittedParameter {
    /// Qualified name, e.g. `coulomb.coulomb_pos_n`.
    pub name: String,
    /// Value written to the model.
    pub value: f64,
    /// 95 % confidence interval, where the method gives one.
    pub interval: Option<(f64, f64)>,
    /// For a parameter held at its bound: the value the record asked for without the bound and
    /// its 95 % interval, when the method knows it.
    pub asked: Option<(f64, (f64, f64))>,
    /// What the fit did with it.
    pub status: Status,
}

/// The recursive estimate over the record.
#[derive(Debug, Clone, Serialize)]
pub struct Track {
    /// Names of the recursively estimated coefficients.
    pub names: Vec<String>,
    /// Time (s) and estimates at a quarter, half, three quarters and the end of the samples.
    pub points: Vec<(f64, Vec<f64>)>,
    /// Forgetting factor used.
    pub forgetting: f64,
    /// The largest difference between the two halves of the record, when both could be fitted.
    pub change: Option<HalfChange>,
}

/// The coefficient whose batch estimates on the two halves of the record differ most.
#[derive(Debug, Clone, Serialize)]
pub struct HalfChange {
    /// Its name.
    pub name: String,
    /// Estimate on the first half of the usable samples.
    pub first: f64,
    /// Estimate on the second half.
    pub second: f64,
    /// `|second - first| / sqrt(se_1² + se_2²)`: beyond about 3 the difference is no chance.
    pub z: f64,
}

/// A fitted model and how it was fitted.
#[derive(Debug, Clone)]
pub struct MethodFit {
    /// The method.
    pub method: FitMethod,
    /// The fitted plant description.
    pub spec: PlantSpec,
    /// Every parameter the balance of forces names, as written.
    pub parameters: Vec<FittedParameter>,
    /// The criterion the method minimised: mode, NRMSE of the model as given and as fitted.
    pub criterion: (Mode, f64, f64),
    /// The same criterion at the least-squares estimate (where output error starts).
    pub start: f64,
    /// The figure `compare` gives (inverse dynamics, moving samples), as given and as fitted.
    pub inverse_dynamics: (f64, f64),
    /// The recursive estimate over time (`recursive` only).
    pub track: Option<Track>,
    /// How the numbers were made.
    pub note: String,
}

/// Fit a model's free parameters with the chosen method. `progress(done, total)` is called as
/// the fit goes on.
pub fn fit_model(
    model: &Model,
    raw: &Dataset,
    d: &Prepared,
    opts: &FitOptions,
    progress: &dyn Fn(usize, usize),
) -> anyhow::Result<MethodFit> {
    let force_unit = units(model).1;
    let given = balance(&model.spec, raw, d)?.evaluate();
    let id_before = id_comparison(&given, force_unit, "as given")?.nrmse;
    let (ls_spec, ls_fit) = fit_spec(&model.spec, raw, d, None)?;
    let id_after = |spec: &PlantSpec| -> anyhow::Result<f64> {
        let fit = balance(spec, raw, d)?.evaluate();
        Ok(id_comparison(&fit, force_unit, "fitted")?.nrmse)
    };
    match opts.method {
        FitMethod::LeastSquares => {
            let parameters =
                on_written_scale(parameters_of(&model.spec, &ls_fit), &ls_spec, &ls_fit);
            // The figure `compare` gives for the written model (moving samples), not the fit's
            // criterion, which also weighs the samples at rest.
            let after = id_comparison(&ls_fit, force_unit, "fitted")?.nrmse;
            Ok(MethodFit {
                method: opts.method,
                spec: ls_spec,
                parameters,
                criterion: (Mode::InverseDynamics, id_before, after),
                start: after,
                inverse_dynamics: (id_before, after),
                track: None,
                note: "balance of forces on the filtered measurements, one batch; nonlinear \
                       parameters by grid search"
                    .into(),
            })
        }
        FitMethod::Recursive => {
            let (spec, fit, track) = recursive(&model.spec, &ls_spec, &ls_fit, raw, d, opts)?;
            let parameters = parameters_of(&model.spec, &fit);
            let after = id_after(&spec)?;
            Ok(MethodFit {
                method: opts.method,
                spec,
                parameters,
                criterion: (Mode::InverseDynamics, id_before, after),
                start: id_comparison(&ls_fit, force_unit, "least squares")?.nrmse,
                inverse_dynamics: (id_before, after),
                track: Some(track),
                note: format!(
                    "balance of forces, sample by sample in time order (square-root RLS, \
                     forgetting {}, memory {}); nonlinear parameters from the least-squares grid \
                     search",
                    opts.forgetting,
                    if opts.forgetting < 1.0 {
                        format!("{:.0} samples", 1.0 / (1.0 - opts.forgetting))
                    } else {
                        "the whole record".into()
                    }
                ),
            })
        }
        FitMethod::OutputError => {
            output_error(model, &ls_spec, &ls_fit, raw, d, opts, id_before, progress)
        }
    }
}

/// Why a fit that held a parameter at its bound cannot be written, or `None`: the first
/// parameter the fit held there, with what the record asked of it where that is known. A bound
/// the record's own interval reaches is an estimate ([`Status::Estimated`]), not this.
pub fn held_at_bound(parameters: &[FittedParameter]) -> Option<String> {
    let p = parameters.iter().find(|p| p.status == Status::AtBound)?;
    Some(match p.asked {
        Some((v, (lo, hi))) => format!(
            "{} is held at its bound {:.4e}: the record asks for {v:.4e} (95 % [{lo:.4e}, \
             {hi:.4e}]), which it cannot be, so the model misses what acts there (`actuator \
             diagnose` names candidates; to take the bound as yours, set it and list it in [lab] \
             fixed)",
            p.name, p.value
        ),
        None => format!(
            "{} ended at its bound {:.4e}: the record does not determine it with this model (to \
             take the bound as yours, set it and list it in [lab] fixed)",
            p.name, p.value
        ),
    })
}

/// [`held_at_bound`] of the parameters a balance fit of `spec` left (`spec` with the free flags
/// it was fitted with).
pub fn held_at_bound_in(spec: &PlantSpec, fit: &IdFit) -> Option<String> {
    held_at_bound(&parameters_of(spec, fit))
}

/// Parameters of a model as a balance fit left them.
fn parameters_of(spec: &PlantSpec, fit: &IdFit) -> Vec<FittedParameter> {
    let params = spec.params();
    let mut out = Vec::new();
    for (j, name) in fit.names.iter().enumerate() {
        let Some((_, p)) = params.iter().find(|(n, _)| n == name) else {
            continue;
        };
        let v = fit.values[j];
        let asked = fit.asked.get(j).copied().flatten();
        // An interval is the admissible part of the record's: a friction level cannot be
        // negative whatever its spread.
        let admissible = |(lo, hi): (f64, f64)| (lo.max(p.def.min), hi.min(p.def.max));
        let (status, interval) = match (fit.intervals[j], asked) {
            (Some(i), _) => (Status::Estimated, Some(admissible(i))),
            // Pinned at a bound the record's own interval reaches: the bound is a value the
            // data allow (a Coulomb level of 0 where no dry friction shows), an estimate.
            (None, Some(a)) if a.interval.0 <= v && v <= a.interval.1 => {
                (Status::Estimated, Some(admissible(a.interval)))
            }
            // Beyond the bound alone, but the fit with the bound is as good as the one without
            // (the other coefficients make up for it: a Coulomb level trading with a spring's
            // pretension): the record does not separate it from them, and the bound stands.
            (None, Some(a)) if a.allowed => (Status::Kept, None),
            // The record asks for a value beyond what the parameter can be, and the fit with
            // the bound is worse beyond chance: the model misses what acts there, a failure.
            (None, Some(_)) => (Status::AtBound, None),
            (None, None) if !p.free => (Status::Fixed, None),
            (None, None) if v <= p.def.min || v >= p.def.max => (Status::AtBound, None),
            (None, None) => (Status::Kept, None),
        };
        out.push(FittedParameter {
            name: name.clone(),
            value: v,
            interval,
            status,
            asked: asked
                .filter(|_| status != Status::Estimated)
                .map(|a| (a.value, a.interval)),
        });
    }
    for (name, v) in &fit.nonlinear {
        if params.iter().any(|(n, p)| n == name && p.free) {
            out.push(FittedParameter {
                name: name.clone(),
                value: *v,
                interval: fit
                    .nonlinear_intervals
                    .iter()
                    .find(|(n, _)| n == name)
                    .map(|(_, i)| *i),
                status: Status::Grid,
                asked: None,
            });
        }
    }
    out
}

/// The parameters as the written model has them, where the balance was fitted on another scale:
/// on the pneumatic chamber's compliance (see `regress`) the forces come out per the fitted
/// coupling and the mass's coefficient is the coupling itself; the model keeps the declared mass
/// and scales the forces, and so do the printed values and intervals.
fn on_written_scale(
    mut parameters: Vec<FittedParameter>,
    spec: &PlantSpec,
    fit: &IdFit,
) -> Vec<FittedParameter> {
    if !fit.names.iter().any(|n| n == PNEUMATIC_COMPLIANCE) {
        return parameters;
    }
    for p in &mut parameters {
        let Some(written) = spec.get(&p.name) else {
            continue;
        };
        if p.name == "pneumatic.mass_kg" {
            p.status = Status::Kept;
            p.interval = None;
        } else if p.value != 0.0 {
            let r = written / p.value;
            p.interval = p.interval.map(|(lo, hi)| {
                let (a, b) = (lo * r, hi * r);
                (a.min(b), a.max(b))
            });
        }
        p.value = written;
    }
    parameters
}

/// Recursive least squares over the balance of the least-squares spec (its nonlinear
/// parameters), the coefficients the batch fit could estimate re-estimated in time order.
fn recursive(
    given: &PlantSpec,
    ls_spec: &PlantSpec,
    ls_fit: &IdFit,
    raw: &Dataset,
    d: &Prepared,
    opts: &FitOptions,
) -> anyhow::Result<(PlantSpec, IdFit, Track)> {
    if !(opts.forgetting > 0.0 && opts.forgetting <= 1.0) {
        anyhow::bail!("--forgetting must be in (0, 1], got {}", opts.forgetting);
    }
    let bal = balance(ls_spec, raw, d)?;
    let cols: Vec<usize> = (0..bal.terms.len()).filter(|&j| ls_fit.free[j]).collect();
    if cols.is_empty() {
        anyhow::bail!("no parameter of the model can be estimated from these data");
    }
    let rms = |x: &mut dyn Iterator<Item = f64>, n: usize| {
        let s = (x.map(|v| v * v).sum::<f64>() / n.max(1) as f64).sqrt();
        if s > 0.0 && s.is_finite() {
            s
        } else {
            1.0
        }
    };
    let target_of = |k: usize| -> f64 {
        bal.terms
            .iter()
            .enumerate()
            .filter(|(j, _)| !ls_fit.free[*j])
            .map(|(j, t)| -ls_fit.values[j] * t.col[k])
            .sum()
    };
    let n = bal.index.len();
    // Regressors and target scaled to unit RMS: one prior covariance suits every column, whatever
    // its unit (a mass in kg next to a stiffness in N/m).
    let scale: Vec<f64> = cols
        .iter()
        .map(|&j| rms(&mut bal.index.iter().map(|&k| bal.terms[j].col[k]), n))
        .collect();
    let y_scale = rms(&mut bal.index.iter().map(|&k| target_of(k)), n);
    // The prior is the model as given: `θ''_j = θ_j s_j / s_y`.
    let theta0: Vec<f64> = cols
        .iter()
        .zip(&scale)
        .map(|(&j, s)| given.get(&bal.terms[j].name).unwrap_or(0.0) * s / y_scale)
        .collect();
    let mut est = Dsfi::with_initial(
        &theta0,
        DsfiConfig {
            forgetting: opts.forgetting,
            initial_covariance: 1e6,
            information_floor: Some(1e-9),
        },
    )?;
    let unscale = |theta: &[f64]| -> Vec<f64> {
        theta
            .iter()
            .zip(&scale)
            .map(|(t, s)| t * y_scale / s)
            .collect()
    };
    let mut psi = vec![0.0; cols.len()];
    let marks: Vec<usize> = (1..=4).map(|q| (q * n / 4).max(1) - 1).collect();
    let mut points = Vec::new();
    for (r, &k) in bal.index.iter().enumerate() {
        for ((p, &j), s) in psi.iter_mut().zip(&cols).zip(&scale) {
            *p = bal.terms[j].col[k] / s;
        }
        est.step(&psi, target_of(k) / y_scale)?;
        if marks.contains(&r) {
            points.push((raw.time[k], unscale(est.theta())));
        }
    }
    let theta = unscale(est.theta());
    let mut values = ls_fit.values.clone();
    let mut free = ls_fit.free.clone();
    for (&j, v) in cols.iter().zip(&theta) {
        let (lo, hi) = bal.terms[j].bounds;
        values[j] = v.clamp(lo, hi);
        // The recursive estimate knows no bounds: one that left them is pinned there.
        if *v < lo || *v > hi {
            free[j] = false;
        }
    }
    // Intervals: `σ̂² P`, with σ̂² the residual variance of the final estimate, widened like the
    // batch fit's for the correlation of the filtered residual.
    let provisional = bal.with_values(
        values.clone(),
        free.clone(),
        vec![None; values.len()],
        ls_fit.parameters - cols.len(),
        ls_fit.breakaway,
    );
    let dof = n.saturating_sub(cols.len()).max(1) as f64;
    let sigma2 = provisional.residual.iter().map(|r| r * r).sum::<f64>() / dof;
    let t = student_t_quantile(0.975, dof);
    let widen = (1.0 / d.n_eff_per_sample.clamp(1e-6, 1.0)).sqrt();
    let cov = est.covariance_matrix();
    let mut intervals = vec![None; values.len()];
    for (c, &j) in cols.iter().enumerate() {
        if let (true, Some(p)) = (free[j], cov.as_ref()) {
            let se = (sigma2 * p[(c, c)]).sqrt() / scale[c];
            let half = t * se * widen;
            intervals[j] = Some((values[j] - half, values[j] + half));
        }
    }
    let fit = bal.with_values(
        values,
        free,
        intervals,
        ls_fit.parameters - cols.len(),
        ls_fit.breakaway,
    );
    let mut spec = ls_spec.clone();
    apply_fit(&mut spec, &bal, &fit)?;
    let track = Track {
        names: cols.iter().map(|&j| bal.terms[j].name.clone()).collect(),
        points,
        forgetting: opts.forgetting,
        change: half_change(&bal, &cols, ls_fit, d),
    };
    Ok((spec, fit, track))
}

/// Chow-style check of a constant plant: the batch fit on each half of the usable samples, and
/// the coefficient whose two estimates differ most in units of their joint standard error.
fn half_change(
    bal: &super::regress::Balance,
    cols: &[usize],
    ls_fit: &IdFit,
    d: &Prepared,
) -> Option<HalfChange> {
    let mid = bal.index.len() / 2;
    let (a, b) = bal.index.split_at(mid);
    let extra = ls_fit.parameters.saturating_sub(cols.len());
    let fa = bal.fit(Some(a), extra, d.n_eff_per_sample);
    let fb = bal.fit(Some(b), extra, d.n_eff_per_sample);
    // 95 % half-width over 1.96: the standard error.
    let se = |i: (f64, f64)| 0.5 * (i.1 - i.0) / 1.96;
    cols.iter()
        .filter_map(|&j| {
            let (ia, ib) = (fa.intervals[j]?, fb.intervals[j]?);
            let (x, y) = (fa.values[j], fb.values[j]);
            let joint = se(ia).hypot(se(ib));
            (joint > 0.0).then(|| HalfChange {
                name: bal.terms[j].name.clone(),
                first: x,
                second: y,
                z: (y - x).abs() / joint,
            })
        })
        .max_by(|p, q| p.z.total_cmp(&q.z))
}

/// Integrated autocorrelation time of a residual, `τ = 1 + 2 Σ ρ(l)` summed while `ρ` stays
/// above 0.05: the samples per independent one, by which the covariance of a fit to correlated
/// residuals is too small.
fn correlation_time(r: &[f64]) -> f64 {
    let n = r.len();
    if n < 4 {
        return 1.0;
    }
    let mean = r.iter().sum::<f64>() / n as f64;
    let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
    if var <= 0.0 {
        return 1.0;
    }
    let mut tau = 1.0;
    let mut lag = 1;
    while lag < n / 4 {
        let rho = r[lag..]
            .iter()
            .zip(r)
            .map(|(a, b)| (a - mean) * (b - mean))
            .sum::<f64>()
            / var;
        if rho < 0.05 {
            break;
        }
        // Past 64 lags the sum takes every `step`-th lag, each standing for `step` of them.
        let step = if lag < 64 { 1 } else { lag / 16 };
        tau += 2.0 * rho * step as f64;
        lag += step;
    }
    tau.min(n as f64)
}

/// Output error from the least-squares estimate.
#[allow(clippy::too_many_arguments)]
fn output_error(
    model: &Model,
    ls_spec: &PlantSpec,
    ls_fit: &IdFit,
    raw: &Dataset,
    d: &Prepared,
    opts: &FitOptions,
    id_before: f64,
    progress: &dyn Fn(usize, usize),
) -> anyhow::Result<MethodFit> {
    if !matches!(opts.mode, Mode::KStep | Mode::FreeRun) {
        anyhow::bail!(
            "output_error fits a predicted position: --mode k_step or free_run, not {}",
            opts.mode.name()
        );
    }
    let params = ls_spec.params();
    let free_in_model = |name: &str| params.iter().any(|(n, p)| n == name && p.free);
    // What the batch fit could estimate, and the grid-searched parameters: the rest stays.
    let mut names: Vec<String> = ls_fit
        .names
        .iter()
        .enumerate()
        .filter(|(j, n)| ls_fit.free[*j] && free_in_model(n))
        .map(|(_, n)| n.clone())
        .collect();
    names.extend(
        ls_fit
            .nonlinear
            .iter()
            .filter(|(n, _)| free_in_model(n) && !n.starts_with("stribeck.velocity_neg"))
            .map(|(n, _)| n.clone()),
    );
    if names.is_empty() {
        anyhow::bail!("no parameter of the model can be estimated from these data");
    }
    let mut theta0 = Vec::with_capacity(names.len());
    let (mut lower, mut upper) = (Vec::new(), Vec::new());
    for name in &names {
        let (_, p) = params
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| anyhow::anyhow!("{name}: not a parameter of the model"))?;
        let v = ls_spec.get(name).unwrap_or(p.value);
        let lo = if p.def.min_strict {
            p.def.min + 1e-9 * v.abs().max(1e-9)
        } else {
            p.def.min
        };
        theta0.push(v.clamp(lo, p.def.max));
        lower.push(lo);
        upper.push(p.def.max);
    }
    let bounds = Bounds::new(lower, upper)?;
    let with = |theta: &[f64]| -> anyhow::Result<Model> {
        let mut spec = ls_spec.clone();
        for (name, v) in names.iter().zip(theta) {
            set_nonlinear(&mut spec, name, *v)?;
        }
        Ok(Model {
            name: model.name.clone(),
            spec,
        })
    };
    let predict = |m: &Model| compare(m, raw, d, opts.mode, opts.k.max(1));
    let start = predict(&with(&theta0)?)?;
    let given = predict(model).map(|c| c.nrmse).unwrap_or(f64::NAN);
    let n_res = start.measured.len();
    let residual = |theta: &[f64], out: &mut [f64]| {
        match with(theta).and_then(|m| predict(&m)) {
            Ok(c) if c.measured.len() == out.len() => {
                for ((o, y), p) in out.iter_mut().zip(&c.measured).zip(&c.predicted) {
                    *o = y - p;
                }
            }
            // A parameter set the plant refuses, or a simulation that diverges: infeasible.
            _ => out.fill(f64::NAN),
        }
    };
    let lm = LmOptions {
        max_iterations: 40,
        ..LmOptions::default()
    };
    let fit = minimize_with_progress(residual, n_res, &theta0, Some(&bounds), &lm, |p| {
        progress(p.iteration, p.max_iterations);
        ControlFlow::Continue(())
    })?;
    let best = with(&fit.theta)?;
    let after = predict(&best)?;
    // Residuals of a position prediction are correlated over many samples: the covariance of
    // the fit, made for independent residuals, is widened by their correlation time.
    let widen = correlation_time(&fit.residuals).sqrt();
    let ci = fit.confidence_intervals(0.95);
    let mut parameters: Vec<FittedParameter> = parameters_of(&model.spec, ls_fit)
        .into_iter()
        .filter(|p| !names.contains(&p.name))
        .map(|mut p| {
            p.value = best.spec.get(&p.name).unwrap_or(p.value);
            p
        })
        .collect();
    for (j, name) in names.iter().enumerate() {
        let v = fit.theta[j];
        let (lo, hi) = ci[j];
        let half = 0.5 * (hi - lo) * widen;
        let (min, max) = (bounds.lower()[j], bounds.upper()[j]);
        // Held at a bound: what the record asks (the cost's minimum with the bound lifted) and
        // its interval decide, as for the least squares: a bound inside that interval is an
        // estimate, one outside it the model failing there.
        let asked = v + fit.unbounded_step[j];
        let (status, interval, asked) = if !half.is_finite() {
            let status = if fit.at_bound[j] {
                Status::AtBound
            } else {
                Status::Estimated
            };
            (status, None, None)
        } else if !fit.at_bound[j] || (asked - v).abs() <= half {
            let (a, b) = if fit.at_bound[j] {
                (asked - half, asked + half)
            } else {
                (v - half, v + half)
            };
            (Status::Estimated, Some((a.max(min), b.min(max))), None)
        } else {
            (
                Status::AtBound,
                None,
                asked
                    .is_finite()
                    .then_some((asked, (asked - half, asked + half))),
            )
        };
        parameters.push(FittedParameter {
            name: name.clone(),
            value: v,
            interval,
            status,
            asked,
        });
    }
    let id_fitted = {
        let f = balance(&best.spec, raw, d)?.evaluate();
        id_comparison(&f, units(model).1, "fitted")?.nrmse
    };
    Ok(MethodFit {
        method: FitMethod::OutputError,
        spec: best.spec,
        parameters,
        criterion: (opts.mode, given, after.nrmse),
        start: start.nrmse,
        inverse_dynamics: (id_before, id_fitted),
        track: None,
        note: format!(
            "Levenberg-Marquardt on the position ({}) from the least-squares estimate (NRMSE \
             {:.4} there), {} iterations, {} evaluations, {:?}; intervals widened by the \
             residual's correlation time",
            start.note, start.nrmse, fit.iterations, fit.evaluations, fit.termination
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::signals::prepare;
    use crate::lab::Dataset;

    /// 20 s at 1 kHz of a 2 kg carriage under two sines of force, its friction `drag(v)`,
    /// integrated here (semi-implicit Euler at 0.1 ms), position read to 1 µm.
    fn carriage(drag: &dyn Fn(f64) -> f64) -> Dataset {
        let (mass, dt, sub) = (2.0, 1e-3, 10);
        let (mut x, mut v) = (0.0f64, 0.0f64);
        let mut d = Dataset {
            origin: "carriage".into(),
            time: vec![],
            input: vec![],
            output: vec![],
            supply: None,
            current: None,
        };
        for k in 0..20_000 {
            let t = k as f64 * dt;
            let u = 60.0 * (std::f64::consts::TAU * 0.7 * t).sin()
                + 25.0 * (std::f64::consts::TAU * 2.3 * t).sin();
            d.time.push(t);
            d.input.push(u);
            d.output.push((x * 1e6).round() * 1e-6);
            for _ in 0..sub {
                // m v' = u - F(v)
                v += dt / sub as f64 * (u - drag(v)) / mass;
                x += dt / sub as f64 * v;
            }
        }
        d
    }

    fn fit_friction(d: &Dataset) -> MethodFit {
        let mut model =
            Model::from_names("linear_axis", &["viscous,coulomb".into()]).expect("model");
        model
            .spec
            .set_command(crate::physics::CommandUnit::Newton)
            .expect("force");
        let prep = prepare(d, None);
        fit_model(&model, d, &prep, &FitOptions::default(), &|_, _| {}).expect("fits")
    }

    fn parameter<'a>(f: &'a MethodFit, name: &str) -> &'a FittedParameter {
        f.parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} in {:?}", f.parameters))
    }

    #[test]
    fn a_coulomb_level_the_record_puts_at_zero_is_an_estimate_at_its_bound() {
        // Viscous friction only: the record allows no dry friction, and the fit says so with an
        // interval, never a failure.
        let f = fit_friction(&carriage(&|v| 40.0 * v));
        assert_eq!(held_at_bound(&f.parameters), None, "{:?}", f.parameters);
        for dir in ["pos", "neg"] {
            let p = parameter(&f, &format!("coulomb.coulomb_{dir}_n"));
            let (lo, hi) = p.interval.unwrap_or_else(|| panic!("{p:?}"));
            assert_eq!(p.status, Status::Estimated, "{p:?}");
            assert!(
                lo >= 0.0 && lo <= p.value && p.value <= hi && hi < 1.0,
                "{p:?}"
            );
        }
    }

    #[test]
    fn a_coulomb_level_the_record_asks_below_zero_is_a_failure_naming_what_it_asked() {
        // Fluid drag F = c₂ v |v|: the best line through it over the record's speeds crosses
        // zero force above zero speed, so the record asks for a negative dry friction.
        let d = carriage(&|v| 150.0 * v * v.abs());
        let f = fit_friction(&d);
        // The same least squares on the carriage's own speeds, without the lab: the line
        // a + c v through c₂ v² over the moving samples, per direction.
        let speeds: Vec<f64> = d
            .output
            .windows(3)
            .map(|w| (w[2] - w[0]) / 2e-3)
            .filter(|v| *v > 0.01)
            .collect();
        let n = speeds.len() as f64;
        let (sv, svv) = (
            speeds.iter().sum::<f64>(),
            speeds.iter().map(|v| v * v).sum::<f64>(),
        );
        let sf: f64 = speeds.iter().map(|v| 150.0 * v * v).sum();
        let svf: f64 = speeds.iter().map(|v| 150.0 * v * v * v).sum();
        let intercept = (sf * svv - sv * svf) / (n * svv - sv * sv);
        assert!(intercept < -0.5, "{intercept}");
        let p = parameter(&f, "coulomb.coulomb_pos_n");
        assert_eq!(p.status, Status::AtBound, "{:?}", f.parameters);
        let (asked, (lo, hi)) = p.asked.unwrap_or_else(|| panic!("{p:?}"));
        assert!(lo <= asked && asked <= hi && hi < 0.0, "{p:?}");
        assert!(
            (asked - intercept).abs() < 0.5 * intercept.abs(),
            "asked {asked:.3} N, the line's own intercept {intercept:.3} N"
        );
        let why = held_at_bound(&f.parameters).expect("a failure");
        assert!(
            why.contains("coulomb.coulomb_") && why.contains("the record asks for -"),
            "{why}"
        );
    }

    #[test]
    fn correlation_time_is_one_for_white_and_long_for_a_slow_residual() {
        let mut x = 0x2545_f491_4f6c_dd1d_u64;
        let mut white = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let w: Vec<f64> = (0..20_000).map(|_| white()).collect();
        assert!(correlation_time(&w) < 1.2, "{}", correlation_time(&w));
        // AR(1) with a = 0.9: τ = (1 + a) / (1 - a) = 19.
        let mut s = 0.0;
        let ar: Vec<f64> = (0..200_000)
            .map(|_| {
                s = 0.9 * s + white();
                s
            })
            .collect();
        let tau = correlation_time(&ar);
        assert!((12.0..26.0).contains(&tau), "{tau}");
    }
}
