//! Whether a model predicts motion: the position `k` samples ahead of each held-out sample,
//! from the measured state and the model's own accelerations, scored against coasting (the
//! same prediction with no force at all). The balance of forces judges a model by its equation
//! error in force units; a fit can shrink that error by shrinking its scale (a mass run to its
//! bound), or trade it where the motion does not care. The position it predicts cannot be
//! cheated that way, so the lab judges candidates, rungs and written models by it too.

use serde::Serialize;

use super::data::Dataset;
use super::regress::{balance, fit_spec, Balance};
use super::signals::Prepared;
use crate::physics::PlantSpec;

/// Horizon of the held-out prediction, samples (the `--k` default of `compare`).
pub const HORIZON: usize = 10;

/// A model's `k`-step prediction of the held-out part of a record.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Prediction {
    /// Horizon in samples.
    pub k: usize,
    /// Horizon in s.
    pub horizon_s: f64,
    /// Predictions scored: starts in the held-out part from which the balance holds over the
    /// whole horizon.
    pub samples: usize,
    /// RMS error of the predicted position (m or rad).
    pub rmse: f64,
    /// RMS error of coasting, `y(k0) + K T v(k0)`, on the same samples.
    pub rmse_coasting: f64,
    /// `1 - rmse / rmse_coasting`: 1 predicts the motion exactly, 0 no better than coasting,
    /// below 0 worse than no model at all.
    pub skill: f64,
}

impl Prediction {
    /// True when the model predicts the held-out motion better than coasting.
    pub fn predicts(&self) -> bool {
        self.skill > 0.0
    }

    /// `1 - rmse / rmse_base`: how much the error of `base`'s prediction falls with this one.
    pub fn improvement_over(&self, base: &Prediction) -> f64 {
        1.0 - self.rmse / base.rmse.max(f64::MIN_POSITIVE)
    }

    /// One line: the skill and the two errors.
    pub fn describe(&self, unit: &str) -> String {
        format!(
            "{}-step ({:.3} s) prediction of the held-out part, fitted on the part before it: \
             skill {:.2} (RMS error {:.3e} {unit}, coasting {:.3e} {unit}, {} samples)",
            self.k, self.horizon_s, self.skill, self.rmse, self.rmse_coasting, self.samples
        )
    }
}

/// The model's acceleration at each measured state, `a = -Σ_{j≠inertia} θ_j φ_j(k) / m` (the
/// balance solved for the inertia's column), or `None` for an inertia that is not positive.
pub fn acceleration(bal: &Balance) -> Option<Vec<f64>> {
    let mass = bal.terms.first()?.value;
    if mass.is_nan() || mass <= 0.0 {
        return None;
    }
    let mut acc = vec![0.0; bal.terms[0].col.len()];
    for t in &bal.terms[1..] {
        for (a, c) in acc.iter_mut().zip(&t.col) {
            *a -= t.value * c / mass;
        }
    }
    Some(acc)
}

/// `y(k0+K) = y(k0) + K T v(k0) + T² (K/2 a(k0) + Σ_{i=1}^{K-1} (K - i) a(k0+i))`: the double
/// integral of the acceleration by the trapezoidal rule (a(k) is the filtered derivative at
/// t_k, not held over the sample after it: weighting it as held shifts the prediction by half a
/// sample, which a fitted mass would absorb). With `acc` `None`, coasting.
pub fn ahead(prep: &Prepared, acc: Option<&[f64]>, k0: usize, k: usize) -> f64 {
    let dt = prep.dt;
    let mut y = prep.y[k0] + k as f64 * dt * prep.v[k0];
    if let Some(acc) = acc {
        y += dt * dt * 0.5 * k as f64 * acc[k0];
        for i in 1..k {
            y += dt * dt * (k - i) as f64 * acc[k0 + i];
        }
    }
    y
}

/// The starts `k0` from which a `k`-step prediction stays inside one stretch of the record and
/// the filter's interior.
pub fn starts(prep: &Prepared, k: usize) -> impl Iterator<Item = usize> + '_ {
    let n = prep.y.len();
    let mut stretch = vec![0usize; n];
    for (i, &start) in prep.segment_starts.iter().enumerate() {
        let end = prep.segment_starts.get(i + 1).copied().unwrap_or(n).min(n);
        stretch[start.min(end)..end].fill(i);
    }
    (0..n.saturating_sub(k)).filter(move |&k0| {
        prep.interior[k0] && prep.interior[k0 + k] && stretch[k0] == stretch[k0 + k]
    })
}

