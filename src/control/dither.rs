//! Dither for friction compensation (Isermann & Raab, "friction compensation: dither (periodic
//! signal added to u)"): `u_d(k) = A sin(2π f k T_0)`, with fixed or self-adapting amplitude `A` and
//! frequency `f`.
//!
//! Self-adaptation (the paper's "automatically generated dither adapts its amplitude and
//! frequency"; its law is not given, this one is documented here):
//! - *stuck*: `|e_w| > e_tol` and the smoothed position ripple `r` (mean `|Δy|` per sample) is below
//!   `r_move`: the friction holds, `A ← min(A + ρ_A T_0, A_max)` and `f ← max(f (1 - ρ_f T_0), f_min)`
//!   (a lower frequency moves more per period);
//! - *too much ripple*: `r > r_max`: `A ← max(A - ρ_A T_0, A_min)`, `f ← min(f (1 + ρ_f T_0), f_max)`
//!   (the plant's low-pass damps a faster dither);
//! - *on target*: `|e_w| <= e_tol`: `A ← max(A - ρ_A T_0 / 4, A_min)`, the dither fades.

use super::param_error::{non_negative, positive, range, ParamError};
use super::DitherSection as Section;
use crate::param_key;

/// Configuration of [`Dither`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DitherConfig {
    /// Sampling period `T_0` (s).
    pub period_s: f64,
    /// Starting (and, when not adapting, fixed) amplitude (command unit).
    pub amplitude: f64,
    /// Starting (and fixed) frequency (Hz), at most `1 / (2 T_0)`.
    pub frequency_hz: f64,
    /// Adapt amplitude and frequency.
    pub adapt: bool,
    /// Amplitude band `[A_min, A_max]`.
    pub amplitude_min: f64,
    pub amplitude_max: f64,
    /// Frequency band `[f_min, f_max]` (Hz).
    pub frequency_min_hz: f64,
    pub frequency_max_hz: f64,
    /// `ρ_A`, amplitude rate (command unit per s).
    pub amplitude_rate_per_s: f64,
    /// `ρ_f`, relative frequency rate (1/s).
    pub frequency_rate_per_s: f64,
    /// `e_tol` (m): error considered on target.
    pub error_tolerance_m: f64,
    /// `r_move` (m per sample): ripple below this counts as standstill.
    pub ripple_moving_m: f64,
    /// `r_max` (m per sample): ripple above this is too much.
    pub ripple_max_m: f64,
    /// Time constant of the ripple smoothing (s).
    pub ripple_time_constant_s: f64,
}

/// Dither generator. Allocation-free.
#[derive(Debug, Clone)]
pub struct Dither {
    config: DitherConfig,
    amplitude: f64,
    frequency_hz: f64,
    phase: f64,
    ripple: f64,
    last_position: Option<f64>,
}

impl Dither {
    /// Checks bands, rates and that `f_max <= 1 / (2 T_0)`.
    pub fn new(config: DitherConfig) -> Result<Self, ParamError> {
        let c = &config;
        positive("period_s", c.period_s)?;
        // Named by the keys of `[axis.dither]` they come from.
        non_negative(param_key!(Section, amplitude), c.amplitude)?;
        positive(param_key!(Section, frequency_hz), c.frequency_hz)?;
        let amplitude_min = param_key!(Section, amplitude_min);
        non_negative(amplitude_min, c.amplitude_min)?;
        if !(c.amplitude_max >= c.amplitude_min && c.amplitude_max.is_finite()) {
            return Err(ParamError::new(
                param_key!(Section, amplitude_max),
                format!("must be >= {amplitude_min}, got {}", c.amplitude_max),
            ));
        }
        positive(param_key!(Section, frequency_min_hz), c.frequency_min_hz)?;
        range("frequency", c.frequency_min_hz, c.frequency_max_hz + 1e-12)?;
        let nyquist = 0.5 / c.period_s;
        if c.frequency_max_hz > nyquist + 1e-9 || c.frequency_hz > nyquist + 1e-9 {
            return Err(ParamError::new(
                param_key!(Section, frequency_max_hz),
                format!("must be <= 1/(2 T0) = {nyquist} Hz"),
            ));
        }
        non_negative(
            param_key!(Section, amplitude_rate_per_s),
            c.amplitude_rate_per_s,
        )?;
        non_negative(
            param_key!(Section, frequency_rate_per_s),
            c.frequency_rate_per_s,
        )?;
        non_negative(param_key!(Section, error_tolerance_m), c.error_tolerance_m)?;
        non_negative(param_key!(Section, ripple_moving_m), c.ripple_moving_m)?;
        positive(param_key!(Section, ripple_max_m), c.ripple_max_m)?;
        positive(
            param_key!(Section, ripple_time_constant_s),
            c.ripple_time_constant_s,
        )?;
        Ok(Self {
            amplitude: c.amplitude,
            frequency_hz: c.frequency_hz,
            config,
            phase: 0.0,
            ripple: 0.0,
            last_position: None,
        })
    }

