//! Signals for the inverse-dynamics regression: zero-phase low-pass filtered position, its first
//! two derivatives, and the command, current and supply through the same filter, so that every
//! signal of the balance of forces sees the same filter and none lags another.

use super::data::Dataset;

/// The prepared signals of a data set.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Sample period `T_0` in s.
    pub dt: f64,
    /// Filter corner in Hz.
    pub cutoff_hz: f64,
    /// Filtered position.
    pub y: Vec<f64>,
    /// Velocity of the filtered position.
    pub v: Vec<f64>,
    /// Acceleration of the filtered position.
    pub a: Vec<f64>,
    /// Filtered command.
    pub u: Vec<f64>,
    /// Filtered current, when recorded.
    pub current: Option<Vec<f64>>,
    /// Filtered supply, when recorded.
    pub supply: Option<Vec<f64>>,
    /// Speed below which a sample counts as standstill.
    pub v_standstill: f64,
    /// Samples away from the filter's start-up at both ends of each continuous stretch.
    pub interior: Vec<bool>,
    /// Samples usable for the regression: moving, and interior.
    pub valid: Vec<bool>,
    /// First sample of each continuous stretch (0 first; more after gaps in the time).
    pub segment_starts: Vec<usize>,
    /// Samples at rest where the model's friction must hold the body ([`standstill_samples`]).
    pub standstill: Vec<usize>,
    /// Number of statistically independent samples, `N_eff = 2 f_c N T_0` (the residual of a
    /// band-limited regression is correlated over about `1/(2 f_c)`), at most `N`.
    pub n_eff_per_sample: f64,
    /// Standard deviation of the filtered acceleration the position sensor's noise alone
    /// leaves ([`position_noise`] times [`acceleration_noise_gain`]), 0 where unknown: no
    /// model explains the balance better than that.
    pub acceleration_noise: f64,
}

/// Default filter corner: a tenth of the sample rate, at most 50 Hz.
pub fn default_cutoff_hz(dt: f64) -> f64 {
    (0.1 / dt).min(50.0)
}

/// The filter corner for a record: the default, or, where the position rings at a resonance
/// above 70 % of it, 2.5 times the resonance (at most 40 % of the sample rate). Below its
/// motion's band the filter still balances a linear model (both sides filtered alike), but a
/// column nonlinear in the motion (a hardening spring, damping per direction) is computed from
/// a position the filter has stripped of the resonance: on a mass-spring-damper at 63 Hz
/// sampled at 610 Hz the 50 Hz default fitted the damping 9.6 % apart between directions.
pub fn record_cutoff_hz(d: &Dataset) -> f64 {
    let dt = d.period_s();
    let base = default_cutoff_hz(dt);
    match resonance_hz(&d.output, dt, 0.7 * base) {
        Some(f) => (2.5 * f).min(0.4 / dt).max(base),
        None => base,
    }
}

/// Samples per segment of the position's spectrum ([`resonance_hz`]).
const SPECTRUM_SEGMENT: usize = 256;
/// Most segments averaged into the spectrum.
const SPECTRUM_SEGMENTS: usize = 128;

/// Welch's estimate of the power spectrum of `y`: segments of 256 samples, half overlapping
/// (at most 128 of them, spread over a longer record), Hann window, each segment's mean and
/// slope removed (the motion's drift is not power). Bins below `from_bin` are left at zero.
struct Spectrum {
    /// `Σ_segments |X_k|²` per bin `k` of `df`.
    power: Vec<f64>,
    /// Bin width, Hz.
    df: f64,
}

/// The window and the transform's factors of [`welch`], made once.
struct Periodogram {
    window: Vec<f64>,
    /// cos and sin of 2π j / l: bin k at sample i takes entry (k i) mod l.
    twiddle: Vec<(f64, f64)>,
    /// `Σ (i - mean i)²`, for the slope removed from each segment.
    sxx: f64,
}