/// The prediction of the balance `bal` (a model fitted on the samples before `split`) from
/// every sample at or after `split` whose next `k` samples are all in the balance; `None`
/// without a positive inertia or without such motion.
pub fn held_out(bal: &Balance, prep: &Prepared, split: usize, k: usize) -> Option<Prediction> {
    let acc = acceleration(bal)?;
    // Only over stretches where the balance holds at every sample (moving, away from the end
    // stops): a body that sticks or sits on a stop is held by forces the balance does not
    // model, and coasting predicts it exactly.
    let mut held = vec![0usize; prep.y.len() + 1];
    for &i in &bal.index {
        if let Some(h) = held.get_mut(i + 1) {
            *h = 1;
        }
    }
    for i in 1..held.len() {
        held[i] += held[i - 1];
    }
    let (mut se, mut se_coast, mut samples) = (0.0, 0.0, 0usize);
    // Against the filtered position: the prediction starts from filtered signals, and what the
    // filter took out of the raw one no model predicts.
    for k0 in starts(prep, k).filter(|&k0| k0 >= split && held[k0 + k + 1] - held[k0] == k + 1) {
        let y = prep.y[k0 + k];
        se += (y - ahead(prep, Some(&acc), k0, k)).powi(2);
        se_coast += (y - ahead(prep, None, k0, k)).powi(2);
        samples += 1;
    }
    if samples == 0 || se_coast <= 0.0 {
        return None;
    }
    let (rmse, rmse_coasting) = (
        (se / samples as f64).sqrt(),
        (se_coast / samples as f64).sqrt(),
    );
    Some(Prediction {
        k,
        horizon_s: k as f64 * prep.dt,
        samples,
        rmse,
        rmse_coasting,
        skill: 1.0 - rmse / rmse_coasting,
    })
}

/// `spec` refitted (inverse dynamics) on the first `1 - fraction` of the record and its
/// prediction of the rest, `k` samples ahead: what a written model is checked with.
pub fn validate(
    spec: &PlantSpec,
    data: &Dataset,
    prep: &Prepared,
    fraction: f64,
    k: usize,
) -> anyhow::Result<Prediction> {
    let n = data.len();
    let split = (((1.0 - fraction) * n as f64).round() as usize).clamp(1, n.saturating_sub(1));
    let train: Vec<usize> = balance(spec, data, prep)?
        .index
        .into_iter()
        .filter(|&i| i < split)
        .collect();
    let (trained, _) = fit_spec(spec, data, prep, Some(&train))?;
    held_out(&balance(&trained, data, prep)?, prep, split, k).ok_or_else(|| {
        anyhow::anyhow!(
            "{}: no prediction of the held-out part (no motion after sample {split}, or the \
             inertia refitted on the rest is not positive)",
            data.origin
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lab::fixtures;
    use crate::lab::signals::prepare;
    use crate::physics::EffectKind;

    /// A linear axis with a spring, viscous and Coulomb friction under a force command, 1 µm
    /// noise.
    fn axis() -> PlantSpec {
        fixtures::force_axis(
            &[EffectKind::Spring, EffectKind::Viscous, EffectKind::Coulomb],
            5,
            1e-6,
        )
    }

    /// 30 s at 1 kHz under two sines of force, by the physics plant.
    fn record(spec: &PlantSpec) -> Dataset {
        fixtures::under_sines(spec, 30_000, &[(40.0, 0.9, 0.0), (15.0, 3.1, 0.4)], None)
    }

    #[test]
    fn the_right_model_predicts_the_held_out_motion_and_a_collapsed_mass_does_not() {
        let spec = axis();
        let d = record(&spec);
        let prep = prepare(&d, None);
        let right = validate(&spec, &d, &prep, 0.3, HORIZON).expect("predicts");
        assert!(right.predicts() && right.skill > 0.9, "{right:?}");
        assert!(right.samples > 5_000, "{right:?}");
        assert!((right.horizon_s - 0.01).abs() < 1e-12);
        // The mass held at a millionth of the truth: the balance still closes with the other
        // coefficients, but the accelerations it implies are a million times too large.
        let mut light = spec.clone();
        let m = spec.get("linear_axis.mass_kg").expect("mass");
        light
            .set("linear_axis.mass_kg", 1e-6 * m)
            .expect("admissible");
        light.set_free("linear_axis.mass_kg", false).expect("known");
        let wrong = validate(&light, &d, &prep, 0.3, HORIZON).expect("a prediction");
        assert!(!wrong.predicts() && wrong.skill < -100.0, "{wrong:?}");
        assert!(wrong.improvement_over(&right) < -100.0);
        // Coasting is the same on both: the benchmark does not move with the model.
        assert_eq!(wrong.rmse_coasting, right.rmse_coasting);
    }
}
