//! Disturbance observer for fault detection by state estimation (Isermann & Raab, "with state
//! estimation"): states `x = [Y, Y', I, x4]`, `x4` a constant disturbance that absorbs the
//! friction and pretension offset, discrete observer
//! `x̂(k+1) = A x̂(k) + b u(k) + h e(k)`, `e(k) = y(k) - cᵀ x̂(k)`, `h` by pole placement.
//!
//! Continuous model of the solenoid drive, `x4` in position units (statics `Y = K_P U + x4`):
//! `Y'' = (K_Mag I - c (Y - x4) - d Y') / m`, `I' = (K_I U - I) / T_I`, `x4' = 0`, discretised
//! with a zero-order hold at `T_0`. Moving in `+`, Coulomb friction acts like `x4 = -F_C / c`, in
//! `-` like `x4 = +F_C / c`: after the learning phase, `x4` is compared with a nominal band per
//! direction while the residual is small; rising friction shows as `x4+` below its band and `x4-`
//! above its band while the position still follows.
//!
//! The gain follows Ackermann's formula for the observer, `h = φ(A) O⁻¹ [0 0 0 1]ᵀ`,
//! `O = [cᵀ; cᵀA; cᵀA²; cᵀA³]`, `φ(z) = Π (z - z_i)` the wanted characteristic polynomial of
//! `A - h cᵀ`. (The paper's `h = [0.5459, 47.485, 0, 1.017]` at 2.5 ms belongs to its model and
//! poles; [`DisturbanceObserver::gain`] gives ours.)

use nalgebra::{DMatrix, Matrix4, Vector4};

use super::ObserverSection;
use crate::param::ParamError;

/// Plant parameters and design of [`DisturbanceObserver`].
#[derive(Debug, Clone, PartialEq)]
pub struct ObserverConfig {
    /// `T_0` (s).
    pub period_s: f64,
    /// `[axis.observer]` as declared: the model `m`, `d`, `c`, `K_Mag`, `K_I`, `T_I`, the poles,
    /// the residual and speed thresholds, and the learning of the `x4` bands.
    pub params: ObserverSection,
}

/// The position of `x4` relative to its band.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Deviation {
    #[default]
    Inside,
    Below,
    Above,
}

/// What one observer step found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObserverOutput {
    /// `x̂(k)` before the update, `[Y, Y', I, x4]`.
    pub state: [f64; 4],
    /// `e(k) = y(k) - Ŷ(k)` (m).
    pub residual: f64,
    /// Smoothed `x4` of the `+` and `-` directions (m).
    pub x4_pos: f64,
    pub x4_neg: f64,
    /// Both bands learned.
    pub learned: bool,
    /// Persistent deviations.
    pub deviation_pos: Deviation,
    pub deviation_neg: Deviation,
    /// `x4+` below and `x4-` above their bands: rising friction.
    pub friction_rise: bool,
}

#[derive(Debug, Clone, Copy, Default)]
struct DirectionBand {
    n: u32,
    mean: f64,
    m2: f64,
    low: f64,
    high: f64,
    smoothed: Option<f64>,
    outside: u32,
    deviation: Deviation,
}

/// The discrete disturbance observer with learned `x4` bands. `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct DisturbanceObserver {
    config: ObserverConfig,
    /// `warmup_s` in periods.
    warmup_samples: u32,
    a: Matrix4<f64>,
    b: Vector4<f64>,
    h: Vector4<f64>,
    x: Vector4<f64>,
    started: bool,
    samples: u32,
    bands: [DirectionBand; 2],
}

fn discretise(config: &ObserverConfig) -> (Matrix4<f64>, Vector4<f64>) {
    let c = &config.params;
    let (m, d, k) = (c.mass_kg, c.damping_n_s_per_m, c.spring_n_per_m);
    let mut ac = DMatrix::<f64>::zeros(5, 5);
    ac[(0, 1)] = 1.0;
    ac[(1, 0)] = -k / m;
    ac[(1, 1)] = -d / m;
    ac[(1, 2)] = c.force_constant_n_per_a / m;
    ac[(1, 3)] = k / m;
    ac[(2, 2)] = -1.0 / c.current_time_constant_s;
    ac[(2, 4)] = c.current_gain_a_per_v / c.current_time_constant_s;
    let e = (ac * config.period_s).exp();
    let a = Matrix4::from_fn(|i, j| e[(i, j)]);
    let b = Vector4::from_fn(|i, _| e[(i, 4)]);
    (a, b)
}

