//! `dead_time` in the lab: the first step of the power stage, the command shifted by whole
//! samples, the delay searched on a grid of sample periods; its signature is a residual that
//! follows the command's rate.

use super::{command_visible, corr, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::signals::Prepared;
use crate::physics::{EffectKind, Family, PlantSpec};

const DELAY: Key = Key::effect(EffectKind::DeadTime, "delay");

/// The lab's side of `dead_time`.
pub struct DeadTime;

impl LabEffect for DeadTime {
    fn kind(&self) -> EffectKind {
        EffectKind::DeadTime
    }

    fn place(&self) -> u16 {
        70
    }

    fn representable(&self, family: Family, d: &Prepared) -> bool {
        command_visible(family, d)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        Ok(vec![(
            DELAY.name(cx.spec)?,
            (1..=12).map(|i| i as f64 * cx.d.dt).collect(),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = DELAY.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn command_stage(&self) -> Option<u8> {
        Some(0)
    }

    fn shape_command(&self, spec: &PlantSpec, u: &mut Vec<f64>, dt: f64) -> anyhow::Result<()> {
        // u'(k) = u(k - T_t / T_0), the first sample held before the record starts
        let shift = (DELAY.value(spec)? / dt).round() as usize;
        if shift > 0 && !u.is_empty() {
            let first = u[0];
            let mut shifted = vec![first; shift.min(u.len())];
            shifted.extend_from_slice(&u[..u.len().saturating_sub(shift)]);
            *u = shifted;
        }
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the command's past",
            shown_by: "fast command changes against the response (steps or a chirp)",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let u = &ev.d.u;
        format!(
            "residual follows the command's rate: correlation with du/dt {:+.2}",
            corr(
                ev.r(),
                &ev.at(&|k| if k > 0 { u[k] - u[k - 1] } else { 0.0 })
            )
        )
    }
}
