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
use super::model::Model;
use super::regress::{balance, fit_spec, representable, IdFit};
use super::signals::Prepared;
use crate::ident::f_test_nested;
use crate::physics::{EffectKind, PlantSpec};

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
    /// Parameters added (free coefficients plus grid-searched ones).
    pub parameters_added: i64,
    /// Fitted values of the effect's parameters.
    pub parameters: Vec<(String, f64)>,
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
    /// The effect most likely missing, or none.
    pub verdict: Option<String>,
    /// Samples used (moving and at rest) and the effective number behind the tests.
    pub samples: usize,
    /// `N_eff`.
    pub effective_samples: f64,
    /// Effects the family allows but the regression cannot see, or that the model lacks data for.
    pub not_assessed: Vec<String>,
}

/// Effects the lab can diagnose from the balance of forces (stiction from the samples at rest,
/// backlash and varying_ratio from the `motor_gear` load balance).
pub const CATALOGUE: &[EffectKind] = &[
    EffectKind::Viscous,
    EffectKind::Coulomb,
    EffectKind::Stiction,
    EffectKind::Stribeck,
    EffectKind::Spring,
    EffectKind::PositionStiffness,
    EffectKind::Hysteresis,
    EffectKind::DirectionAsymmetry,
    EffectKind::Deadzone,
    EffectKind::SupplyGain,
    EffectKind::SupplyFriction,
    EffectKind::DeadTime,
    EffectKind::Saturation,
    EffectKind::Payload,
    EffectKind::Offset,
    EffectKind::Backlash,
    EffectKind::VaryingRatio,
];

fn corr(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1) as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}

fn mean_where(r: &[f64], idx: &[usize], sel: impl Fn(usize) -> bool) -> (f64, usize) {
    let mut s = 0.0;
    let mut n = 0;
    for (i, &k) in idx.iter().enumerate() {
        if sel(k) {
            s += r[i];
            n += 1;
        }
    }
    (if n > 0 { s / n as f64 } else { 0.0 }, n)
}

