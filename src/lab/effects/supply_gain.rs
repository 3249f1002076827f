//! `supply_gain` in the lab: the drive's gain times `(S / S_nom)^κ` (the power stage computed for
//! the nominal supply), the exponent searched on a grid; its signature is a residual structured
//! by supply times command. On the pneumatic drive each valve has its own law (`κ` for the
//! negative command, `κ + Δκ` for the positive one): the negative command's exponent is searched
//! with the positive one's held, then the positive one's.

use super::{command_visible, corr, Cx, Evidence, Grid, LabEffect, SupplyFactor, Separation};
use crate::lab::params::Key;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

/// The exponent `κ` (the negative command's, when the law is one per direction).
const EXPONENT: Key = Key::effect(EffectKind::SupplyGain, "exponent");

/// `Δκ`, the positive command's exponent minus the negative command's (pneumatic only).
const POS_SHIFT: Key = Key::effect(EffectKind::SupplyGain, "exponent_pos_shift");

/// The exponents searched: 0 to 5 by 0.25.
fn exponents() -> impl Iterator<Item = f64> {
    (0..=20).map(|i| i as f64 * 0.25)
}

/// True when the family's drive takes a law per direction (two valves, not a PWM stage).
fn per_direction(family: Family) -> bool {
    family == Family::Pneumatic
}

/// The lab's side of `supply_gain`.
pub struct SupplyGain;

impl LabEffect for SupplyGain {
    fn kind(&self) -> EffectKind {
        EffectKind::SupplyGain
    }

    fn place(&self) -> u16 {
        60
    }

    fn representable(&self, family: Family, d: &Prepared) -> bool {
        d.supply.is_some() && command_visible(family, d)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let mut grids = vec![(EXPONENT.name(cx.spec)?, exponents().collect())];
        if per_direction(cx.spec.family) {
            // Every shift that may put the positive command's exponent on the grid, whatever
            // the negative one's turns out to be (see `set_grid_value` for the others).
            grids.push((
                POS_SHIFT.name(cx.spec)?,
                (-20..=20).map(|i| i as f64 * 0.25).collect(),
            ));
        }
        Ok(grids)
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let mut out = vec![];
        for key in [EXPONENT, POS_SHIFT] {
            if key == EXPONENT || per_direction(cx.spec.family) {
                let h = key.resolve(cx.spec)?;
                out.push((h.name, h.value));
            }
        }
        Ok(out)
    }

    fn set_grid_value(&self, spec: &mut PlantSpec, name: &str, value: f64) -> anyhow::Result<()> {
        if !per_direction(spec.family) {
            spec.set(name, value)?;
            return Ok(());
        }
        let (kappa, shift) = (EXPONENT.value(spec)?, POS_SHIFT.value(spec)?);
        // The negative command's exponent moves with the positive one's held: the two valves'
        // columns are apart, so searching one law at a time finds both.
        let (kappa, shift) = if name == EXPONENT.name(spec)? {
            (value, kappa + shift - value)
        } else {
            (kappa, value)
        };
        // The positive command's exponent kept on the grid's range: a shift beyond it is the
        // range's end (a point that repeats another, never a refused one, so that a fit that
        // steps past it, as the output error's Jacobian does, sees the law stop there).
        let (lo, hi) = (exponents().fold(f64::MAX, f64::min), exponents().fold(0.0, f64::max));
        let shift = (kappa + shift).clamp(lo, hi) - kappa;
        spec.set(&EXPONENT.name(spec)?, kappa)?;
        spec.set(&POS_SHIFT.name(spec)?, shift)?;
        Ok(())
    }

    fn supply_factor(&self, spec: &PlantSpec) -> anyhow::Result<Option<SupplyFactor>> {
        let kappa = EXPONENT.value(spec)?;
        let shift = if per_direction(spec.family) {
            POS_SHIFT.value(spec)?
        } else {
            0.0
        };
        // The drive's factor (S / S_nom)^κ, κ + Δκ for a positive command; none from a supply
        // below zero.
        let factor = move |r: f64, positive: bool| {
            r.max(0.0)
                .powf(if positive { kappa + shift } else { kappa })
        };
        Ok(Some(Box::new(factor)))
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the supply times the command",
            shown_by: "the same commands at several supply levels",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let d = ev.d;
        match &d.supply {
            Some(s) => {
                let mut text = format!(
                    "residual structured by supply: correlation with supply·u {:+.2}, with supply {:+.2}",
                    corr(ev.r(), &ev.at(&|k| s[k] * d.u[k])),
                    corr(ev.r(), &ev.at(&|k| s[k]))
                );
                if per_direction(ev.family) {
                    // Each valve its own law: the stroke whose residual follows the supply.
                    let stroke = |positive: bool| {
                        corr(
                            ev.r(),
                            &ev.at(&|k| {
                                if (d.u[k] > 0.0) == positive {
                                    s[k] * d.u[k]
                                } else {
                                    0.0
                                }
                            }),
                        )
                    };
                    text += &format!(
                        "; negative command (down stroke) {:+.2}, positive command (up stroke) {:+.2}",
                        stroke(false),
                        stroke(true)
                    );
                }
                text
            }
            None => "no supply recorded".into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pneumatic() -> PlantSpec {
        PlantSpec::new(Family::Pneumatic)
            .with_effect(EffectKind::SupplyGain)
            .expect("pneumatic takes supply_gain")
    }

    #[test]
    fn the_negative_commands_law_moves_with_the_positive_ones_held() {
        let mut spec = pneumatic();
        let (e, s) = (
            EXPONENT.name(&spec).expect("key"),
            POS_SHIFT.name(&spec).expect("key"),
        );
        SupplyGain.set_grid_value(&mut spec, &s, -0.8).expect("sets");
        let up = EXPONENT.value(&spec).expect("κ") + POS_SHIFT.value(&spec).expect("Δκ");
        SupplyGain.set_grid_value(&mut spec, &e, 1.75).expect("sets");
        assert_eq!(EXPONENT.value(&spec).expect("κ"), 1.75);
        let held = 1.75 + POS_SHIFT.value(&spec).expect("Δκ");
        assert!((held - up).abs() < 1e-12, "up law {up} became {held}");
        // A shift past the grid's range is its end, never a refusal.
        SupplyGain.set_grid_value(&mut spec, &s, -4.0).expect("sets");
        assert!((POS_SHIFT.value(&spec).expect("Δκ") + 1.75).abs() < 1e-12);
    }

    #[test]
    fn the_drive_factor_takes_the_law_of_the_commands_sign() {
        let mut spec = pneumatic();
        let s = POS_SHIFT.name(&spec).expect("key");
        spec.set(&EXPONENT.name(&spec).expect("key"), 2.0).expect("κ");
        spec.set(&s, -1.5).expect("Δκ");
        let f = SupplyGain
            .supply_factor(&spec)
            .expect("reads")
            .expect("a factor");
        assert!((f(0.5, false) - 0.25).abs() < 1e-12);
        assert!((f(0.5, true) - 0.5f64.powf(0.5)).abs() < 1e-12);
        // A PWM stage: one law, whatever the shift says.
        let mut axis = PlantSpec::new(Family::LinearAxis)
            .with_effect(EffectKind::SupplyGain)
            .expect("linear_axis takes supply_gain");
        axis.set(&EXPONENT.name(&axis).expect("key"), 1.0).expect("κ");
        let f = SupplyGain
            .supply_factor(&axis)
            .expect("reads")
            .expect("a factor");
        assert_eq!(f(0.5, true), f(0.5, false));
    }
}
