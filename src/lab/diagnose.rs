//! Which effect is missing: for every effect of the catalogue that the model lacks and the family
//! allows, add it, refit the free parameters (bounded) and measure the error drop, judged with a
//! penalty for the added parameters (BIC), a significance test (F test) and the error on held-out
//! data; show each effect's signature in the residual of the model as it is; rank, and name the
//! effect most likely missing, or none.
//!
//! The residual of a band-limited regression is correlated over about `1/(2 f_c)`: the tests and
//! the penalty count `N_eff = 2 f_c T_0 N` independent samples, not `N`.

use serde::Serialize;

use super::data::Dataset;
use super::effects::{self, Evidence};
use super::model::Model;
use super::predict::{self, Prediction};
use super::regress::{balance, fit_spec, fit_spec_on, representable, IdFit};
use super::signals::Prepared;
use super::structure::{self, ResidualMap};
use super::undecided;
use crate::ident::f_test_nested;
use crate::physics::{EffectKind, Family, PlantSpec};

/// Thresholds of the verdict.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Level of the F test (default 0.001).
    pub alpha: f64,
    /// Smallest relative NRMSE drop, in and out of sample, that counts (default 0.05).
    pub min_improvement: f64,
    /// Fraction of the samples (the last ones) held out for validation (default 0.3).
    pub holdout: f64,
    /// Worker threads (default: available cores).
    pub threads: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            alpha: 1e-3,
            min_improvement: 0.05,
            holdout: 0.3,
            threads: std::thread::available_parallelism().map_or(2, |n| n.get()),
        }
    }
}

/// One candidate effect.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Effect name.
    pub effect: String,
    /// NRMSE with the effect added and refitted.
    pub nrmse: f64,
    /// Relative NRMSE drop, `(NRMSE_base - NRMSE) / NRMSE_base`.
    pub improvement: f64,
    /// True when the drop passes the F test, the BIC and the held-out check.
    pub significant: bool,
    /// The effect's signature in the residual of the base model.
    pub evidence: String,
    /// p-value of the F test.
    pub p_value: f64,
    /// `BIC_with - BIC_base` on `N_eff` samples (negative favours the effect).
    pub delta_bic: f64,
    /// Relative NRMSE drop on the held-out samples.
    pub holdout_improvement: f64,
    /// The candidate, fitted on the training part, predicting the held-out motion
    /// [`predict::HORIZON`] samples ahead ([`predict`]); `None` where it has no positive inertia.
    pub prediction: Option<Prediction>,
    /// How much the error of that prediction falls against the base's, `1 - RMS_c / RMS_base`.
    pub prediction_improvement: Option<f64>,
    /// RMS residual over the base's, both in the balance's units (`sqrt(RSS / RSS_base)`):
    /// comparable between candidates where the NRMSE is not, as a candidate that reshapes the
    /// drive (a dead zone) moves the spread of the reference the NRMSE divides by.
    pub residual_ratio: f64,
    /// Parameters added (free coefficients plus grid-searched ones).
    pub parameters_added: i64,
    /// Fitted values of the effect's parameters.
    pub parameters: Vec<(String, f64)>,
    /// Body parameters held at the base's value because the fit with them free ran them to
    /// their bound ([`super::collapse::at_bound`]).
    pub held: Vec<String>,
    /// The residual of the refitted candidate, on [`Candidate::index`]: where its structure
    /// is looked for.
    #[serde(skip)]
    pub residual: Vec<f64>,
    /// Sample index of each residual.
    #[serde(skip)]
    pub index: Vec<usize>,
}