/// The signature of `kind` in the residual `base` of the model without it.
fn evidence(kind: EffectKind, base: &IdFit, data: &Dataset, d: &Prepared, unit: &str) -> String {
    let r = &base.residual;
    let idx = &base.index;
    let sd = (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt();
    let at = |f: &dyn Fn(usize) -> f64| idx.iter().map(|&k| f(k)).collect::<Vec<f64>>();
    let eps = d.v_standstill;
    match kind {
        EffectKind::Coulomb | EffectKind::DirectionAsymmetry if kind == EffectKind::Coulomb => {
            let (p, _) = mean_where(r, idx, |k| d.v[k] > 0.0);
            let (m, _) = mean_where(r, idx, |k| d.v[k] < 0.0);
            format!(
                "residual steps with the sign of velocity: mean {p:+.3e} {unit} moving positive, \
                 {m:+.3e} moving negative (step {:.1} residual RMS)",
                (p - m).abs() / sd.max(f64::MIN_POSITIVE)
            )
        }
        EffectKind::Viscous => format!(
            "residual grows with velocity: correlation with v {:+.2}",
            corr(r, &at(&|k| d.v[k]))
        ),
        EffectKind::Stribeck => {
            let (lo, _) = mean_where(r, idx, |k| d.v[k].abs() < 4.0 * eps);
            let (hi, _) = mean_where(r, idx, |k| d.v[k].abs() >= 4.0 * eps);
            let lo_s = corr(r, &at(&|k| d.v[k].signum() * (-(d.v[k].abs() / (4.0 * eps))).exp()));
            format!(
                "residual peaks at low speed with the sign of velocity: correlation with \
                 sign(v) e^(-|v|/v_S) {lo_s:+.2} (mean {lo:+.3e} slow, {hi:+.3e} fast)"
            )
        }
        EffectKind::Spring => format!(
            "residual structured by position: correlation with y {:+.2}",
            corr(r, &at(&|k| d.y[k]))
        ),
        EffectKind::Payload => {
            // A load that saturates: the position slope of the residual differs inside and out.
            let ys = at(&|k| d.y[k].abs());
            let mid = super::signals::abs_quantile(&ys, 0.5);
            let part = |inner: bool| {
                let (rr, yy): (Vec<f64>, Vec<f64>) = idx
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| (d.y[k].abs() < mid) == inner)
                    .map(|(i, &k)| (r[i], d.y[k]))
                    .unzip();
                corr(&rr, &yy)
            };
            format!(
                "residual bends with position: correlation with y {:+.2} for |y| below its median, {:+.2} above",
                part(true),
                part(false)
            )
        }
        EffectKind::Stiction => {
            let held = base.standstill_residual.iter().filter(|x| **x != 0.0).count();
            let (up, down) = base
                .standstill_residual
                .iter()
                .fold((0.0f64, 0.0f64), |(a, b), &x| (a.max(x), b.max(-x)));
            format!(
                "held at rest beyond the sliding friction: {held} of {} samples at rest need more, up to {up:.3e} {unit} positive and {down:.3e} negative over the band [-{:.3e}, {:.3e}]",
                base.standstill.len(),
                base.band.1,
                base.band.0
            )
        }
        EffectKind::Saturation => {
            let q = super::signals::abs_quantile(&data.input, 0.9);
            let (hi, _) = mean_where(
                &at(&|k| data.input[k].signum()).iter().zip(r).map(|(s, x)| s * x).collect::<Vec<_>>(),
                idx,
                |k| data.input[k].abs() > q,
            );
            let (lo, _) = mean_where(
                &at(&|k| data.input[k].signum()).iter().zip(r).map(|(s, x)| s * x).collect::<Vec<_>>(),
                idx,
                |k| data.input[k].abs() <= q,
            );
            format!(
                "drive falls short at large commands: mean residual times sign(u) {hi:+.3e} {unit} where |u| is in its top 10 %, {lo:+.3e} elsewhere"
            )
        }
        EffectKind::Backlash => {
            // Reversals of the drive signal; the play decouples the load just after them.
            let drive = d.current.as_ref().unwrap_or(&d.u);
            let window = (0.05 / d.dt).ceil() as usize;
            let mut since = vec![usize::MAX; drive.len()];
            let mut last: Option<usize> = None;
            for k in 1..drive.len() {
                if drive[k].signum() != drive[k - 1].signum() {
                    last = Some(k);
                }
                if let Some(l) = last {
                    since[k] = k - l;
                }
            }
            let rms = |sel: &dyn Fn(usize) -> bool| {
                let (s, m) = idx
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| sel(k))
                    .fold((0.0, 0usize), |(s, m), (i, _)| (s + r[i] * r[i], m + 1));
                (s / m.max(1) as f64).sqrt()
            };
            format!(
                "residual bursts after drive reversals: RMS {:.3e} {unit} within 50 ms after one, {:.3e} elsewhere",
                rms(&|k| since[k] < window),
                rms(&|k| since[k] >= window)
            )
        }
        EffectKind::VaryingRatio => {
            let drive = d.current.as_ref().unwrap_or(&d.u);
            format!(
                "drive gain grows with the load angle: correlation of the residual with (1/cos θ - 1)·D {:+.2}",
                corr(r, &at(&|k| (1.0 / d.y[k].cos() - 1.0) * drive[k]))
            )
        }
        EffectKind::PositionStiffness => {
            let drive = d.current.as_ref().unwrap_or(&d.u);
            format!(
                "residual structured by position times drive: correlation with y·D {:+.2}, with y \
                 {:+.2}",
                corr(r, &at(&|k| d.y[k] * drive[k])),
                corr(r, &at(&|k| d.y[k]))
            )
        }
        EffectKind::Hysteresis => {
            let du: Vec<f64> = {
                let drive = d.current.as_ref().unwrap_or(&d.u);
                idx.iter()
                    .map(|&k| if k > 0 { drive[k] - drive[k - 1] } else { 0.0 })
                    .collect()
            };
            let up = mean_where(&du.iter().map(|x| x.signum()).collect::<Vec<_>>(), &(0..idx.len()).collect::<Vec<_>>(), |_| true).0;
            let _ = up;
            let mut s = (0.0, 0usize, 0.0, 0usize);
            for (i, x) in du.iter().enumerate() {
                if *x > 0.0 {
                    s.0 += r[i];
                    s.1 += 1;
                } else if *x < 0.0 {
                    s.2 += r[i];
                    s.3 += 1;
                }
            }
            format!(
                "residual follows the sign of the drive change: mean {:+.3e} {unit} while it rises, \
                 {:+.3e} while it falls",
                s.0 / s.1.max(1) as f64,
                s.2 / s.3.max(1) as f64
            )
        }
        EffectKind::DirectionAsymmetry => {
            let neg = corr(
                &idx.iter().enumerate().filter(|(_, &k)| d.v[k] < 0.0).map(|(i, _)| r[i]).collect::<Vec<_>>(),
                &idx.iter().filter(|&&k| d.v[k] < 0.0).map(|&k| d.u[k]).collect::<Vec<_>>(),
            );
            let pos = corr(
                &idx.iter().enumerate().filter(|(_, &k)| d.v[k] > 0.0).map(|(i, _)| r[i]).collect::<Vec<_>>(),
                &idx.iter().filter(|&&k| d.v[k] > 0.0).map(|&k| d.u[k]).collect::<Vec<_>>(),
            );
            format!(
                "drive gain differs by direction: correlation of residual with the command \
                 {pos:+.2} moving positive, {neg:+.2} moving negative"
            )
        }
        EffectKind::Deadzone => format!(
            "residual follows the sign of the command: correlation with sign(u) {:+.2}",
            corr(r, &at(&|k| data.input[k].signum()))
        ),
        EffectKind::SupplyGain => match &d.supply {
            Some(s) => format!(
                "residual structured by supply: correlation with supply·u {:+.2}, with supply {:+.2}",
                corr(r, &at(&|k| s[k] * d.u[k])),
                corr(r, &at(&|k| s[k]))
            ),
            None => "no supply recorded".into(),
        },
        EffectKind::SupplyFriction => match &d.supply {
            Some(s) => {
                // The friction the residual carries, signed as the friction opposing motion.
                let fr = at(&|k| d.v[k].signum());
                let rf: Vec<f64> = r.iter().zip(&fr).map(|(x, g)| x * g).collect();
                let sup = at(&|k| s[k]);
                let mut sorted = sup.clone();
                sorted.sort_by(f64::total_cmp);
                let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
                let (hi, _) = mean_where(&rf, idx, |k| s[k] > median);
                let (lo, _) = mean_where(&rf, idx, |k| s[k] <= median);
                format!(
                    "friction in the residual follows the supply: residual times sign(v) correlates \
                     {:+.2} with the supply, mean {hi:+.3e} {unit} above its median, {lo:+.3e} below",
                    corr(&rf, &sup)
                )
            }
            None => "no supply recorded".into(),
        },
        EffectKind::DeadTime => format!(
            "residual follows the command's rate: correlation with du/dt {:+.2}",
            corr(
                r,
                &at(&|k| if k > 0 { d.u[k] - d.u[k - 1] } else { 0.0 })
            )
        ),
        EffectKind::Offset => {
            let (m, _) = mean_where(r, idx, |_| true);
            format!(
                "residual has a constant part: mean {m:+.3e} {unit} ({:.1} residual RMS)",
                m.abs() / sd.max(f64::MIN_POSITIVE)
            )
        }
        _ => String::new(),
    }
}

