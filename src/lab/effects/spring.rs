//! `spring` in the lab: columns `c y` and `F_0`; its signature is a residual structured by
//! position.

use super::{corr, Cx, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::Term;
use crate::physics::EffectKind;

const STIFFNESS: Key = Key::effect(EffectKind::Spring, "stiffness");
const PRETENSION: Key = Key::effect(EffectKind::Spring, "pretension");

/// The lab's side of `spring`.
pub struct Spring;

impl LabEffect for Spring {
    fn kind(&self) -> EffectKind {
        EffectKind::Spring
    }

    fn place(&self) -> u16 {
        130
    }

    fn load_terms(
        &self,
        cx: &Cx,
        _dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        // F = F_0 + c y
        terms.push(Term::param(STIFFNESS.resolve(cx.spec)?, cx.d.y.clone()));
        terms.push(Term::param(
            PRETENSION.resolve(cx.spec)?,
            vec![1.0; cx.d.y.len()],
        ));
        Ok(())
    }

    fn reproduces(&self) -> &'static [EffectKind] {
        &[EffectKind::Offset]
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "position",
            shown_by: "the same motion about several positions",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        format!(
            "residual structured by position: correlation with y {:+.2}",
            corr(ev.r(), &ev.at(&|k| ev.d.y[k]))
        )
    }
}
