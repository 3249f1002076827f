//! `backlash` in the lab: the play of `motor_gear`'s contact, part of the transmitted torque
//! ([`crate::lab::regress_gear`]), searched on a grid; its signature is a residual that bursts
//! after the drive reverses.

use super::{geometric, Cx, Evidence, Gear, Grid, LabEffect, Separation};
use crate::lab::params::Key;
use crate::lab::signals::{abs_quantile, Prepared};
use crate::physics::{EffectKind, Family, PlantSpec};

const GAP: Key = Key::effect(EffectKind::Backlash, "gap");

/// The lab's side of `backlash`.
pub struct Backlash;

impl LabEffect for Backlash {
    fn kind(&self) -> EffectKind {
        EffectKind::Backlash
    }

    fn place(&self) -> u16 {
        40
    }

    fn representable(&self, family: Family, _d: &Prepared) -> bool {
        family == Family::MotorGear
    }

    fn grid(&self, cx: &Cx) -> anyhow::Result<Vec<Grid>> {
        let span = 2.0 * abs_quantile(&cx.d.y, 0.95).max(1e-12);
        Ok(vec![(
            GAP.name(cx.spec)?,
            geometric(span * 2e-4, span * 0.05, 14),
        )])
    }

    fn nonlinear(&self, cx: &Cx) -> anyhow::Result<Vec<(String, f64)>> {
        let h = GAP.resolve(cx.spec)?;
        Ok(vec![(h.name, h.value)])
    }

    fn gear(&self, spec: &PlantSpec, gear: &mut Gear) -> anyhow::Result<()> {
        let b = 0.5 * GAP.value(spec)?;
        let (kg, cg) = (gear.stiffness, gear.damping);
        // Bao et al. eq. 1-2: a dead zone of half width b, the contact one-sided (it pushes, it
        // never pulls).
        gear.contact = Box::new(move |twist, rate| {
            if twist >= b {
                (kg * (twist - b) + cg * rate).max(0.0)
            } else if twist <= -b {
                (kg * (twist + b) + cg * rate).min(0.0)
            } else {
                0.0
            }
        });
        Ok(())
    }

    /// A play shows only where the transmitted torque reverses, and where the load is held there
    /// (a closed loop with stiction), the balance hardly depends on it; a wider play then wins by
    /// the noise of the drive side's run across it (on the README's heavy fork lever, 27.7 mrad
    /// against the plant's 5 by 1.3 % of the residual).
    fn prefers_smallest(&self) -> bool {
        true
    }

    fn separated_by(&self) -> Separation {
        Separation {
            follows: "the drive's direction of travel since it last reversed",
            shown_by: "reversals of the motion at more than one speed, the load-side position recorded",
        }
    }

    fn evidence(&self, ev: &Evidence) -> String {
        // Reversals of the drive signal; the play decouples the load just after them.
        let (r, idx, d) = (ev.r(), ev.idx(), ev.d);
        let drive = ev.drive();
        let window = (0.05 / d.dt).ceil() as usize;
        let mut since = vec![usize::MAX; drive.len()];
        let mut last: Option<usize> = None;
        for k in 1..drive.len() {
            if drive[k].signum() != drive[k - 1].signum() {
                last = Some(k);
            }
            if let Some(l) = last {
                since[k] = k - l;
            }
        }
        let rms = |sel: &dyn Fn(usize) -> bool| {
            let (s, m) = idx
                .iter()
                .enumerate()
                .filter(|(_, &k)| sel(k))
                .fold((0.0, 0usize), |(s, m), (i, _)| (s + r[i] * r[i], m + 1));
            (s / m.max(1) as f64).sqrt()
        };
        format!(
            "residual bursts after drive reversals: RMS {:.3e} {} within 50 ms after one, {:.3e} elsewhere",
            rms(&|k| since[k] < window),
            ev.unit,
            rms(&|k| since[k] >= window)
        )
    }
}
