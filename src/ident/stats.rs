//! Distribution functions and nested-model tests, self-contained.
//!
//! The special functions follow the classical formulations: the Lanczos approximation of
//! `ln Γ` (g = 7, nine coefficients, relative error below 1e-14), the continued fraction of the
//! regularised incomplete beta function evaluated by the modified Lentz method, and the
//! series / continued fraction pair for the regularised incomplete gamma function. On top of them:
//! Student-t, F and χ² distribution functions, and the F-test and likelihood-ratio test that the
//! lab uses to judge whether adding a physical effect to a model improves it significantly.

use super::error::IdentError;

/// 95 % quantile of the χ² distribution with one degree of freedom: the likelihood-ratio
/// threshold of one parameter at the 5 % level (profile intervals, "as good as the best").
pub const CHI2_1_95: f64 = 3.841_458_820_694_124;

const LANCZOS_G: f64 = 7.0;
const LANCZOS: [f64; 9] = [
    0.999_999_999_999_809_9,
    676.520_368_121_885_1,
    -1_259.139_216_722_402_8,
    771.323_428_777_653_1,
    -176.615_029_162_140_6,
    12.507_343_278_686_905,
    -0.138_571_095_265_720_12,
    9.984_369_578_019_572e-6,
    1.505_632_735_149_311_6e-7,
];

const EPS: f64 = 1e-15;
const TINY: f64 = 1e-300;
const MAX_ITER: usize = 10_000;

/// Natural logarithm of the gamma function, `ln Γ(x)` for `x > 0` (Lanczos approximation).
pub fn ln_gamma(x: f64) -> f64 {
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1-x) = π / sin(πx).
        let s = (std::f64::consts::PI * x).sin().abs();
        return std::f64::consts::PI.ln() - s.ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = LANCZOS[0];
    let t = x + LANCZOS_G + 0.5;
    for (i, c) in LANCZOS.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Continued fraction for the incomplete beta function (modified Lentz).
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    let qab = a + b;
    let qap = a + 1.0;
    let qam = a - 1.0;
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..MAX_ITER {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < EPS {
            break;
        }
    }
    h
}

/// Regularised incomplete beta function `I_x(a, b) = B(x; a, b) / B(a, b)`, `a, b > 0`,
/// `0 <= x <= 1`. Returns NaN outside the domain.
pub fn regularized_incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if !(a > 0.0 && b > 0.0 && (0.0..=1.0).contains(&x)) {
        return f64::NAN;
    }
    if x == 0.0 {
        return 0.0;
    }
    if x == 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    let front = ln_front.exp();
    // The continued fraction converges fast for x < (a+1)/(a+b+2); use the symmetry otherwise.
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b
    }
}

/// Regularised lower incomplete gamma function `P(a, x) = γ(a, x) / Γ(a)`, `a > 0`, `x >= 0`.
pub fn regularized_gamma_p(a: f64, x: f64) -> f64 {
    if !(a > 0.0 && x >= 0.0) {
        return f64::NAN;
    }
    if x == 0.0 {
        return 0.0;
    }
    if x < a + 1.0 {
        gamma_series(a, x)
    } else {
        1.0 - gamma_continued_fraction(a, x)
    }
}

/// Regularised upper incomplete gamma function `Q(a, x) = 1 - P(a, x)`.
pub fn regularized_gamma_q(a: f64, x: f64) -> f64 {
    if !(a > 0.0 && x >= 0.0) {
        return f64::NAN;
    }
    if x == 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        1.0 - gamma_series(a, x)
    } else {
        gamma_continued_fraction(a, x)
    }
}

fn gamma_series(a: f64, x: f64) -> f64 {
    let mut ap = a;
    let mut sum = 1.0 / a;
    let mut del = sum;
    for _ in 0..MAX_ITER {
        ap += 1.0;
        del *= x / ap;
        sum += del;
        if del.abs() < sum.abs() * EPS {
            break;
        }
    }
    sum * (-x + a * x.ln() - ln_gamma(a)).exp()
}

