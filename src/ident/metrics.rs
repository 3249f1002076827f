//! Goodness-of-fit measures, information criteria and residual correlation tests shared by the
//! lab and the supervision level.
//!
//! - fit `= 100 (1 - ‖y - ŷ‖ / ‖y - ȳ‖)` in %, NRMSE `= RMSE / std(y)`, RMSE in the unit of y;
//! - AIC `= N ln(RSS/N) + 2k`, AICc `= AIC + 2k(k+1)/(N-k-1)`, BIC `= N ln(RSS/N) + k ln N`
//!   (Gaussian errors, additive constants dropped: only differences matter);
//! - normalised auto- and cross-correlations with the 95 % band `±1.96/√N` of a white sequence,
//!   the Ljung–Box portmanteau test, and the nonlinear correlation tests of Billings & Voon (1986).

use super::error::{check_finite, check_len, IdentError};
use super::stats::{chi_squared_sf, NestedTest};

/// Half-width of the 95 % confidence band of a sample correlation of a white sequence of
/// length `n`: `1.96 / √n`.
pub fn correlation_bound_95(n: usize) -> f64 {
    1.96 / (n as f64).sqrt()
}

fn check_pair(y: &[f64], y_hat: &[f64]) -> Result<(), IdentError> {
    check_len("prediction", y.len(), y_hat.len())?;
    if y.is_empty() {
        return Err(IdentError::TooFewSamples { needed: 1, got: 0 });
    }
    check_finite("measurement", y)?;
    check_finite("prediction", y_hat)
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Root-mean-square error `√(Σ (y - ŷ)² / N)`, in the unit of `y`.
pub fn rmse(y: &[f64], y_hat: &[f64]) -> Result<f64, IdentError> {
    check_pair(y, y_hat)?;
    let sse: f64 = y.iter().zip(y_hat).map(|(a, b)| (a - b) * (a - b)).sum();
    Ok((sse / y.len() as f64).sqrt())
}

/// RMSE normalised by the (population) standard deviation of `y`; 0 is perfect, 1 is as good
/// as predicting the mean. Infinite for a constant `y` with non-zero error.
pub fn nrmse(y: &[f64], y_hat: &[f64]) -> Result<f64, IdentError> {
    let e = rmse(y, y_hat)?;
    let m = mean(y);
    let std = (y.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / y.len() as f64).sqrt();
    Ok(if std > 0.0 {
        e / std
    } else if e == 0.0 {
        0.0
    } else {
        f64::INFINITY
    })
}

/// Fit in percent, `100 (1 - ‖y - ŷ‖ / ‖y - ȳ‖)`; 100 is perfect, 0 is the mean, can be
/// negative.
pub fn fit_percent(y: &[f64], y_hat: &[f64]) -> Result<f64, IdentError> {
    Ok(100.0 * (1.0 - nrmse(y, y_hat)?))
}

fn check_ic(n: usize, k: usize, rss: f64) -> Result<(), IdentError> {
    if n == 0 {
        return Err(IdentError::TooFewSamples { needed: 1, got: 0 });
    }
    if !(rss >= 0.0 && rss.is_finite()) {
        return Err(IdentError::InvalidParameter {
            name: "rss",
            reason: format!("residual sum of squares must be finite and >= 0, got {rss}"),
        });
    }
    let _ = k;
    Ok(())
}

/// Akaike information criterion `N ln(RSS/N) + 2k` for `n` samples and `k` parameters.
pub fn aic(n: usize, k: usize, rss: f64) -> Result<f64, IdentError> {
    check_ic(n, k, rss)?;
    let n = n as f64;
    Ok(n * (rss / n).ln() + 2.0 * k as f64)
}

/// Small-sample corrected AIC, `AIC + 2k(k+1)/(N-k-1)`; needs `N > k + 1`.
pub fn aicc(n: usize, k: usize, rss: f64) -> Result<f64, IdentError> {
    if n <= k + 1 {
        return Err(IdentError::TooFewSamples {
            needed: k + 2,
            got: n,
        });
    }
    let kf = k as f64;
    Ok(aic(n, k, rss)? + 2.0 * kf * (kf + 1.0) / (n as f64 - kf - 1.0))
}

/// Bayesian information criterion `N ln(RSS/N) + k ln N`.
pub fn bic(n: usize, k: usize, rss: f64) -> Result<f64, IdentError> {
    check_ic(n, k, rss)?;
    let nf = n as f64;
    Ok(nf * (rss / nf).ln() + k as f64 * nf.ln())
}

/// A sample correlation function with its 95 % band.
#[derive(Debug, Clone, PartialEq)]
pub struct Correlation {
    /// Lags in samples.
    pub lags: Vec<i64>,
    /// Normalised correlation at each lag, in [-1, 1].
    pub values: Vec<f64>,
    /// `1.96/√N`.
    pub bound: f64,
}

impl Correlation {
    /// Fraction of the lags (lag 0 excluded) whose value lies outside `±bound`.
    pub fn fraction_outside(&self) -> f64 {
        let (out, total) = self
            .lags
            .iter()
            .zip(&self.values)
            .filter(|(l, _)| **l != 0)
            .fold((0usize, 0usize), |(o, t), (_, v)| {
                (o + usize::from(v.abs() > self.bound), t + 1)
            });
        if total == 0 {
            0.0
        } else {
            out as f64 / total as f64
        }
    }

    /// Largest |value| over the lags other than 0, with its lag.
    pub fn max_abs_off_zero(&self) -> Option<(i64, f64)> {
        self.lags
            .iter()
            .zip(&self.values)
            .filter(|(l, _)| **l != 0)
            .map(|(l, v)| (*l, *v))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    }

    /// True when at most `allowed_fraction` of the lags (lag 0 excluded) leave the 95 % band;
    /// 0.05 is the nominal rate for a white sequence.
    pub fn within_bounds(&self, allowed_fraction: f64) -> bool {
        self.fraction_outside() <= allowed_fraction
    }
}

fn centred(x: &[f64]) -> Vec<f64> {
    let m = mean(x);
    x.iter().map(|v| v - m).collect()
}

/// `Σ_k a(k) b(k+τ) / √(Σa² Σb²)` for centred `a, b`, lags `τ` in `lags`.
fn correlate(a: &[f64], b: &[f64], lags: impl Iterator<Item = i64>) -> Correlation {
    let n = a.len();
    let norm = (a.iter().map(|v| v * v).sum::<f64>() * b.iter().map(|v| v * v).sum::<f64>()).sqrt();
    let mut out_lags = Vec::new();
    let mut values = Vec::new();
    for tau in lags {
        let mut acc = 0.0;
        if tau >= 0 {
            let t = tau as usize;
            for k in 0..n.saturating_sub(t) {
                acc += a[k] * b[k + t];
            }
        } else {
            let t = (-tau) as usize;
            for k in t..n {
                acc += a[k] * b[k - t];
            }
        }
        out_lags.push(tau);
        values.push(if norm > 0.0 { acc / norm } else { 0.0 });
    }
    Correlation {
        lags: out_lags,
        values,
        bound: correlation_bound_95(n),
    }
}

fn check_series(x: &[f64], max_lag: usize) -> Result<(), IdentError> {
    if x.len() <= max_lag + 1 {
        return Err(IdentError::TooFewSamples {
            needed: max_lag + 2,
            got: x.len(),
        });
    }
    check_finite("sequence", x)
}

/// Normalised autocorrelation `r_xx(τ) = Σ x̃(k) x̃(k+τ) / Σ x̃²`, `τ = 0..=max_lag` (x̃ centred).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Result<Correlation, IdentError> {
    check_series(x, max_lag)?;
    let c = centred(x);
    Ok(correlate(&c, &c, 0..=max_lag as i64))
}