impl Periodogram {
    fn new() -> Periodogram {
        let l = SPECTRUM_SEGMENT;
        let xm = (l as f64 - 1.0) / 2.0;
        Periodogram {
            window: (0..l)
                .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / l as f64).cos())
                .collect(),
            twiddle: (0..l)
                .map(|j| {
                    let (sin, cos) = (std::f64::consts::TAU * j as f64 / l as f64).sin_cos();
                    (cos, sin)
                })
                .collect(),
            sxx: (0..l).map(|i| (i as f64 - xm).powi(2)).sum(),
        }
    }

    /// `|X_k|²` of one segment of [`SPECTRUM_SEGMENT`] samples, mean and slope removed, added
    /// to `power` from bin `from_bin` on; `seg` is scratch.
    fn add(&self, part: &[f64], from_bin: usize, seg: &mut [f64], power: &mut [f64]) {
        let l = part.len();
        let n = l as f64;
        let xm = (n - 1.0) / 2.0;
        let ym = part.iter().sum::<f64>() / n;
        let sxy: f64 = part
            .iter()
            .enumerate()
            .map(|(i, v)| (i as f64 - xm) * (v - ym))
            .sum();
        let slope = sxy / self.sxx;
        for (i, v) in part.iter().enumerate() {
            seg[i] = (v - ym - slope * (i as f64 - xm)) * self.window[i];
        }
        for (k, p) in power.iter_mut().enumerate().skip(from_bin) {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in seg.iter().enumerate() {
                let (cos, sin) = self.twiddle[(k * i) % l];
                re += v * cos;
                im -= v * sin;
            }
            *p += re * re + im * im;
        }
    }
}

/// The starts of the segments of [`welch`]: half overlapping, at most [`SPECTRUM_SEGMENTS`]
/// of them spread over the record (a million samples cost what 16 000 do).
fn segment_starts(len: usize) -> impl Iterator<Item = usize> {
    let l = SPECTRUM_SEGMENT;
    let hop = (l / 2).max(len.saturating_sub(l) / (SPECTRUM_SEGMENTS - 1));
    (0..)
        .map(move |i| i * hop)
        .take_while(move |s| s + l <= len)
}

fn welch(y: &[f64], dt: f64, from_bin: usize) -> Option<Spectrum> {
    let l = SPECTRUM_SEGMENT;
    if y.len() < 4 * l || dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let pg = Periodogram::new();
    let mut power = vec![0.0; l / 2];
    let mut seg = vec![0.0; l];
    let mut segments = 0usize;
    for start in segment_starts(y.len()) {
        pg.add(&y[start..start + l], from_bin, &mut seg, &mut power);
        segments += 1;
    }
    (segments > 0).then(|| Spectrum {
        power,
        df: 1.0 / (l as f64 * dt),
    })
}

impl Spectrum {
    /// First bin of the top fifth of the band, where a sensor's noise shows and the motion of
    /// a machine sampled for its dynamics does not.
    fn top(&self) -> usize {
        self.power.len() * 4 / 5
    }

    /// The median power of the top fifth of the band.
    fn floor(&self) -> f64 {
        let mut tail: Vec<f64> = self.power[self.top()..].to_vec();
        tail.sort_by(f64::total_cmp);
        tail[tail.len() / 2].max(f64::MIN_POSITIVE)
    }
}

/// A peak of the position's power spectrum above `above` Hz that stands 10 times over the
/// spectrum an octave below it and 100 times over the record's noise floor (the median of the
/// top fifth of the band): a resonance the motion rings at, not the falling tail of the
/// motion's own band.
pub fn resonance_hz(y: &[f64], dt: f64, above: f64) -> Option<f64> {
    let bins = SPECTRUM_SEGMENT / 2;
    let df = 1.0 / (SPECTRUM_SEGMENT as f64 * dt);
    let first = ((above / df).ceil() as usize).max(2);
    if !(df.is_finite() && first + 4 < bins) {
        return None;
    }
    let sp = welch(y, dt, first / 2)?;
    let (power, floor, top) = (&sp.power, sp.floor(), sp.top());
    (first..top)
        .filter(|&k| power[k] >= power[k - 1] && power[k] >= power[k + 1])
        .filter(|&k| power[k] > 100.0 * floor && power[k] > 10.0 * power[k / 2])
        .max_by(|&a, &b| power[a].total_cmp(&power[b]))
        .map(|k| k as f64 * sp.df)
}

