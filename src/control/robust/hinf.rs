//! H∞ output-feedback synthesis by the two-Riccati solution (Doyle, Glover, Khargonekar &
//! Francis 1989; Glover & Doyle 1988, in the form of Zhou, Doyle & Glover, *Robust and Optimal
//! Control*, 1996, ch. 16–17) with the γ-iteration.
//!
//! Generalised plant `ẋ = A x + B1 w + B2 u`, `z = C1 x + D12 u`, `y = C2 x + D21 w + D22 u`
//! with `D11 = 0`, `D22 = 0`, `D12` of full column rank and `D21` of full row rank. `u` and `y`
//! are first scaled so that `D12ᵀD12 = I` and `D21D21ᵀ = I`; `D12ᵀC1` and `B1D21ᵀ` may be
//! nonzero. For a given γ a controller with `‖T_zw‖∞ < γ` exists iff
//! - `X∞ ≥ 0` stabilises `(A - B2D12ᵀC1)ᵀX + X(A - B2D12ᵀC1) + X(γ⁻²B1B1ᵀ - B2B2ᵀ)X
//!   + C1ᵀ(I - D12D12ᵀ)C1 = 0`,
//! - `Y∞ ≥ 0` stabilises `(A - B1D21ᵀC2)Y + Y(A - B1D21ᵀC2)ᵀ + Y(γ⁻²C1ᵀC1 - C2ᵀC2)Y
//!   + B1(I - D21ᵀD21)B1ᵀ = 0`,
//! - `ρ(X∞Y∞) < γ²`.
//!
//! The central controller is `F = -(D12ᵀC1 + B2ᵀX∞)`, `L = -(B1D21ᵀ + Y∞C2ᵀ)`,
//! `Z = (I - γ⁻²Y∞X∞)⁻¹`, `Â = A + γ⁻²B1B1ᵀX∞ + B2F + ZL(C2 + γ⁻²D21B1ᵀX∞)`, `B̂ = -ZL`,
//! `Ĉ = F`, `D̂ = 0`.

use nalgebra::DMatrix;

use super::lti::{lft_lower, max_singular, Ss};
use super::riccati::{care, CareSolution};
use super::RobustError;

/// A generalised plant `P = [A B1 B2; C1 D11 D12; C2 D21 D22]`.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneralizedPlant {
    /// The whole plant, inputs `[w; u]`, outputs `[z; y]`.
    pub sys: Ss,
    /// Number of control inputs `u` (the last inputs).
    pub nu: usize,
    /// Number of measurements `y` (the last outputs).
    pub ny: usize,
}

/// Options of the γ-iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HinfOptions {
    /// Stop the bisection when `γ_hi / γ_lo - 1` is below this.
    pub gamma_rel_tol: f64,
    /// Give up above this γ.
    pub gamma_max: f64,
    /// The controller is built at `γ = margin · γ_opt` (central controllers at `γ_opt` itself
    /// are ill-conditioned; 1.05 to 1.2 is usual).
    pub margin: f64,
}

impl Default for HinfOptions {
    fn default() -> Self {
        Self {
            gamma_rel_tol: 1e-4,
            gamma_max: 1e8,
            margin: 1.1,
        }
    }
}

/// The Riccati solutions at one γ.
#[derive(Debug, Clone)]
pub struct HinfCandidate {
    pub gamma: f64,
    pub x: CareSolution,
    pub y: CareSolution,
    /// Spectral radius `ρ(X∞Y∞)`.
    pub rho_xy: f64,
}

/// Result of [`hinfsyn`].
#[derive(Debug, Clone)]
pub struct HinfSolution {
    /// Smallest feasible γ found by the bisection (within the relative tolerance).
    pub gamma_opt: f64,
    /// γ at which the controller was built.
    pub gamma: f64,
    /// The central controller `u = K y`.
    pub controller: Ss,
    /// Riccati solutions and checks at `gamma`.
    pub candidate: HinfCandidate,
    /// Number of feasibility tests made.
    pub iterations: usize,
}

struct Scaled {
    a: DMatrix<f64>,
    b1: DMatrix<f64>,
    b2: DMatrix<f64>,
    c1: DMatrix<f64>,
    c2: DMatrix<f64>,
    d12: DMatrix<f64>,
    d21: DMatrix<f64>,
    /// `u = su ũ`.
    su: DMatrix<f64>,
    /// `ỹ = sy y`.
    sy: DMatrix<f64>,
}

