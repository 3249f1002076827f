//! Batch least squares for linear-in-the-parameters models, `y = Ψ θ + e`.
//!
//! Solves `θ̂ = argmin ‖y - Ψθ‖²` (Isermann & Raab 1993, equation-error estimation,
//! `e(k) = y(k) - ψᵀ(k) θ`) with a Householder QR factorisation of the column-equilibrated
//! regressor matrix, never through the normal equations, so the error grows with the condition
//! number of `Ψ` and not with its square. Rank and condition come from the singular values of the
//! triangular factor; a rank-deficient problem is refused and the offending column is named.

use nalgebra::{DMatrix, DVector};

use super::error::{check_finite, check_len, IdentError};
use super::stats::student_t_quantile;

/// Tuning of the batch solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LsOptions {
    /// Ratio of smallest to largest singular value of the column-equilibrated regressor below
    /// which the problem counts as rank deficient. Default `1e-10`.
    pub rank_tolerance: f64,
}

impl Default for LsOptions {
    fn default() -> Self {
        Self {
            rank_tolerance: 1e-10,
        }
    }
}

/// A least-squares estimate with its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct LsFit {
    /// Estimated parameters `θ̂`.
    pub theta: DVector<f64>,
    /// Residuals `e = y - Ψθ̂`.
    pub residuals: DVector<f64>,
    /// Residual sum of squares `eᵀe`.
    pub rss: f64,
    /// Unbiased residual variance `σ̂² = eᵀe / (N - p)`.
    pub residual_variance: f64,
    /// Parameter covariance `σ̂² (ΨᵀΨ)⁻¹`.
    pub covariance: DMatrix<f64>,
    /// Standard errors, square roots of the diagonal of the covariance.
    pub std_errors: DVector<f64>,
    /// 2-norm condition number of `Ψ` as given.
    pub condition_number: f64,
    /// Condition number after scaling every column to unit norm (what limits the accuracy).
    pub scaled_condition_number: f64,
    /// Number of samples `N`.
    pub samples: usize,
}

impl LsFit {
    /// Number of parameters `p`.
    pub fn parameters(&self) -> usize {
        self.theta.len()
    }

    /// Residual degrees of freedom `N - p`.
    pub fn dof(&self) -> usize {
        self.samples - self.theta.len()
    }

    /// Two-sided confidence intervals `θ̂_i ± t_{(1+level)/2, N-p} σ_i` at `level` (e.g. 0.95).
    pub fn confidence_intervals(&self, level: f64) -> Vec<(f64, f64)> {
        let t = student_t_quantile(0.5 * (1.0 + level), self.dof() as f64);
        self.theta
            .iter()
            .zip(self.std_errors.iter())
            .map(|(th, se)| (th - t * se, th + t * se))
            .collect()
    }

    /// Model output `ψᵀθ̂` for one regressor row.
    pub fn predict(&self, psi: &[f64]) -> Result<f64, IdentError> {
        check_len("regressor", self.theta.len(), psi.len())?;
        Ok(psi.iter().zip(self.theta.iter()).map(|(a, b)| a * b).sum())
    }
}

/// Least-squares estimate with default options; see [`least_squares_with`].
pub fn least_squares(psi: &DMatrix<f64>, y: &DVector<f64>) -> Result<LsFit, IdentError> {
    least_squares_with(psi, y, &LsOptions::default())
}

