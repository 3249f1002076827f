//! Algebraic Riccati and Lyapunov equations with `nalgebra`.
//!
//! The continuous algebraic Riccati equation (CARE) `AᵀX + XA + XRX + Q = 0` (symmetric `R`,
//! `Q`; `R` indefinite in H∞ problems) is solved through the Hamiltonian
//! `H = [A R; -Q -Aᵀ]`: the matrix sign function `W = sign(H)` (Newton iteration with
//! determinant scaling, Roberts 1980 / Byers 1987) gives the stable invariant subspace as the
//! null space of `W + I`, so `[W12; W22 + I] X = -[W11 + I; W21]`, solved in least squares.
//! Newton–Kleinman steps then refine `X`, and the residual is reported.

use nalgebra::DMatrix;

use super::RobustError;

/// A stabilising CARE solution with its checks.
#[derive(Debug, Clone)]
pub struct CareSolution {
    /// The symmetric solution `X`.
    pub x: DMatrix<f64>,
    /// Relative residual `‖AᵀX + XA + XRX + Q‖_F / (‖AᵀX‖ + ‖XA‖ + ‖XRX‖ + ‖Q‖)`.
    pub residual: f64,
    /// Largest real part of the eigenvalues of `A + RX` (negative when stabilising).
    pub closed_loop_abscissa: f64,
}

