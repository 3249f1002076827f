//! When the data do not decide: candidates whose fits the record cannot tell apart from the
//! chosen one's, and the record that would.
//!
//! Two candidates that each add an effect to the same base are not nested, so the F test that
//! judges each against the base cannot compare them. Vuong's test does: the log-likelihood
//! ratio of the two fits per sample, `d_i = ln p_a(e_i) - ln p_b(e_i)`, has mean zero when the
//! two fit equally well, and its sum over the record divided by its spread is normal under that
//! hypothesis. Two changes fit it to this balance: the residual is correlated over about
//! `1/(2 f_c)` (see [`super::diagnose`]), so the sum counts `N_eff = n_eff_per_sample N`
//! samples; and the statistic carries the BIC's penalty for the parameters the two differ by.

use super::diagnose::Candidate;
use super::effects;
use crate::physics::EffectKind;

/// Two-sided level below which the data decide between two candidates: `|z|` beyond 1.96.
pub const DECIDING_Z: f64 = 1.96;

/// A rival whose residual RMS is this much larger than the chosen one's (relative to the
/// rival's) is decided against, whatever the statistic says.
pub const MATERIAL: f64 = 0.25;

/// Vuong's statistic of candidate `a` against `b` on the samples both residuals cover:
/// positive when `a` fits better, normal with unit variance when they fit equally well. The
/// spread of the log-likelihood ratio's sum comes from the sums over blocks of
/// `1 / n_eff_per_sample` samples (batch means: the ratio is correlated as the residuals are,
/// and the blocks measure by how much). `None` when fewer than 10 blocks are shared or the
/// ratio does not vary (identical fits).
pub fn vuong_z(a: &Candidate, b: &Candidate, n_eff_per_sample: f64) -> Option<f64> {
    let (ea, eb) = common(a, b);
    let n = ea.len();
    let block = (1.0 / n_eff_per_sample.clamp(1e-6, 1.0)).round().max(1.0) as usize;
    let blocks = n / block;
    if blocks < 10 {
        return None;
    }
    let var = |e: &[f64]| e.iter().map(|x| x * x).sum::<f64>() / n as f64;
    let (va, vb) = (var(&ea), var(&eb));
    if va.is_nan() || vb.is_nan() || va <= 0.0 || vb <= 0.0 {
        return None;
    }
    // d_i = ln N(e_a,i; 0, σ_a²) - ln N(e_b,i; 0, σ_b²): the pointwise log-likelihood ratio.
    let d =
        |i: usize| -0.5 * (va / vb).ln() - ea[i] * ea[i] / (2.0 * va) + eb[i] * eb[i] / (2.0 * vb);
    let sums: Vec<f64> = (0..blocks)
        .map(|b| (b * block..(b + 1) * block).map(d).sum())
        .collect();
    let total: f64 = sums.iter().sum();
    let mean = total / blocks as f64;
    let sd = (sums.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (blocks - 1) as f64).sqrt();
    if sd.is_nan() || sd <= 0.0 {
        return None;
    }
    let n_eff = blocks as f64;
    // Vuong's z with the Schwarz correction on the effective samples, in the units of the raw
    // sum: (Σd - (k_a - k_b) ln(N_eff) / 2 · block) / (sd_block √blocks).
    let penalty =
        0.5 * (a.parameters_added - b.parameters_added) as f64 * n_eff.ln() * block as f64;
    Some((sums.iter().sum::<f64>() - penalty) / (sd * n_eff.sqrt()))
}

/// The residuals of `a` and `b` on the sample indices both cover, in index order.
fn common(a: &Candidate, b: &Candidate) -> (Vec<f64>, Vec<f64>) {
    let (mut i, mut j) = (0, 0);
    let (mut ea, mut eb) = (Vec::new(), Vec::new());
    while i < a.index.len() && j < b.index.len() {
        match a.index[i].cmp(&b.index[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                if let (Some(x), Some(y)) = (a.residual.get(i), b.residual.get(j)) {
                    ea.push(*x);
                    eb.push(*y);
                }
                i += 1;
                j += 1;
            }
        }
    }
    (ea, eb)
}

/// One member of an undecided set beside the chosen candidate: its name and its statistic
/// against the chosen one.
#[derive(Debug, Clone, PartialEq)]
pub struct Rival {
    pub effect: String,
    /// [`vuong_z`] of the chosen candidate against this one (`None`: identical fits, or too
    /// short a record to compute it).
    pub z: Option<f64>,
}

