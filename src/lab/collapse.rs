//! A fit that collapsed is a failure to report, never a model: a parameter of the body the data
//! were to determine ended at a bound its physics cannot reach (a mass, a drive gain, a time
//! constant fitted to the smallest admissible value), or the residual vanished to rounding, which
//! measured data cannot give (the balance's scale ran to zero, or its reference moved with the
//! fit), or the residual fell below what the position sensor's noise alone leaves in the balance.
//! `fit` refuses to write such a model, `diagnose` does not call its candidate
//! significant, and `discover` does not take the rung.

use super::data::Dataset;
use super::regress::{balance, Balance, IdFit};
use super::signals::Prepared;
use crate::physics::PlantSpec;

/// Below this NRMSE a fit of measured data has fitted its own reference, not the data: a
/// sensor's quantisation alone leaves far more.
pub const NRMSE_FLOOR: f64 = 1e-9;

/// Share of a parameter's default within which a value counts as sitting on a bound that must
/// not be reached.
const AT_BOUND: f64 = 1e-6;

/// Why the fit from `given` (the free flags it was fitted with) to `fitted` collapsed, or
/// `None` for a fit that may stand. `nrmse` is the fit's figure. With `base`, the fit of the
/// model below it (a candidate's base, a rung's foot), only a collapse the fit added counts: a
/// parameter already at its bound there is the base's failure, reported with the base.
pub fn collapsed(
    given: &PlantSpec,
    fitted: &PlantSpec,
    nrmse: f64,
    base: Option<&PlantSpec>,
) -> Option<String> {
    if nrmse.is_finite() && nrmse < NRMSE_FLOOR {
        return Some(format!(
            "the residual vanished (NRMSE {nrmse:.1e}, below {NRMSE_FLOOR:.0e}): a record with \
             a sensor cannot be explained to rounding; the balance's scale ran to zero or its \
             reference moved with the fit"
        ));
    }
    at_bound(given, fitted, base)
        .into_iter()
        .next()
        .map(|name| {
            let value = fitted.get(&name).unwrap_or(f64::NAN);
            let min = fitted
                .params()
                .into_iter()
                .find(|(n, _)| *n == name)
                .map_or(0.0, |(_, p)| p.def.min);
            format!(
            "{name} = {value:.3e} ended at its lower bound {min} (it must stay above it): the fit \
             collapsed, the data do not determine it with this model"
        )
        })
}

/// Why a fit may not stand, or `None`: [`collapsed`], then [`drive_vanished`], then
/// [`below_noise`] on `fit` (the fitted balance's residual, where there is one). The one check
/// `fit` applies before it writes, `diagnose` before it calls a candidate significant and
/// `discover` before it takes a rung.
#[allow(clippy::too_many_arguments)]
pub fn refused(
    given: &PlantSpec,
    fitted: &PlantSpec,
    nrmse: f64,
    base: Option<&PlantSpec>,
    fit: Option<&IdFit>,
    data: &Dataset,
    d: &Prepared,
) -> anyhow::Result<Option<String>> {
    if let Some(why) = collapsed(given, fitted, nrmse, base) {
        return Ok(Some(why));
    }
    if let Some(why) = drive_vanished(fitted, base, data, d)? {
        return Ok(Some(why));
    }
    Ok(fit.and_then(|f| below_noise(f, d)))
}

/// Share of the acceleration noise ([`Prepared::acceleration_noise`]) below which a fit's
/// residual, as an acceleration, has fitted the noise: the filtered noise is uncorrelated with
/// every column, so a model that is right leaves it whole.
pub const NOISE_SHARE: f64 = 0.5;

/// Why `fit` explains the record better than its sensor allows, or `None`: the RMS of its
/// moving residual over its inertia coefficient, an acceleration, below [`NOISE_SHARE`] of the
/// acceleration the position noise puts in the balance.
pub fn below_noise(fit: &IdFit, d: &Prepared) -> Option<String> {
    let inertia = fit.values.first().copied()?;
    if d.acceleration_noise <= 0.0 || inertia.is_nan() || inertia <= 0.0 || fit.residual.is_empty()
    {
        return None;
    }
    let rms = (fit.residual.iter().map(|r| r * r).sum::<f64>() / fit.residual.len() as f64).sqrt();
    let per_inertia = rms / inertia;
    (per_inertia < NOISE_SHARE * d.acceleration_noise).then(|| {
        format!(
            "the residual ({per_inertia:.3e} per unit of inertia) is below half the acceleration \
             the position sensor's noise alone leaves ({:.3e}, from the record's spectrum): the \
             fit explains noise, a degenerate solution",
            d.acceleration_noise
        )
    })
}