/// `AᵀX + XA + XRX + Q` for the given `X`.
pub fn care_residual(
    a: &DMatrix<f64>,
    r: &DMatrix<f64>,
    q: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> DMatrix<f64> {
    a.transpose() * x + x * a + x * r * x + q
}

fn relative_residual(
    a: &DMatrix<f64>,
    r: &DMatrix<f64>,
    q: &DMatrix<f64>,
    x: &DMatrix<f64>,
) -> f64 {
    let res = care_residual(a, r, q, x).norm();
    let scale = (a.transpose() * x).norm() + (x * a).norm() + (x * r * x).norm() + q.norm();
    if scale == 0.0 {
        res
    } else {
        res / scale
    }
}

/// Matrix sign function by the scaled Newton iteration `Z ← (Z/c + c Z⁻¹)/2`,
/// `c = |det Z|^{1/N}`. Fails when an iterate is singular or when it does not converge (an
/// eigenvalue on or very near the imaginary axis).
pub fn matrix_sign(h: &DMatrix<f64>) -> Result<DMatrix<f64>, RobustError> {
    let n = h.nrows();
    let mut z = h.clone();
    for _ in 0..100 {
        let lu = z.clone().lu();
        let log_det: f64 = lu.u().diagonal().iter().map(|v| v.abs().ln()).sum();
        if !log_det.is_finite() {
            return Err(RobustError::Riccati(
                "Hamiltonian has an eigenvalue at 0".into(),
            ));
        }
        let zi = lu
            .try_inverse()
            .ok_or_else(|| RobustError::Riccati("singular sign-function iterate".into()))?;
        let c = (log_det / n as f64).exp();
        let next = (&z / c + zi * c) * 0.5;
        let change = (&next - &z).norm();
        let size = next.norm();
        z = next;
        if !size.is_finite() {
            return Err(RobustError::Riccati("sign function diverged".into()));
        }
        if change <= 1e-13 * size.max(1.0) * (n as f64) {
            return Ok(z);
        }
    }
    // Accept a slowly converged result only if it squares to the identity.
    let check = (&z * &z - DMatrix::identity(n, n)).norm();
    if check < 1e-8 * (n as f64) {
        Ok(z)
    } else {
        Err(RobustError::Riccati(
            "sign function did not converge (Hamiltonian eigenvalue on the imaginary axis)".into(),
        ))
    }
}

/// Solve `A X + X B = C` by the Kronecker form `(I ⊗ A + Bᵀ ⊗ I) vec X = vec C` (small sizes).
pub fn sylvester(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
) -> Result<DMatrix<f64>, RobustError> {
    let (n, m) = (a.nrows(), b.nrows());
    if a.ncols() != n || b.ncols() != m || c.nrows() != n || c.ncols() != m {
        return Err(RobustError::Dimension("sylvester".into()));
    }
    let mut k = DMatrix::zeros(n * m, n * m);
    for j in 0..m {
        for i in 0..n {
            let row = j * n + i;
            for l in 0..n {
                k[(row, j * n + l)] += a[(i, l)];
            }
            for l in 0..m {
                k[(row, l * n + i)] += b[(l, j)];
            }
        }
    }
    let v = DMatrix::from_column_slice(n * m, 1, c.as_slice());
    let sol = k
        .lu()
        .solve(&v)
        .ok_or(RobustError::Singular("Sylvester/Lyapunov equation"))?;
    Ok(DMatrix::from_column_slice(n, m, sol.as_slice()))
}

/// Controllability-type Lyapunov equation `A P + P Aᵀ + Q = 0`.
pub fn lyapunov(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>, RobustError> {
    let p = sylvester(a, &a.transpose(), &(-q))?;
    Ok((&p + p.transpose()) * 0.5)
}

/// Stabilising solution of `AᵀX + XA + XRX + Q = 0` (see the module notes), checked: the
/// relative residual must be below `1e-6` and `A + RX` must be stable.
pub fn care(
    a: &DMatrix<f64>,
    r: &DMatrix<f64>,
    q: &DMatrix<f64>,
) -> Result<CareSolution, RobustError> {
    let n = a.nrows();
    if a.ncols() != n || r.shape() != (n, n) || q.shape() != (n, n) {
        return Err(RobustError::Dimension("care".into()));
    }
    let mut h = DMatrix::zeros(2 * n, 2 * n);
    h.view_mut((0, 0), (n, n)).copy_from(a);
    h.view_mut((0, n), (n, n)).copy_from(r);
    h.view_mut((n, 0), (n, n)).copy_from(&(-q));
    h.view_mut((n, n), (n, n)).copy_from(&(-a.transpose()));
    let w = matrix_sign(&h)?;
    let id = DMatrix::<f64>::identity(n, n);
    let mut lhs = DMatrix::zeros(2 * n, n);
    lhs.view_mut((0, 0), (n, n))
        .copy_from(&w.view((0, n), (n, n)));
    lhs.view_mut((n, 0), (n, n))
        .copy_from(&(w.view((n, n), (n, n)) + &id));
    let mut rhs = DMatrix::zeros(2 * n, n);
    rhs.view_mut((0, 0), (n, n))
        .copy_from(&(-(w.view((0, 0), (n, n)) + &id)));
    rhs.view_mut((n, 0), (n, n))
        .copy_from(&(-w.view((n, 0), (n, n))));
    let svd = lhs.svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smin.is_nan() || smin <= 1e-12 * smax {
        return Err(RobustError::Riccati(
            "stable subspace is not a graph (no stabilising solution)".into(),
        ));
    }
    let x = svd
        .solve(&rhs, 0.0)
        .map_err(|e| RobustError::Riccati(e.to_string()))?;
    let mut x = (&x + x.transpose()) * 0.5;
    // Newton–Kleinman refinement: (A + RX)ᵀ ΔX + ΔX (A + RX) = -Res.
    let mut res = relative_residual(a, r, q, &x);
    for _ in 0..4 {
        if res < 1e-13 {
            break;
        }
        let f = a + r * &x;
        let Ok(dx) = sylvester(&f.transpose(), &f, &(-care_residual(a, r, q, &x))) else {
            break;
        };
        let cand = &x + (&dx + dx.transpose()) * 0.5;
        let cres = relative_residual(a, r, q, &cand);
        if cres < res {
            x = cand;
            res = cres;
        } else {
            break;
        }
    }
    let abscissa = (a + r * &x)
        .complex_eigenvalues()
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max);
    if res.is_nan() || res >= 1e-6 {
        return Err(RobustError::Riccati(format!(
            "residual {res:.2e} too large"
        )));
    }
    if abscissa.is_nan() || abscissa >= 0.0 {
        return Err(RobustError::Riccati(format!(
            "solution not stabilising (max Re λ(A + RX) = {abscissa:.3e})"
        )));
    }
    Ok(CareSolution {
        x,
        residual: res,
        closed_loop_abscissa: abscissa,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_lqr_riccati_has_the_closed_form() {
        // 2aX - b²X² + c² = 0 → X = (a + √(a² + b²c²)) / b².
        let (a, b, c) = (1.5, 2.0, 3.0);
        let s = care(
            &DMatrix::from_element(1, 1, a),
            &DMatrix::from_element(1, 1, -b * b),
            &DMatrix::from_element(1, 1, c * c),
        )
        .expect("solvable");
        let exact = (a + (a * a + b * b * c * c).sqrt()) / (b * b);
        assert!((s.x[(0, 0)] - exact).abs() < 1e-12 * exact);
        assert!(s.residual < 1e-12);
    }

    #[test]
    fn double_integrator_lqr_has_the_closed_form() {
        // A = [0 1; 0 0], B = [0; 1], Q = I, R = 1: X = [√3 1; 1 √3].
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
        let r = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, -1.0]);
        let q = DMatrix::identity(2, 2);
        let s = care(&a, &r, &q).expect("solvable");
        let r3 = 3f64.sqrt();
        let exact = DMatrix::from_row_slice(2, 2, &[r3, 1.0, 1.0, r3]);
        assert!((&s.x - exact).norm() < 1e-10);
        assert!(s.closed_loop_abscissa < 0.0);
    }

    #[test]
    fn imaginary_axis_eigenvalues_are_reported() {
        // A = 0, R = +1, Q = 1: H = [0 1; -1 0] has eigenvalues ±j.
        let z = DMatrix::zeros(1, 1);
        let one = DMatrix::from_element(1, 1, 1.0);
        assert!(care(&z, &one, &one).is_err());
    }

    #[test]
    fn lyapunov_solution_satisfies_the_equation() {
        let a = DMatrix::from_row_slice(3, 3, &[-1.0, 2.0, 0.0, 0.0, -3.0, 1.0, 0.5, 0.0, -2.0]);
        let q = DMatrix::from_row_slice(3, 3, &[2.0, 0.1, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0, 3.0]);
        let p = lyapunov(&a, &q).expect("ok");
        assert!((&a * &p + &p * a.transpose() + &q).norm() < 1e-12);
    }
}
