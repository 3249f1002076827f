//! Pole placement of the axis' discrete controller on an identified linear plant, and what the
//! design predicts: closed-loop poles, step response, stability margins.
//!
//! The plant is discretised with a zero-order hold at the cycle's period,
//! `G(z) = B(z⁻¹) / A(z⁻¹)` with `A = 1 + a_1 z⁻¹ + … + a_n z⁻ⁿ`, `B = b_1 z⁻¹ + … + b_n z⁻ⁿ`.
//! The controller is the daemon's general transfer function (Isermann & Raab's
//! `u(k) = -Σ p_i u(k-i) + Σ q_j e(k-j)`) with an integrator,
//! `P = (1 - z⁻¹)(1 + r_1 z⁻¹ + … + r_{n-1} z^{-(n-1)})`, `Q = q_0 + … + q_n z⁻ⁿ`: `2n` unknowns
//! for the `2n` coefficients of the closed loop's characteristic polynomial `A P + B Q`, so every
//! closed-loop pole is placed (for a second-order plant the controller is the PIDT1 the paper uses).
//! Runs at design time and allocates.

use nalgebra::{Complex, DMatrix, DVector};

use crate::control::robust::Ss;

/// Why a design cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DesignError {
    #[error("the plant is not a finite linear system: {0}")]
    Plant(String),
    #[error("the plant cannot be controlled by pole placement (B and A share a root): {0}")]
    Singular(String),
}

/// A continuous single-input plant `ẋ = A x + B u`, `y = C x`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousPlant {
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
}

impl ContinuousPlant {
    /// The body `m y'' + d y' + c y = K u`, optionally behind a first-order lag `T F' + F = K u`
    /// (the solenoid's coil). States `[y, y', F]`.
    pub fn body(mass: f64, damping: f64, stiffness: f64, gain: f64, lag_s: Option<f64>) -> Self {
        match lag_s {
            None => ContinuousPlant {
                a: DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -stiffness / mass, -damping / mass]),
                b: DMatrix::from_row_slice(2, 1, &[0.0, gain / mass]),
                c: DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
            },
            Some(t) => ContinuousPlant {
                a: DMatrix::from_row_slice(
                    3,
                    3,
                    &[
                        0.0,
                        1.0,
                        0.0,
                        -stiffness / mass,
                        -damping / mass,
                        1.0 / mass,
                        0.0,
                        0.0,
                        -1.0 / t,
                    ],
                ),
                b: DMatrix::from_row_slice(3, 1, &[0.0, 0.0, gain / t]),
                c: DMatrix::from_row_slice(1, 3, &[1.0, 0.0, 0.0]),
            },
        }
    }

    /// Frequency response `G(jω)`.
    pub fn response(&self, w_rad_s: f64) -> Complex<f64> {
        let n = self.a.nrows();
        let s = Complex::new(0.0, w_rad_s);
        let m = DMatrix::<Complex<f64>>::from_fn(n, n, |i, j| {
            let d = if i == j { s } else { Complex::new(0.0, 0.0) };
            d - Complex::new(self.a[(i, j)], 0.0)
        });
        let b = DVector::<Complex<f64>>::from_fn(n, |i, _| Complex::new(self.b[(i, 0)], 0.0));
        match m.lu().solve(&b) {
            Some(x) => (0..n).map(|i| x[i] * self.c[(0, i)]).sum(),
            None => Complex::new(f64::INFINITY, 0.0),
        }
    }

    /// `B(z⁻¹) / A(z⁻¹)` of the zero-order-hold discretisation at `period_s`: `(a, b)` with
    /// `a[0] = 1` and `b[0] = 0`, both of length `n + 1`.
    pub fn discretise(&self, period_s: f64) -> Result<(Vec<f64>, Vec<f64>), DesignError> {
        let n = self.a.nrows();
        let ss = Ss::new(
            self.a.clone(),
            self.b.clone(),
            self.c.clone(),
            DMatrix::zeros(1, 1),
        )
        .and_then(|s| s.zoh(period_s))
        .map_err(|e| DesignError::Plant(e.to_string()))?;
        // Faddeev–LeVerrier: adj(zI - A) = Σ N_k z^{n-1-k}, N_0 = I, N_k = A N_{k-1} + a_k I,
        // a_k = -tr(A N_{k-1}) / k; so G(z) = Σ C N_k B z^{n-1-k} / (zⁿ + a_1 z^{n-1} + …).
        let mut a = vec![1.0; n + 1];
        let mut b = vec![0.0; n + 1];
        let mut nk = DMatrix::<f64>::identity(n, n);
        for k in 1..=n {
            b[k] = (&ss.c * &nk * &ss.b)[(0, 0)];
            let an = &ss.a * &nk;
            a[k] = -an.trace() / k as f64;
            nk = an + DMatrix::identity(n, n) * a[k];
        }
        if a.iter().chain(&b).any(|v| !v.is_finite()) {
            return Err(DesignError::Plant("non-finite discretisation".into()));
        }
        Ok((a, b))
    }
}