/// The result of a diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// Mode the numbers come from (always `inverse_dynamics`).
    pub mode: String,
    /// NRMSE of the model with its free parameters refitted.
    pub nrmse_base: f64,
    /// Candidates, best first.
    pub candidates: Vec<Candidate>,
    /// The effect most likely missing, or none (also when the error is `unexplained`).
    pub verdict: Option<String>,
    /// True when the residual holds a structure that no candidate explains (see
    /// [`super::structure`]): the verdict is `unexplained`, no effect of the catalogue.
    pub unexplained: bool,
    /// Candidates the record cannot tell apart ([`super::undecided`]), the best first: when
    /// not empty, there is no verdict, and the set is the answer.
    pub undecided: Vec<String>,
    /// Each member of the undecided set after the first, with its statistic against the first.
    #[serde(skip)]
    pub rivals: Vec<undecided::Rival>,
    /// What each member of the undecided set follows and the record that would decide.
    pub separating_record: Option<String>,
    /// The residual of the best model (the verdict's candidate, else the model as it is)
    /// mapped against every signal, with the structures left in it.
    pub residual_map: ResidualMap,
    /// Samples used (moving and at rest) and the effective number behind the tests.
    pub samples: usize,
    /// `N_eff`.
    pub effective_samples: f64,
    /// The model as it is, fitted on the training part, predicting the held-out motion.
    pub base_prediction: Option<Prediction>,
    /// Why the model as it is does not stand on this record ([`super::collapse::refused`]: a
    /// body parameter at its bound, a drive gone one way, a residual below the noise), or
    /// `None`. Its candidates are still judged against it, but a fit of it would not be written.
    pub base_refused: Option<String>,
    /// Effects the family allows but the regression cannot see, or that the model lacks data for.
    pub not_assessed: Vec<String>,
    /// Candidates that pass every test on the whole record (F test, BIC, the drop) but not on
    /// its held-out part or in the motion they predict there: what the record suggests without
    /// confirming it, the best first.
    pub unconfirmed: Vec<String>,
}

/// The signature of an addition in the residual of the base: an effect's, or what a declared
/// term is.
fn signature(
    kind: &Addition,
    spec: &PlantSpec,
    base: &IdFit,
    data: &Dataset,
    d: &Prepared,
    unit: &str,
) -> String {
    match kind {
        Addition::Effect(k) => evidence(*k, spec.family, base, data, d, unit),
        Addition::Term(n) => spec.term(n).map_or_else(String::new, |t| {
            format!("the model's own term: F = {} ({unit})", t.force)
        }),
    }
}

/// What a candidate adds to the base: an effect of the catalogue or a term the model declares as
/// a candidate (`[[lab.term]]` with `candidate = true`).
#[derive(Debug, Clone, PartialEq)]
pub enum Addition {
    /// An effect of the catalogue.
    Effect(EffectKind),
    /// A declared term, by name.
    Term(String),
}

impl Addition {
    /// Its name, as candidates, verdicts and ladders print it.
    pub fn name(&self) -> &str {
        match self {
            Addition::Effect(k) => k.name(),
            Addition::Term(n) => n,
        }
    }

    /// The addition named `name` for `spec`: a declared term of that name, else an effect.
    pub fn named(spec: &PlantSpec, name: &str) -> anyhow::Result<Addition> {
        if spec.term(name).is_some() {
            return Ok(Addition::Term(name.to_string()));
        }
        EffectKind::from_name(name)
            .map(Addition::Effect)
            .ok_or_else(|| anyhow::anyhow!("unknown effect or term '{name}'"))
    }

    /// Make it part of `spec`.
    pub fn add_to(&self, spec: &mut PlantSpec) -> anyhow::Result<()> {
        match self {
            Addition::Effect(k) => {
                spec.add_effect(*k)?;
            }
            Addition::Term(n) => spec.activate_term(n)?,
        }
        Ok(())
    }

    /// Grid searches its fit adds.
    fn searches(&self, spec: &PlantSpec, d: &Prepared, data: &Dataset) -> usize {
        let mut s = spec.clone();
        if self.add_to(&mut s).is_err() {
            return 0;
        }
        match self {
            Addition::Effect(k) => super::regress::grid_for(&s, *k, d, data).map_or(0, |g| g.len()),
            Addition::Term(n) => s
                .term(n)
                .map_or(0, |t| t.linear.iter().filter(|&&l| !l).count()),
        }
    }
}

/// The signature of `kind` in the residual `base` of the model without it, as its lab side
/// describes it ([`super::effects`]).
fn evidence(
    kind: EffectKind,
    family: Family,
    base: &IdFit,
    data: &Dataset,
    d: &Prepared,
    unit: &str,
) -> String {
    let ev = Evidence {
        family,
        base,
        data,
        d,
        unit,
    };
    effects::of(kind).map_or_else(|_| String::new(), |e| e.evidence(&ev))
}

/// A candidate whose held-out prediction errs by this share more than the base's is refused:
/// on the independent and hidden-effect sweeps every verdict predicts within 0.25 of the base
/// (most far better), while candidates that balance the forces but not the motion lose 0.7 to
/// 10⁹.
pub const PREDICTION_LOSS: f64 = 0.5;

