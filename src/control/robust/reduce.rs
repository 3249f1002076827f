//! Order reduction by balanced truncation (Moore 1981; square-root form of Laub et al. 1987).
//!
//! Gramians `A P + P Aᵀ + B Bᵀ = 0`, `Aᵀ Q + Q A + Cᵀ C = 0`; with `P = L_p L_pᵀ`,
//! `Q = L_q L_qᵀ` and `L_qᵀ L_p = U Σ Vᵀ`, the balancing projections are
//! `T = L_p V_r Σ_r^{-1/2}`, `T_i = Σ_r^{-1/2} U_rᵀ L_qᵀ`, the reduced system
//! `(T_i A T, T_i B, C T, D)`, and `‖G - G_r‖∞ ≤ 2 Σ_{i>r} σ_i` (Hankel singular values σ_i).

use nalgebra::DMatrix;

use super::lti::Ss;
use super::riccati::lyapunov;
use super::RobustError;

/// A reduced system with its Hankel singular values and error bound.
#[derive(Debug, Clone)]
pub struct Reduced {
    pub sys: Ss,
    /// All Hankel singular values of the full system, descending.
    pub hankel: Vec<f64>,
    /// `2 Σ_{i>r} σ_i`.
    pub error_bound: f64,
}

/// Symmetric square-root factor `L` with `M ≈ L Lᵀ` (negative round-off eigenvalues dropped).
fn factor(m: &DMatrix<f64>) -> DMatrix<f64> {
    let e = m.clone().symmetric_eigen();
    let d = e.eigenvalues.map(|l| l.max(0.0).sqrt());
    &e.eigenvectors * DMatrix::from_diagonal(&d)
}

/// Balanced truncation of a stable system to `order` states (kept as is if not larger).
pub fn balanced_truncation(sys: &Ss, order: usize) -> Result<Reduced, RobustError> {
    if !sys.is_stable() {
        return Err(RobustError::Model(
            "balanced truncation needs a stable system".into(),
        ));
    }
    let p = lyapunov(&sys.a, &(&sys.b * sys.b.transpose()))?;
    let q = lyapunov(&sys.a.transpose(), &(sys.c.transpose() * &sys.c))?;
    let (lp, lq) = (factor(&p), factor(&q));
    let svd = (lq.transpose() * &lp).svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Err(RobustError::Singular("balanced truncation SVD"));
    };
    let mut idx: Vec<usize> = (0..svd.singular_values.len()).collect();
    idx.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let hankel: Vec<f64> = idx.iter().map(|&i| svd.singular_values[i]).collect();
    let r = order.min(sys.order());
    let positive = hankel
        .iter()
        .take_while(|s| **s > 1e-14 * hankel[0])
        .count();
    let r = r.min(positive);
    let n = sys.order();
    let mut t = DMatrix::zeros(n, r);
    let mut ti = DMatrix::zeros(r, n);
    for (k, &i) in idx.iter().take(r).enumerate() {
        let s = svd.singular_values[i].sqrt();
        t.set_column(k, &(lp.clone() * vt.row(i).transpose() / s));
        ti.set_row(k, &(u.column(i).transpose() * lq.transpose() / s));
    }
    let red = Ss::new(&ti * &sys.a * &t, &ti * &sys.b, &sys.c * &t, sys.d.clone())?;
    let error_bound = 2.0 * hankel.iter().skip(r).sum::<f64>();
    Ok(Reduced {
        sys: red,
        hankel,
        error_bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncation_error_respects_the_bound() {
        // Three lags 1/(s+1) + 0.1/(s+10) + 0.001/(s+100) in parallel.
        let a = DMatrix::from_diagonal(&nalgebra::DVector::from_row_slice(&[-1.0, -10.0, -100.0]));
        let b = DMatrix::from_row_slice(3, 1, &[1.0, 1.0, 1.0]);
        let c = DMatrix::from_row_slice(1, 3, &[1.0, 0.1, 0.001]);
        let g = Ss::new(a, b, c, DMatrix::zeros(1, 1)).expect("valid");
        let r = balanced_truncation(&g, 2).expect("stable");
        assert_eq!(r.sys.order(), 2);
        let mut err = g.clone();
        // Difference system G - G_r.
        let n = 3 + 2;
        let mut a = DMatrix::zeros(n, n);
        a.view_mut((0, 0), (3, 3)).copy_from(&g.a);
        a.view_mut((3, 3), (2, 2)).copy_from(&r.sys.a);
        let mut b = DMatrix::zeros(n, 1);
        b.view_mut((0, 0), (3, 1)).copy_from(&g.b);
        b.view_mut((3, 0), (2, 1)).copy_from(&r.sys.b);
        let mut c = DMatrix::zeros(1, n);
        c.view_mut((0, 0), (1, 3)).copy_from(&g.c);
        c.view_mut((0, 3), (1, 2)).copy_from(&(-&r.sys.c));
        err = Ss::new(a, b, c, err.d * 0.0).expect("valid");
        let e = err.hinf_norm(1e-6);
        // σ_{r+1} ≤ ‖G - G_r‖∞ ≤ 2 Σ_{i>r} σ_i (tight for one truncated state).
        assert!(
            e <= r.error_bound * (1.0 + 1e-4),
            "error {e} bound {}",
            r.error_bound
        );
        assert!(
            e >= r.hankel[2] * (1.0 - 1e-4),
            "error {e} below σ3 {}",
            r.hankel[2]
        );
    }
}