/// Product of two polynomials in `z⁻¹`.
pub fn poly_mul(x: &[f64], y: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; x.len() + y.len() - 1];
    for (i, xi) in x.iter().enumerate() {
        for (j, yj) in y.iter().enumerate() {
            out[i + j] += xi * yj;
        }
    }
    out
}

/// The monic polynomial in `z⁻¹` whose roots in `z` are `poles` (complex ones in conjugate
/// pairs), real coefficients.
pub fn poly_from_poles(poles: &[Complex<f64>]) -> Vec<f64> {
    let mut c = vec![Complex::new(1.0, 0.0)];
    for p in poles {
        let mut next = vec![Complex::new(0.0, 0.0); c.len() + 1];
        for (i, ci) in c.iter().enumerate() {
            next[i] += ci;
            next[i + 1] -= ci * p;
        }
        c = next;
    }
    c.iter().map(|x| x.re).collect()
}

/// Roots in `z` of a polynomial `1 + c_1 z⁻¹ + … + c_n z⁻ⁿ` (eigenvalues of its companion matrix).
pub fn roots(c: &[f64]) -> Vec<Complex<f64>> {
    let n = c.len().saturating_sub(1);
    if n == 0 {
        return Vec::new();
    }
    let mut m = DMatrix::<f64>::zeros(n, n);
    for j in 0..n {
        m[(0, j)] = -c[j + 1] / c[0];
    }
    for i in 1..n {
        m[(i, i - 1)] = 1.0;
    }
    m.complex_eigenvalues().iter().copied().collect()
}

/// The designed controller: `q` and `p` as the daemon's `[axis.controller]` takes them.
#[derive(Debug, Clone, PartialEq)]
pub struct Controller {
    pub q: Vec<f64>,
    /// Denominator without its leading 1, integrator included.
    pub p: Vec<f64>,
}

impl Controller {
    /// Denominator with its leading 1.
    pub fn denominator(&self) -> Vec<f64> {
        std::iter::once(1.0).chain(self.p.iter().copied()).collect()
    }
}

/// Place the closed-loop poles `poles` (`2n` of them) for the discrete plant `(a, b)`.
pub fn place(a: &[f64], b: &[f64], poles: &[Complex<f64>]) -> Result<Controller, DesignError> {
    let n = a.len() - 1;
    let unknowns = 2 * n;
    if poles.len() != unknowns {
        return Err(DesignError::Plant(format!(
            "{} poles for a plant of order {n}: need {unknowns}",
            poles.len()
        )));
    }
    // D = A (1 - z⁻¹): the plant with the controller's integrator.
    let d = poly_mul(a, &[1.0, -1.0]);
    let t = poly_from_poles(poles);
    let coef = |v: &[f64], i: isize| -> f64 {
        if i < 0 {
            0.0
        } else {
            v.get(i as usize).copied().unwrap_or(0.0)
        }
    };
    // Row j (power z^-j, j = 1..2n): Σ r_i d_{j-i} + Σ q_k b_{j-k} = t_j - d_j.
    let mut m = DMatrix::<f64>::zeros(unknowns, unknowns);
    let mut rhs = DVector::<f64>::zeros(unknowns);
    for row in 0..unknowns {
        let j = row as isize + 1;
        for i in 1..n {
            m[(row, i - 1)] = coef(&d, j - i as isize);
        }
        for k in 0..=n {
            m[(row, n - 1 + k)] = coef(b, j - k as isize);
        }
        rhs[row] = coef(&t, j) - coef(&d, j);
    }
    let x = m
        .clone()
        .lu()
        .solve(&rhs)
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .ok_or_else(|| DesignError::Singular(format!("A = {a:?}, B = {b:?}")))?;
    let mut r = vec![1.0];
    r.extend(x.iter().take(n - 1));
    let den = poly_mul(&r, &[1.0, -1.0]);
    Ok(Controller {
        q: x.iter().skip(n - 1).copied().collect(),
        p: den[1..].to_vec(),
    })
}

