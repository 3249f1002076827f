//! `position_stiffness` in the lab: the drive's gain `c_0 + c_1 g + c_2 g²`, `g = Y_0 - y`, with
//! `c_0` held in the drive's reference and columns for `c_1` and `c_2` on the drive force; its
//! signature is a residual structured by position times drive.

use super::{corr, Cx, DriveForce, Evidence, LabEffect, PositionGain, Separation};
use crate::lab::params::Key;
use crate::lab::regress::Term;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

/// `Y_0`, the reference position.
const POLE: Key = Key::effect(EffectKind::PositionStiffness, "pole");
/// The constant term (held).
const C0: Key = Key::effect(EffectKind::PositionStiffness, "c0");
/// The linear term (fitted).
const C1: Key = Key::effect(EffectKind::PositionStiffness, "c1");
/// The quadratic term (fitted).
const C2: Key = Key::effect(EffectKind::PositionStiffness, "c2");

/// The lab's side of `position_stiffness`.
pub struct PositionStiffness;

impl LabEffect for PositionStiffness {
    fn kind(&self) -> EffectKind {
        EffectKind::PositionStiffness
    }

    fn place(&self) -> u16 {
        140
    }

    fn representable(&self, family: Family, _d: &Prepared) -> bool {
        matches!(family, Family::LinearAxis | Family::Solenoid)
    }

    fn position_gain(&self, spec: &PlantSpec) -> anyhow::Result<Option<PositionGain>> {
        let (y0, c0, c1, c2) = (
            POLE.value(spec)?,
            C0.value(spec)?,
            C1.value(spec)?,
            C2.value(spec)?,
        );
        // The gain c_0 + c_1 g + c_2 g² at g = Y_0 - y, never below zero.
        let at = move |y: f64| {
            let e = y0 - y;
            (c0 + e * (c1 + e * c2)).max(0.0)
        };
        Ok(Some(PositionGain {
            held: c0,
            at: Box::new(at),
        }))
    }

    fn drive_gain_terms(
        &self,
        cx: &Cx,
        drive: &DriveForce,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let (spec, y) = (cx.spec, &cx.d.y);
        let y0 = POLE.value(spec)?;
        let n = y.len();
        // The columns of c_1 and c_2: the drive force K D K± times g and g², g = Y_0 - y.
        terms.push(Term::param(
            C1.resolve(spec)?,
            (0..n)
                .map(|k| -drive.gain * drive.signal[k] * drive.direction[k] * (y0 - y[k]))
                .collect(),
        ));
        terms.push(Term::param(
            C2.resolve(spec)?,
            (0..n)
                .map(|k| -drive.gain * drive.signal[k] * drive.direction[k] * (y0 - y[k]).powi(2))
                .collect(),
        ));
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "position times the drive force",
            shown_by: "the same commands about several positions",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (d, drive) = (ev.d, ev.drive());
        format!(
            "residual structured by position times drive: correlation with y·D {:+.2}, with y \
             {:+.2}",
            corr(ev.r(), &ev.at(&|k| d.y[k] * drive[k])),
            corr(ev.r(), &ev.at(&|k| d.y[k]))
        )
    }
}
