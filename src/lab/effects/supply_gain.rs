//! `supply_gain` in the lab: the drive's gain times `(S / S_nom)^κ` (the power stage computed for
//! the nominal supply), the exponent searched on a grid; its signature is a residual structured
//! by supply times command.

use super::{command_visible, corr, Cx, Evidence, Grid, LabEffect, SupplyFactor};
use crate::lab::params::Key;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

/// The exponent `κ`.
const EXPONENT: Key = Key::effect(EffectKind::SupplyGain, "exponent");

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
        Ok(vec![(
            EXPONENT.name(cx.spec)?,
            (0..=20).map(|i| i as f64 * 0.25).collect(),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = EXPONENT.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn supply_factor(&self, spec: &PlantSpec) -> anyhow::Result<Option<SupplyFactor>> {
        let kappa = EXPONENT.value(spec)?;
        // The drive's factor (S / S_nom)^κ, none from a supply below zero.
        let factor = move |r: f64| r.max(0.0).powf(kappa);
        Ok(Some(Box::new(factor)))
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let d = ev.d;
        match &d.supply {
            Some(s) => format!(
                "residual structured by supply: correlation with supply·u {:+.2}, with supply {:+.2}",
                corr(ev.r(), &ev.at(&|k| s[k] * d.u[k])),
                corr(ev.r(), &ev.at(&|k| s[k]))
            ),
            None => "no supply recorded".into(),
        }
    }
}
