//! `varying_ratio` in the lab: the gear ratio `h_0 / cos θ` of `motor_gear`, part of the
//! transmitted torque ([`crate::lab::regress_gear`]), its angle limit searched on a grid; its
//! signature is a drive gain that grows with the load angle.

use super::{corr, Cx, Evidence, Grid, LabEffect};
use crate::lab::params::Key;
use crate::lab::signals::{abs_quantile, Prepared};
use crate::physics::{EffectKind, Family};

const MAX_ANGLE: Key = Key::effect(EffectKind::VaryingRatio, "max_angle");

/// The lab's side of `varying_ratio`.
pub struct VaryingRatio;

impl LabEffect for VaryingRatio {
    fn kind(&self) -> EffectKind {
        EffectKind::VaryingRatio
    }

    fn place(&self) -> u16 {
        50
    }

    fn representable(&self, family: Family, _d: &Prepared) -> bool {
        family == Family::MotorGear
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        // Limits below the largest angle clip 1/cos θ; 1.5 rad leaves it unclipped.
        let mut g: Vec<f64> = [0.5, 0.75, 0.9, 0.97]
            .iter()
            .map(|&q| abs_quantile(&cx.d.y, q).min(1.5))
            .collect();
        g.push(1.5);
        Ok(vec![(MAX_ANGLE.name(cx.spec)?, g)])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = MAX_ANGLE.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (d, drive) = (ev.d, ev.drive());
        format!(
            "drive gain grows with the load angle: correlation of the residual with (1/cos θ - 1)·D {:+.2}",
            corr(ev.r(), &ev.at(&|k| (1.0 / d.y[k].cos() - 1.0) * drive[k]))
        )
    }
}
