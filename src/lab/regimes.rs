//! Where a model fails: the error broken down by regime (direction, speed bands, after
//! reversals, position, supply, time) and residual tests (whiteness, cross-correlation with the
//! input, the nonlinear correlation tests of Billings and Voon) with their 95 % bounds.

use serde::Serialize;

use super::compare::Comparison;
use super::data::Dataset;
use super::signals::Prepared;
use crate::ident::{autocorrelation, billings_voon, cross_correlation, ljung_box};

/// Error in one regime.
#[derive(Debug, Clone, Serialize)]
pub struct Regime {
    /// Kind of regime: direction, speed, reversal, position, supply, time.
    pub group: String,
    /// Which band, in words.
    pub label: String,
    /// Samples in it.
    pub samples: usize,
    /// RMSE in the compared unit.
    pub rmse: f64,
    /// Mean residual (bias) in the compared unit.
    pub mean: f64,
    /// Fraction of the total squared error.
    pub share: f64,
}

/// A residual test against its 95 % bound.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualTest {
    /// Name (`whiteness`, `ljung_box`, `input_residual`, or a Billings–Voon test).
    pub name: String,
    /// Largest |correlation| off lag 0, or the p-value for Ljung–Box.
    pub value: f64,
    /// Lag of that value (0 for Ljung–Box).
    pub lag: i64,
    /// The 95 % bound (`1.96/√N`, or 0.05 for a p-value).
    pub bound: f64,
    /// True when within the bound.
    pub pass: bool,
}

/// The breakdown of a comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Breakdown {
    /// Overall RMSE.
    pub rmse: f64,
    /// Per regime.
    pub regimes: Vec<Regime>,
    /// Residual tests.
    pub tests: Vec<ResidualTest>,
    /// The worst regime, in words.
    pub worst: String,
}

fn quantiles(mut x: Vec<f64>, qs: &[f64]) -> Vec<f64> {
    x.sort_by(|a, b| a.total_cmp(b));
    if x.is_empty() {
        return vec![0.0; qs.len()];
    }
    qs.iter()
        .map(|q| x[((x.len() - 1) as f64 * q).round() as usize])
        .collect()
}