/// Least-squares estimate `θ̂ = R⁻¹ Qᵀ y` from `Ψ D⁻¹ = Q R` (`D` the column norms).
///
/// Needs `N > p` samples (a residual variance needs at least one degree of freedom).
pub fn least_squares_with(
    psi: &DMatrix<f64>,
    y: &DVector<f64>,
    options: &LsOptions,
) -> Result<LsFit, IdentError> {
    let (n_rows, n_cols) = psi.shape();
    check_len("output vector", n_rows, y.len())?;
    if n_cols == 0 {
        return Err(IdentError::InvalidParameter {
            name: "regressor",
            reason: "regressor matrix has no columns".into(),
        });
    }
    if n_rows <= n_cols {
        return Err(IdentError::TooFewSamples {
            needed: n_cols + 1,
            got: n_rows,
        });
    }
    check_finite("regressor matrix", psi.as_slice())?;
    check_finite("output vector", y.as_slice())?;

    // Column equilibration: Ψ = Ψ_s D.
    let mut scaled = psi.clone();
    let mut norms = DVector::zeros(n_cols);
    for j in 0..n_cols {
        let norm = scaled.column(j).norm();
        if norm == 0.0 {
            return Err(IdentError::RankDeficient {
                column: j,
                rank: n_cols - 1,
                columns: n_cols,
            });
        }
        norms[j] = norm;
        scaled.column_mut(j).unscale_mut(norm);
    }

    let qr = scaled.qr();
    let r = qr.r();

    // Rank and condition from the singular values of R (those of Ψ_s).
    let svd = r.clone().svd(false, true);
    let s = &svd.singular_values;
    let s_max = s.max();
    let s_min = s.min();
    let scaled_condition_number = if s_min > 0.0 {
        s_max / s_min
    } else {
        f64::INFINITY
    };
    if s_min.is_nan() || s_min <= options.rank_tolerance * s_max {
        let rank = s
            .iter()
            .filter(|&&v| v > options.rank_tolerance * s_max)
            .count();
        let column = collinear_column(&svd.v_t, s);
        return Err(IdentError::RankDeficient {
            column,
            rank,
            columns: n_cols,
        });
    }
    let r_raw = DMatrix::from_fn(n_cols, n_cols, |i, j| r[(i, j)] * norms[j]);
    let s_raw = r_raw.singular_values();
    let raw_min = s_raw.min();
    let condition_number = if raw_min > 0.0 {
        s_raw.max() / raw_min
    } else {
        f64::INFINITY
    };

    let mut qty = y.clone();
    qr.q_tr_mul(&mut qty);
    let rhs = qty.rows(0, n_cols).into_owned();
    let theta_s = r
        .solve_upper_triangular(&rhs)
        .ok_or(IdentError::RankDeficient {
            column: n_cols - 1,
            rank: n_cols - 1,
            columns: n_cols,
        })?;
    let theta = theta_s.component_div(&norms);

    let residuals = y - psi * &theta;
    let rss = residuals.norm_squared();
    let dof = (n_rows - n_cols) as f64;
    let residual_variance = rss / dof;

    let r_inv = r
        .solve_upper_triangular(&DMatrix::identity(n_cols, n_cols))
        .ok_or(IdentError::RankDeficient {
            column: n_cols - 1,
            rank: n_cols - 1,
            columns: n_cols,
        })?;
    let unscaled = &r_inv * r_inv.transpose();
    let covariance = DMatrix::from_fn(n_cols, n_cols, |i, j| {
        residual_variance * unscaled[(i, j)] / (norms[i] * norms[j])
    });
    let std_errors = DVector::from_fn(n_cols, |i, _| covariance[(i, i)].max(0.0).sqrt());
    check_finite("estimate", theta.as_slice())?;

    Ok(LsFit {
        theta,
        residuals,
        rss,
        residual_variance,
        covariance,
        std_errors,
        condition_number,
        scaled_condition_number,
        samples: n_rows,
    })
}

/// Rows of a regressor rotated into its triangular factor at a time: small enough that the
/// block and the factor stay in the first-level cache.
const FACTOR_BLOCK_ROWS: usize = 64;

/// The triangular factor of a tall regressor, `Ψ D⁻¹ = Q R` with `D` the column norms, taken
/// row block by row block: each block is stacked under the factor so far and rotated into it by
/// Householder reflections (a sequential tall-skinny QR). `Q` is never formed.
///
/// Every least-squares problem on a subset of the columns, with a target that is a combination
/// of the others, then reduces to one of `p × p` ([`least_squares_rotated`]): `Qᵀ Ψ_S` and
/// `Qᵀ y` are columns of `R D`. The regressor is read once, in place, however many subsets are
/// solved on it.
#[derive(Debug, Clone, PartialEq)]
pub struct ColumnFactor {
    /// Upper triangular `R` of the column-equilibrated regressor (`p × p`).
    pub r: DMatrix<f64>,
    /// Column norms `D` over the rows taken (0 for a column that is zero there).
    pub norms: DVector<f64>,
    /// Rows taken, `N`.
    pub samples: usize,
}

