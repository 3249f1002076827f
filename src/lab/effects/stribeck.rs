//! `stribeck` in the lab: dry friction columns `sign(v) e^{-|v/v_S±|}` per direction, the
//! Stribeck velocity searched on a grid (one value for both directions); its signature is a
//! residual that peaks at low speed with the sign of velocity.

use super::{corr, geometric, mean_where, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::{Dry, Term};
use crate::lab::signals::abs_quantile;
use crate::physics::{EffectKind, PlantSpec};

const EXCESS_POS: Key = Key::effect(EffectKind::Stribeck, "excess_pos");
const EXCESS_NEG: Key = Key::effect(EffectKind::Stribeck, "excess_neg");
const VELOCITY_POS: Key = Key::effect(EffectKind::Stribeck, "velocity_pos");
const VELOCITY_NEG: Key = Key::effect(EffectKind::Stribeck, "velocity_neg");

/// The lab's side of `stribeck`.
pub struct Stribeck;

impl LabEffect for Stribeck {
    fn kind(&self) -> EffectKind {
        EffectKind::Stribeck
    }

    fn place(&self) -> u16 {
        120
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let vmax = abs_quantile(&cx.d.v, 0.95).max(1e-12);
        Ok(vec![(
            VELOCITY_POS.name(cx.spec)?,
            geometric(vmax * 0.01, vmax * 0.5, 10),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = VELOCITY_POS.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn set_grid_value(&self, spec: &mut PlantSpec, name: &str, value: f64) -> anyhow::Result<()> {
        spec.set(name, value)?;
        if name == VELOCITY_POS.name(spec)? {
            let neg = VELOCITY_NEG.name(spec)?;
            spec.set(&neg, value)?;
        }
        Ok(())
    }

    fn load_terms(
        &self,
        cx: &Cx,
        dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let v = &cx.d.v;
        let vp = VELOCITY_POS.value(cx.spec)?;
        let vn = VELOCITY_NEG.value(cx.spec)?;
        let scale = |k: usize| dry.map_or(1.0, |s| s[k]);
        // F = (F_S± - F_C±) sign(v) e^{-|v/v_S±|} (Bao et al. eq. 4)
        terms.push(
            Term::param(
                EXCESS_POS.resolve(cx.spec)?,
                (0..v.len())
                    .map(|k| {
                        let c = if v[k] > 0.0 { (-v[k] / vp).exp() } else { 0.0 };
                        c * scale(k)
                    })
                    .collect(),
            )
            .dry(Dry::Pos),
        );
        terms.push(
            Term::param(
                EXCESS_NEG.resolve(cx.spec)?,
                (0..v.len())
                    .map(|k| {
                        let c = if v[k] < 0.0 { -(v[k] / vn).exp() } else { 0.0 };
                        c * scale(k)
                    })
                    .collect(),
            )
            .dry(Dry::Neg),
        );
        Ok(())
    }

    fn reproduces(&self) -> &'static [EffectKind] {
        &[EffectKind::Coulomb]
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "low speed",
            shown_by: "motion at several slow speeds, held long enough to settle",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        let eps = d.v_standstill;
        let (lo, _) = mean_where(r, idx, |k| d.v[k].abs() < 4.0 * eps);
        let (hi, _) = mean_where(r, idx, |k| d.v[k].abs() >= 4.0 * eps);
        let lo_s = corr(
            r,
            &ev.at(&|k| d.v[k].signum() * (-(d.v[k].abs() / (4.0 * eps))).exp()),
        );
        format!(
            "residual peaks at low speed with the sign of velocity: correlation with \
             sign(v) e^(-|v|/v_S) {lo_s:+.2} (mean {lo:+.3e} slow, {hi:+.3e} fast)"
        )
    }
}
