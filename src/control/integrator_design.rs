//! Quadratic-cost design of the P gain for an integrating drive (Isermann & Raab, pneumatic drive:
//! "gains from minimising a quadratic cost").
//!
//! Plant per direction `Y(k) = Y(k-1) + K_I T_0 U(k-1)`; with a constant set-point the error obeys
//! `e(k+1) = e(k) - b U(k)`, `b = K_I T_0`. Minimising `J = Σ (e(k)² + r U(k)²)` gives `U = q e`
//! with the scalar Riccati solution `P = (1 + √(1 + 4 r / b²)) / 2` and `q = b P / (r + b² P)`;
//! the closed-loop pole is `1 - q b = r / (r + b² P)`, so every `K_I` gets the same
//! pole for the same `r / b²`. `r` is in (command / m)⁻²... i.e. m² per command².

/// `q = b P / (r + b² P)`, `P = (1 + √(1 + 4 r / b²)) / 2`, `b = K_I T_0` (quadratic-cost P gain).
/// Returns `None` for a non-positive or non-finite `K_I`, `T_0` or a negative `r`.
pub fn integrator_lq_gain(gain_m_per_s: f64, period_s: f64, effort_weight_m2: f64) -> Option<f64> {
    let valid = gain_m_per_s > 0.0
        && gain_m_per_s.is_finite()
        && period_s > 0.0
        && period_s.is_finite()
        && effort_weight_m2 >= 0.0
        && effort_weight_m2.is_finite();
    if !valid {
        return None;
    }
    let b = gain_m_per_s * period_s;
    let p = 0.5 * (1.0 + (1.0 + 4.0 * effort_weight_m2 / (b * b)).sqrt());
    Some(b * p / (effort_weight_m2 + b * b * p))
}

/// `r` that puts the closed-loop pole at `z_c` for the drive gain `K_I`:
/// from `z_c = r / (r + b² P)`, `r = b² z_c / (1 - z_c)²` (with `P = 1 / (1 - z_c)`).
pub fn effort_weight_for_pole(gain_m_per_s: f64, period_s: f64, pole: f64) -> Option<f64> {
    if !((0.0..1.0).contains(&pole) && gain_m_per_s > 0.0 && period_s > 0.0) {
        return None;
    }
    let b = gain_m_per_s * period_s;
    Some(b * b * pole / ((1.0 - pole) * (1.0 - pole)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_matches_the_riccati_solution_and_the_pole_design() {
        let (k, t0) = (0.03, 0.02);
        let r = effort_weight_for_pole(k, t0, 0.4).expect("valid");
        let q = integrator_lq_gain(k, t0, r).expect("valid");
        assert!(
            (1.0 - q * k * t0 - 0.4).abs() < 1e-12,
            "pole {}",
            1.0 - q * k * t0
        );
        // Brute force: the cost of a few gains around q from e(0) = 1 is largest away from q.
        let cost = |q: f64| {
            let (mut e, mut j) = (1.0_f64, 0.0);
            for _ in 0..2000 {
                let u = q * e;
                j += e * e + r * u * u;
                e -= k * t0 * u;
            }
            j
        };
        assert!(cost(q) < cost(q * 1.05) && cost(q) < cost(q * 0.95));
        // r = 0: deadbeat.
        let q0 = integrator_lq_gain(k, t0, 0.0).expect("valid");
        assert!((q0 * k * t0 - 1.0).abs() < 1e-12);
        assert!(integrator_lq_gain(-1.0, t0, r).is_none());
    }
}