/// The significant candidates the record cannot tell from `chosen`: their residuals differ by
/// less than `margin` (RMS, relative), or by less than [`MATERIAL`] and the statistic does not
/// decide (`|z| <` [`DECIDING_Z`]). On a long record a difference of a percent is
/// "significant" and says nothing of the physics (a dead zone's threshold between two grid
/// points against dry friction's exact least squares); a residual twice the chosen one's is a
/// decision even where the statistic is weak, as it is when the evidence comes in bursts (a
/// gear's play after each of a few dozen reversals: z = 1.4 with half the residual). A rival that reproduces the chosen effect ([`super::effects::LabEffect::reproduces`])
/// is the chosen one with parameters to spare, not a rival.
pub fn rivals(
    chosen: &Candidate,
    candidates: &[Candidate],
    n_eff_per_sample: f64,
    margin: f64,
) -> Vec<Rival> {
    candidates
        .iter()
        .filter(|c| c.significant && c.effect != chosen.effect && !reproduces(c, chosen))
        .filter_map(|c| {
            let z = vuong_z(chosen, c, n_eff_per_sample);
            let apart =
                (1.0 - chosen.residual_ratio / c.residual_ratio.max(f64::MIN_POSITIVE)).abs();
            // No statistic (identical fits, or too short a record) decides nothing either.
            undecided_pair(z, apart, margin).then(|| Rival {
                effect: c.effect.clone(),
                z,
            })
        })
        .collect()
}

/// The rule of [`rivals`] for one pair: the statistic `z` of the chosen against the rival,
/// `apart` the relative difference of their residuals' RMS (against the rival's).
fn undecided_pair(z: Option<f64>, apart: f64, margin: f64) -> bool {
    // No statistic (identical fits, or too short a record) decides nothing either.
    let weak = z.is_none_or(|z| z.abs() < DECIDING_Z);
    apart < margin || (weak && apart < MATERIAL)
}

/// True when `c`'s effect reproduces `chosen`'s.
fn reproduces(c: &Candidate, chosen: &Candidate) -> bool {
    let kind = |name: &str| EffectKind::from_name(name);
    match (kind(&c.effect), kind(&chosen.effect)) {
        (Some(k), Some(target)) => effects::of(k).is_ok_and(|e| e.reproduces().contains(&target)),
        _ => false,
    }
}