impl DisturbanceObserver {
    /// Discretises the model and places the poles; fails for non-physical parameters or an
    /// unobservable model.
    pub fn new(config: ObserverConfig) -> Result<Self, ParamError> {
        use crate::param::ParamError as E;
        use crate::param_key;
        use ObserverSection as S;
        let period_s = config.period_s;
        let p = &config.params;
        for (name, v) in [
            ("period_s", period_s),
            (param_key!(S, mass_kg), p.mass_kg),
            (param_key!(S, spring_n_per_m), p.spring_n_per_m),
            (
                param_key!(S, force_constant_n_per_a),
                p.force_constant_n_per_a,
            ),
            (param_key!(S, current_gain_a_per_v), p.current_gain_a_per_v),
            (
                param_key!(S, current_time_constant_s),
                p.current_time_constant_s,
            ),
            (param_key!(S, residual_max_m), p.residual_max_m),
            (
                param_key!(S, smoothing_time_constant_s),
                p.smoothing_time_constant_s,
            ),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(E::new(name, format!("must be finite and > 0, got {v}")));
            }
        }
        if p.damping_n_s_per_m.is_nan() || p.damping_n_s_per_m < 0.0 {
            return Err(E::new(param_key!(S, damping_n_s_per_m), "must be >= 0"));
        }
        if p.poles.iter().any(|x| x.is_nan() || x.abs() >= 1.0) {
            return Err(E::new(
                param_key!(S, poles),
                "must lie inside the unit circle",
            ));
        }
        let (a, b) = discretise(&config);
        let c = Vector4::new(1.0, 0.0, 0.0, 0.0).transpose();
        let ca = c * a;
        let ca2 = ca * a;
        let ca3 = ca2 * a;
        let o = Matrix4::from_rows(&[c, ca, ca2, ca3]);
        let o_inv = o
            .try_inverse()
            .ok_or_else(|| E::new("observer", "model is not observable from the position"))?;
        let mut phi: Matrix4<f64> = Matrix4::identity();
        for &p in &config.params.poles {
            phi *= a - Matrix4::identity() * p;
        }
        let h: Vector4<f64> = phi * o_inv * Vector4::new(0.0, 0.0, 0.0, 1.0);
        if h.iter().any(|v| !v.is_finite()) {
            return Err(E::new(param_key!(S, poles), "pole placement failed"));
        }
        // Samples after the start before anything is learned or compared (start-up transient).
        let warmup_samples = (config.params.warmup_s / period_s)
            .round()
            .clamp(0.0, f64::from(u32::MAX)) as u32;
        Ok(Self {
            config,
            warmup_samples,
            a,
            b,
            h,
            x: Vector4::zeros(),
            started: false,
            samples: 0,
            bands: [DirectionBand::default(); 2],
        })
    }

    /// Observer gain `h` (SI units of the states per m of residual).
    pub fn gain(&self) -> [f64; 4] {
        [self.h[0], self.h[1], self.h[2], self.h[3]]
    }

    /// `A` and `b` of the discrete model (row-major `A`).
    pub fn model(&self) -> ([[f64; 4]; 4], [f64; 4]) {
        let mut a = [[0.0; 4]; 4];
        for (i, row) in a.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.a[(i, j)];
            }
        }
        (a, [self.b[0], self.b[1], self.b[2], self.b[3]])
    }

    /// Learned bands `(low, high)` of `x4+` and `x4-`, once learned.
    pub fn bands(&self) -> Option<[(f64, f64); 2]> {
        let n = self.config.params.learn_samples;
        (self.bands[0].n >= n && self.bands[1].n >= n).then(|| {
            [
                (self.bands[0].low, self.bands[0].high),
                (self.bands[1].low, self.bands[1].high),
            ]
        })
    }

    /// Take bands learned before (a stored state): `[(low, high) of x4+, (low, high) of x4-]`.
    /// Non-finite or inverted bands are ignored and learned again.
    pub fn restore_bands(&mut self, bands: [(f64, f64); 2]) {
        for (band, (low, high)) in self.bands.iter_mut().zip(bands) {
            if low.is_finite() && high.is_finite() && low <= high {
                *band = DirectionBand {
                    n: self.config.params.learn_samples,
                    mean: 0.5 * (low + high),
                    low,
                    high,
                    ..DirectionBand::default()
                };
            }
        }
    }

    /// Forget the learned bands and learn again.
    pub fn relearn(&mut self) {
        self.bands = [DirectionBand::default(); 2];
    }

    /// One step with the measured position `y(k)` and the voltage `u(k)` applied in this period.
    pub fn step(&mut self, position: f64, command: f64) -> ObserverOutput {
        let c = &self.config.params;
        let period_s = self.config.period_s;
        if !self.started && position.is_finite() {
            // Start at rest at the measured position, disturbance absorbing the offset.
            let i0 = c.current_gain_a_per_v * command;
            let x4 = position - c.force_constant_n_per_a * i0 / c.spring_n_per_m;
            self.x = Vector4::new(position, 0.0, i0, x4);
            self.started = true;
        }
        let state = [self.x[0], self.x[1], self.x[2], self.x[3]];
        let e = position - self.x[0];
        if e.is_finite() && command.is_finite() {
            self.x = self.a * self.x + self.b * command + self.h * e;
        }
        let alpha = period_s / (c.smoothing_time_constant_s + period_s);
        let speed = state[1];
        self.samples = self.samples.saturating_add(1);
        let quiet = self.samples > self.warmup_samples && e.abs() <= c.residual_max_m;
        let dir = if !quiet {
            None
        } else if speed > c.moving_speed_m_per_s {
            Some(0)
        } else if speed < -c.moving_speed_m_per_s {
            Some(1)
        } else {
            None
        };
        if let Some(d) = dir {
            let x4 = state[3];
            let band = &mut self.bands[d];
            let s = band.smoothed.map_or(x4, |s| s + alpha * (x4 - s));
            band.smoothed = Some(s);
            if band.n < c.learn_samples {
                // Welford on the smoothed x4.
                band.n += 1;
                let delta = s - band.mean;
                band.mean += delta / f64::from(band.n);
                band.m2 += delta * (s - band.mean);
                if band.n == c.learn_samples {
                    let sigma = (band.m2 / f64::from(band.n.max(2) - 1)).sqrt();
                    let half = (c.band_sigmas * sigma).max(c.band_min_halfwidth_m);
                    band.low = band.mean - half;
                    band.high = band.mean + half;
                }
            } else {
                let now = if s < band.low {
                    Deviation::Below
                } else if s > band.high {
                    Deviation::Above
                } else {
                    Deviation::Inside
                };
                if now == Deviation::Inside {
                    band.outside = 0;
                    band.deviation = Deviation::Inside;
                } else {
                    band.outside = band.outside.saturating_add(1);
                    if band.outside >= c.persistence_samples.max(1) {
                        band.deviation = now;
                    }
                }
            }
        }
        let learned = self.bands.iter().all(|b| b.n >= c.learn_samples);
        let (p, n) = (&self.bands[0], &self.bands[1]);
        ObserverOutput {
            state,
            residual: e,
            x4_pos: p.smoothed.unwrap_or(f64::NAN),
            x4_neg: n.smoothed.unwrap_or(f64::NAN),
            learned,
            deviation_pos: p.deviation,
            deviation_neg: n.deviation,
            friction_rise: learned
                && p.deviation == Deviation::Below
                && n.deviation == Deviation::Above,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> ObserverConfig {
        ObserverConfig {
            period_s: 0.0025,
            params: ObserverSection {
                mass_kg: 0.4956,
                damping_n_s_per_m: 20.0,
                spring_n_per_m: 1650.0,
                force_constant_n_per_a: 16.3,
                current_gain_a_per_v: 0.1,
                current_time_constant_s: 0.00859,
                poles: [0.6, 0.6, 0.7, 0.7],
                residual_max_m: 1e-4,
                moving_speed_m_per_s: 1e-3,
                warmup_s: 0.0,
                learn_samples: 50,
                band_sigmas: 4.0,
                band_min_halfwidth_m: 2e-5,
                smoothing_time_constant_s: 0.01,
                persistence_samples: 5,
            },
        }
    }

    #[test]
    fn placed_poles_are_the_eigenvalues_of_the_error_dynamics() {
        let o = DisturbanceObserver::new(cfg()).expect("valid");
        let c = Vector4::new(1.0, 0.0, 0.0, 0.0).transpose();
        let f = o.a - o.h * c;
        // Characteristic polynomial of f at each pole is zero: det(F - p I) = 0.
        for &p in &[0.6, 0.7] {
            let det = (f - Matrix4::identity() * p).determinant();
            assert!(det.abs() < 1e-9, "det at {p} = {det}");
        }
        assert!(o.gain().iter().all(|g| g.is_finite()));
    }

    #[test]
    fn a_constant_force_disturbance_appears_in_x4() {
        // Simulate the linear model exactly with a disturbance x4 = -0.2 mm, u = 6 V.
        let mut o = DisturbanceObserver::new(cfg()).expect("valid");
        let (a, b) = (o.a, o.b);
        let mut x = Vector4::new(0.0, 0.0, 0.0, -2e-4);
        let mut out = ObserverOutput::default();
        for _ in 0..400 {
            out = o.step(x[0], 6.0);
            x = a * x + b * 6.0;
        }
        assert!((out.state[3] + 2e-4).abs() < 1e-7, "x4 = {}", out.state[3]);
        assert!(out.residual.abs() < 1e-9);
    }

    #[test]
    fn restored_bands_count_as_learned_and_bad_ones_are_learned_again() {
        let mut o = DisturbanceObserver::new(cfg()).expect("valid");
        assert_eq!(o.bands(), None);
        let stored = [(-3e-4, -1e-4), (1e-4, 3e-4)];
        o.restore_bands(stored);
        assert_eq!(o.bands(), Some(stored));
        let mut fresh = DisturbanceObserver::new(cfg()).expect("valid");
        fresh.restore_bands([(f64::NAN, 1.0), (2e-4, 1e-4)]);
        assert_eq!(fresh.bands(), None, "NaN and inverted bands are not taken");
    }
}
