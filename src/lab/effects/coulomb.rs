//! `coulomb` in the lab: a dry friction column per direction, `F_C± sign(v)` (times the supply's
//! factor when the friction follows the supply); its signature is a residual that steps with
//! the sign of velocity.

use super::{mean_where, Cx, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::{Dry, Term};
use crate::physics::EffectKind;

const COULOMB_POS: Key = Key::effect(EffectKind::Coulomb, "coulomb_pos");
const COULOMB_NEG: Key = Key::effect(EffectKind::Coulomb, "coulomb_neg");

/// The lab's side of `coulomb`.
pub struct Coulomb;

impl LabEffect for Coulomb {
    fn kind(&self) -> EffectKind {
        EffectKind::Coulomb
    }

    fn place(&self) -> u16 {
        20
    }

    fn load_terms(
        &self,
        cx: &Cx,
        dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let v = &cx.d.v;
        let scale = |k: usize| dry.map_or(1.0, |s| s[k]);
        // F = F_C+ (v > 0), -F_C- (v < 0)
        terms.push(
            Term::param(
                COULOMB_POS.resolve(cx.spec)?,
                (0..v.len())
                    .map(|k| {
                        let c = if v[k] > 0.0 { 1.0 } else { 0.0 };
                        c * scale(k)
                    })
                    .collect(),
            )
            .dry(Dry::Pos),
        );
        terms.push(
            Term::param(
                COULOMB_NEG.resolve(cx.spec)?,
                (0..v.len())
                    .map(|k| {
                        let c = if v[k] < 0.0 { -1.0 } else { 0.0 };
                        c * scale(k)
                    })
                    .collect(),
            )
            .dry(Dry::Neg),
        );
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the direction of motion",
            shown_by: "motion that goes on while the command reverses (a sine of the command near the loop's bandwidth)",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        let (p, _) = mean_where(r, idx, |k| d.v[k] > 0.0);
        let (m, _) = mean_where(r, idx, |k| d.v[k] < 0.0);
        format!(
            "residual steps with the sign of velocity: mean {p:+.3e} {} moving positive, \
             {m:+.3e} moving negative (step {:.1} residual RMS)",
            ev.unit,
            (p - m).abs() / ev.sd().max(f64::MIN_POSITIVE)
        )
    }
}
