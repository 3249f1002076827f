//! Whether a model predicts motion: the position `k` samples ahead of each held-out sample,
//! from the measured state and the model's own accelerations, scored against coasting (the
//! same prediction with no force at all). The balance of forces judges a model by its equation
//! error in force units; a fit can shrink that error by shrinking its scale, or trade it where
//! the motion does not care. The position it predicts cannot be cheated that way, so the lab
//! judges candidates, rungs and written models by it too.
//!
//! The prediction is the model linearised about the measured motion: its acceleration at the
//! measured state, plus its own slopes `∂a/∂v` and `∂a/∂y` (the balance rebuilt at the state
//! moved by a step) times how far the predicted state has left the measured one. Taken at the
//! measured states alone, nothing of the model's damping acts on the speed it predicts: on a
//! body whose friction balances the drive (a pneumatic cylinder, m/c of 1-2 ms against samples
//! of 10 ms) a small force error integrates to centimetres over the horizon, where the model's
//! own damping holds the speed at its equilibrium. Stiff slopes (c/m far above the sample
//! rate) are integrated implicitly, so they relax the predicted state instead of ringing.

use serde::Serialize;

use super::data::Dataset;
use super::regress::{balance, balance_at_states, fit_spec, Balance};
use super::signals::{abs_quantile, Prepared};
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

/// Step of the finite differences of the model's force in the state, as a share of the record's
/// speed (its 95 % quantile) and of its travel: small beside the deviations a prediction makes,
/// large beside the rounding of the columns.
const SLOPE_STEP: f64 = 1e-3;

/// The model along the measured motion: its acceleration at each measured state and how that
/// acceleration changes with the state there.
#[derive(Debug, Clone, PartialEq)]
pub struct Dynamics {
    /// The model's acceleration at the measured state ([`acceleration`]).
    pub acc: Vec<f64>,
    /// `∂a/∂v` at the measured state, 1/s: minus the model's damping over its inertia.
    pub dadv: Vec<f64>,
    /// `∂a/∂y` at the measured state, 1/s²: minus the model's stiffness over its inertia.
    pub dady: Vec<f64>,
}

/// The dynamics of `spec` (whose balance on the record is `bal`) along the measured motion;
/// `None` without a positive inertia. The slopes are central differences of the model's
/// acceleration with the filtered speed, then the position, moved at every sample at once: each
/// column is filtered like the one it stands for, so a switch of the force (dry friction at a
/// reversal) spreads over the filter's reach as it does in the balance.
pub fn dynamics(
    spec: &PlantSpec,
    data: &Dataset,
    prep: &Prepared,
    bal: &Balance,
) -> anyhow::Result<Option<Dynamics>> {
    let Some(acc) = acceleration(bal) else {
        return Ok(None);
    };
    let (lo, hi) = prep
        .y
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &y| {
            (lo.min(y), hi.max(y))
        });
    let v_step = SLOPE_STEP * abs_quantile(&prep.v, 0.95);
    let y_step = SLOPE_STEP * (hi - lo);
    let dadv = slope(spec, data, prep, v_step, |p, h| {
        for (moved, v) in p.v.iter_mut().zip(&prep.v) {
            *moved = v + h;
        }
    })?;
    let dady = slope(spec, data, prep, y_step, |p, h| {
        for (moved, y) in p.y.iter_mut().zip(&prep.y) {
            *moved = y + h;
        }
    })?;
    Ok(Some(Dynamics { acc, dadv, dady }))
}

/// `∂a/∂x ≈ (a(x + h) - a(x - h)) / 2h` per sample, the state moved by `shift`; zero where the
/// step is not a positive number (a record that does not move) or the difference is not finite.
fn slope(
    spec: &PlantSpec,
    data: &Dataset,
    prep: &Prepared,
    step: f64,
    shift: impl Fn(&mut Prepared, f64),
) -> anyhow::Result<Vec<f64>> {
    let n = prep.y.len();
    if !(step.is_finite() && step > 0.0) {
        return Ok(vec![0.0; n]);
    }
    let mut moved = prep.clone();
    let mut at = |h: f64| -> anyhow::Result<Option<Vec<f64>>> {
        shift(&mut moved, h);
        Ok(acceleration(&balance_at_states(spec, data, &moved)?))
    };
    let (Some(up), Some(down)) = (at(step)?, at(-step)?) else {
        return Ok(vec![0.0; n]);
    };
    Ok(up
        .iter()
        .zip(&down)
        .map(|(u, d)| {
            let s = (u - d) / (2.0 * step);
            if s.is_finite() {
                s
            } else {
                0.0
            }
        })
        .collect())
}