impl ColumnFactor {
    /// The factor of the regressor whose column `j` is `columns[j][k]` for `k` in `rows`.
    pub fn new(columns: &[&[f64]], rows: &[usize]) -> ColumnFactor {
        let p = columns.len();
        let norms = DVector::from_iterator(
            p,
            columns
                .iter()
                .map(|c| rows.iter().map(|&k| c[k] * c[k]).sum::<f64>().sqrt()),
        );
        let scale: Vec<f64> = norms
            .iter()
            .map(|&n| if n > 0.0 { 1.0 / n } else { 0.0 })
            .collect();
        // Column-major work area: rows 0..p the factor so far, rows p.. the next block.
        let ld = p + FACTOR_BLOCK_ROWS;
        let mut w = vec![0.0; ld * p];
        let mut v = [0.0; FACTOR_BLOCK_ROWS];
        for block in rows.chunks(FACTOR_BLOCK_ROWS) {
            let b = block.len();
            for (j, c) in columns.iter().enumerate() {
                let col = &mut w[j * ld + p..j * ld + p + b];
                for (x, &k) in col.iter_mut().zip(block) {
                    *x = c[k] * scale[j];
                }
            }
            for j in 0..p {
                // Reflection of `[R_jj; block column j]` onto `β e_1` (LAPACK's convention:
                // `H = I - τ u uᵀ`, `u_0 = 1`); the factor's rows below `j` are zero in column j.
                let alpha = w[j * ld + j];
                let below = &w[j * ld + p..j * ld + p + b];
                let sigma = dot(below, below);
                if sigma == 0.0 {
                    continue;
                }
                let norm = (alpha * alpha + sigma).sqrt();
                let beta = if alpha > 0.0 { -norm } else { norm };
                let tau = (beta - alpha) / beta;
                let inv = 1.0 / (alpha - beta);
                for (u, &x) in v.iter_mut().zip(below) {
                    *u = x * inv;
                }
                w[j * ld + j] = beta;
                w[j * ld + p..j * ld + p + b].fill(0.0);
                for c in j + 1..p {
                    let col = &mut w[c * ld..c * ld + p + b];
                    let s = tau * (col[j] + dot(&v[..b], &col[p..p + b]));
                    col[j] -= s;
                    for (x, u) in col[p..p + b].iter_mut().zip(&v[..b]) {
                        *x -= s * u;
                    }
                }
            }
        }
        let r = DMatrix::from_fn(p, p, |i, j| if i <= j { w[j * ld + i] } else { 0.0 });
        ColumnFactor {
            r,
            norms,
            samples: rows.len(),
        }
    }

    /// `Qᵀ Ψ_j`, column `j` of the regressor in the factor's coordinates (`R_j D_j`).
    pub fn rotated_column(&self, j: usize) -> DVector<f64> {
        self.r.column(j) * self.norms[j]
    }
}

