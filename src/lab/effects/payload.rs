//! `payload` in the lab: the column `clamp(y / y_full, -1, 1)` with the full-scale position
//! searched on a grid; its signature is a residual that bends with position.

use super::{corr, geometric, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::Term;
use crate::lab::signals::abs_quantile;
use crate::physics::EffectKind;

const MAX_LOAD: Key = Key::effect(EffectKind::Payload, "max_load");
const FULL_SCALE: Key = Key::effect(EffectKind::Payload, "full_scale");

/// The lab's side of `payload`.
pub struct Payload;

impl LabEffect for Payload {
    fn kind(&self) -> EffectKind {
        EffectKind::Payload
    }

    fn place(&self) -> u16 {
        160
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        // The clamp must act inside the record, or the payload is a spring.
        let ymax = abs_quantile(&cx.d.y, 0.98).max(1e-12);
        Ok(vec![(
            FULL_SCALE.name(cx.spec)?,
            geometric(ymax * 0.1, ymax * 0.9, 12),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = FULL_SCALE.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn load_terms(
        &self,
        cx: &Cx,
        _dry: Option<&[f64]>,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let full = FULL_SCALE.value(cx.spec)?;
        // F = F_max clamp(y / y_full, -1, 1)
        terms.push(Term::param(
            MAX_LOAD.resolve(cx.spec)?,
            cx.d.y.iter().map(|y| (y / full).clamp(-1.0, 1.0)).collect(),
        ));
        Ok(())
    }

    fn reproduces(&self) -> &'static [EffectKind] {
        // Saturated over the whole travel it is a constant force.
        &[EffectKind::Offset]
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "position over the travel",
            shown_by: "the same motion about several positions across the travel",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        // A load that saturates: the position slope of the residual differs inside and out.
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        let ys = ev.at(&|k| d.y[k].abs());
        let mid = abs_quantile(&ys, 0.5);
        let part = |inner: bool| {
            let (rr, yy): (Vec<f64>, Vec<f64>) = idx
                .iter()
                .enumerate()
                .filter(|(_, &k)| (d.y[k].abs() < mid) == inner)
                .map(|(i, &k)| (r[i], d.y[k]))
                .unzip();
            corr(&rr, &yy)
        };
        format!(
            "residual bends with position: correlation with y {:+.2} for |y| below its median, {:+.2} above",
            part(true),
            part(false)
        )
    }
}