fn gamma_continued_fraction(a: f64, x: f64) -> f64 {
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..MAX_ITER {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < EPS {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

/// Standard normal distribution function `Φ(x) = (1 + erf(x/√2)) / 2`.
pub fn normal_cdf(x: f64) -> f64 {
    let p = regularized_gamma_p(0.5, 0.5 * x * x);
    if x >= 0.0 {
        0.5 + 0.5 * p
    } else {
        0.5 - 0.5 * p
    }
}

/// Student-t distribution function with `dof > 0` degrees of freedom:
/// `P(T <= t) = 1 - I_{ν/(ν+t²)}(ν/2, 1/2) / 2` for `t >= 0`.
pub fn student_t_cdf(t: f64, dof: f64) -> f64 {
    if t.is_nan() || dof.is_nan() || dof <= 0.0 {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let tail = 0.5 * regularized_incomplete_beta(0.5 * dof, 0.5, dof / (dof + t * t));
    if t >= 0.0 {
        1.0 - tail
    } else {
        tail
    }
}

/// Quantile of the Student-t distribution: the `t` with `P(T <= t) = p`, `0 < p < 1`
/// (bisection on [`student_t_cdf`] to full double precision).
pub fn student_t_quantile(p: f64, dof: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && dof > 0.0) {
        return f64::NAN;
    }
    if p == 0.5 {
        return 0.0;
    }
    let mut hi = 1.0;
    while student_t_cdf(hi, dof) < p.max(1.0 - p) {
        hi *= 2.0;
        if hi > 1e300 {
            break;
        }
    }
    let mut lo = 0.0;
    let target = p.max(1.0 - p);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_cdf(mid, dof) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi {
            break;
        }
    }
    let q = 0.5 * (lo + hi);
    if p > 0.5 {
        q
    } else {
        -q
    }
}

/// F distribution function, `P(F <= x) = I_{d1 x/(d1 x + d2)}(d1/2, d2/2)`.
pub fn f_cdf(x: f64, d1: f64, d2: f64) -> f64 {
    if !(d1 > 0.0 && d2 > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 0.0;
    }
    regularized_incomplete_beta(0.5 * d1, 0.5 * d2, d1 * x / (d1 * x + d2))
}

/// Upper tail of the F distribution, `P(F > x) = I_{d2/(d2 + d1 x)}(d2/2, d1/2)`
/// (computed directly, so small p-values keep their precision).
pub fn f_sf(x: f64, d1: f64, d2: f64) -> f64 {
    if !(d1 > 0.0 && d2 > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    regularized_incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * x))
}

/// χ² distribution function with `k` degrees of freedom, `P(k/2, x/2)`.
pub fn chi_squared_cdf(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    regularized_gamma_p(0.5 * k, 0.5 * x)
}

/// Upper tail of the χ² distribution, `Q(k/2, x/2)`.
pub fn chi_squared_sf(x: f64, k: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    regularized_gamma_q(0.5 * k, 0.5 * x)
}

/// Result of a test of a restricted model against a larger model that contains it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NestedTest {
    /// Test statistic (F or likelihood ratio).
    pub statistic: f64,
    /// Numerator degrees of freedom: the number of added parameters.
    pub df1: f64,
    /// Denominator degrees of freedom (F-test only; `f64::INFINITY` for the χ² test).
    pub df2: f64,
    /// Probability of a statistic at least this large if the added parameters are zero.
    pub p_value: f64,
}

impl NestedTest {
    /// Whether the larger model is significantly better at level `alpha` (e.g. 0.05).
    pub fn significant(&self, alpha: f64) -> bool {
        self.p_value < alpha
    }
}

fn check_nested(
    rss_restricted: f64,
    k_restricted: usize,
    rss_full: f64,
    k_full: usize,
    n: usize,
) -> Result<(), IdentError> {
    if k_full <= k_restricted {
        return Err(IdentError::InvalidParameter {
            name: "k_full",
            reason: format!(
                "the full model must have more parameters than the restricted one ({k_full} <= {k_restricted})"
            ),
        });
    }
    if n <= k_full {
        return Err(IdentError::TooFewSamples {
            needed: k_full + 1,
            got: n,
        });
    }
    if !(rss_restricted.is_finite() && rss_full.is_finite()) {
        return Err(IdentError::NonFinite {
            what: "residual sum of squares",
        });
    }
    if rss_restricted < 0.0 || rss_full < 0.0 {
        return Err(IdentError::InvalidParameter {
            name: "rss",
            reason: format!("sums of squares must be >= 0, got {rss_restricted} and {rss_full}"),
        });
    }
    Ok(())
}

/// F-test for nested least-squares models:
/// `F = ((RSS_r - RSS_f) / (k_f - k_r)) / (RSS_f / (n - k_f))`, `F ~ F(k_f - k_r, n - k_f)`.
pub fn f_test_nested(
    rss_restricted: f64,
    k_restricted: usize,
    rss_full: f64,
    k_full: usize,
    n: usize,
) -> Result<NestedTest, IdentError> {
    check_nested(rss_restricted, k_restricted, rss_full, k_full, n)?;
    let df1 = (k_full - k_restricted) as f64;
    let df2 = (n - k_full) as f64;
    let gain = (rss_restricted - rss_full).max(0.0);
    let statistic = if rss_full > 0.0 {
        (gain / df1) / (rss_full / df2)
    } else if gain > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    let p_value = if statistic.is_infinite() {
        0.0
    } else {
        f_sf(statistic, df1, df2)
    };
    Ok(NestedTest {
        statistic,
        df1,
        df2,
        p_value,
    })
}