/// Normalised cross-correlation `r_xy(τ) = Σ x̃(k) ỹ(k+τ) / √(Σx̃² Σỹ²)`,
/// `τ = -max_lag..=max_lag`; positive lags: `x` leads `y` (e.g. input `u` against residual `e`:
/// correlation at `τ > 0` means the input still explains the residual, a missing dynamic).
pub fn cross_correlation(x: &[f64], y: &[f64], max_lag: usize) -> Result<Correlation, IdentError> {
    check_len("second sequence", x.len(), y.len())?;
    check_series(x, max_lag)?;
    check_finite("second sequence", y)?;
    let (a, b) = (centred(x), centred(y));
    Ok(correlate(&a, &b, -(max_lag as i64)..=max_lag as i64))
}

/// Ljung–Box whiteness test, `Q = N(N+2) Σ_{τ=1..h} r²(τ)/(N-τ) ~ χ²(h)`; a small p-value
/// rejects whiteness.
pub fn ljung_box(x: &[f64], lags: usize) -> Result<NestedTest, IdentError> {
    if lags == 0 {
        return Err(IdentError::InvalidParameter {
            name: "lags",
            reason: "need at least 1 lag".into(),
        });
    }
    let r = autocorrelation(x, lags)?;
    let n = x.len() as f64;
    let q = n
        * (n + 2.0)
        * r.values
            .iter()
            .enumerate()
            .skip(1)
            .map(|(t, v)| v * v / (n - t as f64))
            .sum::<f64>();
    Ok(NestedTest {
        statistic: q,
        df1: lags as f64,
        df2: f64::INFINITY,
        p_value: chi_squared_sf(q, lags as f64),
    })
}

