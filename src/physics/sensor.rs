//! Sensor model: `y_m = q · round((y + o + σ n) / q)` with `n` standard normal, plus a stuck mode;
//! current and supply readings get their own noise and quantisation.

use super::fault::FaultModifiers;
use super::params::{ParamDef, Quantity};
use super::rng::SplitMix64;
use super::Measurement;

/// Sensor parameters, in the order of [`SENSOR_PARAMS`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorSpec {
    /// Position resolution (m or rad); 0 for none.
    pub position_quantum: f64,
    /// Position noise standard deviation.
    pub position_noise: f64,
    /// Constant position offset.
    pub position_offset: f64,
    /// Current resolution (A).
    pub current_quantum_a: f64,
    /// Current noise standard deviation (A).
    pub current_noise_a: f64,
    /// Supply noise standard deviation (V or Pa).
    pub supply_noise: f64,
}

/// Parameters of the `[sensor]` table.
pub const SENSOR_PARAMS: &[ParamDef] = &[
    ParamDef::non_negative(
        "position_quantum",
        Quantity::Position,
        0.0,
        "position resolution",
    ),
    ParamDef::non_negative(
        "position_noise",
        Quantity::Position,
        0.0,
        "position noise std",
    ),
    ParamDef::any(
        "position_offset",
        Quantity::Position,
        0.0,
        "position offset",
    ),
    ParamDef::non_negative(
        "current_quantum_a",
        Quantity::Named("A"),
        0.0,
        "current resolution",
    ),
    ParamDef::non_negative(
        "current_noise_a",
        Quantity::Named("A"),
        0.0,
        "current noise std",
    ),
    ParamDef::non_negative("supply_noise", Quantity::Supply, 0.0, "supply noise std"),
];

impl SensorSpec {
    /// From values in [`SENSOR_PARAMS`] order.
    pub fn from_values(v: &[f64]) -> Self {
        SensorSpec {
            position_quantum: v[0],
            position_noise: v[1],
            position_offset: v[2],
            current_quantum_a: v[3],
            current_noise_a: v[4],
            supply_noise: v[5],
        }
    }
}

#[inline]
fn quantise(x: f64, q: f64) -> f64 {
    if q > 0.0 {
        (x / q).round() * q
    } else {
        x
    }
}

/// A sensor with its own seeded noise source.
#[derive(Debug, Clone)]
pub struct Sensor {
    spec: SensorSpec,
    rng: SplitMix64,
    stuck_at: Option<f64>,
    last_position: f64,
}

impl Sensor {
    /// A sensor; the same seed gives the same noise.
    pub fn new(spec: SensorSpec, seed: u64) -> Self {
        Sensor {
            spec,
            rng: SplitMix64::new(seed),
            stuck_at: None,
            last_position: 0.0,
        }
    }

    /// Reading of `truth` under the sensor faults in `m`.
    pub fn read(&mut self, truth: Measurement, m: &FaultModifiers) -> Measurement {
        let s = &self.spec;
        let position = if m.sensor_stuck {
            *self.stuck_at.get_or_insert(self.last_position)
        } else {
            self.stuck_at = None;
            // A noise burst on a noiseless sensor uses the resolution as its base level.
            let base = if s.position_noise > 0.0 {
                s.position_noise
            } else {
                s.position_quantum
            };
            let sigma = if m.sensor_noise != 1.0 {
                base * m.sensor_noise
            } else {
                s.position_noise
            };
            let noise = if sigma > 0.0 {
                sigma * self.rng.normal()
            } else {
                0.0
            };
            quantise(
                truth.position + s.position_offset + m.sensor_offset + noise,
                s.position_quantum,
            )
        };
        self.last_position = position;
        let current = if s.current_noise_a > 0.0 {
            truth.current_a + s.current_noise_a * self.rng.normal()
        } else {
            truth.current_a
        };
        let supply_noise = if s.supply_noise > 0.0 {
            s.supply_noise * self.rng.normal()
        } else {
            0.0
        };
        Measurement {
            position,
            velocity: truth.velocity,
            current_a: quantise(current, s.current_quantum_a),
            supply_voltage_v: if truth.supply_voltage_v != 0.0 {
                truth.supply_voltage_v + supply_noise
            } else {
                0.0
            },
            supply_pressure_pa: if truth.supply_pressure_pa != 0.0 {
                truth.supply_pressure_pa + supply_noise
            } else {
                0.0
            },
        }
    }
}
