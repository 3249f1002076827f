//! Feed-forward friction compensation with a safety factor (Isermann & Raab):
//! `U_comp(k) = α · F_C± / K · sign(e_w(k))`.

/// Feed-forward Coulomb friction compensation driven by the sign of the control error.
///
/// The sign of the error stands in for the unknown direction of the coming motion; `α < 1`
/// leaves the remainder to the integral part, so the compensation never over-compensates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionFeedForward {
    /// Safety factor α, 0..1.
    pub alpha: f64,
    /// Coulomb friction for motion in + direction, expressed as actuator input (V or duty).
    pub u_coulomb_pos: f64,
    /// Coulomb friction for motion in - direction, as actuator input, positive number.
    pub u_coulomb_neg: f64,
    /// Errors smaller than this count as zero, so sensor quantisation does not toggle the sign.
    pub deadband: f64,
}

impl FrictionFeedForward {
    /// From friction forces and the actuator's force gain `K` (N per input unit).
    pub fn from_forces(
        alpha: f64,
        coulomb_pos_n: f64,
        coulomb_neg_n: f64,
        gain_n_per_input: f64,
        deadband: f64,
    ) -> Self {
        Self {
            alpha,
            u_coulomb_pos: coulomb_pos_n / gain_n_per_input,
            u_coulomb_neg: coulomb_neg_n / gain_n_per_input,
            deadband,
        }
    }

    /// `U_comp = α F_C± / K sign(e)` (Isermann & Raab, feed-forward friction compensation).
    pub fn compensation(&self, e: f64) -> f64 {
        if e > self.deadband {
            self.alpha * self.u_coulomb_pos
        } else if e < -self.deadband {
            -self.alpha * self.u_coulomb_neg
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compensates_in_the_direction_of_the_error_with_the_safety_factor() {
        let ff = FrictionFeedForward::from_forces(0.8, 0.5, 0.4, 2.0, 1e-6);
        assert!((ff.compensation(1e-3) - 0.8 * 0.25).abs() < 1e-12);
        assert!((ff.compensation(-1e-3) + 0.8 * 0.2).abs() < 1e-12);
        assert_eq!(ff.compensation(5e-7), 0.0);
    }
}
