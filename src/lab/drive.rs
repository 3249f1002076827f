//! The drive from the data: the constants of a family's drive that the records determine, with
//! 95 % intervals, and the declared ones they contradict.
//!
//! - `solenoid` without a recorded current: the coil's time constant `T_I` (the lag from the
//!   voltage to the force), by the profile of the balance's residual over `T_I` with every other
//!   free parameter refitted at each point. The static gain `K_I K_Mag` scales the drive as the
//!   mass does, so only their ratio is determined (the fitted mass carries it).
//! - `pneumatic`: the chamber's lag `τ` and the valve speeds per direction `K_I1`, `K_I2`, from the
//!   balance with the declared mass as the scale of the forces (see `regress`: without viscous
//!   damping in the model the compliance is the balance's reference and the speeds come out
//!   directly).
//!
//! Other families' drives are the scale reference of the balance itself (a force command, a
//! measured current): nothing to identify there.

use serde::Serialize;

use super::data::Dataset;
use super::regress::{
    balance, fit_spec, COIL_TIME_CONSTANT, PNEUMATIC_COMPLIANCE, PNEUMATIC_COUPLING,
};
use super::signals::Prepared;
use crate::ident::stats::CHI2_1_95;
use crate::physics::{Family, PlantSpec};

/// One drive constant as the data determine it.
#[derive(Debug, Clone, Serialize)]
pub struct DriveConstant {
    /// Qualified parameter name.
    pub name: String,
    /// What it means, for messages ("coil time constant").
    pub label: String,
    /// Unit as printed, and the factor from SI to it.
    pub unit: String,
    #[serde(skip)]
    pub scale: f64,
    /// The model's value (declared, or the family default when not declared).
    pub declared: f64,
    /// True when the model declares it (`[lab] fixed`).
    pub is_declared: bool,
    /// The value the data give, and its 95 % interval.
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

impl DriveConstant {
    /// True when a declared value lies outside the interval the data give (with a 5 % margin:
    /// a model need not be better than its data sheet).
    pub fn contradicted(&self) -> bool {
        self.is_declared
            && (self.declared < self.low.min(self.value * 0.95)
                || self.declared > self.high.max(self.value * 1.05))
    }

