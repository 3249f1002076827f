//! `viscous` in the lab: a column per direction, `d± v`; its signature is a residual that grows
//! with velocity.

use super::{corr, Cx, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::Term;
use crate::physics::EffectKind;

const DAMPING_POS: Key = Key::effect(EffectKind::Viscous, "damping_pos");
const DAMPING_NEG: Key = Key::effect(EffectKind::Viscous, "damping_neg");

/// The lab's side of `viscous`.
pub struct Viscous;

impl LabEffect for Viscous {
    fn kind(&self) -> EffectKind {
        EffectKind::Viscous
    }

    fn place(&self) -> u16 {
        10
    }

    fn load_terms(
        &self,
        cx: &Cx,
        _dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let v = &cx.d.v;
        // F = d+ v (v > 0), d- v (v < 0)
        terms.push(Term::param(
            DAMPING_POS.resolve(cx.spec)?,
            v.iter().map(|&v| if v > 0.0 { v } else { 0.0 }).collect(),
        ));
        terms.push(Term::param(
            DAMPING_NEG.resolve(cx.spec)?,
            v.iter().map(|&v| if v < 0.0 { v } else { 0.0 }).collect(),
        ));
        Ok(())
    }

    fn spans_speed(&self) -> bool {
        true
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "speed",
            shown_by: "motion at several speeds in both directions",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        format!(
            "residual grows with velocity: correlation with v {:+.2}",
            corr(ev.r(), &ev.at(&|k| ev.d.v[k]))
        )
    }
}