/// `M^{-1/2}` of a symmetric positive definite matrix.
fn inv_sqrt(m: &DMatrix<f64>, what: &'static str) -> Result<DMatrix<f64>, RobustError> {
    let e = m.clone().symmetric_eigen();
    let lmax = e.eigenvalues.max();
    let lmin = e.eigenvalues.min();
    if lmin.is_nan() || lmin <= 1e-12 * lmax.max(1e-300) {
        return Err(RobustError::Infeasible(format!("{what} is rank deficient")));
    }
    let d = DMatrix::from_diagonal(&e.eigenvalues.map(|l| 1.0 / l.sqrt()));
    Ok(&e.eigenvectors * d * e.eigenvectors.transpose())
}

impl GeneralizedPlant {
    /// Partition a plant with inputs `[w; u]` and outputs `[z; y]`.
    pub fn new(sys: Ss, nu: usize, ny: usize) -> Result<Self, RobustError> {
        if nu == 0 || ny == 0 || nu >= sys.inputs() || ny >= sys.outputs() {
            return Err(RobustError::Dimension(format!(
                "generalised plant with {} inputs, {} outputs cannot have nu = {nu}, ny = {ny}",
                sys.inputs(),
                sys.outputs()
            )));
        }
        Ok(Self { sys, nu, ny })
    }

    pub fn nw(&self) -> usize {
        self.sys.inputs() - self.nu
    }

    pub fn nz(&self) -> usize {
        self.sys.outputs() - self.ny
    }

    /// Closed loop `T_zw = F_l(P, K)`.
    pub fn close(&self, k: &Ss) -> Result<Ss, RobustError> {
        lft_lower(&self.sys, self.nu, self.ny, k)
    }

    fn scaled(&self) -> Result<Scaled, RobustError> {
        let (nw, nz, nu, ny) = (self.nw(), self.nz(), self.nu, self.ny);
        let s = &self.sys;
        let d11 = s.d.view((0, 0), (nz, nw)).into_owned();
        let d22 = s.d.view((nz, nw), (ny, nu)).into_owned();
        if max_singular(&d11) != 0.0 {
            return Err(RobustError::Infeasible("D11 must be zero".into()));
        }
        if max_singular(&d22) != 0.0 {
            return Err(RobustError::Infeasible("D22 must be zero".into()));
        }
        let d12 = s.d.view((0, nw), (nz, nu)).into_owned();
        let d21 = s.d.view((nz, 0), (ny, nw)).into_owned();
        let su = inv_sqrt(&(d12.transpose() * &d12), "D12")?;
        let sy = inv_sqrt(&(&d21 * d21.transpose()), "D21")?;
        Ok(Scaled {
            a: s.a.clone(),
            b1: s.b.columns(0, nw).into_owned(),
            b2: s.b.columns(nw, nu) * &su,
            c1: s.c.rows(0, nz).into_owned(),
            c2: &sy * s.c.rows(nz, ny),
            d12: d12 * &su,
            d21: &sy * d21,
            su,
            sy,
        })
    }
}

fn psd_ok(x: &DMatrix<f64>) -> bool {
    let e = x.clone().symmetric_eigen();
    e.eigenvalues.min() >= -1e-9 * x.norm().max(1e-12)
}

fn candidate(p: &Scaled, gamma: f64) -> Result<HinfCandidate, RobustError> {
    let g2 = 1.0 / (gamma * gamma);
    let nz = p.c1.nrows();
    let nw = p.b1.ncols();
    // X∞: (A - B2D12ᵀC1)ᵀX + X(..) + X(γ⁻²B1B1ᵀ - B2B2ᵀ)X + C1ᵀ(I - D12D12ᵀ)C1 = 0.
    let ax = &p.a - &p.b2 * p.d12.transpose() * &p.c1;
    let rx = &p.b1 * p.b1.transpose() * g2 - &p.b2 * p.b2.transpose();
    let qx = p.c1.transpose() * (DMatrix::identity(nz, nz) - &p.d12 * p.d12.transpose()) * &p.c1;
    let x = care(&ax, &rx, &qx)?;
    if !psd_ok(&x.x) {
        return Err(RobustError::Infeasible(format!(
            "X∞ not ≥ 0 at γ = {gamma}"
        )));
    }
    // Y∞ (dual): (A - B1D21ᵀC2)Y + Y(..)ᵀ + Y(γ⁻²C1ᵀC1 - C2ᵀC2)Y + B1(I - D21ᵀD21)B1ᵀ = 0.
    let ay = (&p.a - &p.b1 * p.d21.transpose() * &p.c2).transpose();
    let ry = p.c1.transpose() * &p.c1 * g2 - p.c2.transpose() * &p.c2;
    let qy = &p.b1 * (DMatrix::identity(nw, nw) - p.d21.transpose() * &p.d21) * p.b1.transpose();
    let y = care(&ay, &ry, &qy)?;
    if !psd_ok(&y.x) {
        return Err(RobustError::Infeasible(format!(
            "Y∞ not ≥ 0 at γ = {gamma}"
        )));
    }
    let rho = (&x.x * &y.x)
        .complex_eigenvalues()
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max);
    if rho.is_nan() || rho >= gamma * gamma {
        return Err(RobustError::Infeasible(format!(
            "ρ(XY) = {rho:.4e} ≥ γ² = {:.4e}",
            gamma * gamma
        )));
    }
    Ok(HinfCandidate {
        gamma,
        x,
        y,
        rho_xy: rho,
    })
}

