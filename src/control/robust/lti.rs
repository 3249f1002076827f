//! Linear time-invariant systems in state-space form, `ẋ = A x + B u`, `y = C x + D u`
//! (continuous) or `x(k+1) = A x(k) + B u(k)`, `y(k) = C x(k) + D u(k)` (discrete): frequency
//! response, H∞ norm, interconnection, balancing, Tustin and zero-order-hold discretisation.
//!
//! These run at design time and may allocate; the per-cycle controller is
//! [`super::StateSpaceController`].

use nalgebra::{Complex, DMatrix};

use super::RobustError;

/// Complex matrix, for frequency responses.
pub type CMatrix = DMatrix<Complex<f64>>;

/// A state-space system `(A, B, C, D)`; continuous or discrete is up to the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct Ss {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
}

impl Ss {
    /// A system, checking that `A` is n×n, `B` n×m, `C` p×n and `D` p×m.
    pub fn new(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> Result<Self, RobustError> {
        let n = a.nrows();
        if a.ncols() != n
            || b.nrows() != n
            || c.ncols() != n
            || d.nrows() != c.nrows()
            || d.ncols() != b.ncols()
        {
            return Err(RobustError::Dimension(format!(
                "A {}x{}, B {}x{}, C {}x{}, D {}x{}",
                a.nrows(),
                a.ncols(),
                b.nrows(),
                b.ncols(),
                c.nrows(),
                c.ncols(),
                d.nrows(),
                d.ncols()
            )));
        }
        if a.iter()
            .chain(b.iter())
            .chain(c.iter())
            .chain(d.iter())
            .any(|v| !v.is_finite())
        {
            return Err(RobustError::Dimension("non-finite entry".into()));
        }
        Ok(Self { a, b, c, d })
    }

    /// Number of states.
    pub fn order(&self) -> usize {
        self.a.nrows()
    }

    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.b.ncols()
    }

    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.c.nrows()
    }

    /// Eigenvalues of `A` (the poles, for a minimal realisation).
    pub fn poles(&self) -> Vec<Complex<f64>> {
        if self.order() == 0 {
            return Vec::new();
        }
        self.a.complex_eigenvalues().iter().copied().collect()
    }

    /// Continuous-time stability: every eigenvalue of `A` has `Re λ < 0`.
    pub fn is_stable(&self) -> bool {
        self.poles().iter().all(|p| p.re < 0.0)
    }

    /// Discrete-time stability: every eigenvalue of `A` has `|λ| < 1`.
    pub fn is_stable_discrete(&self) -> bool {
        self.poles().iter().all(|p| p.norm() < 1.0)
    }

    /// `G(s) = C (sI - A)⁻¹ B + D` at a complex point `s` (or `z` for a discrete system).
    pub fn eval(&self, s: Complex<f64>) -> Result<CMatrix, RobustError> {
        let n = self.order();
        let d = self.d.map(|v| Complex::new(v, 0.0));
        if n == 0 {
            return Ok(d);
        }
        let a = self.a.map(|v| Complex::new(v, 0.0));
        let m = CMatrix::identity(n, n) * s - a;
        let b = self.b.map(|v| Complex::new(v, 0.0));
        let x = m
            .lu()
            .solve(&b)
            .ok_or(RobustError::Singular("frequency response"))?;
        let c = self.c.map(|v| Complex::new(v, 0.0));
        Ok(c * x + d)
    }

    /// Largest singular value of `G(jω)` (continuous); infinite at a pole on the axis.
    pub fn sigma_max(&self, w_rad_s: f64) -> f64 {
        match self.eval(Complex::new(0.0, w_rad_s)) {
            Ok(g) => max_singular_complex(&g),
            Err(_) => f64::INFINITY,
        }
    }

    /// Largest singular value of `G(e^{jωT})` (discrete, period `T`).
    pub fn sigma_max_discrete(&self, w_rad_s: f64, period_s: f64) -> f64 {
        let z = Complex::new(0.0, w_rad_s * period_s).exp();
        match self.eval(z) {
            Ok(g) => max_singular_complex(&g),
            Err(_) => f64::INFINITY,
        }
    }

    /// Frequencies bracketing the dynamics: a decade below the slowest nonzero pole magnitude to
    /// two decades above the fastest, at least `[1e-3, 1e3]` rad/s around them.
    fn frequency_range(&self) -> (f64, f64) {
        let mags: Vec<f64> = self
            .poles()
            .iter()
            .map(|p| p.norm())
            .filter(|m| *m > 1e-9)
            .collect();
        let lo = mags.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = mags.iter().copied().fold(0.0, f64::max);
        let lo = if lo.is_finite() {
            (lo * 0.01).min(1e-3)
        } else {
            1e-3
        };
        let hi = (hi * 100.0).max(1e3);
        (lo, hi)
    }

    /// Peak of `σ_max(G(jω))` over a logarithmic grid of `n` points in `[w_lo, w_hi]` plus
    /// `ω = 0`, refined by golden-section search around the best grid point. Returns
    /// `(peak, ω_peak)`. Independent of the Hamiltonian test in [`Ss::hinf_norm`].
    pub fn peak_gain_sweep(&self, w_lo: f64, w_hi: f64, n: usize) -> (f64, f64) {
        let n = n.max(3);
        let (l0, l1) = (w_lo.max(1e-12).ln(), w_hi.max(w_lo * 1.0001).ln());
        let mut best = (self.sigma_max(0.0), 0.0);
        let mut best_k = None;
        for k in 0..n {
            let w = (l0 + (l1 - l0) * k as f64 / (n - 1) as f64).exp();
            let g = self.sigma_max(w);
            if g > best.0 {
                best = (g, w);
                best_k = Some(k);
            }
        }
        if let Some(k) = best_k {
            let step = (l1 - l0) / (n - 1) as f64;
            let (mut a, mut b) = (l0 + step * (k as f64 - 1.0), l0 + step * (k as f64 + 1.0));
            let phi = 0.5 * (5f64.sqrt() - 1.0);
            for _ in 0..60 {
                let x1 = b - phi * (b - a);
                let x2 = a + phi * (b - a);
                let (g1, g2) = (self.sigma_max(x1.exp()), self.sigma_max(x2.exp()));
                if g1 > best.0 {
                    best = (g1, x1.exp());
                }
                if g2 > best.0 {
                    best = (g2, x2.exp());
                }
                if g1 >= g2 {
                    b = x2;
                } else {
                    a = x1;
                }
            }
        }
        best
    }

    /// H∞ norm `sup_ω σ_max(G(jω))` of a stable continuous system, by the Hamiltonian test of
    /// Boyd, Balakrishnan & Bruinsma / Steinbuch: `γ > ‖G‖∞` iff
    /// `H(γ) = [A + B R⁻¹DᵀC, B R⁻¹Bᵀ; -Cᵀ(I + D R⁻¹Dᵀ)C, -(A + B R⁻¹DᵀC)ᵀ]`, `R = γ²I - DᵀD`,
    /// has no eigenvalue on the imaginary axis. Returns `f64::INFINITY` for an unstable system.
    /// Relative accuracy about `tol`.
    pub fn hinf_norm(&self, tol: f64) -> f64 {
        if !self.is_stable() {
            return f64::INFINITY;
        }
        let (wl, wh) = self.frequency_range();
        let mut lb = self.peak_gain_sweep(wl, wh, 200).0;
        lb = lb.max(max_singular(&self.d));
        if self.order() == 0 {
            return lb;
        }
        if lb == 0.0 {
            return 0.0;
        }
        let n = self.order();
        let m = self.inputs();
        for _ in 0..60 {
            let g = lb * (1.0 + 2.0 * tol);
            let r = DMatrix::identity(m, m) * (g * g) - self.d.transpose() * &self.d;
            let Some(ri) = r.try_inverse() else {
                return g;
            };
            let f = &self.a + &self.b * &ri * self.d.transpose() * &self.c;
            let p = self.outputs();
            let q = self.c.transpose()
                * (DMatrix::identity(p, p) + &self.d * &ri * self.d.transpose())
                * &self.c;
            let mut h = DMatrix::zeros(2 * n, 2 * n);
            h.view_mut((0, 0), (n, n)).copy_from(&f);
            h.view_mut((0, n), (n, n))
                .copy_from(&(&self.b * &ri * self.b.transpose()));
            h.view_mut((n, 0), (n, n)).copy_from(&(-q));
            h.view_mut((n, n), (n, n)).copy_from(&(-f.transpose()));
            let scale = h.norm().max(1.0);
            let mut ws: Vec<f64> = h
                .complex_eigenvalues()
                .iter()
                .filter(|l| l.re.abs() <= 1e-9 * scale.max(l.norm()) && l.im >= 0.0)
                .map(|l| l.im)
                .collect();
            if ws.is_empty() {
                return g;
            }
            ws.sort_by(|a, b| a.total_cmp(b));
            let mut new_lb = lb;
            for w in &ws {
                new_lb = new_lb.max(self.sigma_max(*w));
            }
            for pair in ws.windows(2) {
                new_lb = new_lb.max(self.sigma_max(0.5 * (pair[0] + pair[1])));
            }
            if new_lb <= lb * (1.0 + tol) {
                return g;
            }
            lb = new_lb;
        }
        lb
    }

    /// Series connection `other ∘ self`: the output of `self` drives `other`.
    pub fn series(&self, other: &Ss) -> Result<Ss, RobustError> {
        if other.inputs() != self.outputs() {
            return Err(RobustError::Dimension(
                "series: inner outputs != outer inputs".into(),
            ));
        }
        let (n1, n2) = (self.order(), other.order());
        let mut a = DMatrix::zeros(n1 + n2, n1 + n2);
        a.view_mut((0, 0), (n1, n1)).copy_from(&self.a);
        a.view_mut((n1, 0), (n2, n1))
            .copy_from(&(&other.b * &self.c));
        a.view_mut((n1, n1), (n2, n2)).copy_from(&other.a);
        let mut b = DMatrix::zeros(n1 + n2, self.inputs());
        b.view_mut((0, 0), (n1, self.inputs())).copy_from(&self.b);
        b.view_mut((n1, 0), (n2, self.inputs()))
            .copy_from(&(&other.b * &self.d));
        let mut c = DMatrix::zeros(other.outputs(), n1 + n2);
        c.view_mut((0, 0), (other.outputs(), n1))
            .copy_from(&(&other.d * &self.c));
        c.view_mut((0, n1), (other.outputs(), n2))
            .copy_from(&other.c);
        Ss::new(a, b, c, &other.d * &self.d)
    }

    /// Diagonal similarity `A ← T⁻¹AT`, `B ← T⁻¹B`, `C ← CT` with `T = diag(t)` chosen by
    /// Osborne's iteration (powers of two) so that rows and columns of `A` have similar norms;
    /// the transfer function is unchanged. Returns the balanced system and `t`.
    pub fn balanced_diagonally(&self) -> (Ss, Vec<f64>) {
        let n = self.order();
        let mut a = self.a.clone();
        let mut t = vec![1.0f64; n];
        for _ in 0..100 {
            let mut changed = false;
            for i in 0..n {
                let mut c = 0.0;
                let mut r = 0.0;
                for j in 0..n {
                    if j != i {
                        c += a[(j, i)].abs();
                        r += a[(i, j)].abs();
                    }
                }
                if c == 0.0 || r == 0.0 {
                    continue;
                }
                let mut f = 1.0;
                let s = c + r;
                let (mut cc, mut rr) = (c, r);
                while cc < rr / 2.0 {
                    cc *= 2.0;
                    rr /= 2.0;
                    f *= 2.0;
                }
                while cc >= rr * 2.0 {
                    cc /= 2.0;
                    rr *= 2.0;
                    f /= 2.0;
                }
                if (cc + rr) < 0.95 * s {
                    changed = true;
                    t[i] *= f;
                    for j in 0..n {
                        a[(j, i)] *= f;
                        a[(i, j)] /= f;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let mut b = self.b.clone();
        let mut c = self.c.clone();
        for (i, ti) in t.iter().enumerate() {
            b.row_mut(i).scale_mut(1.0 / ti);
            c.column_mut(i).scale_mut(*ti);
        }
        (
            Ss {
                a,
                b,
                c,
                d: self.d.clone(),
            },
            t,
        )
    }

    /// Bilinear (Tustin) discretisation at period `T`: `s = α (z - 1)/(z + 1)` with `α = 2/T`, or
    /// with prewarping at `ω_p`, `α = ω_p / tan(ω_p T / 2)` (the response matches exactly at
    /// `ω_p`). `M = (αI - A)⁻¹`, `A_d = M (αI + A)`, `B_d = √(2α) M B`, `C_d = √(2α) C M`,
    /// `D_d = D + C M B`.
    pub fn tustin(&self, period_s: f64, prewarp_rad_s: Option<f64>) -> Result<Ss, RobustError> {
        if !(period_s > 0.0 && period_s.is_finite()) {
            return Err(RobustError::Dimension(format!("period {period_s} s")));
        }
        let alpha = match prewarp_rad_s {
            Some(wp) if wp > 0.0 && wp * period_s < std::f64::consts::PI => {
                wp / (0.5 * wp * period_s).tan()
            }
            Some(wp) => {
                return Err(RobustError::Dimension(format!(
                    "prewarp frequency {wp} rad/s must lie in (0, π/T)"
                )))
            }
            None => 2.0 / period_s,
        };
        let n = self.order();
        let id = DMatrix::<f64>::identity(n, n);
        let m = (&id * alpha - &self.a)
            .try_inverse()
            .ok_or(RobustError::Singular("Tustin: pole at 2/T"))?;
        let k = (2.0 * alpha).sqrt();
        let ad = &m * (&id * alpha + &self.a);
        let bd = &m * &self.b * k;
        let cd = &self.c * &m * k;
        let dd = &self.d + &self.c * &m * &self.b;
        Ss::new(ad, bd, cd, dd)
    }

    /// Zero-order-hold discretisation: `[A_d B_d; 0 I] = exp([A B; 0 0] T)`, `C_d = C`, `D_d = D`.
    pub fn zoh(&self, period_s: f64) -> Result<Ss, RobustError> {
        let (n, m) = (self.order(), self.inputs());
        let mut big = DMatrix::zeros(n + m, n + m);
        big.view_mut((0, 0), (n, n))
            .copy_from(&(&self.a * period_s));
        big.view_mut((0, n), (n, m))
            .copy_from(&(&self.b * period_s));
        let e = big.exp();
        Ss::new(
            e.view((0, 0), (n, n)).into_owned(),
            e.view((0, n), (n, m)).into_owned(),
            self.c.clone(),
            self.d.clone(),
        )
    }
}

/// Largest singular value of a real matrix (0 for an empty one).
pub fn max_singular(m: &DMatrix<f64>) -> f64 {
    if m.is_empty() {
        return 0.0;
    }
    m.clone()
        .svd(false, false)
        .singular_values
        .iter()
        .copied()
        .fold(0.0, f64::max)
}

/// Largest singular value of a complex matrix (0 for an empty one).
pub fn max_singular_complex(m: &CMatrix) -> f64 {
    if m.is_empty() {
        return 0.0;
    }
    m.clone()
        .svd(false, false)
        .singular_values
        .iter()
        .copied()
        .fold(0.0, f64::max)
}

/// Lower linear fractional transformation `F_l(P, K)` of a plant partitioned as
/// `[A B1 B2; C1 D11 D12; C2 D21 0]` with `nw`, `nu` inputs and `nz`, `ny` outputs closed by
/// `u = K y`: the closed loop from `w` to `z`, states `[x; x_K]`.
pub fn lft_lower(p: &Ss, nu: usize, ny: usize, k: &Ss) -> Result<Ss, RobustError> {
    let nw = p
        .inputs()
        .checked_sub(nu)
        .ok_or_else(|| RobustError::Dimension("lft: nu > inputs".into()))?;
    let nz = p
        .outputs()
        .checked_sub(ny)
        .ok_or_else(|| RobustError::Dimension("lft: ny > outputs".into()))?;
    if k.inputs() != ny || k.outputs() != nu {
        return Err(RobustError::Dimension("lft: controller size".into()));
    }
    let n = p.order();
    let nk = k.order();
    let b1 = p.b.columns(0, nw).into_owned();
    let b2 = p.b.columns(nw, nu).into_owned();
    let c1 = p.c.rows(0, nz).into_owned();
    let c2 = p.c.rows(nz, ny).into_owned();
    let d11 = p.d.view((0, 0), (nz, nw)).into_owned();
    let d12 = p.d.view((0, nw), (nz, nu)).into_owned();
    let d21 = p.d.view((nz, 0), (ny, nw)).into_owned();
    let d22 = p.d.view((nz, nw), (ny, nu));
    if d22.iter().any(|v| *v != 0.0) {
        return Err(RobustError::Dimension("lft: D22 must be zero".into()));
    }
    let mut a = DMatrix::zeros(n + nk, n + nk);
    a.view_mut((0, 0), (n, n))
        .copy_from(&(&p.a + &b2 * &k.d * &c2));
    a.view_mut((0, n), (n, nk)).copy_from(&(&b2 * &k.c));
    a.view_mut((n, 0), (nk, n)).copy_from(&(&k.b * &c2));
    a.view_mut((n, n), (nk, nk)).copy_from(&k.a);
    let mut b = DMatrix::zeros(n + nk, nw);
    b.view_mut((0, 0), (n, nw))
        .copy_from(&(&b1 + &b2 * &k.d * &d21));
    b.view_mut((n, 0), (nk, nw)).copy_from(&(&k.b * &d21));
    let mut c = DMatrix::zeros(nz, n + nk);
    c.view_mut((0, 0), (nz, n))
        .copy_from(&(&c1 + &d12 * &k.d * &c2));
    c.view_mut((0, n), (nz, nk)).copy_from(&(&d12 * &k.c));
    let d = &d11 + &d12 * &k.d * &d21;
    Ss::new(a, b, c, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_order(a: f64) -> Ss {
        Ss::new(
            DMatrix::from_element(1, 1, -a),
            DMatrix::from_element(1, 1, a),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
        )
        .expect("valid")
    }

    #[test]
    fn norm_of_a_lag_is_its_dc_gain() {
        let g = first_order(3.0);
        assert!((g.hinf_norm(1e-8) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn norm_of_a_resonance_matches_the_closed_form() {
        // ω_n² / (s² + 2ζω_n s + ω_n²): peak 1 / (2ζ√(1-ζ²)).
        let (wn, z) = (10.0, 0.1);
        let g = Ss::new(
            DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -wn * wn, -2.0 * z * wn]),
            DMatrix::from_row_slice(2, 1, &[0.0, wn * wn]),
            DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            DMatrix::zeros(1, 1),
        )
        .expect("valid");
        let exact = 1.0 / (2.0 * z * (1.0 - z * z).sqrt());
        assert!((g.hinf_norm(1e-9) / exact - 1.0).abs() < 1e-6);
        let (peak, _) = g.peak_gain_sweep(0.1, 1000.0, 400);
        assert!((peak / exact - 1.0).abs() < 1e-6);
    }

    #[test]
    fn tustin_maps_s_to_the_bilinear_point() {
        let g = first_order(50.0);
        let t = 1e-3;
        let gd = g.tustin(t, None).expect("ok");
        let w = 100.0;
        let z = Complex::new(0.0, w * t).exp();
        let s = (z - 1.0) / (z + 1.0) * (2.0 / t);
        let hc = g.eval(s).expect("ok")[(0, 0)];
        let hd = gd.eval(z).expect("ok")[(0, 0)];
        assert!((hc - hd).norm() < 1e-12);
        // With prewarping the response at ω_p is exact.
        let gp = g.tustin(t, Some(w)).expect("ok");
        let hp = gp.eval(z).expect("ok")[(0, 0)];
        let he = g.eval(Complex::new(0.0, w)).expect("ok")[(0, 0)];
        assert!((hp - he).norm() < 1e-12);
    }

    #[test]
    fn zoh_of_a_lag_is_exact() {
        let g = first_order(20.0);
        let gd = g.zoh(0.01).expect("ok");
        let p = (-0.2f64).exp();
        assert!((gd.a[(0, 0)] - p).abs() < 1e-12);
        assert!((gd.b[(0, 0)] - (1.0 - p)).abs() < 1e-12);
    }

    #[test]
    fn diagonal_balancing_keeps_the_transfer_function() {
        let g = Ss::new(
            DMatrix::from_row_slice(2, 2, &[-1.0, 1e6, -1e-4, -3.0]),
            DMatrix::from_row_slice(2, 1, &[1.0, 2.0]),
            DMatrix::from_row_slice(1, 2, &[1.0, 0.5]),
            DMatrix::zeros(1, 1),
        )
        .expect("valid");
        let (gb, _) = g.balanced_diagonally();
        assert!(gb.a.amax() < g.a.amax());
        for w in [0.1, 1.0, 10.0] {
            let a = g.eval(Complex::new(0.0, w)).expect("ok")[(0, 0)];
            let b = gb.eval(Complex::new(0.0, w)).expect("ok")[(0, 0)];
            assert!((a - b).norm() < 1e-9 * a.norm().max(1.0));
        }
    }
}