    /// Current amplitude `A`.
    pub fn amplitude(&self) -> f64 {
        self.amplitude
    }

    /// Current frequency `f` (Hz).
    pub fn frequency_hz(&self) -> f64 {
        self.frequency_hz
    }

    /// Smoothed ripple `r` (m per sample).
    pub fn ripple_m(&self) -> f64 {
        self.ripple
    }

    /// Back to the starting amplitude and frequency.
    pub fn reset(&mut self) {
        self.amplitude = self.config.amplitude;
        self.frequency_hz = self.config.frequency_hz;
        self.phase = 0.0;
        self.ripple = 0.0;
        self.last_position = None;
    }

    /// `u_d(k) = A sin(φ(k))`, `φ(k+1) = φ(k) + 2π f T_0`; adapts `A`, `f` first when enabled.
    pub fn step(&mut self, setpoint: f64, position: f64) -> f64 {
        let c = self.config;
        if position.is_finite() {
            if let Some(last) = self.last_position {
                let a = c.period_s / (c.ripple_time_constant_s + c.period_s);
                self.ripple += a * ((position - last).abs() - self.ripple);
            }
            self.last_position = Some(position);
        }
        let e = setpoint - position;
        if c.adapt && e.is_finite() {
            let da = c.amplitude_rate_per_s * c.period_s;
            let df = c.frequency_rate_per_s * c.period_s;
            if self.ripple > c.ripple_max_m {
                self.amplitude = (self.amplitude - da).max(c.amplitude_min);
                self.frequency_hz = (self.frequency_hz * (1.0 + df)).min(c.frequency_max_hz);
            } else if e.abs() > c.error_tolerance_m {
                if self.ripple < c.ripple_moving_m {
                    self.amplitude = (self.amplitude + da).min(c.amplitude_max);
                    self.frequency_hz = (self.frequency_hz * (1.0 - df)).max(c.frequency_min_hz);
                }
            } else {
                self.amplitude = (self.amplitude - 0.25 * da).max(c.amplitude_min);
            }
        }
        let u = self.amplitude * self.phase.sin();
        self.phase += std::f64::consts::TAU * self.frequency_hz * c.period_s;
        if self.phase >= std::f64::consts::TAU {
            self.phase -= std::f64::consts::TAU;
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(adapt: bool) -> DitherConfig {
        DitherConfig {
            period_s: 0.0025,
            amplitude: 0.2,
            frequency_hz: 50.0,
            adapt,
            amplitude_min: 0.0,
            amplitude_max: 1.0,
            frequency_min_hz: 20.0,
            frequency_max_hz: 200.0,
            amplitude_rate_per_s: 1.0,
            frequency_rate_per_s: 1.0,
            error_tolerance_m: 20e-6,
            ripple_moving_m: 1e-6,
            ripple_max_m: 10e-6,
            ripple_time_constant_s: 0.02,
        }
    }

    #[test]
    fn fixed_dither_is_a_sine_of_the_set_amplitude_and_frequency() {
        let mut d = Dither::new(cfg(false)).expect("valid");
        let u: Vec<f64> = (0..8).map(|_| d.step(1.0, 0.0)).collect();
        // 50 Hz at 400 Hz: 8 samples per period.
        assert!(u[0].abs() < 1e-12);
        assert!((u[2] - 0.2).abs() < 1e-12);
        assert!((u[6] + 0.2).abs() < 1e-12);
        assert_eq!(d.amplitude(), 0.2);
    }

    #[test]
    fn adapting_dither_grows_while_stuck_and_shrinks_with_ripple() {
        let mut d = Dither::new(cfg(true)).expect("valid");
        for _ in 0..200 {
            d.step(1e-3, 0.0);
        }
        assert!(d.amplitude() > 0.6, "A = {}", d.amplitude());
        assert!(d.frequency_hz() < 50.0);
        let a = d.amplitude();
        let f = d.frequency_hz();
        for k in 0..200 {
            let y = if k % 2 == 0 { 0.0 } else { 50e-6 };
            d.step(1e-3, y);
        }
        assert!(d.amplitude() < a);
        assert!(d.frequency_hz() > f);
    }

    #[test]
    fn rejects_a_frequency_above_nyquist() {
        let mut c = cfg(false);
        c.frequency_max_hz = 300.0;
        assert!(Dither::new(c).is_err());
    }
}