/// The body's parameters, free in `given`, that `fitted` ran to a lower bound they must stay
/// above, and that were not there already in `base`.
pub fn at_bound(given: &PlantSpec, fitted: &PlantSpec, base: Option<&PlantSpec>) -> Vec<String> {
    let free: Vec<String> = given
        .params()
        .into_iter()
        .filter(|(_, p)| p.free)
        .map(|(n, _)| n)
        .collect();
    // The body's own parameters (mass, drive constants) carry the balance's scale; an effect's
    // strictly positive parameter (a spring's stiffness) at its bound is the effect vanishing,
    // which its candidate's figures judge.
    let body = format!("{}.", fitted.family.name());
    let mut names = Vec::new();
    for (name, p) in fitted.params() {
        if !free.contains(&name) || !name.starts_with(&body) {
            continue;
        }
        let near = AT_BOUND * p.def.default.abs().max(f64::MIN_POSITIVE);
        // A parameter that must stay above its lower bound (a mass, a gain, a time constant):
        // at the bound it is not determined, it has vanished.
        let at_bound = |v: f64| p.def.min_strict && v <= p.def.min + near;
        let before = base.and_then(|b| b.get(&name));
        if at_bound(p.value) && !before.is_some_and(at_bound) {
            names.push(name);
        }
    }
    names
}

/// Share of its base's drive force, per direction of motion, below which a fit's drive counts
/// as gone: the command no longer moves the body that way in the model.
pub const DRIVE_LEFT: f64 = 0.2;

/// RMS of the force the command puts into `spec`'s balance, over its samples moving positive and
/// over those moving negative: the balance at the model's coefficients less the same balance
/// with the command held at zero, so that every stage of the drive (a gain per direction, a dead
/// zone, a saturation) is counted as the model has it.
pub fn drive_per_direction(
    spec: &PlantSpec,
    data: &Dataset,
    d: &Prepared,
) -> anyhow::Result<[f64; 2]> {
    let driven = balance(spec, data, d)?;
    let mut quiet = data.clone();
    quiet.input.iter_mut().for_each(|u| *u = 0.0);
    let mut quiet_d = d.clone();
    quiet_d.u.iter_mut().for_each(|u| *u = 0.0);
    let idle = balance(spec, &quiet, &quiet_d)?;
    let force = |b: &Balance, k: usize| b.terms.iter().map(|t| t.value * t.col[k]).sum::<f64>();
    let (mut sq, mut count) = ([0.0; 2], [0usize; 2]);
    for &k in &driven.index {
        let side = match d.v[k] {
            v if v > 0.0 => 0,
            v if v < 0.0 => 1,
            _ => continue,
        };
        let f = force(&driven, k) - force(&idle, k);
        if f.is_finite() {
            sq[side] += f * f;
            count[side] += 1;
        }
    }
    Ok([0, 1].map(|s| (sq[s] / count[s].max(1) as f64).sqrt()))
}

