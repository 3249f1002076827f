//! `saturation` in the lab: the middle step of the power stage, `u' = min(max(u, u_min), u_max)`,
//! each limit searched on a grid of the command's quantiles; its signature is a drive that falls
//! short at large commands.

use super::{command_visible, mean_where, Cx, Evidence, Grid, LabEffect, Separation};
use crate::lab::data::Dataset;
use crate::lab::params::Key;
use crate::lab::signals::{abs_quantile, Prepared};
use crate::physics::{EffectKind, Family, PlantSpec};

const MAX: Key = Key::effect(EffectKind::Saturation, "max");
const MIN: Key = Key::effect(EffectKind::Saturation, "min");

/// The lab's side of `saturation`.
pub struct Saturation;

impl LabEffect for Saturation {
    fn kind(&self) -> EffectKind {
        EffectKind::Saturation
    }

    fn place(&self) -> u16 {
        90
    }

    fn representable(&self, family: Family, d: &Prepared) -> bool {
        command_visible(family, d)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let side = |sign: f64| -> Vec<f64> {
            let mut x: Vec<f64> = cx
                .raw
                .input
                .iter()
                .map(|u| u * sign)
                .filter(|u| *u > 0.0)
                .collect();
            if x.len() < 20 {
                return Vec::new();
            }
            x.sort_by(f64::total_cmp);
            [0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.94, 0.97, 0.99, 0.997]
                .iter()
                .map(|q| sign * x[((x.len() - 1) as f64 * q) as usize])
                .collect()
        };
        let mut out = Vec::new();
        for (key, sign) in [(MAX, 1.0), (MIN, -1.0)] {
            let g = side(sign);
            if !g.is_empty() {
                out.push((key.name(cx.spec)?, g));
            }
        }
        Ok(out)
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let (hi, lo) = (MAX.resolve(cx.spec)?, MIN.resolve(cx.spec)?);
        Ok(vec![(hi.name, hi.value), (lo.name, lo.value)])
    }

    fn start(&self, spec: &mut PlantSpec, raw: &Dataset) -> anyhow::Result<()> {
        // Free limits start outside the commands, so that searching one leaves the other idle.
        let (lo, hi) = raw
            .input
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), &u| (a.min(u), b.max(u)));
        for (key, v) in [(MIN, lo - 1.0), (MAX, hi + 1.0)] {
            let h = key.resolve(spec)?;
            if h.free {
                spec.set(&h.name, v)?;
            }
        }
        Ok(())
    }

    fn command_stage(&self) -> Option<u8> {
        Some(1)
    }

    fn shape_command(&self, spec: &PlantSpec, u: &mut Vec<f64>, _dt: f64) -> anyhow::Result<()> {
        let (lo, hi) = (MIN.value(spec)?, MAX.value(spec)?);
        for x in u {
            // u' = min(max(u, u_min), u_max)
            *x = x.max(lo).min(hi);
        }
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the command beyond a limit",
            shown_by: "commands both below and beyond the drive's limit",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx, input) = (ev.r(), ev.idx(), &ev.data.input);
        let q = abs_quantile(input, 0.9);
        let signed: Vec<f64> = ev
            .at(&|k| input[k].signum())
            .iter()
            .zip(r)
            .map(|(s, x)| s * x)
            .collect();
        let (hi, _) = mean_where(&signed, idx, |k| input[k].abs() > q);
        let (lo, _) = mean_where(&signed, idx, |k| input[k].abs() <= q);
        format!(
            "drive falls short at large commands: mean residual times sign(u) {hi:+.3e} {} where |u| is in its top 10 %, {lo:+.3e} elsewhere",
            ev.unit
        )
    }
}
