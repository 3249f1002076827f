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

/// The `qs`-quantiles of `x` (ascending `qs` in 0..=1): the element at rank
/// `round((N - 1) q)`, found by selection, each on what is left above the previous rank.
fn quantiles(mut x: Vec<f64>, qs: &[f64]) -> Vec<f64> {
    if x.is_empty() {
        return vec![0.0; qs.len()];
    }
    let last = x.len() - 1;
    let mut from = 0;
    let mut out = Vec::with_capacity(qs.len());
    for q in qs {
        let rank = ((last as f64 * q).round() as usize).min(last);
        if rank >= from {
            x[from..].select_nth_unstable_by(rank - from, |a, b| a.total_cmp(b));
            from = rank;
        }
        out.push(x[rank]);
    }
    out
}

/// A regime: which samples it holds, as a test on the sample index `k`.
struct Band {
    group: &'static str,
    label: String,
    test: Test,
}

/// The tests of [`Band`], closed so that the one pass over the samples is a plain loop.
enum Test {
    /// `v > lo` (`lo` given), `v < -lo`, or `|v| <= lo`.
    Positive(f64),
    Negative(f64),
    Slow(f64),
    /// `lo < |v| <= hi`.
    Speed(f64, f64),
    /// Speed band of the moving samples, `lo < |v| <= hi` (no upper end on the last band).
    SpeedBand {
        lo: f64,
        hi: f64,
        last: bool,
    },
    /// Samples since the last reversal below / at least the window.
    NearReversal(usize),
    AwayFromReversal(usize),
    /// `lo <= x < hi`, or `<= hi` when last; `x` the position, supply or time.
    Position(f64, f64, bool),
    Supply(f64, f64, bool),
    Time(f64, f64, bool),
}

/// Running sums of one regime.
#[derive(Default, Clone, Copy)]
struct Sums {
    squares: f64,
    sum: f64,
    count: usize,
}

/// Break the error of `c` down by regime and test its residual. The residual tests run on a
/// second thread while the regimes are summed.
pub fn breakdown(c: &Comparison, data: &Dataset, prep: &Prepared) -> Breakdown {
    let r = c.residual();
    let (regimes, tests) = std::thread::scope(|s| {
        let tests = s.spawn(|| residual_tests(c, data));
        let regimes = regimes(c, &r, data, prep);
        (
            regimes,
            tests
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e)),
        )
    });
    let n = r.len();
    let sse: f64 = r.iter().map(|e| e * e).sum();
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
        tests,
        worst,
    }
}