/// Likelihood-ratio test for nested models with Gaussian errors:
/// `LR = n ln(RSS_r / RSS_f)`, asymptotically `χ²(k_f - k_r)`.
pub fn likelihood_ratio_test(
    rss_restricted: f64,
    k_restricted: usize,
    rss_full: f64,
    k_full: usize,
    n: usize,
) -> Result<NestedTest, IdentError> {
    check_nested(rss_restricted, k_restricted, rss_full, k_full, n)?;
    let df1 = (k_full - k_restricted) as f64;
    let statistic = if rss_full > 0.0 {
        (n as f64 * (rss_restricted / rss_full).ln()).max(0.0)
    } else if rss_restricted > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    let p_value = if statistic.is_infinite() {
        0.0
    } else {
        chi_squared_sf(statistic, df1)
    };
    Ok(NestedTest {
        statistic,
        df1,
        df2: f64::INFINITY,
        p_value,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn ln_gamma_matches_factorials_and_half() {
        // Γ(n) = (n-1)!
        let mut fact = 1.0_f64;
        for n in 1..20 {
            if n > 1 {
                fact *= (n - 1) as f64;
            }
            assert!(
                close(
                    ln_gamma(n as f64),
                    fact.ln(),
                    1e-12 * fact.ln().abs().max(1.0)
                ),
                "n={n}"
            );
        }
        // Γ(1/2) = √π
        assert!(close(ln_gamma(0.5), 0.5 * std::f64::consts::PI.ln(), 1e-13));
        // Γ(0.1) = 9.513507698668732
        assert!(close(ln_gamma(0.1), 9.513_507_698_668_732_f64.ln(), 1e-12));
    }

    #[test]
    fn incomplete_beta_matches_closed_forms() {
        // I_x(2, 3) = sum_{j=2}^{4} C(4,j) x^j (1-x)^{4-j}
        for &x in &[0.05_f64, 0.3, 0.5, 0.77, 0.99] {
            let exact: f64 = (2..=4)
                .map(|j| {
                    let c = [1.0, 4.0, 6.0, 4.0, 1.0][j];
                    c * x.powi(j as i32) * (1.0 - x).powi(4 - j as i32)
                })
                .sum();
            assert!(
                close(regularized_incomplete_beta(2.0, 3.0, x), exact, 1e-13),
                "x={x}"
            );
        }
        // I_x(a, 1) = x^a
        assert!(close(
            regularized_incomplete_beta(3.7, 1.0, 0.42),
            0.42_f64.powf(3.7),
            1e-13
        ));
        assert!(regularized_incomplete_beta(1.0, 1.0, 1.5).is_nan());
    }

    #[test]
    fn distributions_match_table_values() {
        // F(2, 10) upper 5 % point is 4.1028; F(3, 30) upper 1 % point is 4.5097.
        assert!(close(f_sf(4.102_821, 2.0, 10.0), 0.05, 1e-6));
        assert!(close(f_cdf(4.509_74, 3.0, 30.0), 0.99, 1e-5));
        // t(10) 97.5 % quantile 2.228139; t(1) is Cauchy: quantile(0.75) = 1.
        assert!(close(
            student_t_quantile(0.975, 10.0),
            2.228_138_851_986,
            1e-9
        ));
        assert!(close(student_t_quantile(0.75, 1.0), 1.0, 1e-12));
        assert!(close(
            student_t_quantile(0.025, 10.0),
            -2.228_138_851_986,
            1e-9
        ));
        // χ²(1) 95 % point 3.841459; χ²(4) at 9.487729 is 0.95.
        assert!(close(chi_squared_sf(3.841_458_820_694, 1.0), 0.05, 1e-10));
        assert!(close(chi_squared_sf(CHI2_1_95, 1.0), 0.05, 1e-12));
        assert!(close(chi_squared_cdf(9.487_729_036_781, 4.0), 0.95, 1e-10));
        assert!(close(normal_cdf(1.959_963_984_540), 0.975, 1e-12));
        assert!(close(normal_cdf(-1.0), 0.158_655_253_931_457, 1e-12));
    }

    #[test]
    fn f_test_separates_useful_from_useless_parameters() {
        // Large drop in RSS for one added parameter: significant.
        let t = f_test_nested(100.0, 2, 50.0, 3, 200).expect("valid test");
        assert!(t.statistic > 190.0 && t.p_value < 1e-20);
        // Tiny drop, consistent with noise: not significant.
        let t = f_test_nested(100.0, 2, 99.8, 3, 200).expect("valid test");
        assert!(t.p_value > 0.3, "p = {}", t.p_value);
        assert!(!t.significant(0.05));
        let lr = likelihood_ratio_test(100.0, 2, 99.8, 3, 200).expect("valid test");
        assert!(lr.p_value > 0.3);
        assert!(f_test_nested(1.0, 3, 1.0, 3, 100).is_err());
        assert!(f_test_nested(1.0, 2, 1.0, 3, 3).is_err());
    }
}