/// What a controller does on one discrete plant.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// Closed-loop poles in `z`.
    pub poles: Vec<Complex<f64>>,
    /// Largest `|z|` of the closed-loop poles: below 1 is stable.
    pub spectral_radius: f64,
    /// Gain margin (factor by which the loop gain may grow), at the phase crossovers where the
    /// loop gain is below 1; `None` when there is none.
    pub gain_margin: Option<f64>,
    /// Phase margin, degrees; `None` when the loop gain never crosses 1.
    pub phase_margin_deg: Option<f64>,
    /// Crossover frequency of the loop gain, rad/s.
    pub crossover_rad_s: Option<f64>,
    /// Largest sensitivity `max |1 / (1 + L)|`; its inverse is the smallest distance to -1.
    pub sensitivity_peak: f64,
    /// Step response of the set-point (unit step), sampled at the period.
    pub step: Vec<f64>,
    pub period_s: f64,
}

impl Analysis {
    /// Overshoot of the unit step response, as a fraction.
    pub fn overshoot(&self) -> f64 {
        (self.step.iter().copied().fold(f64::MIN, f64::max) - 1.0).max(0.0)
    }

    /// First time the step reaches 90 %.
    pub fn rise_time_s(&self) -> Option<f64> {
        self.step
            .iter()
            .position(|&y| y >= 0.9)
            .map(|k| k as f64 * self.period_s)
    }

    /// Time after which the step stays within ±2 %.
    pub fn settling_time_s(&self) -> Option<f64> {
        let last_out = self.step.iter().rposition(|y| (y - 1.0).abs() > 0.02)?;
        (last_out + 1 < self.step.len()).then(|| (last_out + 1) as f64 * self.period_s)
    }

    /// Time the step needs to reach 63 %: the time constant of a first-order model of the loop.
    pub fn time_constant_s(&self) -> Option<f64> {
        self.step
            .iter()
            .position(|&y| y >= 1.0 - (-1.0_f64).exp())
            .map(|k| k as f64 * self.period_s)
    }
}

fn eval(c: &[f64], z_inv: Complex<f64>) -> Complex<f64> {
    let mut acc = Complex::new(0.0, 0.0);
    for v in c.iter().rev() {
        acc = acc * z_inv + v;
    }
    acc
}