/// The standard deviation of the position sensor's noise: each segment's mean power in the
/// top fifth of its band taken as white, `σ² = P / Σ w²`, the median over the segments (a jump
/// between joined records, a fast step, puts broadband power into a few of them). `None` for a
/// record too short for a spectrum. Where the motion itself reaches that band the estimate is
/// high, where the sensor is quantised and the body rests it is low.
pub fn position_noise(y: &[f64], dt: f64) -> Option<f64> {
    let l = SPECTRUM_SEGMENT;
    if y.len() < 4 * l || dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let pg = Periodogram::new();
    let top = l / 2 * 4 / 5;
    let mut seg = vec![0.0; l];
    let mut power = vec![0.0; l / 2];
    let mut levels: Vec<f64> = segment_starts(y.len())
        .map(|start| {
            power.fill(0.0);
            pg.add(&y[start..start + l], top, &mut seg, &mut power);
            power[top..].iter().sum::<f64>() / (power.len() - top) as f64
        })
        .collect();
    if levels.is_empty() {
        return None;
    }
    let mid = levels.len() / 2;
    let (_, median, _) = levels.select_nth_unstable_by(mid, f64::total_cmp);
    let energy: f64 = pg.window.iter().map(|w| w * w).sum();
    Some((*median / energy).sqrt())
}

/// The standard deviation of the filtered acceleration ([`prepare`]'s) that white position
/// noise of unit standard deviation leaves: `sqrt(Σ h_n²)` over the impulse response `h` of the
/// zero-phase filter and the two central differences.
pub fn acceleration_noise_gain(cutoff_hz: f64, dt: f64) -> f64 {
    // Four passes of a first-order lag decay within ~12 time constants 1/(2π f_c) each way.
    let half = (12.0 / (std::f64::consts::TAU * cutoff_hz * dt)).ceil() as usize + 4;
    let mut impulse = vec![0.0; 2 * half + 1];
    impulse[half] = 1.0;
    let a = derivative(&derivative(&zero_phase(&impulse, cutoff_hz, dt), dt), dt);
    a[2..a.len() - 2].iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Two first-order low-passes in series over `x` in place, forward or backward, each
/// `s_k = s_{k-1} + α (x_k - s_{k-1})`, `α = 1 - e^{-2π f_c T}`, both starting at the first
/// sample they see. Running the two in one loop gives the same numbers as two separate passes
/// (the second pass starts at the first output of the first, which is that same sample) while
/// the processor overlaps the two dependency chains.
fn lowpass_twice(x: &mut [f64], alpha: f64, reverse: bool) {
    let step = |(s1, s2): &mut (f64, f64), v: &mut f64| {
        *s1 += alpha * (*v - *s1);
        *s2 += alpha * (*s1 - *s2);
        *v = *s2;
    };
    if reverse {
        let Some(&last) = x.last() else { return };
        let mut s = (last, last);
        x.iter_mut().rev().for_each(|v| step(&mut s, v));
    } else {
        let Some(&first) = x.first() else { return };
        let mut s = (first, first);
        x.iter_mut().for_each(|v| step(&mut s, v));
    }
}

/// Zero-phase low-pass: two first-order passes forward and two backward (fourth-order magnitude,
/// no phase lag).
pub fn zero_phase(x: &[f64], cutoff_hz: f64, dt: f64) -> Vec<f64> {
    let alpha = 1.0 - (-2.0 * std::f64::consts::PI * cutoff_hz * dt).exp();
    let mut out = x.to_vec();
    lowpass_twice(&mut out, alpha, false);
    lowpass_twice(&mut out, alpha, true);
    out
}

/// Central difference `x'_k = (x_{k+1} - x_{k-1}) / (2 T_0)`, one-sided at the ends.
pub fn derivative(x: &[f64], dt: f64) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    if n < 2 {
        return d;
    }
    for k in 1..n - 1 {
        d[k] = (x[k + 1] - x[k - 1]) / (2.0 * dt);
    }
    d[0] = (x[1] - x[0]) / dt;
    d[n - 1] = (x[n - 1] - x[n - 2]) / dt;
    d
}

/// The `q`-quantile of `|x|` (0..1).
pub fn abs_quantile(x: &[f64], q: f64) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mut s: Vec<f64> = x.iter().map(|v| v.abs()).collect();
    let i = ((s.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, m, _) = s.select_nth_unstable_by(i, |a, b| a.total_cmp(b));
    *m
}