/// Break the error of `c` down by regime and test its residual.
pub fn breakdown(c: &Comparison, data: &Dataset, prep: &Prepared) -> Breakdown {
    let r = c.residual();
    let n = r.len();
    let sse: f64 = r.iter().map(|e| e * e).sum();
    let total = sse.max(f64::MIN_POSITIVE);
    let mut regimes = Vec::new();
    let mut add = |group: &str, label: String, sel: &dyn Fn(usize, usize) -> bool| {
        let mut s = 0.0;
        let mut m = 0.0;
        let mut cnt = 0;
        for (i, &k) in c.index.iter().enumerate() {
            if sel(i, k) {
                s += r[i] * r[i];
                m += r[i];
                cnt += 1;
            }
        }
        if cnt > 0 {
            regimes.push(Regime {
                group: group.to_string(),
                label,
                samples: cnt,
                rmse: (s / cnt as f64).sqrt(),
                mean: m / cnt as f64,
                share: s / total,
            });
        }
    };
    let eps = prep.v_standstill;
    let v = &prep.v;
    let (pu, vu) = if c.unit == "N·m" || c.unit == "rad" {
        ("rad", "rad/s")
    } else {
        ("m", "m/s")
    };
    add("direction", "moving positive".into(), &|_, k| v[k] > eps);
    add("direction", "moving negative".into(), &|_, k| v[k] < -eps);
    add("direction", "standstill".into(), &|_, k| v[k].abs() <= eps);
    add(
        "speed",
        format!("standstill (|v| <= {eps:.2e} {vu})"),
        &|_, k| v[k].abs() <= eps,
    );
    add(
        "speed",
        format!("near zero ({eps:.2e}..{:.2e} {vu})", 3.0 * eps),
        &|_, k| v[k].abs() > eps && v[k].abs() <= 3.0 * eps,
    );
    let fast: Vec<f64> = c
        .index
        .iter()
        .map(|&k| v[k].abs())
        .filter(|s| *s > 3.0 * eps)
        .collect();
    let q = quantiles(fast, &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]);
    for b in 0..3 {
        let (lo, hi) = (q[b].max(3.0 * eps), q[b + 1]);
        add("speed", format!("{lo:.2e}..{hi:.2e} {vu}"), &|_, k| {
            v[k].abs() > lo.max(3.0 * eps) && (v[k].abs() <= hi || b == 2) && v[k].abs() >= lo
        });
    }
    // Reversals: the sign of the motion changes (standstill in between does not count).
    let window = ((0.05 / prep.dt).round() as usize).max(5);
    let mut since = vec![usize::MAX; v.len()];
    let mut last_dir = 0.0;
    let mut last_rev: Option<usize> = None;
    for k in 0..v.len() {
        if v[k].abs() > eps {
            let d = v[k].signum();
            if last_dir != 0.0 && d != last_dir {
                last_rev = Some(k);
            }
            last_dir = d;
        }
        if let Some(kr) = last_rev {
            since[k] = k - kr;
        }
    }
    let wt = window as f64 * prep.dt;
    add(
        "reversal",
        format!("within {wt:.3} s after a reversal"),
        &|_, k| since[k] < window,
    );
    add("reversal", "away from reversals".into(), &|_, k| {
        since[k] >= window
    });
    let qy = quantiles(
        c.index.iter().map(|&k| data.output[k]).collect(),
        &[0.0, 0.25, 0.5, 0.75, 1.0],
    );
    for b in 0..4 {
        let (lo, hi) = (qy[b], qy[b + 1]);
        add("position", format!("{lo:.3e}..{hi:.3e} {pu}"), &|_, k| {
            data.output[k] >= lo && (data.output[k] < hi || (b == 3 && data.output[k] <= hi))
        });
    }
    if let Some(s) = &data.supply {
        let qs = quantiles(
            c.index.iter().map(|&k| s[k]).collect(),
            &[0.0, 0.25, 0.5, 0.75, 1.0],
        );
        for b in 0..4 {
            let (lo, hi) = (qs[b], qs[b + 1]);
            if hi > lo || b == 0 {
                add("supply", format!("{lo:.4e}..{hi:.4e}"), &|_, k| {
                    s[k] >= lo && (s[k] < hi || (b == 3 && s[k] <= hi))
                });
            }
        }
    }
    let t0 = data.time[0];
    let span = data.time[data.len() - 1] - t0;
    for b in 0..8 {
        let (lo, hi) = (t0 + span * b as f64 / 8.0, t0 + span * (b + 1) as f64 / 8.0);
        add("time", format!("{lo:.1}..{hi:.1} s"), &|_, k| {
            data.time[k] >= lo && (data.time[k] < hi || b == 7)
        });
    }
    let rmse = (sse / n.max(1) as f64).sqrt();
    let worst = regimes
        .iter()
        .filter(|g| g.samples * 33 >= n && g.group != "time")
        .max_by(|a, b| a.rmse.total_cmp(&b.rmse))
        .map(|g| {
            format!(
                "worst regime: {} {} — RMSE {:.3e} {} ({:.1}× overall), {:.0} % of the squared \
                 error from {:.0} % of the samples, mean residual {:+.3e}",
                g.group,
                g.label,
                g.rmse,
                c.unit,
                g.rmse / rmse.max(f64::MIN_POSITIVE),
                100.0 * g.share,
                100.0 * g.samples as f64 / n.max(1) as f64,
                g.mean
            )
        })
        .unwrap_or_else(|| "no regime stands out".into());
    Breakdown {
        rmse,
        regimes,
        tests: residual_tests(c, data),
        worst,
    }
}

/// Residual tests on at most 20 000 evenly spaced samples, 20 lags.
pub fn residual_tests(c: &Comparison, data: &Dataset) -> Vec<ResidualTest> {
    let r = c.residual();
    let stride = (r.len() / 20_000).max(1);
    let e: Vec<f64> = r.iter().step_by(stride).copied().collect();
    let u: Vec<f64> = c
        .index
        .iter()
        .step_by(stride)
        .map(|&k| data.input[k])
        .collect();
    let lags = 20;
    let mut out = Vec::new();
    let mut corr = |name: &str, cr: &crate::ident::Correlation| {
        let (lag, value) = cr.max_abs_off_zero().unwrap_or((0, 0.0));
        out.push(ResidualTest {
            name: name.to_string(),
            value: value.abs(),
            lag,
            bound: cr.bound,
            pass: value.abs() <= cr.bound,
        });
    };
    if let Ok(a) = autocorrelation(&e, lags) {
        corr("whiteness", &a);
    }
    if let Ok(x) = cross_correlation(&u, &e, lags) {
        corr("input_residual", &x);
    }
    if let Ok(bv) = billings_voon(&u, &e, lags) {
        for (name, cr) in bv.all().into_iter().skip(2) {
            corr(name, cr);
        }
    }
    if let Ok(lb) = ljung_box(&e, lags) {
        out.push(ResidualTest {
            name: "ljung_box".into(),
            value: lb.p_value,
            lag: 0,
            bound: 0.05,
            pass: lb.p_value >= 0.05,
        });
    }
    out
}
