//! `stiction` in the lab: no column of its own; at rest the friction the balance demands must lie
//! inside the breakaway band, and free breakaway levels are set to the largest holding force
//! seen at rest. Its signature is a body held at rest beyond the sliding friction.

use super::{Breakaway, Evidence, LabEffect, Separation};
use crate::lab::params::Key;
use crate::physics::{EffectKind, PlantSpec};

const BREAKAWAY_POS: Key = Key::effect(EffectKind::Stiction, "breakaway_pos");
const BREAKAWAY_NEG: Key = Key::effect(EffectKind::Stiction, "breakaway_neg");

/// The lab's side of `stiction`.
pub struct Stiction;

impl LabEffect for Stiction {
    fn kind(&self) -> EffectKind {
        EffectKind::Stiction
    }

    fn place(&self) -> u16 {
        30
    }

    fn breakaway(&self, spec: &PlantSpec) -> anyhow::Result<Option<Breakaway>> {
        Ok(Some(Breakaway {
            pos: BREAKAWAY_POS.resolve(spec)?,
            neg: BREAKAWAY_NEG.resolve(spec)?,
        }))
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "rest against motion",
            shown_by: "starts from rest under slowly rising commands",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let base = ev.base;
        let held = base
            .standstill_residual
            .iter()
            .filter(|x| **x != 0.0)
            .count();
        let (up, down) = base
            .standstill_residual
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), &x| (a.max(x), b.max(-x)));
        format!(
            "held at rest beyond the sliding friction: {held} of {} samples at rest need more, up to {up:.3e} {} positive and {down:.3e} negative over the band [-{:.3e}, {:.3e}]",
            base.standstill.len(),
            ev.unit,
            base.band.1,
            base.band.0
        )
    }
}