/// Why `fitted` collapsed by letting the body move one way without its drive, or `None`: its
/// drive force on one direction of motion fell below [`DRIVE_LEFT`] of `base`'s (the fit it was
/// refitted from; without one, the body of `fitted` with no effect). The motion then has to be
/// explained by the other forces alone, and on a record where they balance the drive (steady
/// strokes against friction) a model whose drive and friction both vanish coasts: its balance
/// closes at a smaller scale and it predicts a steady speed well, but it is not the machine.
pub fn drive_vanished(
    fitted: &PlantSpec,
    base: Option<&PlantSpec>,
    data: &Dataset,
    d: &Prepared,
) -> anyhow::Result<Option<String>> {
    let plain;
    let reference = match base {
        Some(b) => b,
        None => {
            let mut p = fitted.clone();
            p.effects.clear();
            plain = p;
            &plain
        }
    };
    // A model the inverse-dynamics balance cannot hold (a motor_gear, an effect fitted by
    // simulation alone) is judged by its own fit's checks.
    let (Ok(now), Ok(before)) = (
        drive_per_direction(fitted, data, d),
        drive_per_direction(reference, data, d),
    ) else {
        return Ok(None);
    };
    Ok(["positive", "negative"]
        .iter()
        .zip(now.iter().zip(&before))
        .find(|(_, (&n, &b))| b > 0.0 && n < DRIVE_LEFT * b)
        .map(|(side, (n, b))| {
            format!(
                "the drive's force on {side} motion fell to {:.0} % of {} ({n:.3e} against \
                 {b:.3e} RMS): the fit lets the body move that way without the force that \
                 moves it, the drive and what it works against vanishing together",
                100.0 * n / b,
                if base.is_some() {
                    "its base's"
                } else {
                    "the body's alone"
                }
            )
        }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solenoid() -> PlantSpec {
        PlantSpec::from_toml(
            include_str!("../../config/plants/solenoid.toml"),
            "solenoid.toml",
        )
        .expect("plant")
    }

    /// A linear axis under a force command, its position read with `noise_m` of noise: 20 s
    /// at 1 kHz under two sines of force.
    fn record(noise_m: f64) -> (PlantSpec, crate::lab::Dataset) {
        use crate::physics::EffectKind;
        let spec = crate::lab::fixtures::force_axis(
            &[EffectKind::Spring, EffectKind::Viscous],
            11,
            noise_m,
        );
        let d = crate::lab::fixtures::under_sines(
            &spec,
            20_000,
            &[(40.0, 1.1, 0.0), (15.0, 4.3, 0.0)],
            None,
        );
        (spec, d)
    }

    #[test]
    fn a_residual_below_the_sensor_noise_is_refused() {
        use crate::lab::regress::fit_spec;
        use crate::lab::signals::prepare;
        let (spec, noisy) = record(2e-4);
        let prep = prepare(&noisy, None);
        assert!(prep.acceleration_noise > 0.0);
        let (_, fit) = fit_spec(&spec, &noisy, &prep, None).expect("fits");
        // The right model leaves the noise whole: it stands.
        assert_eq!(below_noise(&fit, &prep), None);
        // The same motion without the noise, judged against the noisy sensor's floor: the fit
        // explains more than that sensor can have measured.
        let (_, clean) = record(0.0);
        let mut clean_prep = prepare(&clean, None);
        clean_prep.acceleration_noise = prep.acceleration_noise;
        let (_, clean_fit) = fit_spec(&spec, &clean, &clean_prep, None).expect("fits");
        let rms = |f: &IdFit| {
            (f.residual.iter().map(|r| r * r).sum::<f64>() / f.residual.len() as f64).sqrt()
                / f.values[0]
        };
        let why = below_noise(&clean_fit, &clean_prep).unwrap_or_else(|| {
            panic!(
                "not below the noise: {:.3e} clean, {:.3e} noisy, floor {:.3e}",
                rms(&clean_fit),
                rms(&fit),
                prep.acceleration_noise
            )
        });
        assert!(why.contains("noise"), "{why}");
    }

    #[test]
    fn a_mass_at_its_bound_and_a_vanished_residual_are_collapses() {
        let given = solenoid();
        let mut fitted = given.clone();
        assert_eq!(collapsed(&given, &fitted, 0.05, None), None);
        fitted.set("solenoid.mass_kg", 1e-12).expect("admissible");
        let why = collapsed(&given, &fitted, 0.05, None).expect("a collapse");
        assert!(why.contains("solenoid.mass_kg"), "{why}");
        // A parameter the fit was not asked for is the user's, at whatever value.
        let mut fixed = given.clone();
        fixed.set_free("solenoid.mass_kg", false).expect("known");
        assert_eq!(collapsed(&fixed, &fitted, 0.05, None), None);
        // A Coulomb level of 0 is a guide without dry friction, not a collapse.
        let mut dry = given.clone();
        dry.set("coulomb.coulomb_pos_n", 0.0).expect("admissible");
        assert_eq!(collapsed(&given, &dry, 0.05, None), None);
        // A base already at the bound: the candidate adds no collapse of its own.
        assert_eq!(collapsed(&given, &fitted, 0.05, Some(&fitted)), None);
        let why = collapsed(&given, &given, 3.4e-15, None).expect("rounding");
        assert!(why.contains("vanished"), "{why}");
    }

    #[test]
    fn a_drive_gone_on_one_side_is_a_collapse_and_a_reduced_one_is_not() {
        use crate::lab::signals::prepare;
        use crate::physics::EffectKind;
        let (spec, data) = record(0.0);
        let prep = prepare(&data, None);
        // The body alone drives both ways as its record was made.
        assert_eq!(
            drive_vanished(&spec, None, &data, &prep).expect("balances"),
            None
        );
        let mut asym = spec.clone();
        asym.add_effect(EffectKind::DirectionAsymmetry)
            .expect("known");
        let [pos, neg] = drive_per_direction(&asym, &data, &prep).expect("balances");
        assert!(pos > 1.0 && neg > 1.0, "{pos} {neg}");
        // Half the gain on negative motion halves the drive there: a weaker drive, not a gone one.
        asym.set("direction_asymmetry.gain_neg", 0.5)
            .expect("admissible");
        let [_, half] = drive_per_direction(&asym, &data, &prep).expect("balances");
        assert!((half / neg - 0.5).abs() < 1e-6, "{half} against {neg}");
        assert_eq!(
            drive_vanished(&asym, Some(&spec), &data, &prep).expect("balances"),
            None
        );
        // No gain there: the body moves that way with no drive in the model.
        asym.set("direction_asymmetry.gain_neg", 0.0)
            .expect("admissible");
        let why = drive_vanished(&asym, Some(&spec), &data, &prep)
            .expect("balances")
            .expect("a collapse");
        assert!(why.contains("negative motion fell to 0 %"), "{why}");
        // A dead zone wider than every force the record's command gives takes the drive from both
        // sides; one narrower than most leaves most of it.
        let peak = data.input.iter().fold(0.0_f64, |m, u| m.max(u.abs()));
        let mut wide = spec.clone();
        wide.add_effect(EffectKind::Deadzone).expect("known");
        wide.set("deadzone.threshold_n", 1.1 * peak)
            .expect("admissible");
        let why = drive_vanished(&wide, None, &data, &prep)
            .expect("balances")
            .expect("a collapse");
        assert!(why.contains("the body's alone"), "{why}");
        wide.set("deadzone.threshold_n", 0.05 * peak)
            .expect("admissible");
        assert_eq!(
            drive_vanished(&wide, None, &data, &prep).expect("balances"),
            None
        );
    }
}