    /// "coil time constant 8.6 ms declared, the data say 5.1 ± 0.2 ms".
    pub fn sentence(&self) -> String {
        let s = self.scale;
        let half = 0.5 * (self.high - self.low) * s;
        format!(
            "{} {:.3} {u} {}, the data say {:.3} ± {half:.2} {u}",
            self.label,
            self.declared * s,
            if self.is_declared {
                "declared"
            } else {
                "by default"
            },
            self.value * s,
            u = self.unit
        )
    }
}

fn free(spec: &PlantSpec, name: &str) -> bool {
    spec.params().iter().any(|(n, p)| n == name && p.free)
}

/// The drive constants the data determine for `spec` (empty where the drive is the reference).
pub fn identify(
    spec: &PlantSpec,
    raw: &Dataset,
    d: &Prepared,
) -> anyhow::Result<Vec<DriveConstant>> {
    match spec.family {
        Family::Solenoid if raw.current.is_none() => coil(spec, raw, d),
        Family::Pneumatic => valves(spec, raw, d),
        _ => Ok(Vec::new()),
    }
}

/// Profile of the residual over the coil's time constant.
fn coil(spec: &PlantSpec, raw: &Dataset, d: &Prepared) -> anyhow::Result<Vec<DriveConstant>> {
    let declared = spec.get(COIL_TIME_CONSTANT).unwrap_or(0.0);
    let is_declared = !free(spec, COIL_TIME_CONSTANT);
    let mut s = spec.clone();
    s.set_free(COIL_TIME_CONSTANT, true)?;
    let (best, fit) = fit_spec(&s, raw, d, None)?;
    let t0 = best.get(COIL_TIME_CONSTANT).unwrap_or(declared);
    // Residual at T_I with the others refitted (nonlinear ones kept as found).
    let mut fixed = best.clone();
    fixed.set_free(COIL_TIME_CONSTANT, false)?;
    let rss_at = |t: f64| -> anyhow::Result<f64> {
        let mut x = fixed.clone();
        x.set(COIL_TIME_CONSTANT, t)?;
        Ok(balance(&x, raw, d)?.fit(None, 0, d.n_eff_per_sample).rss)
    };
    let rss0 = rss_at(t0)?.min(fit.rss);
    // 95 % profile interval: RSS(T_I) ≤ RSS_min (1 + χ²₁(0.95) / N_eff).
    let n_eff = (fit.weighted_samples * d.n_eff_per_sample).max(10.0);
    let limit = rss0 * (1.0 + CHI2_1_95 / n_eff);
    let edge = |dir: f64| -> anyhow::Result<f64> {
        let (mut inside, mut step) = (t0, 0.02);
        for _ in 0..60 {
            let t = inside * (1.0 + dir * step);
            if t <= 0.0 {
                break;
            }
            if rss_at(t)? <= limit {
                inside = t;
                step *= 1.5;
            } else if step < 1e-3 {
                break;
            } else {
                step *= 0.5;
            }
        }
        Ok(inside)
    };
    let (low, high) = (edge(-0.5)?, edge(1.0)?);
    Ok(vec![DriveConstant {
        name: COIL_TIME_CONSTANT.into(),
        label: "coil time constant".into(),
        unit: "ms".into(),
        scale: 1e3,
        declared,
        is_declared,
        value: t0,
        low,
        high,
    }])
}

/// The chamber's lag and the valve speeds from the balance with the mass as the reference.
fn valves(spec: &PlantSpec, raw: &Dataset, d: &Prepared) -> anyhow::Result<Vec<DriveConstant>> {
    let names = [
        (
            "pneumatic.velocity_time_constant_s",
            "chamber lag",
            "ms",
            1e3,
        ),
        (
            "pneumatic.gain_down_m_per_s",
            "valve speed down (K_I1)",
            "mm/s",
            1e3,
        ),
        (
            "pneumatic.gain_up_m_per_s",
            "valve speed up (K_I2)",
            "mm/s",
            1e3,
        ),
    ];
    let mut s = spec.clone();
    for (n, ..) in names {
        s.set_free(n, true)?;
    }
    s.set_free("pneumatic.mass_kg", false)?;
    let (fitted, _) = fit_spec(&s, raw, d, None)?;
    // Intervals: the balance at the fitted values, refitted once more for its intervals.
    let bal = balance(&fitted, raw, d)?;
    let fit = bal.fit(None, 0, d.n_eff_per_sample);
    let rel = |name: &str| -> f64 {
        fit.names
            .iter()
            .position(|n| n == name)
            .and_then(|j| fit.intervals[j].map(|(lo, hi)| (hi - lo, fit.values[j])))
            .map_or(f64::NAN, |(w, v)| 0.5 * w / v.abs().max(f64::MIN_POSITIVE))
    };
    // The coupling's relative error: fitted as such with the mass as the reference, or carried
    // by the mass's coefficient with the compliance as the reference (see `regress`), where the
    // valve speeds come out directly.
    let on_compliance = fit.names.iter().any(|n| n == PNEUMATIC_COMPLIANCE);
    let r_coupling = if on_compliance {
        rel("pneumatic.mass_kg")
    } else {
        rel(PNEUMATIC_COUPLING)
    };
    Ok(names
        .iter()
        // The lag is not determined where viscous damping takes the same column (the fit kept
        // the coupling as declared).
        .filter(|(name, ..)| !name.ends_with("time_constant_s") || r_coupling.is_finite())
        .map(|&(name, label, unit, scale)| {
            let value = fitted.get(name).unwrap_or(f64::NAN);
            // K = coefficient / r and τ = τ_decl / r: relative errors add in quadrature.
            let r = if name.ends_with("time_constant_s") {
                r_coupling
            } else if on_compliance {
                rel(name)
            } else {
                (rel(name).powi(2) + r_coupling.powi(2)).sqrt()
            };
            let r = if r.is_finite() { r } else { 0.0 };
            DriveConstant {
                name: name.into(),
                label: label.into(),
                unit: unit.into(),
                scale,
                declared: spec.get(name).unwrap_or(f64::NAN),
                is_declared: !free(spec, name),
                value,
                low: value * (1.0 - r),
                high: value * (1.0 + r),
            }
        })
        .collect())
}
