//! `deadzone` in the lab: the last step of the power stage, `u' = u ∓ u_0` outside `±u_0` and 0
//! inside, the threshold searched on a grid; its signature is a residual that follows the sign
//! of the command.

use super::{command_visible, corr, geometric, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::signals::{abs_quantile, Prepared};
use crate::physics::{EffectKind, Family, PlantSpec};

const THRESHOLD: Key = Key::effect(EffectKind::Deadzone, "threshold");

/// The lab's side of `deadzone`.
pub struct Deadzone;

impl LabEffect for Deadzone {
    fn kind(&self) -> EffectKind {
        EffectKind::Deadzone
    }

    fn place(&self) -> u16 {
        80
    }

    fn representable(&self, family: Family, d: &Prepared) -> bool {
        command_visible(family, d)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let umax = abs_quantile(&cx.raw.input, 0.95).max(1e-12);
        Ok(vec![(
            THRESHOLD.name(cx.spec)?,
            geometric(umax * 0.003, umax * 0.4, 12),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = THRESHOLD.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn command_stage(&self) -> Option<u8> {
        Some(2)
    }

    fn shape_command(&self, spec: &PlantSpec, u: &mut Vec<f64>, _dt: f64) -> anyhow::Result<()> {
        let u0 = THRESHOLD.value(spec)?;
        for x in u {
            // u' = u - u_0 (u > u_0), u + u_0 (u < -u_0), 0 between
            *x = if *x > u0 {
                *x - u0
            } else if *x < -u0 {
                *x + u0
            } else {
                0.0
            };
        }
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the command's size",
            shown_by: "small commands of either sign held until the motion settles, and commands that cross zero while the body still moves",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        format!(
            "residual follows the sign of the command: correlation with sign(u) {:+.2}",
            corr(ev.r(), &ev.at(&|k| ev.data.input[k].signum()))
        )
    }
}
