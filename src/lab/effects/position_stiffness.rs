//! `position_stiffness` in the lab: the drive's gain `c_0 + c_1 g + c_2 g²`, `g = Y_0 - y`, with
//! columns for `c_1` and `c_2` on the drive force (built with the drive in `regress.rs`); its
//! signature is a residual structured by position times drive.

use super::{corr, Evidence, LabEffect};
use crate::lab::params::Key;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family};

/// `Y_0`, the reference position.
pub const POLE: Key = Key::effect(EffectKind::PositionStiffness, "pole");
/// The constant term (held).
pub const C0: Key = Key::effect(EffectKind::PositionStiffness, "c0");
/// The linear term (fitted).
pub const C1: Key = Key::effect(EffectKind::PositionStiffness, "c1");
/// The quadratic term (fitted).
pub const C2: Key = Key::effect(EffectKind::PositionStiffness, "c2");

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