/// Closed loop of `controller` and the discrete plant `(a, b)` at `period_s`.
pub fn analyse(a: &[f64], b: &[f64], controller: &Controller, period_s: f64) -> Analysis {
    let den = controller.denominator();
    let char_poly = {
        let ap = poly_mul(a, &den);
        let bq = poly_mul(b, &controller.q);
        let len = ap.len().max(bq.len());
        (0..len)
            .map(|i| ap.get(i).unwrap_or(&0.0) + bq.get(i).unwrap_or(&0.0))
            .collect::<Vec<_>>()
    };
    let poles = roots(&char_poly);
    let spectral_radius = poles.iter().map(|p| p.norm()).fold(0.0, f64::max);
    // Loop gain L = B Q / (A P) on the unit circle, from 10⁻³ of Nyquist to Nyquist.
    let nyquist = std::f64::consts::PI / period_s;
    let points = 4000;
    let mut gain_margin: Option<f64> = None;
    let mut phase_margin: Option<f64> = None;
    let mut crossover = None;
    let mut sensitivity_peak: f64 = 0.0;
    let mut prev: Option<(f64, Complex<f64>)> = None;
    for k in 0..=points {
        let w = nyquist * 10f64.powf(-3.0 + 3.0 * k as f64 / points as f64);
        let z_inv = Complex::from_polar(1.0, -w * period_s);
        let l = eval(b, z_inv) * eval(&controller.q, z_inv) / (eval(a, z_inv) * eval(&den, z_inv));
        sensitivity_peak = sensitivity_peak.max(1.0 / (Complex::new(1.0, 0.0) + l).norm());
        if let Some((w0, l0)) = prev {
            // Phase crossover: Im L changes sign with Re L < 0.
            if l0.im.signum() != l.im.signum() {
                let f = l0.im / (l0.im - l.im);
                let re = l0.re + f * (l.re - l0.re);
                if (-1.0..0.0).contains(&re) {
                    let gm = -1.0 / re;
                    gain_margin = Some(gain_margin.map_or(gm, |g: f64| g.min(gm)));
                }
            }
            if (l0.norm() - 1.0).signum() != (l.norm() - 1.0).signum() {
                let f = (l0.norm() - 1.0) / (l0.norm() - l.norm());
                let lc = l0 + (l - l0) * f;
                let pm = 180.0 + lc.arg().to_degrees();
                let pm = if pm > 180.0 { pm - 360.0 } else { pm };
                if phase_margin.is_none_or(|p| pm < p) {
                    phase_margin = Some(pm);
                    crossover = Some(w0 + f * (w - w0));
                }
            }
        }
        prev = Some((w, l));
    }
    // Step response of y / r = B Q / (A P + B Q).
    let num = poly_mul(b, &controller.q);
    let samples = 4000;
    let mut y = vec![0.0; samples];
    for k in 0..samples {
        let mut acc = 0.0;
        for (i, ni) in num.iter().enumerate() {
            if i <= k {
                acc += ni;
            }
        }
        for (i, ci) in char_poly.iter().enumerate().skip(1) {
            if i <= k {
                acc -= ci * y[k - i];
            }
        }
        y[k] = acc;
    }
    Analysis {
        poles,
        spectral_radius,
        gain_margin,
        phase_margin_deg: phase_margin,
        crossover_rad_s: crossover,
        sensitivity_peak,
        step: y,
        period_s,
    }
}

/// The command's response to a set-point change `reference` (one value per period): the
/// closed loop's `u / r = A Q / (A P + B Q)`.
pub fn command_response(
    a: &[f64],
    b: &[f64],
    controller: &Controller,
    reference: &[f64],
) -> Vec<f64> {
    let den = controller.denominator();
    let num = poly_mul(a, &controller.q);
    let ap = poly_mul(a, &den);
    let bq = poly_mul(b, &controller.q);
    let char_poly: Vec<f64> = (0..ap.len().max(bq.len()))
        .map(|i| ap.get(i).unwrap_or(&0.0) + bq.get(i).unwrap_or(&0.0))
        .collect();
    let mut u = vec![0.0; reference.len()];
    for k in 0..reference.len() {
        let mut acc = 0.0;
        for (i, ni) in num.iter().enumerate().take(k + 1) {
            acc += ni * reference[k - i];
        }
        for (i, ci) in char_poly.iter().enumerate().skip(1).take(k) {
            acc -= ci * u[k - i];
        }
        u[k] = acc;
    }
    u
}