/// Filter and differentiate a data set, each continuous stretch ([`Dataset::segments`]) on its
/// own. `cutoff_hz` defaults to [`record_cutoff_hz`].
pub fn prepare(d: &Dataset, cutoff_hz: Option<f64>) -> Prepared {
    let dt = d.period_s();
    let fc = cutoff_hz
        .unwrap_or_else(|| record_cutoff_hz(d))
        .min(0.45 / dt);
    let segments = d.segments();
    let n = d.output.len();
    let Stretch {
        y,
        v,
        a,
        u,
        current,
        supply,
    } = if segments.len() <= 1 {
        prepare_stretch(d, fc, dt)
    } else {
        let mut all = Stretch::default();
        for r in &segments {
            let part = prepare_stretch(&d.slice(r.clone()), fc, dt);
            all.append(part);
        }
        all
    };
    // Four passes of a first-order lag: the start-up lasts a few time constants 1/(2π f_c).
    let edge = (3.0 / (2.0 * std::f64::consts::PI * fc * dt)).ceil() as usize + 2;
    let mut interior = vec![false; n];
    for r in &segments {
        let e = edge.min(r.len() / 4);
        // e <= len / 4: the interior is never empty or inverted.
        interior[r.start + e..r.end - e].fill(true);
    }
    let v_standstill = 0.03 * abs_quantile(&v, 0.95);
    let valid = v
        .iter()
        .zip(&interior)
        .map(|(vk, inside)| *inside && vk.abs() > v_standstill)
        .collect();
    let mut p = Prepared {
        dt,
        cutoff_hz: fc,
        y,
        v,
        a,
        u,
        current,
        supply,
        v_standstill,
        interior,
        valid,
        segment_starts: segments.iter().map(|r| r.start).collect(),
        standstill: Vec::new(),
        n_eff_per_sample: (2.0 * fc * dt).min(1.0),
        acceleration_noise: position_noise(&d.output, dt)
            .map_or(0.0, |s| s * acceleration_noise_gain(fc, dt)),
    };
    // Once per record: every balance of every candidate checks the same samples.
    p.standstill = standstill_samples(&p);
    p
}

/// Largest acceleration at rest, as a fraction of the 95 % quantile of `|a|`.
const REST_ACCELERATION: f64 = 0.05;

/// Samples at rest (slow and hardly accelerating) between the filter edges, before the first
/// motion and after the last too, except at the extreme positions of the record (within 0.5 %
/// of the range), where an end stop may be what holds the body.
pub fn standstill_samples(d: &Prepared) -> Vec<usize> {
    if !d.valid.iter().any(|v| *v) {
        return Vec::new();
    }
    let (Some(first), Some(last)) = (
        d.interior.iter().position(|v| *v),
        d.interior.iter().rposition(|v| *v),
    ) else {
        return Vec::new();
    };
    let (lo, hi) = d.y[first..=last]
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &y| {
            (a.min(y), b.max(y))
        });
    let margin = 0.005 * (hi - lo);
    // At rest the acceleration is small too: a reversal passes zero speed at full acceleration,
    // with its equation error, and holds nothing.
    let a_rest = REST_ACCELERATION * abs_quantile(&d.a[first..=last], 0.95);
    (first..=last)
        .filter(|&k| {
            d.interior[k]
                && !d.valid[k]
                && d.a[k].abs() <= a_rest
                && d.y[k] > lo + margin
                && d.y[k] < hi - margin
        })
        .collect()
}

/// Filtered signals of one continuous stretch.
#[derive(Default)]
struct Stretch {
    y: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    u: Vec<f64>,
    current: Option<Vec<f64>>,
    supply: Option<Vec<f64>>,
}

impl Stretch {
    fn append(&mut self, mut o: Stretch) {
        self.y.append(&mut o.y);
        self.v.append(&mut o.v);
        self.a.append(&mut o.a);
        self.u.append(&mut o.u);
        for (mine, theirs) in [(&mut self.current, o.current), (&mut self.supply, o.supply)] {
            if let Some(t) = theirs {
                mine.get_or_insert_with(Vec::new).extend(t);
            }
        }
    }
}