/// True when `c` has fewer parameters than `best` and `best` does not cut its residual by
/// `min_improvement` (RMS, in the balance's units).
fn simpler_as_good(c: &Candidate, best: &Candidate, min_improvement: f64) -> bool {
    complexity(c) < complexity(best)
        && 1.0 - best.residual_ratio / c.residual_ratio.max(f64::MIN_POSITIVE) < min_improvement
}

/// Parameters an effect declares (a spring whose stiffness ends at zero is still a spring, not a
/// simpler offset).
fn complexity(c: &Candidate) -> usize {
    // A declared term counts the parameters it was fitted with.
    EffectKind::from_name(&c.effect).map_or_else(
        || {
            if c.parameters.is_empty() {
                usize::MAX
            } else {
                c.parameters.len()
            }
        },
        |k| k.params().len(),
    )
}

fn bic_delta(rss_b: f64, k_b: usize, rss_c: f64, k_c: usize, n_eff: f64) -> f64 {
    // BIC = N_eff ln(RSS/N) + k ln(N_eff); the difference needs only the ratio of the RSS.
    n_eff * (rss_c / rss_b).ln() + (k_c as f64 - k_b as f64) * n_eff.ln()
}

/// Diagnose `model` on the data. `progress(done, total, effect)` is called as candidates finish.
pub fn diagnose(
    model: &Model,
    data: &Dataset,
    d: &Prepared,
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(usize, usize, &str) + Sync),
) -> anyhow::Result<Diagnosis> {
    let unit = super::compare::units(model).1;
    let index = balance(&model.spec, data, d)?.index;
    if index.len() < 100 {
        anyhow::bail!(
            "{}: only {} moving samples; the diagnosis needs motion in the data",
            data.origin,
            index.len()
        );
    }
    let split = ((1.0 - opts.holdout) * index.len() as f64) as usize;
    let (train, test) = index.split_at(split);
    let (first_spec, _) = fit_spec(&model.spec, data, d, None)?;
    // Drive constants searched on a grid (a coil's time constant) are identified here, once, on
    // the base model; the candidates start from them (see `candidate` for the check that a
    // candidate would not rather have another lag).
    let drive: Vec<(String, Vec<f64>)> = super::regress::drive_grid(&first_spec, d, data)
        .into_iter()
        .filter(|(name, _)| first_spec.params().iter().any(|(n, p)| n == name && p.free))
        .map(|(name, grid)| (name, grid.iter().step_by(2).copied().collect()))
        .collect();
    // The base is fitted again from its own fit, the start of every candidate: where a fixed
    // column scales with a free parameter (the pneumatic coupling `m/τ` with a free mass), the
    // residual's unit moves with that parameter, and a base fitted from the declared values
    // would be measured in other units than the candidates (every candidate then showed a large
    // positive ΔBIC on the pneumatic balance).
    let (mut base_spec, _) = fit_spec(&first_spec, data, d, None)?;
    // The base is the fit from that start, as every candidate's is: where the refit moves the
    // balance's scale (the pneumatic coupling fitted with the declared mass as the reference),
    // the start's own fit would be in other units than the candidates'.
    let (_, base) = fit_spec(&base_spec, data, d, None)?;
    if let Some(why) = base.degenerate() {
        anyhow::bail!(
            "{}: the balance of model {}: {why}; no candidate can be judged on it",
            data.origin,
            model.name
        );
    }
    let base_refused = super::collapse::refused(
        &model.spec,
        &base_spec,
        base.nrmse,
        None,
        Some(&base),
        data,
        d,
    )?;
    for (name, _) in &drive {
        base_spec.set_free(name, false)?;
    }
    // Moving samples and samples at rest both enter the residual, rest weighted as much as
    // motion.
    let samples = index.len() + base.standstill.len();
    let n_eff = (base.weighted_samples * d.n_eff_per_sample).max(10.0);
    // From the same starting point as every candidate: where a fixed column scales with a free
    // parameter (the pneumatic c = m / τ), the fit depends on where it starts, and a baseline
    // from the defaults would differ from the candidates by that alone.
    let (base_holdout, base_prediction) = holdout_rss(&base_spec, data, d, train, test)?;
    let family = model.spec.family;
    let mut kinds = Vec::new();
    let mut not_assessed = Vec::new();
    for &k in EffectKind::ALL {
        if !k.supported_by(family) || model.has(k) {
            continue;
        }
        if representable(family, k, d) {
            kinds.push(Addition::Effect(k));
        } else {
            not_assessed.push(k.name().to_string());
        }
    }
    for t in model.spec.terms.iter().filter(|t| t.candidate) {
        if t.uses("supply") && d.supply.is_none() {
            not_assessed.push(t.name.clone());
        } else {
            kinds.push(Addition::Term(t.name.clone()));
        }
    }
    let total = kinds.len();
    // Candidates with more grid searches take longer: started first, so that the workers finish
    // together (the results go back to the catalogue's order below).
    let mut order: Vec<usize> = (0..kinds.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(kinds[i].searches(&base_spec, d, data)));
    let done = std::sync::atomic::AtomicUsize::new(0);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::new());
    let work = || -> anyhow::Result<()> {
        loop {
            let Some(&i) = order.get(next.fetch_add(1, std::sync::atomic::Ordering::SeqCst)) else {
                return Ok(());
            };
            let kind = &kinds[i];
            let c = candidate(
                kind,
                &base_spec,
                &drive,
                &base,
                base_holdout,
                base_prediction.as_ref(),
                data,
                d,
                train,
                test,
                n_eff,
                opts,
                unit,
            )?;
            let finished = done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
            progress(finished, total, kind.name());
            if let Ok(mut g) = results.lock() {
                g.push((i, c));
            }
        }
    };
    let threads = opts.threads.clamp(1, 8).min(kinds.len().max(1));
    std::thread::scope(|s| -> anyhow::Result<()> {
        let handles: Vec<_> = (0..threads).map(|_| s.spawn(work)).collect();
        for h in handles {
            h.join()
                .map_err(|_| anyhow::anyhow!("a diagnosis worker panicked"))??;
        }
        Ok(())
    })?;
    let mut indexed = results
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a diagnosis worker panicked"))?;
    // Workers finish in any order: back to the catalogue's order first, so that candidates
    // with equal ΔBIC rank the same on every run (the sort below is stable).
    indexed.sort_by_key(|(i, _)| *i);
    let mut candidates: Vec<Candidate> = indexed.into_iter().map(|(_, c)| c).collect();
    candidates.sort_by(|a, b| {
        b.significant
            .cmp(&a.significant)
            .then(a.delta_bic.total_cmp(&b.delta_bic))
    });
    // Parsimony: a significant candidate with fewer parameters wins when the best one is not
    // clearly better than it (a spring's pretension is an offset; stribeck sits on coulomb).
    if let Some(best) = candidates.first().filter(|c| c.significant).cloned() {
        let simpler = candidates
            .iter()
            .enumerate()
            .filter(|(_, c)| c.significant && simpler_as_good(c, &best, opts.min_improvement))
            .min_by_key(|(_, c)| complexity(c))
            .map(|(i, _)| i);
        if let Some(i) = simpler {
            let c = candidates.remove(i);
            candidates.insert(0, c);
        }
    }
    let chosen = candidates.first().filter(|c| c.significant);
    // Where the error lives: when the largest structure of the model as it is fits the error
    // better than the best candidate, and the candidate only imitates it, or when no candidate
    // is significant, the error is not of the catalogue.
    let base_map = structure::analyse(&base.residual, &base.index, data, d);
    let (unexplained, residual_map) = match (base_map.structures.first(), chosen) {
        (Some(dominant), Some(c))
            if structure::imitates(
                dominant,
                structure::held(dominant, &c.residual, &c.index, data, d),
                mean_square(&base.residual),
                mean_square(&c.residual),
            ) =>
        {
            (true, base_map)
        }
        (_, Some(c)) => (false, structure::analyse(&c.residual, &c.index, data, d)),
        (Some(_), None) => (true, base_map),
        (None, None) => (false, base_map),
    };
    // Said when the data do not decide: candidates the record cannot tell from the chosen one
    // are reported with it as one set, and none of them is the verdict.
    let rivals = match chosen.filter(|_| !unexplained) {
        Some(c) => undecided::rivals(c, &candidates, d.n_eff_per_sample, opts.min_improvement),
        None => Vec::new(),
    };
    let undecided: Vec<String> = match chosen {
        Some(c) if !rivals.is_empty() => std::iter::once(c.effect.clone())
            .chain(rivals.iter().map(|r| r.effect.clone()))
            .collect(),
        _ => Vec::new(),
    };
    let separating_record =
        (!undecided.is_empty()).then(|| undecided::separating_record(&undecided));
    let unconfirmed = candidates
        .iter()
        .filter(|c| {
            !c.significant
                && !c.evidence.starts_with("refused")
                && c.p_value < opts.alpha
                && c.delta_bic < 0.0
                && c.improvement >= opts.min_improvement
        })
        .map(|c| c.effect.clone())
        .collect();
    let verdict = chosen
        .filter(|_| !unexplained && undecided.is_empty())
        .map(|c| c.effect.clone());
    Ok(Diagnosis {
        mode: "inverse_dynamics".into(),
        nrmse_base: base.nrmse,
        candidates,
        verdict,
        unexplained,
        undecided,
        rivals,
        separating_record,
        residual_map,
        samples,
        effective_samples: n_eff,
        base_prediction,
        base_refused,
        not_assessed,
        unconfirmed,
    })
}

