//! `direction_asymmetry` in the lab: the drive gain of negative motion relative to positive, a
//! gain per direction of the drive force (its negative side a column of its own); its signature
//! is a residual that follows the command differently in each direction.

use super::{corr, DirectionGain, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

/// Drive gain on positive motion (the reference).
const GAIN_POS: Key = Key::effect(EffectKind::DirectionAsymmetry, "gain_pos");
/// Drive gain on negative motion (fitted).
const GAIN_NEG: Key = Key::effect(EffectKind::DirectionAsymmetry, "gain_neg");

/// The lab's side of `direction_asymmetry`.
pub struct DirectionAsymmetry;

impl LabEffect for DirectionAsymmetry {
    fn kind(&self) -> EffectKind {
        EffectKind::DirectionAsymmetry
    }

    fn place(&self) -> u16 {
        150
    }

    fn representable(&self, family: Family, _d: &Prepared) -> bool {
        family == Family::LinearAxis
    }

    fn direction_gain(&self, spec: &PlantSpec) -> anyhow::Result<Option<DirectionGain>> {
        Ok(Some(DirectionGain {
            pos: GAIN_POS.value(spec)?,
            neg: GAIN_NEG.resolve(spec)?,
        }))
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the drive's gain per direction of motion",
            shown_by: "equal commands in both directions at more than one size",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        let side = |sel: &dyn Fn(f64) -> bool| {
            corr(
                &idx.iter()
                    .enumerate()
                    .filter(|(_, &k)| sel(d.v[k]))
                    .map(|(i, _)| r[i])
                    .collect::<Vec<_>>(),
                &idx.iter()
                    .filter(|&&k| sel(d.v[k]))
                    .map(|&k| d.u[k])
                    .collect::<Vec<_>>(),
            )
        };
        let neg = side(&|v| v < 0.0);
        let pos = side(&|v| v > 0.0);
        format!(
            "drive gain differs by direction: correlation of residual with the command \
             {pos:+.2} moving positive, {neg:+.2} moving negative"
        )
    }
}
