//! `supply_friction` in the lab: the dry friction levels times `(S / S_nom)^κ_f` per sample (a
//! seal pressed by its supply), the exponent searched on a grid; its signature is friction in
//! the residual that follows the supply.

use super::{corr, mean_where, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::supply_ratio;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family};

const EXPONENT: Key = Key::effect(EffectKind::SupplyFriction, "exponent");

/// The lab's side of `supply_friction`.
pub struct SupplyFriction;

impl LabEffect for SupplyFriction {
    fn kind(&self) -> EffectKind {
        EffectKind::SupplyFriction
    }

    fn place(&self) -> u16 {
        110
    }

    fn representable(&self, family: Family, d: &Prepared) -> bool {
        d.supply.is_some() && matches!(family, Family::LinearAxis | Family::Pneumatic)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        Ok(vec![(
            EXPONENT.name(cx.spec)?,
            (0..=20).map(|i| i as f64 * 0.25).collect(),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        if cx.raw.supply.is_none() {
            return Ok(Vec::new());
        }
        let h = EXPONENT.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn dry_scale(&self, cx: &Cx) -> anyhow::Result<Option<Vec<f64>>> {
        if cx.raw.supply.is_none() {
            return Ok(None);
        }
        let f = crate::physics::effects::SupplyFriction {
            exponent: EXPONENT.value(cx.spec)?,
        };
        Ok(Some(
            supply_ratio(cx.spec, cx.raw)?
                .into_iter()
                .map(|r| f.factor(r))
                .collect(),
        ))
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the supply while the body slides",
            shown_by: "the same motion at several supply levels",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        match &d.supply {
            Some(s) => {
                // The friction the residual carries, signed as the friction opposing motion.
                let fr = ev.at(&|k| d.v[k].signum());
                let rf: Vec<f64> = r.iter().zip(&fr).map(|(x, g)| x * g).collect();
                let sup = ev.at(&|k| s[k]);
                let mut sorted = sup.clone();
                sorted.sort_by(f64::total_cmp);
                let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
                let (hi, _) = mean_where(&rf, idx, |k| s[k] > median);
                let (lo, _) = mean_where(&rf, idx, |k| s[k] <= median);
                format!(
                    "friction in the residual follows the supply: residual times sign(v) correlates \
                     {:+.2} with the supply, mean {hi:+.3e} {} above its median, {lo:+.3e} below",
                    corr(&rf, &sup),
                    ev.unit
                )
            }
            None => "no supply recorded".into(),
        }
    }
}