/// Mean square of a residual.
fn mean_square(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64
}

/// The residual of `spec` fitted on `train` over `test`, and its prediction of the motion there.
fn holdout_rss(
    spec: &PlantSpec,
    data: &Dataset,
    d: &Prepared,
    train: &[usize],
    test: &[usize],
) -> anyhow::Result<(f64, Option<Prediction>)> {
    let (s, _) = fit_spec(spec, data, d, Some(train))?;
    let bal = balance(&s, data, d)?;
    let split = test.first().copied().unwrap_or(usize::MAX);
    Ok((
        bal.evaluate_on(test).rss,
        predict::held_out(&s, data, d, &bal, split, predict::HORIZON)?,
    ))
}

#[allow(clippy::too_many_arguments)]
fn candidate(
    kind: &Addition,
    base_spec: &PlantSpec,
    drive: &[(String, Vec<f64>)],
    base: &IdFit,
    base_holdout: f64,
    base_prediction: Option<&Prediction>,
    data: &Dataset,
    d: &Prepared,
    train: &[usize],
    test: &[usize],
    n_eff: f64,
    opts: &DiagnoseOptions,
    unit: &str,
) -> anyhow::Result<Candidate> {
    let mut spec = base_spec.clone();
    kind.add_to(&mut spec)?;
    // On all samples and on the training part at once: the grid points are shared.
    let mut fits = fit_spec_on(&spec, data, d, &[None, Some(train)])?.into_iter();
    let (Some((mut fitted, mut fit)), Some((mut trained, _))) = (fits.next(), fits.next()) else {
        anyhow::bail!("{}: no fit for '{}'", data.origin, kind.name());
    };
    // The candidate contains the base: from the base's own solution it cannot end worse. The
    // search above starts every effect afresh and may miss it; then the base's nonlinear
    // parameters are held at the base's values and only the new effect is searched.
    if fit.rss > base.rss {
        let mut held = spec.clone();
        for (name, v) in &base.nonlinear {
            if held.get(name).is_some() {
                super::regress::set_nonlinear(&mut held, name, *v)?;
                held.set_free(name, false)?;
            }
        }
        let mut again = fit_spec_on(&held, data, d, &[None, Some(train)])?.into_iter();
        if let (Some((f_spec, f)), Some((t_spec, _))) = (again.next(), again.next()) {
            if f.rss < fit.rss {
                (fitted, fit, trained) = (f_spec, f, t_spec);
            }
        }
    }
    // A lag in the drive and a missing damping trade against each other, so the base's lag may
    // be far from the candidate's: the lag is profiled over a coarse grid with the candidate's
    // nonlinear parameters kept as found and the linear ones refitted (one regression per point;
    // the exact profile for a candidate linear in its parameters), and the candidate is searched
    // again at the best lag.
    for (name, grid) in drive {
        let mut best: Option<(f64, f64)> = None;
        for &g in grid {
            let mut s = fitted.clone();
            super::regress::set_nonlinear(&mut s, name, g)?;
            let rss = balance(&s, data, d)?.fit(None, 0, d.n_eff_per_sample).rss;
            if rss < fit.rss && best.is_none_or(|(r, _)| rss < r) {
                best = Some((rss, g));
            }
        }
        if let Some((_, g)) = best {
            let mut s = spec.clone();
            super::regress::set_nonlinear(&mut s, name, g)?;
            let (f_spec, f) = fit_spec(&s, data, d, None)?;
            if f.rss < fit.rss {
                (fitted, fit) = (f_spec, f);
                trained = fit_spec(&s, data, d, Some(train))?.0;
                spec = s;
            }
        }
    }
    // A body parameter the candidate ran to its bound (a mass of 1e-12) is not determined with
    // the effect free beside it: held at the base's value, the candidate is fitted again and
    // judged as that (a fit at a bound is never a result; the effect may still be one).
    let mut held_params = Vec::new();
    let vanished = super::collapse::at_bound(&spec, &fitted, Some(base_spec));
    if !vanished.is_empty() {
        let mut hold = spec.clone();
        for name in &vanished {
            if let Some(v) = base_spec.get(name) {
                hold.set(name, v)?;
                hold.set_free(name, false)?;
            }
        }
        let mut again = fit_spec_on(&hold, data, d, &[None, Some(train)])?.into_iter();
        if let (Some((f_spec, f)), Some((t_spec, _))) = (again.next(), again.next()) {
            (fitted, fit, trained) = (f_spec, f, t_spec);
            spec = hold;
            held_params = vanished;
        }
    }
    let trained_balance = balance(&trained, data, d)?;
    let held = trained_balance.evaluate_on(test).rss;
    let split = test.first().copied().unwrap_or(usize::MAX);
    let prediction =
        predict::held_out(&trained, data, d, &trained_balance, split, predict::HORIZON)?;
    let prediction_improvement = prediction
        .zip(base_prediction)
        .map(|(c, b)| c.improvement_over(b));
    let k_b = base.parameters;
    let k_c = fit.parameters.max(k_b + 1);
    let p_value = f_test_nested(
        base.rss,
        k_b,
        fit.rss.min(base.rss),
        k_c,
        n_eff.ceil() as usize,
    )
    .map(|t| t.p_value)
    .unwrap_or(1.0);
    let delta_bic = bic_delta(base.rss, k_b, fit.rss, k_c, n_eff);
    // On the base's reference: the candidate's own target moves with its parameters.
    let nrmse = fit.nrmse_on(base.reference());
    let improvement = (base.nrmse - nrmse) / base.nrmse.max(f64::MIN_POSITIVE);
    let holdout_improvement = 1.0 - (held / base_holdout.max(f64::MIN_POSITIVE)).sqrt();
    // A collapsed fit explains nothing, however small its residual.
    let refused =
        super::collapse::refused(&spec, &fitted, nrmse, Some(base_spec), Some(&fit), data, d)?;
    // A candidate that predicts the held-out motion worse than the model without it is not an
    // effect of this machine, whatever its balance says (the balance can be balanced where the
    // motion does not care). The prediction is noisier than the balance (a pneumatic chamber's
    // lag is a small difference of large terms): only a clear loss counts.
    let predicts_worse = prediction_improvement.is_some_and(|p| p < -PREDICTION_LOSS);
    let significant = refused.is_none()
        && !predicts_worse
        && p_value < opts.alpha
        && delta_bic < 0.0
        && improvement >= opts.min_improvement
        && holdout_improvement >= opts.min_improvement;
    let prefix = format!("{}.", kind.name());
    let parameters = fitted
        .params()
        .into_iter()
        .filter(|(n, _)| n.starts_with(&prefix))
        .map(|(n, p)| (n, p.value))
        .collect();
    Ok(Candidate {
        effect: kind.name().to_string(),
        nrmse,
        improvement,
        significant,
        evidence: match (&refused, held_params.is_empty()) {
            (Some(why), _) => format!(
                "refused: {why}; {}",
                signature(kind, &spec, base, data, d, unit)
            ),
            (None, false) => format!(
                "{} held at the base's value (free, the fit ran it to its bound); {}",
                held_params.join(", "),
                signature(kind, &spec, base, data, d, unit)
            ),
            (None, true) => signature(kind, &spec, base, data, d, unit),
        },
        held: held_params,
        p_value,
        delta_bic,
        holdout_improvement,
        prediction,
        prediction_improvement,
        residual_ratio: (fit.rss / base.rss.max(f64::MIN_POSITIVE)).sqrt(),
        parameters_added: fit.parameters as i64 - k_b as i64,
        parameters,
        residual: fit.residual,
        index: fit.index,
    })
}