/// The correlation tests of Billings & Voon (1986) for the residual `ξ` of a model with input
/// `u`: all are zero (within `±1.96/√N`) for an adequate, possibly nonlinear, model.
#[derive(Debug, Clone, PartialEq)]
pub struct NonlinearCorrelationTests {
    /// `φ_ξξ(τ)`, `τ >= 0` (should be an impulse at 0).
    pub residual_auto: Correlation,
    /// `φ_uξ(τ)`, all τ.
    pub input_residual: Correlation,
    /// `φ_{ξ(ξu)}(τ)`: correlation of `ξ(k)u(k)` with `ξ(k+τ)`, `τ >= 1` meaningful.
    pub residual_residual_input: Correlation,
    /// `φ_{(u²)'ξ}(τ)`, all τ, `(u²)' = u² - mean(u²)`.
    pub input_squared_residual: Correlation,
    /// `φ_{(u²)'ξ²}(τ)`, all τ.
    pub input_squared_residual_squared: Correlation,
}

impl NonlinearCorrelationTests {
    /// All five tests, in the order of the fields, with their names.
    pub fn all(&self) -> [(&'static str, &Correlation); 5] {
        [
            ("residual_auto", &self.residual_auto),
            ("input_residual", &self.input_residual),
            ("residual_residual_input", &self.residual_residual_input),
            ("input_squared_residual", &self.input_squared_residual),
            (
                "input_squared_residual_squared",
                &self.input_squared_residual_squared,
            ),
        ]
    }
}

/// Computes the Billings–Voon correlation tests up to `max_lag`.
pub fn billings_voon(
    u: &[f64],
    residual: &[f64],
    max_lag: usize,
) -> Result<NonlinearCorrelationTests, IdentError> {
    check_len("residual", u.len(), residual.len())?;
    check_series(u, max_lag)?;
    check_finite("residual", residual)?;
    let xi = centred(residual);
    let uc = centred(u);
    let xi_u: Vec<f64> = xi.iter().zip(&uc).map(|(a, b)| a * b).collect();
    let u2: Vec<f64> = uc.iter().map(|v| v * v).collect();
    let xi2: Vec<f64> = xi.iter().map(|v| v * v).collect();
    let lag = max_lag as i64;
    Ok(NonlinearCorrelationTests {
        residual_auto: correlate(&xi, &xi, 0..=lag),
        input_residual: correlate(&uc, &xi, -lag..=lag),
        residual_residual_input: correlate(&centred(&xi_u), &xi, 0..=lag),
        input_squared_residual: correlate(&centred(&u2), &xi, -lag..=lag),
        input_squared_residual_squared: correlate(&centred(&u2), &centred(&xi2), -lag..=lag),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::testutil::TestRng;

    #[test]
    fn fit_measures_on_known_cases() {
        let y = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(fit_percent(&y, &y).expect("same length"), 100.0);
        let mean_model = [3.0; 5];
        assert!(fit_percent(&y, &mean_model).expect("ok").abs() < 1e-12);
        assert!((nrmse(&y, &mean_model).expect("ok") - 1.0).abs() < 1e-12);
        let off = [1.5, 2.5, 3.5, 4.5, 5.5];
        assert!((rmse(&y, &off).expect("ok") - 0.5).abs() < 1e-12);
        // std(y) = √2
        assert!((nrmse(&y, &off).expect("ok") - 0.5 / 2f64.sqrt()).abs() < 1e-12);
        assert!(rmse(&y, &off[..4]).is_err());
        assert!(rmse(&[], &[]).is_err());
    }

    #[test]
    fn information_criteria_penalise_parameters() {
        let a = aic(100, 2, 10.0).expect("ok");
        assert!((a - (100.0 * 0.1f64.ln() + 4.0)).abs() < 1e-12);
        let b = bic(100, 2, 10.0).expect("ok");
        assert!((b - (100.0 * 0.1f64.ln() + 2.0 * 100f64.ln())).abs() < 1e-12);
        // Same RSS, more parameters: worse.
        assert!(aic(100, 3, 10.0).expect("ok") > a && bic(100, 3, 10.0).expect("ok") > b);
        assert!(aicc(100, 2, 10.0).expect("ok") > a);
        assert!(aicc(3, 2, 1.0).is_err());
    }

    #[test]
    fn white_noise_passes_and_coloured_noise_fails() {
        let mut rng = TestRng::new(17);
        let n = 4000;
        let white: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let r = autocorrelation(&white, 30).expect("long enough");
        assert_eq!(r.values[0], 1.0);
        assert!(r.fraction_outside() <= 0.15, "{}", r.fraction_outside());
        assert!(ljung_box(&white, 20).expect("ok").p_value > 0.01);
        // AR(1) with pole 0.7: r(1) ≈ 0.7.
        let mut coloured = vec![0.0; n];
        for k in 1..n {
            coloured[k] = 0.7 * coloured[k - 1] + white[k];
        }
        let r = autocorrelation(&coloured, 30).expect("ok");
        assert!((r.values[1] - 0.7).abs() < 0.05);
        assert!(!r.within_bounds(0.05));
        assert!(ljung_box(&coloured, 20).expect("ok").p_value < 1e-10);
        // Cross-correlation finds a 3-sample delay.
        let delayed: Vec<f64> = (0..n)
            .map(|k| if k >= 3 { white[k - 3] } else { 0.0 })
            .collect();
        let c = cross_correlation(&white, &delayed, 10).expect("ok");
        let (lag, v) = c.max_abs_off_zero().expect("lags");
        assert_eq!(lag, 3);
        assert!(v > 0.95);
        assert!((c.bound - 1.96 / (n as f64).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn billings_voon_detects_an_unmodelled_even_nonlinearity() {
        let mut rng = TestRng::new(99);
        let n = 5000;
        let u: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let noise: Vec<f64> = (0..n).map(|_| 0.1 * rng.normal()).collect();
        // Residual of a linear model of y = u + 0.5 u(k-1)²: the square term is left over.
        let bad: Vec<f64> = (0..n)
            .map(|k| {
                noise[k]
                    + if k > 0 {
                        0.5 * (u[k - 1] * u[k - 1] - 1.0)
                    } else {
                        0.0
                    }
            })
            .collect();
        let t = billings_voon(&u, &bad, 10).expect("ok");
        // Linear cross-correlation cannot see it; the squared-input test can.
        assert!(t.input_residual.within_bounds(0.15));
        let (lag, v) = t.input_squared_residual.max_abs_off_zero().expect("lags");
        assert_eq!(lag, 1);
        assert!(v > 0.5);
        let good = billings_voon(&u, &noise, 10).expect("ok");
        for (name, c) in good.all() {
            assert!(c.within_bounds(0.2), "{name}: {}", c.fraction_outside());
        }
    }
}