/// The position and its derivatives on one thread, the command, current and supply on another.
fn prepare_stretch(d: &Dataset, fc: f64, dt: f64) -> Stretch {
    let n = d.output.len();
    let motion = || {
        let y = zero_phase(&d.output, fc, dt);
        let v = derivative(&y, dt);
        let a = derivative(&v, dt);
        (y, v, a)
    };
    let drive = || {
        (
            zero_phase(&d.input, fc, dt),
            d.current.as_ref().map(|c| zero_phase(c, fc, dt)),
            d.supply.as_ref().map(|c| zero_phase(c, fc, dt)),
        )
    };
    let ((y, v, a), (u, current, supply)) = if n < PARALLEL_SAMPLES {
        (motion(), drive())
    } else {
        std::thread::scope(|s| {
            let other = s.spawn(drive);
            let m = motion();
            (
                m,
                other
                    .join()
                    .unwrap_or_else(|e| std::panic::resume_unwind(e)),
            )
        })
    };
    Stretch {
        y,
        v,
        a,
        u,
        current,
        supply,
    }
}

/// Data sets shorter than this are prepared on one thread; a second would cost more than it
/// saves.
const PARALLEL_SAMPLES: usize = 50_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_slow_sine_are_close() {
        let dt = 1e-3;
        let w = 2.0 * std::f64::consts::PI * 2.0;
        let x: Vec<f64> = (0..4000).map(|k| (w * k as f64 * dt).sin()).collect();
        let f = zero_phase(&x, 50.0, dt);
        let v = derivative(&f, dt);
        let a = derivative(&v, dt);
        for k in 500..3500 {
            let t = k as f64 * dt;
            assert!((v[k] - w * (w * t).cos()).abs() < 0.01 * w, "v at {k}");
            assert!(
                (a[k] + w * w * (w * t).sin()).abs() < 0.02 * w * w,
                "a at {k}"
            );
        }
    }

    #[test]
    fn a_ringing_mode_is_found_and_a_slow_motion_has_none() {
        let dt = 1.0 / 610.0;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut noise = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let slow: Vec<f64> = (0..6000)
            .map(|k| (std::f64::consts::TAU * 1.3 * k as f64 * dt).sin() + 1e-6 * noise())
            .collect();
        assert_eq!(resonance_hz(&slow, dt, 35.0), None);
        // The same motion with a small mode ringing at 63 Hz on it.
        let ringing: Vec<f64> = slow
            .iter()
            .enumerate()
            .map(|(k, y)| y + 1e-3 * (std::f64::consts::TAU * 63.0 * k as f64 * dt).sin())
            .collect();
        let f = resonance_hz(&ringing, dt, 35.0).expect("the mode");
        // Within a bin (610 / 256 Hz).
        assert!((f - 63.0).abs() < 610.0 / 256.0, "{f} Hz");
        // Below the frequency asked about, it is not looked for.
        assert_eq!(resonance_hz(&ringing, dt, 100.0), None);
        // Too short a record for a spectrum.
        assert_eq!(resonance_hz(&ringing[..500], dt, 35.0), None);
    }

    #[test]
    fn the_sensor_noise_is_read_from_the_spectrum_and_its_acceleration_from_the_filter() {
        let dt = 1e-3;
        let sigma = 2e-5;
        let mut rng = crate::physics::rng::SplitMix64::new(7);
        // A motion of 5 cm at 0.7 and 3 Hz, with white sensor noise, and a jump of 1 cm
        // halfway (two records joined): the median over segments ignores the jump.
        let y: Vec<f64> = (0..20_000)
            .map(|k| {
                let t = k as f64 * dt;
                0.05 * (std::f64::consts::TAU * 0.7 * t).sin()
                    + 0.01 * (std::f64::consts::TAU * 3.0 * t).sin()
                    + if k > 10_000 { 0.01 } else { 0.0 }
                    + sigma * rng.normal()
            })
            .collect();
        let s = position_noise(&y, dt).expect("long enough");
        assert!((s / sigma - 1.0).abs() < 0.1, "{s:.3e} against {sigma:.1e}");
        // The same motion read by a noiseless sensor has (almost) none.
        let clean_noise = position_noise(
            &(0..20_000)
                .map(|k| 0.05 * (std::f64::consts::TAU * 0.7 * k as f64 * dt).sin())
                .collect::<Vec<_>>(),
            dt,
        )
        .expect("long enough");
        assert!(clean_noise < 0.01 * sigma, "{clean_noise:.3e}");
        assert!(position_noise(&y[..900], dt).is_none());
        // The gain from the impulse response against the filtered acceleration of pure noise
        // (prepare's own pipeline).
        let noise: Vec<f64> = (0..40_000).map(|_| rng.normal()).collect();
        for fc in [20.0, 50.0, 200.0] {
            let a = derivative(&derivative(&zero_phase(&noise, fc, dt), dt), dt);
            let measured = (a[1000..39_000].iter().map(|x| x * x).sum::<f64>() / 38_000.0).sqrt();
            let gain = acceleration_noise_gain(fc, dt);
            assert!(
                (gain / measured - 1.0).abs() < 0.05,
                "{fc} Hz: {gain} vs {measured}"
            );
        }
    }

    #[test]
    fn rest_before_the_first_motion_and_after_the_last_counts() {
        // 2 s at rest at 0.05 m, 4 s of a sine about it (0 to 0.1 m), 2 s at rest again.
        let dt = 1e-3;
        let w = std::f64::consts::TAU * 0.5;
        let y = |t: f64| {
            if (2.0..6.0).contains(&t) {
                0.05 + 0.05 * (w * (t - 2.0)).sin()
            } else {
                0.05
            }
        };
        let time: Vec<f64> = (0..8000).map(|k| k as f64 * dt).collect();
        let d = Dataset {
            origin: "rest".into(),
            output: time.iter().map(|&t| y(t)).collect(),
            input: vec![0.0; time.len()],
            time,
            supply: None,
            current: None,
        };
        let p = prepare(&d, None);
        let rest = standstill_samples(&p);
        let before = rest.iter().filter(|&&k| k < 1900).count();
        let after = rest.iter().filter(|&&k| k > 6100).count();
        // The filter's edges (its settling at the record's ends) aside, most of both stretches.
        assert!(
            before > 1000 && after > 1000,
            "{before} before, {after} after"
        );
        // Motion is not rest.
        assert!(!rest
            .iter()
            .any(|&k| (2300..5700).contains(&k) && p.valid[k]));
    }

    #[test]
    fn zero_phase_equals_four_separate_passes() {
        let dt = 1e-3;
        let x: Vec<f64> = (0..3000)
            .map(|k| (k as f64 * 0.01).sin() + if k % 97 < 40 { 0.5 } else { -0.2 })
            .collect();
        let alpha = 1.0 - (-2.0 * std::f64::consts::PI * 20.0 * dt).exp();
        // The filter as its definition reads: four separate first-order passes.
        let mut want = x.clone();
        for reverse in [false, false, true, true] {
            let mut s = if reverse {
                want[want.len() - 1]
            } else {
                want[0]
            };
            let mut pass = |v: &mut f64| {
                s += alpha * (*v - s);
                *v = s;
            };
            if reverse {
                want.iter_mut().rev().for_each(&mut pass);
            } else {
                want.iter_mut().for_each(&mut pass);
            }
        }
        assert_eq!(zero_phase(&x, 20.0, dt), want);
        assert!(zero_phase(&[], 20.0, dt).is_empty());
    }

    #[test]
    fn derivatives_stop_at_a_gap_and_its_edges_are_not_used() {
        // Two stretches of a slow sine, far apart in position: filtered across the gap, the
        // jump would be a burst of acceleration in both.
        let dt = 1e-3;
        let w = 2.0 * std::f64::consts::PI;
        let part = |t0: f64, y0: f64, n: usize| {
            let time: Vec<f64> = (0..n).map(|k| t0 + k as f64 * dt).collect();
            Dataset {
                origin: "x".into(),
                output: time.iter().map(|t| y0 + 0.01 * (w * t).sin()).collect(),
                input: vec![0.0; n],
                supply: None,
                current: None,
                time,
            }
        };
        let (one, two) = (part(0.0, 0.0, 2000), part(0.0, 0.5, 2000));
        let d = Dataset::concat(vec![one.clone(), two.clone()]).expect("concat");
        let p = prepare(&d, None);
        assert_eq!(p.segment_starts, vec![0, 2000]);
        // Each stretch is prepared as if it came alone.
        for (alone, offset) in [(prepare(&one, None), 0), (prepare(&two, None), 2000)] {
            for (k, a) in alone.a.iter().enumerate() {
                let b = p.a[offset + k];
                assert!(
                    (a - b).abs() <= 1e-9 * a.abs().max(1.0),
                    "a at {}: {b} vs {a}",
                    offset + k
                );
            }
        }
        // Both ends of both stretches are outside the interior.
        for k in [0, 1999, 2000, 3999] {
            assert!(!p.interior[k] && !p.valid[k], "sample {k}");
        }
        assert!(p.interior[1000] && p.interior[3000]);
    }
}
