//! `offset` in the lab: a constant column, `-F_b`; its signature is a residual with a constant
//! part.

use super::{mean_where, Cx, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::Term;
use crate::physics::EffectKind;

const BIAS: Key = Key::effect(EffectKind::Offset, "bias");

/// The lab's side of `offset`.
pub struct Offset;

impl LabEffect for Offset {
    fn kind(&self) -> EffectKind {
        EffectKind::Offset
    }

    fn place(&self) -> u16 {
        170
    }

    fn load_terms(
        &self,
        cx: &Cx,
        _dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        // F = -F_b
        terms.push(Term::param(
            BIAS.resolve(cx.spec)?,
            vec![-1.0; cx.d.y.len()],
        ));
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "nothing that moves (a constant force)",
            shown_by: "motion in both directions about more than one position",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (m, _) = mean_where(ev.r(), ev.idx(), |_| true);
        format!(
            "residual has a constant part: mean {m:+.3e} {} ({:.1} residual RMS)",
            ev.unit,
            m.abs() / ev.sd().max(f64::MIN_POSITIVE)
        )
    }
}