/// The closed-loop poles of the design goal in `z`: a dominant pair of natural frequency `w`
/// and damping `zeta` (`s = -ζω ± jω√(1-ζ²)`, a double real pole for `ζ ≥ 1`), the others real at
/// `s = -fast · w`.
pub fn goal_poles(order: usize, w: f64, zeta: f64, fast: f64, period_s: f64) -> Vec<Complex<f64>> {
    let to_z = |s: Complex<f64>| (s * period_s).exp();
    let mut poles = if zeta < 1.0 {
        let wd = w * (1.0 - zeta * zeta).sqrt();
        vec![
            to_z(Complex::new(-zeta * w, wd)),
            to_z(Complex::new(-zeta * w, -wd)),
        ]
    } else {
        let s1 = -w * (zeta - (zeta * zeta - 1.0).sqrt());
        let s2 = -w * (zeta + (zeta * zeta - 1.0).sqrt());
        vec![to_z(Complex::new(s1, 0.0)), to_z(Complex::new(s2, 0.0))]
    };
    while poles.len() < 2 * order {
        poles.push(to_z(Complex::new(-fast * w, 0.0)));
    }
    poles
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placed_poles_are_the_closed_loop_poles_and_the_step_settles_at_one() {
        // A second-order body and the solenoid-like third-order plant.
        for plant in [
            ContinuousPlant::body(1.0, 18.0, 2000.0, 10.0, None),
            ContinuousPlant::body(0.5, 20.0, 1650.0, 1.63, Some(0.0086)),
        ] {
            let t0 = 0.0025;
            let (a, b) = plant.discretise(t0).expect("discretises");
            let n = a.len() - 1;
            let goal = goal_poles(n, 40.0, 0.9, 3.0, t0);
            let c = place(&a, &b, &goal).expect("placed");
            let an = analyse(&a, &b, &c, t0);
            let mut want: Vec<f64> = goal.iter().map(|p| p.re).collect();
            let mut got: Vec<f64> = an.poles.iter().map(|p| p.re).collect();
            want.sort_by(f64::total_cmp);
            got.sort_by(f64::total_cmp);
            for (w, g) in want.iter().zip(&got) {
                // Repeated poles split by about the cube root of the rounding error.
                assert!((w - g).abs() < 1e-3, "{want:?} vs {got:?}");
            }
            assert!(an.spectral_radius < 1.0);
            let last = *an.step.last().expect("step");
            assert!((last - 1.0).abs() < 1e-6, "integral action: {last}");
            assert!(an.gain_margin.is_some_and(|g| g > 1.0), "{an:?}");
            assert!(an.phase_margin_deg.is_some_and(|p| p > 0.0));
        }
    }

    #[test]
    fn discretisation_matches_a_fine_simulation_of_the_body() {
        // m y'' + d y' + c y = K u with u = 1 held: the discrete model's step response at the
        // samples equals a fine explicit integration of the continuous one.
        let (m, d, c, k, t0) = (2.0, 10.0, 500.0, 3.0, 0.005);
        let plant = ContinuousPlant::body(m, d, c, k, None);
        let (a, b) = plant.discretise(t0).expect("discretises");
        let mut yd = vec![0.0; 200];
        for i in 1..yd.len() {
            let mut acc = 0.0;
            for j in 1..a.len() {
                if i >= j {
                    acc += b[j] - a[j] * yd[i - j];
                }
            }
            yd[i] = acc;
        }
        let (mut y, mut v) = (0.0, 0.0);
        let h = t0 / 1000.0;
        for (i, ydi) in yd.iter().enumerate().skip(1) {
            for _ in 0..1000 {
                let acc = (k - d * v - c * y) / m;
                v += acc * h;
                y += v * h;
            }
            assert!((y - ydi).abs() < 1e-4 * (k / c), "sample {i}: {y} vs {ydi}");
        }
        // Static gain K / c.
        let dc = b.iter().sum::<f64>() / a.iter().sum::<f64>();
        assert!((dc - k / c).abs() < 1e-9 * k / c);
    }
}

#[cfg(test)]
mod command_tests {
    use super::*;

    #[test]
    fn the_command_settles_at_the_inverse_static_gain() {
        let plant = ContinuousPlant::body(1.75, 45.0, 1358.0, 1.63, Some(0.0086));
        let t0 = 0.0025;
        let (a, b) = plant.discretise(t0).expect("discretises");
        for w in [5.0, 20.0, 40.0] {
            let c = place(&a, &b, &goal_poles(3, w, 1.0, 3.0, t0)).expect("placed");
            let u = command_response(&a, &b, &c, &vec![1.0; 4000]);
            let last = *u.last().expect("u");
            assert!(
                (last - 1358.0 / 1.63).abs() < 1e-3 * 1358.0 / 1.63,
                "{w}: {last}"
            );
        }
    }
}
