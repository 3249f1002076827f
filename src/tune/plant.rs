//! The linear model per direction that the design needs, read from a fitted model, and the
//! corners of its parameters' intervals.

use super::design::ContinuousPlant;
use super::fitted::Fitted;
use crate::physics::Family;

/// Direction of motion: positive (pulling in, extending) or negative.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Positive,
    Negative,
}

impl Direction {
    pub fn name(self) -> &'static str {
        match self {
            Direction::Positive => "positive",
            Direction::Negative => "negative",
        }
    }
}

/// One identified parameter the design uses: where it comes from and its value.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Qualified parameter name of the model file, or a product of them.
    pub names: Vec<&'static str>,
    pub value: f64,
}

/// The axis as the design sees it: `m y'' + d± y' + c y = K± u` behind an optional lag, with the
/// dry friction and the pretension beside it. Forces in N, or per command unit where the lab's
/// balance takes the command as the force (`linear_axis`).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    pub family: Family,
    pub mass: f64,
    pub damping: [f64; 2],
    pub stiffness: f64,
    /// Force per command unit, per direction.
    pub gain: [f64; 2],
    /// Drive lag (the solenoid's coil), s.
    pub lag_s: Option<f64>,
    pub coulomb: Option<[f64; 2]>,
    pub pretension: f64,
    /// Exponent of the supply's effect on the drive, when the model has it.
    pub supply_exponent: Option<f64>,
    /// Nominal supply of the model (V).
    pub supply_nominal: Option<f64>,
}

/// Parameters whose intervals move the linear design, per family.
pub fn design_parameters(family: Family) -> &'static [&'static str] {
    match family {
        Family::Solenoid => &[
            "solenoid.mass_kg",
            "solenoid.current_time_constant_s",
            "solenoid.current_gain_a_per_v",
            "solenoid.force_constant_n_per_a",
            "viscous.damping_pos_n_s_per_m",
            "viscous.damping_neg_n_s_per_m",
            "spring.stiffness_n_per_m",
            "direction_asymmetry.gain_pos",
            "direction_asymmetry.gain_neg",
        ],
        Family::LinearAxis => &[
            "linear_axis.mass_kg",
            "viscous.damping_pos_n_s_per_m",
            "viscous.damping_neg_n_s_per_m",
            "spring.stiffness_n_per_m",
            "direction_asymmetry.gain_pos",
            "direction_asymmetry.gain_neg",
        ],
        _ => &[],
    }
}

impl AxisModel {
    /// The model with the parameters `value(name)` gives (the fitted values, or a corner of
    /// their intervals).
    pub fn with_values(
        family: Family,
        value: &dyn Fn(&str) -> Option<f64>,
    ) -> Result<AxisModel, String> {
        let need = |name: &str| {
            value(name).ok_or_else(|| format!("the model has no {name}, which the design needs"))
        };
        let or_zero = |name: &str| value(name).unwrap_or(0.0);
        let damping = [
            or_zero("viscous.damping_pos_n_s_per_m"),
            or_zero("viscous.damping_neg_n_s_per_m"),
        ];
        let asym = [
            value("direction_asymmetry.gain_pos").unwrap_or(1.0),
            value("direction_asymmetry.gain_neg").unwrap_or(1.0),
        ];
        let coulomb = value("coulomb.coulomb_pos_n")
            .zip(value("coulomb.coulomb_neg_n"))
            .map(|(p, n)| [p, n]);
        match family {
            Family::Solenoid => {
                let k = need("solenoid.current_gain_a_per_v")?
                    * need("solenoid.force_constant_n_per_a")?;
                Ok(AxisModel {
                    family,
                    mass: need("solenoid.mass_kg")?,
                    damping,
                    stiffness: or_zero("spring.stiffness_n_per_m"),
                    gain: [k * asym[0], k * asym[1]],
                    lag_s: Some(need("solenoid.current_time_constant_s")?),
                    coulomb,
                    pretension: or_zero("spring.pretension_n"),
                    supply_exponent: value("supply_gain.exponent"),
                    supply_nominal: value("solenoid.supply_voltage_v"),
                })
            }
            // The lab's balance of a linear axis takes the command as the force (docs/lab.md):
            // its fitted forces are per command unit, the drive's gain is 1.
            Family::LinearAxis => Ok(AxisModel {
                family,
                mass: need("linear_axis.mass_kg")?,
                damping,
                stiffness: or_zero("spring.stiffness_n_per_m"),
                gain: asym,
                lag_s: None,
                coulomb,
                pretension: or_zero("spring.pretension_n"),
                supply_exponent: value("supply_gain.exponent"),
                supply_nominal: value("linear_axis.supply_voltage_v"),
            }),
            other => Err(format!(
                "tune designs the controller of solenoid and linear_axis models; {other} is not one"
            )),
        }
    }

    pub fn from_fitted(f: &Fitted) -> Result<AxisModel, String> {
        AxisModel::with_values(f.model.spec.family, &|n| f.get(n))
    }

    fn index(dir: Direction) -> usize {
        match dir {
            Direction::Positive => 0,
            Direction::Negative => 1,
        }
    }

    /// The linear plant of one direction.
    pub fn linear(&self, dir: Direction) -> ContinuousPlant {
        let i = Self::index(dir);
        ContinuousPlant::body(
            self.mass,
            self.damping[i],
            self.stiffness,
            self.gain[i],
            self.lag_s,
        )
    }

    /// True when the directions differ (damping or drive gain).
    pub fn has_two_directions(&self) -> bool {
        self.damping[0] != self.damping[1] || self.gain[0] != self.gain[1]
    }

    /// Undamped natural frequency `√(c/m)`, rad/s (0 without a spring).
    pub fn natural_frequency(&self) -> f64 {
        (self.stiffness / self.mass).sqrt()
    }
}

/// Every corner of the intervals of `names` that the fit gave (at most 2¹⁰ of them): a value
/// function per corner.
pub fn corners(f: &Fitted, names: &[&str]) -> Vec<Vec<(String, f64)>> {
    let with: Vec<(String, (f64, f64))> = names
        .iter()
        .filter_map(|n| f.intervals.get(*n).map(|iv| (n.to_string(), *iv)))
        .take(10)
        .collect();
    (0..1usize << with.len())
        .map(|mask| {
            with.iter()
                .enumerate()
                .map(|(j, (n, (lo, hi)))| (n.clone(), if mask >> j & 1 == 1 { *hi } else { *lo }))
                .collect()
        })
        .collect()
}