fn central_controller(p: &Scaled, c: &HinfCandidate) -> Result<Ss, RobustError> {
    let g2 = 1.0 / (c.gamma * c.gamma);
    let n = p.a.nrows();
    let (x, y) = (&c.x.x, &c.y.x);
    // F = -(D12ᵀC1 + B2ᵀX), L = -(B1D21ᵀ + YC2ᵀ), Z = (I - γ⁻²YX)⁻¹.
    let f = -(p.d12.transpose() * &p.c1 + p.b2.transpose() * x);
    let l = -(&p.b1 * p.d21.transpose() + y * p.c2.transpose());
    let z = (DMatrix::identity(n, n) - y * x * g2)
        .try_inverse()
        .ok_or(RobustError::Singular("I - γ⁻²YX"))?;
    // Â = A + γ⁻²B1B1ᵀX + B2F + ZL(C2 + γ⁻²D21B1ᵀX).
    let ak = &p.a
        + &p.b1 * p.b1.transpose() * x * g2
        + &p.b2 * &f
        + &z * &l * (&p.c2 + &p.d21 * p.b1.transpose() * x * g2);
    let bk = -(&z * &l);
    // Undo the scaling: u = su ũ, ỹ = sy y.
    let ck = &p.su * f;
    let bk = bk * &p.sy;
    let dk = DMatrix::zeros(ck.nrows(), bk.ncols());
    Ss::new(ak, bk, ck, dk)
}

/// Test whether `‖T_zw‖∞ < γ` is achievable; on success the Riccati solutions.
pub fn hinf_feasible(p: &GeneralizedPlant, gamma: f64) -> Result<HinfCandidate, RobustError> {
    candidate(&p.scaled()?, gamma)
}

/// The central controller at a feasible γ.
pub fn hinf_controller(
    p: &GeneralizedPlant,
    gamma: f64,
) -> Result<(Ss, HinfCandidate), RobustError> {
    let s = p.scaled()?;
    let c = candidate(&s, gamma)?;
    Ok((central_controller(&s, &c)?, c))
}

/// γ-iteration: bracket the optimal γ (doubling or halving from 1), bisect geometrically until
/// `γ_hi / γ_lo - 1 < tol`, then build the central controller at `margin · γ_hi`.
pub fn hinfsyn(p: &GeneralizedPlant, opts: &HinfOptions) -> Result<HinfSolution, RobustError> {
    let s = p.scaled()?;
    let mut iterations = 0;
    let mut feasible = |g: f64| {
        iterations += 1;
        candidate(&s, g).is_ok()
    };
    let (mut lo, mut hi);
    if feasible(1.0) {
        hi = 1.0;
        lo = 0.5;
        while feasible(lo) {
            hi = lo;
            lo *= 0.5;
            if lo < 1e-12 {
                return Err(RobustError::Infeasible(
                    "γ → 0: problem is degenerate".into(),
                ));
            }
        }
    } else {
        lo = 1.0;
        hi = 2.0;
        while !feasible(hi) {
            lo = hi;
            hi *= 2.0;
            if hi > opts.gamma_max {
                return Err(RobustError::Infeasible(format!(
                    "no γ ≤ {} satisfies the existence conditions",
                    opts.gamma_max
                )));
            }
        }
    }
    while hi / lo - 1.0 > opts.gamma_rel_tol {
        let mid = (lo * hi).sqrt();
        if feasible(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let gamma = hi * opts.margin.max(1.0);
    let c = candidate(&s, gamma)?;
    let k = central_controller(&s, &c)?;
    Ok(HinfSolution {
        gamma_opt: hi,
        gamma,
        controller: k,
        candidate: c,
        iterations,
    })
}