/// Parameters an effect declares (a spring whose stiffness ends at zero is still a spring, not a
/// simpler offset).
fn complexity(c: &Candidate) -> usize {
    EffectKind::from_name(&c.effect).map_or(usize::MAX, |k| k.params().len())
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
    let (mut base_spec, base) = fit_spec(&first_spec, data, d, None)?;
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
    let base_holdout = holdout_rss(&base_spec, data, d, train, test)?;
    let family = model.spec.family;
    let mut kinds = Vec::new();
    let mut not_assessed = Vec::new();
    for &k in EffectKind::ALL {
        if !k.supported_by(family) || model.has(k) {
            continue;
        }
        if CATALOGUE.contains(&k) && representable(family, k, d) {
            kinds.push(k);
        } else {
            not_assessed.push(k.name().to_string());
        }
    }
    let total = kinds.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(Vec::new());
    let work = || -> anyhow::Result<()> {
        loop {
            let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            if i >= kinds.len() {
                return Ok(());
            }
            let kind = kinds[i];
            let c = candidate(
                kind,
                &base_spec,
                &drive,
                &base,
                base_holdout,
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
                g.push(c);
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
    let mut candidates = results
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a diagnosis worker panicked"))?;
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
            .filter(|(_, c)| {
                c.significant
                    && complexity(c) < complexity(&best)
                    && (c.nrmse - best.nrmse) / c.nrmse.max(f64::MIN_POSITIVE)
                        < opts.min_improvement
            })
            .min_by_key(|(_, c)| complexity(c))
            .map(|(i, _)| i);
        if let Some(i) = simpler {
            let c = candidates.remove(i);
            candidates.insert(0, c);
        }
    }
    let verdict = candidates
        .first()
        .filter(|c| c.significant)
        .map(|c| c.effect.clone());
    Ok(Diagnosis {
        mode: "inverse_dynamics".into(),
        nrmse_base: base.nrmse,
        candidates,
        verdict,
        samples,
        effective_samples: n_eff,
        not_assessed,
    })
}

fn holdout_rss(
    spec: &PlantSpec,
    data: &Dataset,
    d: &Prepared,
    train: &[usize],
    test: &[usize],
) -> anyhow::Result<f64> {
    let (s, _) = fit_spec(spec, data, d, Some(train))?;
    Ok(balance(&s, data, d)?.evaluate_on(test).rss)
}

#[allow(clippy::too_many_arguments)]
fn candidate(
    kind: EffectKind,
    base_spec: &PlantSpec,
    drive: &[(String, Vec<f64>)],
    base: &IdFit,
    base_holdout: f64,
    data: &Dataset,
    d: &Prepared,
    train: &[usize],
    test: &[usize],
    n_eff: f64,
    opts: &DiagnoseOptions,
    unit: &str,
) -> anyhow::Result<Candidate> {
    let mut spec = base_spec.clone();
    spec.add_effect(kind)?;
    let (mut fitted, mut fit) = fit_spec(&spec, data, d, None)?;
    // A lag in the drive and a missing damping trade against each other, so the base's lag may
    // be far from the candidate's: the lag is profiled over a coarse grid with the candidate's
    // nonlinear parameters kept as found and the linear ones refitted (one regression per point;
    // the exact profile for a candidate linear in its parameters), and the candidate is searched
    // again at the best lag.
    for (name, grid) in drive {
        let mut best: Option<(f64, f64)> = None;
        for &g in grid {
            let mut s = fitted.clone();
            s.set(name, g)?;
            let rss = balance(&s, data, d)?.fit(None, 0, d.n_eff_per_sample).rss;
            if rss < fit.rss && best.is_none_or(|(r, _)| rss < r) {
                best = Some((rss, g));
            }
        }
        if let Some((_, g)) = best {
            let mut s = spec.clone();
            s.set(name, g)?;
            let (f_spec, f) = fit_spec(&s, data, d, None)?;
            if f.rss < fit.rss {
                (fitted, fit) = (f_spec, f);
                spec = s;
            }
        }
    }
    let held = holdout_rss(&spec, data, d, train, test)?;
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
    let improvement = (base.nrmse - fit.nrmse) / base.nrmse.max(f64::MIN_POSITIVE);
    let holdout_improvement = 1.0 - (held / base_holdout.max(f64::MIN_POSITIVE)).sqrt();
    let significant = p_value < opts.alpha
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
        nrmse: fit.nrmse,
        improvement,
        significant,
        evidence: evidence(kind, base, data, d, unit),
        p_value,
        delta_bic,
        holdout_improvement,
        parameters_added: fit.parameters as i64 - k_b as i64,
        parameters,
    })
}

