//! `varying_ratio` in the lab: the gear ratio `h_0 / cos θ` of `motor_gear`, part of the
//! transmitted torque ([`crate::lab::regress_gear`]), its angle limit searched on a grid; its
//! signature is a drive gain that grows with the load angle.

use super::{corr, Cx, Evidence, Gear, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::signals::{abs_quantile, Prepared};
use crate::physics::{EffectKind, Family, PlantSpec};

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

    fn gear(&self, spec: &PlantSpec, gear: &mut Gear) -> anyhow::Result<()> {
        let m = MAX_ANGLE.value(spec)?;
        let h0 = gear.nominal_ratio;
        gear.ratio = Box::new(move |th, w| {
            if th.abs() < m {
                let c = th.cos();
                // h = h_0 / cos θ, dh/dt = h_0 sin θ / cos² θ · θ'
                (h0 / c, h0 * th.sin() / (c * c) * w)
            } else {
                // Beyond the limit the ratio stays at its value there.
                (h0 / m.cos(), 0.0)
            }
        });
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the load angle",
            shown_by: "the same commands across the angle range",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (d, drive) = (ev.d, ev.drive());
        format!(
            "drive gain grows with the load angle: correlation of the residual with (1/cos θ - 1)·D {:+.2}",
            corr(ev.r(), &ev.at(&|k| (1.0 / d.y[k].cos() - 1.0) * drive[k]))
        )
    }
}