/// `Σ x_i y_i` in four interleaved partial sums (which the compiler can keep in vector lanes).
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (xc, yc) = (x.chunks_exact(4), y.chunks_exact(4));
    let tail: f64 = xc
        .remainder()
        .iter()
        .zip(yc.remainder())
        .map(|(a, b)| a * b)
        .sum();
    for (a, b) in xc.zip(yc) {
        for l in 0..4 {
            acc[l] += a[l] * b[l];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Least squares on a regressor known by its rotation: `a = Qᵀ Ψ` and `b = Qᵀ y` for `y` in the
/// range of `Q` (the target a combination of the factor's columns, see [`ColumnFactor`]), on
/// `samples` rows. The estimate and the residual sum of squares are those of the full problem,
/// and so are the statistics (on `samples - p` degrees of freedom); `residuals` are the reduced
/// problem's, `b - a θ̂`.
pub fn least_squares_rotated(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    samples: usize,
    options: &LsOptions,
) -> Result<LsFit, IdentError> {
    let p = a.ncols();
    if samples <= p {
        return Err(IdentError::TooFewSamples {
            needed: p + 1,
            got: samples,
        });
    }
    let mut fit = least_squares_with(a, b, options)?;
    // Same estimate and residual; only the degrees of freedom are the full problem's.
    let ratio = fit.dof() as f64 / (samples - p) as f64;
    fit.residual_variance *= ratio;
    fit.covariance *= ratio;
    fit.std_errors *= ratio.sqrt();
    fit.samples = samples;
    Ok(fit)
}

/// The last column that takes part in the (near) null vector of `Ψ_s`: it is (nearly) a linear
/// combination of the columns before it.
fn collinear_column(v_t: &Option<DMatrix<f64>>, s: &DVector<f64>) -> usize {
    let n = s.len();
    let Some(v_t) = v_t else { return n - 1 };
    let i_min = s.imin();
    let null = v_t.row(i_min);
    let largest = null.amax();
    (0..n)
        .rev()
        .find(|&j| null[j].abs() > 0.1 * largest)
        .unwrap_or(n - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::testutil::TestRng;

    #[test]
    fn recovers_parameters_with_honest_confidence_intervals() {
        let mut rng = TestRng::new(7);
        let theta_true = [2.0, -0.5, 300.0];
        let n = 2000;
        let sigma = 0.1;
        let psi = DMatrix::from_fn(n, 3, |_, j| match j {
            0 => rng.normal(),
            1 => 1e3 * rng.uniform(), // badly scaled column
            _ => 1.0,
        });
        let y = DVector::from_fn(n, |k, _| {
            (0..3).map(|j| psi[(k, j)] * theta_true[j]).sum::<f64>() + sigma * rng.normal()
        });
        let fit = least_squares(&psi, &y).expect("well posed");
        eprintln!(
            "LS theta {:?} se {:?} cond {:.3e} scaled {:.3e}",
            fit.theta.as_slice(),
            fit.std_errors.as_slice(),
            fit.condition_number,
            fit.scaled_condition_number
        );
        let ci = fit.confidence_intervals(0.99);
        for j in 0..3 {
            assert!(
                ci[j].0 < theta_true[j] && theta_true[j] < ci[j].1,
                "theta[{j}] = {} not in {:?}",
                theta_true[j],
                ci[j]
            );
            assert!(fit.std_errors[j] > 0.0);
        }
        assert!((fit.theta[0] - 2.0).abs() < 0.01);
        assert!((fit.residual_variance.sqrt() - sigma).abs() < 0.01);
        assert!(fit.condition_number > fit.scaled_condition_number);
        assert_eq!(fit.dof(), n - 3);
    }

    #[test]
    fn is_accurate_where_normal_equations_fail() {
        // Polynomial regressors on [1, 1.1]: cond(Ψ) ~ 1e7, cond(ΨᵀΨ) ~ 1e14.
        let n = 200;
        let t = DVector::from_fn(n, |k, _| 1.0 + 0.1 * k as f64 / (n - 1) as f64);
        let psi = DMatrix::from_fn(n, 5, |k, j| t[k].powi(j as i32));
        let theta_true = DVector::from_vec(vec![1.0, -2.0, 3.0, -1.5, 0.25]);
        let y = &psi * &theta_true;
        let fit = least_squares(&psi, &y).expect("full rank");
        let err = (&fit.theta - &theta_true).amax();
        assert!(err < 1e-4, "QR error {err}");
        assert!(fit.condition_number > 1e6);
    }

    /// Least squares of the columns `subset` of `cols` against the target `-Σ w_j col_j` over
    /// the other columns, through the factor, on the rows `rows`.
    fn through_factor(
        cols: &[Vec<f64>],
        rows: &[usize],
        subset: &[usize],
        w: &[f64],
    ) -> Result<LsFit, IdentError> {
        let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        let f = ColumnFactor::new(&refs, rows);
        let m = cols.len();
        let mut b = DVector::zeros(m);
        for (j, &wj) in w.iter().enumerate() {
            if !subset.contains(&j) {
                b.axpy(-wj, &f.rotated_column(j), 1.0);
            }
        }
        let a = DMatrix::from_fn(m, subset.len(), |i, c| {
            f.r[(i, subset[c])] * f.norms[subset[c]]
        });
        least_squares_rotated(&a, &b, rows.len(), &LsOptions::default())
    }

    #[test]
    fn the_factor_gives_the_direct_solution_on_any_subset_of_its_columns() {
        // Five columns, one badly scaled, over a row set that skips some rows (more rows than
        // a block, and not a multiple of one): every subset solved through the factor is the
        // direct QR solution on the same rows, estimate, residual and statistics.
        let mut rng = TestRng::new(11);
        let n = 1000;
        let cols: Vec<Vec<f64>> = (0..5)
            .map(|j| {
                (0..n)
                    .map(|_| rng.normal() * if j == 1 { 1e4 } else { 1.0 })
                    .collect()
            })
            .collect();
        let rows: Vec<usize> = (0..n).filter(|k| k % 7 != 3).collect();
        let w = [0.5, -2e-4, 1.5, 3.0, -1.0];
        for subset in [vec![0, 1, 2], vec![1, 3], vec![2], vec![0, 1, 2, 3]] {
            let fit = through_factor(&cols, &rows, &subset, &w).expect("full rank");
            let psi = DMatrix::from_fn(rows.len(), subset.len(), |i, c| cols[subset[c]][rows[i]]);
            let y = DVector::from_fn(rows.len(), |i, _| {
                -(0..5)
                    .filter(|j| !subset.contains(j))
                    .map(|j| w[j] * cols[j][rows[i]])
                    .sum::<f64>()
            });
            let direct = least_squares(&psi, &y).expect("full rank");
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-12);
            for c in 0..subset.len() {
                assert!(close(fit.theta[c], direct.theta[c]), "{subset:?} θ[{c}]");
                assert!(
                    close(fit.std_errors[c], direct.std_errors[c]),
                    "{subset:?} σ[{c}]"
                );
            }
            assert!(close(fit.rss, direct.rss), "{subset:?} rss");
            assert_eq!(fit.dof(), direct.dof());
            let (a, b) = (
                fit.confidence_intervals(0.95),
                direct.confidence_intervals(0.95),
            );
            assert!(close(a[0].1 - a[0].0, b[0].1 - b[0].0));
        }
    }

    #[test]
    fn the_factor_names_the_collinear_column_of_a_subset() {
        let mut rng = TestRng::new(5);
        let n = 300;
        let mut cols: Vec<Vec<f64>> = (0..4)
            .map(|_| (0..n).map(|_| rng.normal()).collect())
            .collect();
        cols[2] = (0..n).map(|k| 2.0 * cols[0][k] - cols[1][k]).collect();
        let rows: Vec<usize> = (0..n).collect();
        // Columns 0, 1, 2 free (2 a combination of the others), 3 the target.
        match through_factor(&cols, &rows, &[0, 1, 2], &[0.0, 0.0, 0.0, 1.0]) {
            Err(IdentError::RankDeficient { column, rank, .. }) => {
                assert_eq!(column, 2);
                assert_eq!(rank, 2);
            }
            other => panic!("expected rank deficiency, got {other:?}"),
        }
        // Without the combination the same columns solve.
        assert!(through_factor(&cols, &rows, &[0, 1], &[0.0, 0.0, 0.0, 1.0]).is_ok());
        // A column that is zero on the rows taken is named too.
        cols[1] = vec![0.0; n];
        assert!(matches!(
            through_factor(&cols, &rows, &[0, 1], &[0.0, 0.0, 0.0, 1.0]),
            Err(IdentError::RankDeficient { column: 1, .. })
        ));
    }

    #[test]
    fn names_the_collinear_column() {
        let mut rng = TestRng::new(3);
        let n = 100;
        let psi = DMatrix::from_fn(n, 4, |_, _| rng.normal());
        let mut psi = psi;
        for k in 0..n {
            psi[(k, 2)] = 2.0 * psi[(k, 0)] - psi[(k, 1)];
        }
        let y = DVector::from_fn(n, |_, _| rng.normal());
        match least_squares(&psi, &y) {
            Err(IdentError::RankDeficient {
                column,
                rank,
                columns,
            }) => {
                assert_eq!(column, 2);
                assert_eq!(rank, 3);
                assert_eq!(columns, 4);
            }
            other => panic!("expected rank deficiency, got {other:?}"),
        }
        let mut zero = DMatrix::from_fn(n, 2, |_, _| rng.normal());
        zero.column_mut(1).fill(0.0);
        assert!(matches!(
            least_squares(&zero, &y),
            Err(IdentError::RankDeficient { column: 1, .. })
        ));
    }

    #[test]
    fn refuses_too_few_samples_and_bad_data() {
        let psi = DMatrix::from_element(3, 3, 1.0);
        let y = DVector::from_element(3, 1.0);
        assert_eq!(
            least_squares(&psi, &y),
            Err(IdentError::TooFewSamples { needed: 4, got: 3 })
        );
        let mut psi = DMatrix::from_fn(10, 2, |i, j| (i * (j + 1)) as f64 + j as f64);
        let y = DVector::from_element(10, 1.0);
        psi[(4, 1)] = f64::NAN;
        assert!(matches!(
            least_squares(&psi, &y),
            Err(IdentError::NonFinite { .. })
        ));
        let short = DVector::from_element(9, 1.0);
        assert!(matches!(
            least_squares(&DMatrix::zeros(10, 2), &short),
            Err(IdentError::DimensionMismatch { .. })
        ));
    }
}