impl Diagnosis {
    /// The verdict as `--json` and the text name it: an effect, `unexplained` or `none`.
    pub fn verdict_name(&self) -> &str {
        match (&self.verdict, self.unexplained) {
            (Some(v), _) => v,
            (None, true) => "unexplained",
            (None, false) if !self.undecided.is_empty() => "undecided",
            (None, false) => "none",
        }
    }

    /// The stable JSON of `diagnose --json`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "mode": self.mode,
            "nrmse_base": self.nrmse_base,
            "candidates": self.candidates.iter().map(|c| serde_json::json!({
                "effect": c.effect,
                "nrmse": c.nrmse,
                "improvement": c.improvement,
                "significant": c.significant,
                "evidence": c.evidence,
                "p_value": c.p_value,
                "delta_bic": c.delta_bic,
                "holdout_improvement": c.holdout_improvement,
                "prediction": c.prediction,
                "prediction_improvement": c.prediction_improvement,
                "residual_ratio": c.residual_ratio,
                "parameters_added": c.parameters_added,
                "held": c.held,
                "parameters": c.parameters.iter().map(|(n, v)| serde_json::json!({"name": n, "value": v})).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "verdict": self.verdict_name(),
            "undecided": (!self.undecided.is_empty()).then(|| serde_json::json!({
                "effects": self.undecided,
                "z": self.rivals.iter().map(|r| serde_json::json!({"effect": r.effect, "z": r.z})).collect::<Vec<_>>(),
                "separated_by": self.separating_record,
            })),
            "structure": self.residual_map.structures,
            "residual_map": self.residual_map.rows,
            "samples": self.samples,
            "effective_samples": self.effective_samples,
            "base_prediction": self.base_prediction,
            "base_refused": self.base_refused,
            "not_assessed": self.not_assessed,
            "unconfirmed": self.unconfirmed,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bic_penalises_parameters_and_rewards_a_smaller_residual() {
        // Same residual, one more parameter: the penalty ln(N_eff).
        let d = bic_delta(10.0, 3, 10.0, 4, 1000.0);
        assert!((d - 1000f64.ln()).abs() < 1e-9);
        // A residual cut by 10 % on 1000 effective samples outweighs one parameter.
        assert!(bic_delta(10.0, 3, 9.0, 4, 1000.0) < 0.0);
        // Scale-free: the ratio of the residuals is all that counts.
        let a = bic_delta(10.0, 3, 8.0, 5, 500.0);
        let b = bic_delta(1e-6, 3, 8e-7, 5, 500.0);
        assert!((a - b).abs() < 1e-9);
    }

    #[test]
    fn a_simpler_candidate_is_less_complex() {
        let c = |effect: &str| Candidate {
            effect: effect.into(),
            nrmse: 0.1,
            improvement: 0.5,
            significant: true,
            evidence: String::new(),
            p_value: 0.0,
            delta_bic: -10.0,
            holdout_improvement: 0.5,
            prediction: None,
            prediction_improvement: None,
            residual_ratio: 0.5,
            parameters_added: 1,
            parameters: Vec::new(),
            held: Vec::new(),
            residual: Vec::new(),
            index: Vec::new(),
        };
        assert!(complexity(&c("offset")) < complexity(&c("spring")));
        assert!(complexity(&c("coulomb")) < complexity(&c("stribeck")));
        assert_eq!(complexity(&c("no_such_effect")), usize::MAX);
    }

    #[test]
    fn the_simpler_candidate_wins_only_where_its_residual_is_as_small() {
        let c = |effect: &str, nrmse: f64, residual_ratio: f64| Candidate {
            effect: effect.into(),
            nrmse,
            improvement: 0.5,
            significant: true,
            evidence: String::new(),
            p_value: 0.0,
            delta_bic: -10.0,
            holdout_improvement: 0.5,
            prediction: None,
            prediction_improvement: None,
            residual_ratio,
            parameters_added: 1,
            parameters: Vec::new(),
            held: Vec::new(),
            residual: Vec::new(),
            index: Vec::new(),
        };
        // A pretension the offset takes as well: the simpler one.
        assert!(simpler_as_good(
            &c("offset", 0.1, 0.50),
            &c("spring", 0.099, 0.49),
            0.05
        ));
        // A dead zone on a pneumatic record (its NRMSE divided by the reshaped drive's spread)
        // against the Coulomb friction that cuts the residual further: Coulomb stays.
        assert!(!simpler_as_good(
            &c("deadzone", 0.015, 0.55),
            &c("coulomb", 0.114, 0.45),
            0.05
        ));
    }
}