/// The regimes of a comparison with the error in each, in one pass over the samples.
fn regimes(c: &Comparison, r: &[f64], data: &Dataset, prep: &Prepared) -> Vec<Regime> {
    let sse: f64 = r.iter().map(|e| e * e).sum();
    let total = sse.max(f64::MIN_POSITIVE);
    let eps = prep.v_standstill;
    let v = &prep.v;
    let (pu, vu) = if c.unit == "N·m" || c.unit == "rad" {
        ("rad", "rad/s")
    } else {
        ("m", "m/s")
    };
    let band = |group, label: String, test| Band { group, label, test };
    let mut bands = vec![
        band("direction", "moving positive".into(), Test::Positive(eps)),
        band("direction", "moving negative".into(), Test::Negative(eps)),
        band("direction", "standstill".into(), Test::Slow(eps)),
        band(
            "speed",
            format!("standstill (|v| <= {eps:.2e} {vu})"),
            Test::Slow(eps),
        ),
        band(
            "speed",
            format!("near zero ({eps:.2e}..{:.2e} {vu})", 3.0 * eps),
            Test::Speed(eps, 3.0 * eps),
        ),
    ];
    let fast: Vec<f64> = c
        .index
        .iter()
        .map(|&k| v[k].abs())
        .filter(|s| *s > 3.0 * eps)
        .collect();
    let q = quantiles(fast, &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]);
    // Terciles of the moving samples; each sample falls in exactly one band (the first starts
    // at the near-zero band's end, so its slowest sample is in it).
    for b in 0..3 {
        let (lo, hi) = (q[b].max(3.0 * eps), q[b + 1]);
        bands.push(band(
            "speed",
            format!("{lo:.2e}..{hi:.2e} {vu}"),
            Test::SpeedBand {
                lo: if b == 0 { 3.0 * eps } else { lo },
                hi,
                last: b == 2,
            },
        ));
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
    bands.push(band(
        "reversal",
        format!("within {wt:.3} s after a reversal"),
        Test::NearReversal(window),
    ));
    bands.push(band(
        "reversal",
        "away from reversals".into(),
        Test::AwayFromReversal(window),
    ));
    let qy = quantiles(
        c.index.iter().map(|&k| data.output[k]).collect(),
        &[0.0, 0.25, 0.5, 0.75, 1.0],
    );
    for b in 0..4 {
        let (lo, hi) = (qy[b], qy[b + 1]);
        bands.push(band(
            "position",
            format!("{lo:.3e}..{hi:.3e} {pu}"),
            Test::Position(lo, hi, b == 3),
        ));
    }
    if let Some(s) = &data.supply {
        let qs = quantiles(
            c.index.iter().map(|&k| s[k]).collect(),
            &[0.0, 0.25, 0.5, 0.75, 1.0],
        );
        for b in 0..4 {
            let (lo, hi) = (qs[b], qs[b + 1]);
            if hi > lo || b == 0 {
                bands.push(band(
                    "supply",
                    format!("{lo:.4e}..{hi:.4e}"),
                    Test::Supply(lo, hi, b == 3),
                ));
            }
        }
    }
    let t0 = data.time[0];
    let span = data.time[data.len() - 1] - t0;
    for b in 0..8 {
        let (lo, hi) = (t0 + span * b as f64 / 8.0, t0 + span * (b + 1) as f64 / 8.0);
        bands.push(band(
            "time",
            format!("{lo:.1}..{hi:.1} s"),
            Test::Time(lo, hi, b == 7),
        ));
    }
    let supply = data.supply.as_deref().unwrap_or(&[]);
    let within = |x: f64, lo: f64, hi: f64, last: bool| x >= lo && (x < hi || (last && x <= hi));
    // The bands of a group do not overlap: a sample's search in its group ends at the first
    // band that holds it.
    let group_end: Vec<usize> = (0..bands.len())
        .map(|b| {
            (b..bands.len())
                .find(|&j| bands[j].group != bands[b].group)
                .unwrap_or(bands.len())
        })
        .collect();
    let sum_range = |range: std::ops::Range<usize>| {
        let mut sums = vec![Sums::default(); bands.len()];
        for (&e, &k) in r[range.clone()].iter().zip(&c.index[range]) {
            let (vk, speed) = (v[k], v[k].abs());
            let mut b = 0;
            while b < bands.len() {
                let hit = match bands[b].test {
                    Test::Positive(lo) => vk > lo,
                    Test::Negative(lo) => vk < -lo,
                    Test::Slow(lo) => speed <= lo,
                    Test::Speed(lo, hi) => speed > lo && speed <= hi,
                    Test::SpeedBand { lo, hi, last } => speed > lo && (speed <= hi || last),
                    Test::NearReversal(w) => since[k] < w,
                    Test::AwayFromReversal(w) => since[k] >= w,
                    Test::Position(lo, hi, last) => within(data.output[k], lo, hi, last),
                    Test::Supply(lo, hi, last) => within(supply[k], lo, hi, last),
                    Test::Time(lo, hi, last) => data.time[k] >= lo && (data.time[k] < hi || last),
                };
                if hit {
                    let sum = &mut sums[b];
                    sum.squares += e * e;
                    sum.sum += e;
                    sum.count += 1;
                    b = group_end[b];
                } else {
                    b += 1;
                }
            }
        }
        sums
    };
    // Two halves of the samples on two threads on long data sets.
    let n = r.len();
    let sums = if n < 100_000 {
        sum_range(0..n)
    } else {
        std::thread::scope(|s| {
            let second = s.spawn(|| sum_range(n / 2..n));
            let mut sums = sum_range(0..n / 2);
            let more = second
                .join()
                .unwrap_or_else(|e| std::panic::resume_unwind(e));
            for (a, b) in sums.iter_mut().zip(more) {
                a.squares += b.squares;
                a.sum += b.sum;
                a.count += b.count;
            }
            sums
        })
    };
    bands
        .into_iter()
        .zip(sums)
        .filter(|(_, s)| s.count > 0)
        .map(|(b, s)| Regime {
            group: b.group.to_string(),
            label: b.label,
            samples: s.count,
            rmse: (s.squares / s.count as f64).sqrt(),
            mean: s.sum / s.count as f64,
            share: s.squares / total,
        })
        .collect()
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
