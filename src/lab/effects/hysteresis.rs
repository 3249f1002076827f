//! `hysteresis` in the lab: a play of width `w` on the whole drive force, a column of its own,
//! the width searched on a grid scaled by the drive force; its signature is a residual that
//! follows the sign of the drive's change.

use super::{geometric, Cx, DriveForce, Evidence, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::regress::{fixed_term, Term};
use crate::lab::signals::{abs_quantile, zero_phase, Prepared};
use crate::physics::{CommandUnit, EffectKind, Family};

/// Width of the play.
const WIDTH: Key = Key::effect(EffectKind::Hysteresis, "width");

/// The lab's side of `hysteresis`.
pub struct Hysteresis;

impl LabEffect for Hysteresis {
    fn kind(&self) -> EffectKind {
        EffectKind::Hysteresis
    }

    fn place(&self) -> u16 {
        100
    }

    fn representable(&self, family: Family, _d: &Prepared) -> bool {
        matches!(family, Family::LinearAxis | Family::Solenoid)
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let (spec, raw) = (cx.spec, cx.raw);
        let umax = abs_quantile(&raw.input, 0.95).max(1e-12);
        // The drive force the play acts on.
        let scale = match spec.family {
            Family::Solenoid => {
                raw.current
                    .as_ref()
                    .map_or(umax * 0.1, |i| abs_quantile(i, 0.95))
                    * Key::family("force_constant_n_per_a").value(spec)?
            }
            Family::LinearAxis if spec.command == CommandUnit::Volt => {
                umax * Key::family("force_gain_n_per_v").value(spec)?
            }
            _ => umax,
        };
        Ok(vec![(
            WIDTH.name(spec)?,
            geometric(scale * 0.005, scale * 0.6, 12),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = WIDTH.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn drive_force_terms(
        &self,
        cx: &Cx,
        drive: &DriveForce,
        terms: &mut Vec<Term>,
    ) -> anyhow::Result<()> {
        let w = WIDTH.value(cx.spec)?;
        let (raw, d) = (cx.raw, cx.d);
        // Play on the unfiltered drive force, then filtered like every other column.
        let full: Vec<f64> = (0..d.y.len())
            .map(|k| drive.whole(k, raw.output[k]))
            .collect();
        let r = 0.5 * w;
        let mut z = full.first().copied().unwrap_or(0.0);
        // The play z = clamp(z, F - w/2, F + w/2); its column is what it takes off the force,
        // F - z.
        let diff: Vec<f64> = full
            .iter()
            .map(|&fk| {
                z = z.clamp(fk - r, fk + r);
                -(z - fk)
            })
            .collect();
        terms.push(fixed_term(
            "hysteresis play",
            zero_phase(&diff, d.cutoff_hz, d.dt),
        ));
        Ok(())
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the direction the drive force last changed",
            shown_by: "a command that rises and falls without changing sign (a sine about an offset)",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        let (r, idx) = (ev.r(), ev.idx());
        let drive = ev.drive();
        let du: Vec<f64> = idx
            .iter()
            .map(|&k| if k > 0 { drive[k] - drive[k - 1] } else { 0.0 })
            .collect();
        let mut s = (0.0, 0usize, 0.0, 0usize);
        for (i, x) in du.iter().enumerate() {
            if *x > 0.0 {
                s.0 += r[i];
                s.1 += 1;
            } else if *x < 0.0 {
                s.2 += r[i];
                s.3 += 1;
            }
        }
        format!(
            "residual follows the sign of the drive change: mean {:+.3e} {} while it rises, \
             {:+.3e} while it falls",
            s.0 / s.1.max(1) as f64,
            ev.unit,
            s.2 / s.3.max(1) as f64
        )
    }
}