/// `y(k0+K)` predicted by the model linearised about the measured motion. The scheme is
/// [`ahead`]'s (velocities at the half samples, `u_{i+1/2} = u_{i-1/2} + T a_i`, the first step
/// a half one; positions `y_{i+1} = y_i + T u_{i+1/2}`), with the acceleration at step `i`
/// `a_i + ∂a/∂v (u - v) + ∂a/∂y (y - y_m)` against the measured speed and position. The
/// stabilising slopes (negative) act on the deviations after the step, solved for in closed
/// form (backward Euler: a damping of any stiffness relaxes the speed to the model's
/// equilibrium, never rings); the destabilising ones on the deviations before it (explicit: a
/// growth the model has is predicted as growth). With both slopes zero it is [`ahead`].
pub fn ahead_linearised(prep: &Prepared, model: &Dynamics, k0: usize, k: usize) -> f64 {
    let dt = prep.dt;
    let mut y = prep.y[k0];
    // The predicted speed and the measured one it is held against: at t_{k0}, then over each step.
    let (mut u, mut v_ref) = (prep.v[k0], prep.v[k0]);
    for i in 0..k {
        let j = k0 + i;
        let h = if i == 0 { 0.5 * dt } else { dt };
        // The measured speed over the step (the one that carries the measured position to the
        // next sample exactly, as `u` carries the predicted one) and the position at its end.
        let y_end = prep.y[j + 1];
        let v_mid = (y_end - prep.y[j]) / dt;
        let (av, ay) = (model.dadv[j], model.dady[j]);
        let (av_in, av_ex) = (av.min(0.0), av.max(0.0));
        let (ay_in, ay_ex) = (ay.min(0.0), ay.max(0.0));
        // Explicit part: the destabilising slopes on the deviations before the step.
        let explicit = av_ex * (u - v_ref) + ay_ex * (y - prep.y[j]);
        // `w = u + h (a + explicit + av_in (w - v_mid) + ay_in (y + T w - y_end))`, solved for w.
        u = (u + h * (model.acc[j] + explicit - av_in * v_mid + ay_in * (y - y_end)))
            / (1.0 - h * av_in - h * dt * ay_in);
        y += dt * u;
        v_ref = v_mid;
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

/// The prediction of `spec` (a model fitted on the samples before `split`, its balance on the
/// record `bal`) from every sample at or after `split` whose next `k` samples are all in the
/// balance; `None` without a positive inertia or without such motion.
pub fn held_out(
    spec: &PlantSpec,
    data: &Dataset,
    prep: &Prepared,
    bal: &Balance,
    split: usize,
    k: usize,
) -> anyhow::Result<Option<Prediction>> {
    let Some(model) = dynamics(spec, data, prep, bal)? else {
        return Ok(None);
    };
    Ok(score(&model, bal, prep, split, k))
}

/// The prediction of `model` scored against coasting (see [`held_out`]).
fn score(
    model: &Dynamics,
    bal: &Balance,
    prep: &Prepared,
    split: usize,
    k: usize,
) -> Option<Prediction> {
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
        se += (y - ahead_linearised(prep, model, k0, k)).powi(2);
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
    let bal = balance(&trained, data, prep)?;
    held_out(&trained, data, prep, &bal, split, k)?.ok_or_else(|| {
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

    /// The axis' model along its own record, from the balance of the true parameters.
    fn along(spec: &PlantSpec, d: &Dataset, prep: &Prepared) -> Dynamics {
        let bal = balance(spec, d, prep).expect("balance");
        dynamics(spec, d, prep, &bal)
            .expect("slopes")
            .expect("a positive mass")
    }

    #[test]
    fn the_slopes_are_the_models_damping_and_stiffness_and_without_them_it_is_ahead() {
        let spec = axis();
        let d = record(&spec);
        let prep = prepare(&d, None);
        let model = along(&spec, &d, &prep);
        let m = spec.get("linear_axis.mass_kg").expect("mass");
        let k = spec.get("spring.stiffness_n_per_m").expect("stiffness");
        // Away from the reversals (where the Coulomb level switches) the slope in speed is the
        // viscous damping over the mass, and everywhere the one in position the spring's.
        let fast = abs_quantile(&prep.v, 0.5);
        let mid = prep.y.len() / 2;
        let at = (mid..prep.y.len())
            .find(|&i| prep.v[i].abs() > fast)
            .expect("a fast sample");
        let side = if prep.v[at] > 0.0 { "pos" } else { "neg" };
        let c = spec
            .get(&format!("viscous.damping_{side}_n_s_per_m"))
            .expect("damping");
        assert!(
            (model.dadv[at] + c / m).abs() < 1e-3 * c / m,
            "{} against {}",
            model.dadv[at],
            -c / m
        );
        assert!(
            (model.dady[at] + k / m).abs() < 1e-3 * k / m,
            "{} against {}",
            model.dady[at],
            -k / m
        );
        // Without slopes the prediction is the double integral of the accelerations.
        let flat = Dynamics {
            dadv: vec![0.0; model.acc.len()],
            dady: vec![0.0; model.acc.len()],
            ..model.clone()
        };
        for k0 in starts(&prep, HORIZON).step_by(997) {
            let (a, b) = (
                ahead(&prep, Some(&model.acc), k0, HORIZON),
                ahead_linearised(&prep, &flat, k0, HORIZON),
            );
            assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-3), "{a} {b}");
        }
    }

    #[test]
    fn a_stiff_damping_holds_a_force_error_to_its_equilibrium_speed() {
        let spec = axis();
        let d = record(&spec);
        let prep = prepare(&d, None);
        // A force error of 1 m/s² against a damping of 100 times the sample rate: the speed
        // relaxes within the first step to `bias / (c/m)` above the measured one, so the
        // position drifts by about `K T bias / (c/m)`; integrated at the measured states the
        // same error is `(K T)² bias / 2`, and integrated explicitly it would ring by a
        // factor of 99 per step.
        let (bias, stiff) = (1.0, 100.0 / prep.dt);
        let n = prep.y.len();
        let model = Dynamics {
            acc: prep.a.iter().map(|a| a + bias).collect(),
            dadv: vec![-stiff; n],
            dady: vec![0.0; n],
        };
        let span = HORIZON as f64 * prep.dt;
        let quasi_static = span * bias / stiff;
        for k0 in starts(&prep, HORIZON).step_by(1013) {
            let truth = prep.y[k0 + HORIZON];
            let linear = ahead_linearised(&prep, &model, k0, HORIZON) - truth;
            let at_measured = ahead(&prep, Some(&model.acc), k0, HORIZON) - truth;
            assert!(
                linear > 0.9 * quasi_static && linear < 1.1 * quasi_static,
                "{linear:e} against {quasi_static:e}"
            );
            assert!(at_measured > 0.4 * span * span * bias, "{at_measured:e}");
        }
    }

    #[test]
    fn the_right_model_predicts_the_held_out_motion_and_a_massless_one_does_not() {
        let spec = axis();
        let d = record(&spec);
        let prep = prepare(&d, None);
        let right = validate(&spec, &d, &prep, 0.3, HORIZON).expect("predicts");
        assert!(right.predicts() && right.skill > 0.9, "{right:?}");
        assert!(right.samples > 5_000, "{right:?}");
        assert!((right.horizon_s - 0.01).abs() < 1e-12);
        // The mass held at a millionth of the truth, then at the value a fit that collapsed
        // ends at: the balance still closes with the other coefficients, but its accelerations
        // are a million times too large or more. Linearised, the model's own damping and spring
        // hold such a body to the force quasi-statically (the speed at which the damping takes
        // what the spring and the drive leave), so the prediction no longer explodes; but a
        // body without inertia does not move as this one does, and it still predicts the
        // motion far worse than coasting (skill about -17), its error over a hundred times
        // the right model's.
        let m = spec.get("linear_axis.mass_kg").expect("mass");
        for mass in [1e-6 * m, 1e-12] {
            let mut light = spec.clone();
            light.set("linear_axis.mass_kg", mass).expect("admissible");
            light.set_free("linear_axis.mass_kg", false).expect("known");
            let wrong = validate(&light, &d, &prep, 0.3, HORIZON).expect("a prediction");
            assert!(!wrong.predicts() && wrong.skill < -10.0, "{wrong:?}");
            assert!(
                wrong.improvement_over(&right) < -100.0,
                "{wrong:?} {right:?}"
            );
            // Coasting is the same on both: the benchmark does not move with the model.
            assert_eq!(wrong.rmse_coasting, right.rmse_coasting);
        }
    }
}