/// What would separate the effects `names`: what each one's force follows, and the records
/// that move those apart. Declared terms say they are the model's own.
pub fn separating_record(names: &[String]) -> String {
    let mut follows = Vec::new();
    let mut shown = Vec::new();
    for n in names {
        match EffectKind::from_name(n).and_then(|k| effects::of(k).ok()) {
            Some(e) => {
                let s = e.separated_by();
                follows.push(format!("{n} follows {}", s.follows));
                if !shown.contains(&s.shown_by) {
                    shown.push(s.shown_by);
                }
            }
            None => follows.push(format!("{n} is the model's own term")),
        }
    }
    let mut text = format!(
        "{}; in this record these move together. A record that moves them apart would decide",
        follows.join(", ")
    );
    if !shown.is_empty() {
        text.push_str(": ");
        text.push_str(&shown.join("; "));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(effect: &str, residual: Vec<f64>, k: i64) -> Candidate {
        Candidate {
            effect: effect.into(),
            nrmse: 0.1,
            improvement: 0.5,
            significant: true,
            evidence: String::new(),
            p_value: 0.0,
            delta_bic: -10.0,
            holdout_improvement: 0.5,
            prediction: None,
            prediction_improvement: None,
            residual_ratio: (residual.iter().map(|x| x * x).sum::<f64>()
                / residual.len().max(1) as f64)
                .sqrt(),
            parameters_added: k,
            parameters: Vec::new(),
            held: Vec::new(),
            index: (0..residual.len()).collect(),
            residual,
        }
    }

    /// A residual of independent normal draws with standard deviation `sd`.
    fn noise(n: usize, sd: f64, seed: u64) -> Vec<f64> {
        let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut uniform = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u, v) = (uniform().max(1e-300), uniform());
                sd * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
            })
            .collect()
    }

    #[test]
    fn equal_fits_are_undecided_and_a_clearly_better_one_decides() {
        let n = 4000;
        // Two fits of the same quality, their errors independent: the data cannot choose.
        let a = cand("deadzone", noise(n, 1.0, 1), 1);
        let b = cand("coulomb", noise(n, 1.0, 2), 1);
        let z = vuong_z(&a, &b, 1.0).expect("z");
        assert!(z.abs() < DECIDING_Z, "z = {z}");
        // A residual 10 % smaller: thousands of samples decide.
        let better = cand("coulomb", noise(n, 0.9, 2), 1);
        let z = vuong_z(&better, &a, 1.0).expect("z");
        assert!(z > 3.0, "z = {z}");
        assert!(vuong_z(&a, &better, 1.0).expect("z") < -3.0);
        // The same 10 % on residuals that hold each draw for 100 samples (40 independent
        // ones, as a band-limited residual does) does not.
        let slow = |sd: f64, seed: u64| -> Vec<f64> {
            noise(n / 100, sd, seed)
                .into_iter()
                .flat_map(|x| std::iter::repeat_n(x, 100))
                .collect()
        };
        let (a, better) = (
            cand("deadzone", slow(1.0, 1), 1),
            cand("coulomb", slow(0.9, 2), 1),
        );
        let z = vuong_z(&better, &a, 0.01).expect("z");
        assert!(z.abs() < DECIDING_Z, "z = {z}");
    }

    #[test]
    fn an_extra_parameter_costs_the_bic_penalty() {
        let n = 2000;
        let r = noise(n, 1.0, 3);
        let mut nudged = r.clone();
        // An equal fit plus a trace: without the penalty this would look a little better.
        for x in nudged.iter_mut() {
            *x *= 0.999;
        }
        let a = cand("stribeck", nudged.clone(), 2);
        let b = cand("coulomb", r.clone(), 1);
        let with_penalty = vuong_z(&a, &b, 1.0).expect("z");
        let even = vuong_z(&cand("stribeck", nudged, 1), &b, 1.0).expect("z");
        assert!(with_penalty < even, "{with_penalty} vs {even}");
    }

    #[test]
    fn only_the_samples_both_cover_are_compared() {
        let mut a = cand("deadzone", vec![1.0, -1.0, 2.0, -2.0], 1);
        a.index = vec![0, 2, 4, 6];
        let mut b = cand("coulomb", vec![5.0, 6.0, 7.0], 1);
        b.index = vec![2, 3, 6];
        let (ea, eb) = common(&a, &b);
        assert_eq!(ea, vec![-1.0, -2.0]);
        assert_eq!(eb, vec![5.0, 7.0]);
        // Too few shared samples to judge.
        assert_eq!(vuong_z(&a, &b, 1.0), None);
    }

    #[test]
    fn rivals_leave_out_the_chosen_the_insignificant_the_worse_and_the_nested() {
        let n = 3000;
        let chosen = cand("coulomb", noise(n, 1.0, 4), 1);
        let tie = cand("deadzone", noise(n, 1.0, 5), 1);
        let mut weak = cand("hysteresis", noise(n, 1.0, 6), 1);
        weak.significant = false;
        // The chosen fit again with one parameter more, that changes next to nothing: the
        // penalty decides for the chosen one.
        let nested = cand(
            "stribeck",
            chosen.residual.iter().map(|x| x * 0.9999).collect(),
            2,
        );
        let worse = cand("viscous", noise(n, 1.5, 8), 1);
        let all = vec![chosen.clone(), tie, weak, nested, worse];
        let r = rivals(&chosen, &all, 1.0, 0.05);
        let names: Vec<&str> = r.iter().map(|r| r.effect.as_str()).collect();
        assert_eq!(names, vec!["deadzone"]);
    }

    #[test]
    fn the_pair_rule_weighs_the_statistic_and_the_size_of_the_difference() {
        // A percent apart: undecided even where the statistic is strong (the staircase).
        assert!(undecided_pair(Some(-4.1), 0.015, 0.05));
        // A tenth apart and a weak statistic: undecided (the cylinder at 3 bar).
        assert!(undecided_pair(Some(1.46), 0.10, 0.05));
        // A tenth apart and a strong statistic: decided.
        assert!(!undecided_pair(Some(3.0), 0.10, 0.05));
        // Half the residual, the statistic weak (a gear's play in bursts): decided.
        assert!(!undecided_pair(Some(1.43), 0.47, 0.05));
        // No statistic: the size of the difference alone.
        assert!(undecided_pair(None, 0.10, 0.05));
        assert!(!undecided_pair(None, 0.30, 0.05));
    }

    #[test]
    fn identical_fits_of_two_effects_are_undecided() {
        let r = noise(2000, 1.0, 9);
        let chosen = cand("deadzone", r.clone(), 1);
        let twin = cand("coulomb", r, 2);
        assert_eq!(vuong_z(&chosen, &twin, 1.0), None);
        let found = rivals(&chosen, &[chosen.clone(), twin], 1.0, 0.05);
        assert_eq!(
            found,
            vec![Rival {
                effect: "coulomb".into(),
                z: None
            }]
        );
    }

    #[test]
    fn the_separating_record_names_what_each_follows() {
        let text = separating_record(&["deadzone".into(), "coulomb".into(), "cogging".into()]);
        assert!(
            text.contains("deadzone follows the command's size"),
            "{text}"
        );
        assert!(
            text.contains("coulomb follows the direction of motion"),
            "{text}"
        );
        assert!(text.contains("cogging is the model's own term"), "{text}");
        assert!(text.contains("while the command reverses"), "{text}");
    }
}
