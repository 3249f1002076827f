//! The lab's side of the terms a model declares itself (`[[lab.term]]`): their columns in the
//! balance of forces and the grids of their nonlinear parameters. A parameter the force is linear
//! in is a coefficient of the regression (its column the force per unit of it); the others are
//! searched over their declared range like a catalogue effect's nonlinear parameters.

use super::data::Dataset;
use super::effects::geometric;
use super::regress::{fixed_term, Term};
use super::signals::{zero_phase, Prepared};
use crate::physics::term::{Signals, TermSpec};
use crate::physics::PlantSpec;

/// Points of the grid of a declared nonlinear parameter: the range is the user's, so it is
/// sampled finely (a period in position needs steps of a few per cent).
const GRID_POINTS: usize = 64;

/// The signals a term sees at sample `k` of the prepared record.
fn signals(d: &Prepared, raw: &Dataset, k: usize) -> Signals {
    Signals {
        y: d.y[k],
        v: d.v[k],
        u: d.u[k],
        supply: d.supply.as_ref().map_or(0.0, |s| s[k]),
        t: raw.time.get(k).copied().unwrap_or(0.0),
    }
}

/// The columns of the model's active terms, each written as the force it takes from the drive
/// (`-F`): per parameter the force is linear in, `-∂F/∂θ`; the rest of the force (those
/// parameters at 0) as a fixed column.
pub fn load_terms(
    spec: &PlantSpec,
    raw: &Dataset,
    d: &Prepared,
    terms: &mut Vec<Term>,
) -> anyhow::Result<()> {
    for t in spec.active_terms() {
        if t.uses("supply") && d.supply.is_none() {
            anyhow::bail!(
                "{}: term '{}' uses the supply, which the record does not hold",
                raw.origin,
                t.name
            );
        }
        let mut zeroed: Vec<f64> = t.params.iter().map(|p| p.value).collect();
        for (z, &lin) in zeroed.iter_mut().zip(&t.linear) {
            if lin {
                *z = 0.0;
            }
        }
        let n = d.y.len();
        let column = |values: &[f64], minus: Option<&[f64]>| -> anyhow::Result<Vec<f64>> {
            (0..n)
                .map(|k| {
                    let f = t.force_with(&signals(d, raw, k), values);
                    let c = -(f - minus.map_or(0.0, |m| -m[k]));
                    if c.is_finite() {
                        Ok(c)
                    } else {
                        Err(anyhow::anyhow!(
                            "{}: term '{}': \"{}\" is not a number at sample {k} (t = {} s)",
                            raw.origin,
                            t.name,
                            t.force,
                            raw.time.get(k).copied().unwrap_or(f64::NAN)
                        ))
                    }
                })
                .collect()
        };
        // The force changes as fast as the motion carries the body through it (a pitch passed
        // at speed): filtered like the acceleration it balances, or its fast part would be
        // asked of the filtered acceleration, which no longer has it.
        let filtered = |c: Vec<f64>| zero_phase(&c, d.cutoff_hz, d.dt);
        let rest = column(&zeroed, None)?;
        for (j, p) in t.params.iter().enumerate() {
            if !t.linear[j] {
                continue;
            }
            let mut unit = zeroed.clone();
            unit[j] = 1.0;
            let col = filtered(column(&unit, Some(&rest))?);
            let name = format!("{}.{}", t.name, p.key);
            terms.push(Term::param(super::params::by_name(spec, &name)?, col));
        }
        if rest.iter().any(|&r| r != 0.0) {
            terms.push(fixed_term(&format!("{}.rest", t.name), filtered(rest)));
        }
    }
    Ok(())
}

/// The nonlinear parameters of the model's active terms and their values.
pub fn nonlinear(spec: &PlantSpec) -> Vec<(String, f64)> {
    spec.active_terms()
        .flat_map(|t| {
            t.params
                .iter()
                .zip(&t.linear)
                .filter(|(_, &lin)| !lin)
                .map(|(p, _)| (format!("{}.{}", t.name, p.key), p.value))
        })
        .collect()
}

/// Grids of the nonlinear parameters of the active terms over their declared ranges: geometric
/// where the range is positive and spans a decade or more, even otherwise.
pub fn grids(spec: &PlantSpec) -> Vec<(String, Vec<f64>)> {
    spec.active_terms()
        .flat_map(|t: &TermSpec| {
            t.params
                .iter()
                .zip(&t.linear)
                .filter(|(_, &lin)| !lin)
                .map(|(p, _)| {
                    let (lo, hi) = (p.def.min, p.def.max);
                    let values = if lo > 0.0 && hi / lo >= 10.0 {
                        geometric(lo, hi, GRID_POINTS)
                    } else {
                        (0..GRID_POINTS)
                            .map(|i| lo + (hi - lo) * i as f64 / (GRID_POINTS - 1) as f64)
                            .collect()
                    };
                    (format!("{}.{}", t.name, p.key), values)
                })
                .collect::<Vec<_>>()
        })
        .collect()
}