impl Diagnosis {
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
                "parameters_added": c.parameters_added,
                "parameters": c.parameters.iter().map(|(n, v)| serde_json::json!({"name": n, "value": v})).collect::<Vec<_>>(),
            })).collect::<Vec<_>>(),
            "verdict": self.verdict,
            "samples": self.samples,
            "effective_samples": self.effective_samples,
            "not_assessed": self.not_assessed,
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
    fn correlation_of_proportional_and_opposite_series() {
        let x: Vec<f64> = (0..50).map(|k| (k as f64 * 0.3).sin()).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 * v + 1.0).collect();
        let z: Vec<f64> = x.iter().map(|v| -v).collect();
        assert!((corr(&x, &y) - 1.0).abs() < 1e-12);
        assert!((corr(&x, &z) + 1.0).abs() < 1e-12);
        assert_eq!(corr(&x, &[1.0; 50]), 0.0);
    }

    #[test]
    fn mean_where_counts_the_selected_samples() {
        let r = [1.0, 2.0, 3.0, 4.0];
        let idx = [10, 11, 12, 13];
        assert_eq!(mean_where(&r, &idx, |k| k >= 12), (3.5, 2));
        assert_eq!(mean_where(&r, &idx, |_| false), (0.0, 0));
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
            parameters_added: 1,
            parameters: Vec::new(),
        };
        assert!(complexity(&c("offset")) < complexity(&c("spring")));
        assert!(complexity(&c("coulomb")) < complexity(&c("stribeck")));
        assert_eq!(complexity(&c("no_such_effect")), usize::MAX);
    }
}
