//! The balance where the body sticks and slips: the moving samples' columns taken at each
//! sample on lightly filtered signals, masked to where the body surely slides, then filtered.
//!
//! A body with dry friction in closed loop sticks and moves in hops of a few tens of
//! milliseconds (stiction above Coulomb, an integrating controller, a valve's small duty).
//! While it is held, its friction is whatever holds it, and the balance at that sample is zero
//! whatever the friction law; the friction law holds only while it slides. Written on the
//! filtered speed, the friction columns switch where the filtered speed does: the zero-phase
//! filter spreads each stop over some 10 ms, and in a record of hops most moving samples lie
//! within that reach of a stop (on `actuator sim --family motor_gear`, 86 % of them, where the
//! residual was 55 times that of the samples away from a stop).
//!
//! So the balance is taken at each sample first, on lightly filtered signals (0.45 of the sample
//! rate: a hop stays sharp, its noise is filtered afterwards), and multiplied by the motion mask
//! `m_k` (1 where the body surely slides): a held sample's balance is zero with the true
//! parameters, so dropping it is exact, and only a slow slide taken as held is information lost.
//! Then each column goes through the regression's filter, `φ_j = LP(m φ_j^raw)` (Σ θ_j LP(m φ_j)
//! = LP(m Σ θ_j φ_j): still linear in the parameters). These columns replace the moving
//! samples'; the samples at rest keep the columns of the filtered signals for the check of the
//! friction the balance demands there.

use super::data::Dataset;
use super::regress::Term;
use super::signals::{abs_quantile, derivative, prepare, zero_phase, Prepared};

/// Corner of the light filter that keeps a hop of the load sharp: the highest the regression's
/// filter takes, 0.45 of the sample rate.
pub const LIGHT_CORNER_PER_RATE: f64 = 0.45;

/// A sample counts as moving where the lightly filtered speed exceeds this many standard
/// deviations of its noise.
pub const MOTION_NOISE_SIGMAS: f64 = 4.0;

/// ... and this share of the 95 % quantile of the speed (an ideal sensor has no noise floor, but
/// the light filter's tails reach a few samples into a rest).
pub const MOTION_SPEED_SHARE: f64 = 0.02;

/// Below this share of the moving samples surely sliding, the mask is not used.
pub const MIN_MASKED_SHARE: f64 = 0.05;

/// Replace the moving samples' columns of `terms` by the masked balance: `build` makes the same
/// terms, in the same order, on the signals it is given (the lightly filtered ones here).
pub fn in_motion(
    raw: &Dataset,
    d: &Prepared,
    terms: &mut [Term],
    build: &dyn Fn(&Prepared, &mut Vec<Term>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let n = d.y.len();
    if n < 8 || raw.len() != n {
        return Ok(());
    }
    let light_hz = (LIGHT_CORNER_PER_RATE / d.dt).max(d.cutoff_hz);
    let light = prepare(raw, Some(light_hz));
    let mask = motion_mask(raw, d, &light);
    // Where the mask keeps almost none of the moving samples, the record does not resolve its
    // stops (a limit cycle at 100 Hz: the motion between samples reads as the sensor's noise and
    // lifts the threshold over every speed); masked, the balance would be zero everywhere and
    // judge nothing, so the moving samples keep their own columns.
    let moving = (0..n).filter(|&k| d.valid[k]).count();
    let kept = (0..n).filter(|&k| d.valid[k] && mask[k] > 0.0).count();
    if (kept as f64) < MIN_MASKED_SHARE * moving as f64 {
        return Ok(());
    }
    let mut cols: Vec<Term> = Vec::with_capacity(terms.len());
    build(&light, &mut cols)?;
    if cols.len() != terms.len() || cols.iter().zip(terms.iter()).any(|(a, b)| a.name != b.name) {
        anyhow::bail!(
            "{}: the balance's terms at each sample do not match its terms",
            raw.origin
        );
    }
    let mut ends: Vec<usize> = d.segment_starts.iter().skip(1).copied().collect();
    ends.push(n);
    for (t, c) in terms.iter_mut().zip(cols) {
        let masked: Vec<f64> = c.col.iter().zip(&mask).map(|(x, m)| x * m).collect();
        for (&start, &end) in d.segment_starts.iter().zip(&ends) {
            let filtered = zero_phase(&masked[start..end], d.cutoff_hz, d.dt);
            for (k, f) in (start..end).zip(filtered) {
                if d.valid[k] {
                    t.col[k] = f;
                }
            }
        }
    }
    Ok(())
}

/// 1 where the load surely slides, 0 where it may be held: the lightly filtered speed beyond
/// its noise (from the position's noise about the regression's filtered position, through the
/// light filter and the difference) and beyond a small share of the speeds of the record.
pub fn motion_mask(raw: &Dataset, d: &Prepared, light: &Prepared) -> Vec<f64> {
    let n = d.y.len();
    let mut dev: Vec<f64> = (0..n)
        .filter(|&k| d.interior[k])
        .map(|k| raw.output[k] - d.y[k])
        .collect();
    if dev.is_empty() {
        dev = (0..n).map(|k| raw.output[k] - d.y[k]).collect();
    }
    // Median absolute deviation: the motion's own share of the deviation stays out.
    let sigma_y = 1.4826 * abs_quantile(&dev, 0.5);
    let gain = speed_noise_gain(light.cutoff_hz, d.dt);
    let threshold =
        (MOTION_NOISE_SIGMAS * gain * sigma_y).max(MOTION_SPEED_SHARE * abs_quantile(&d.v, 0.95));
    let fast: Vec<bool> = light.v.iter().map(|v| v.abs() > threshold).collect();
    // A sample next to one that may be held is taken as held too: the light filter still
    // spreads a start or a stop over a sample.
    (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(1), (k + 2).min(n));
            if fast[lo..hi].iter().all(|f| *f) {
                1.0
            } else {
                0.0
            }
        })
        .collect()
}

/// Standard deviation of the lightly filtered speed per unit of white position noise: the root
/// sum of squares of the filter-and-difference's impulse response.
fn speed_noise_gain(cutoff_hz: f64, dt: f64) -> f64 {
    let mut x = vec![0.0; 257];
    x[128] = 1.0;
    let v = derivative(&zero_phase(&x, cutoff_hz, dt), dt);
    v.iter().map(|h| h * h).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_that_does_not_resolve_its_stops_keeps_its_own_columns() {
        // A limit cycle sampled at 100 Hz: 7 Hz, 14 samples a period, the motion between
        // samples larger than the filter leaves of it. The mask would keep none of the moving
        // samples and the masked balance would be zero on every one.
        let (dt, n) = (0.01, 2000);
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let d = Dataset {
            origin: "cycle".into(),
            output: time
                .iter()
                .map(|t| 0.01 + 0.005 * (std::f64::consts::TAU * 7.0 * t).sin())
                .collect(),
            input: time
                .iter()
                .map(|t| (std::f64::consts::TAU * 7.0 * t).cos().signum())
                .collect(),
            time,
            supply: None,
            current: None,
        };
        let prep = prepare(&d, None);
        let light = prepare(&d, Some((LIGHT_CORNER_PER_RATE / dt).max(prep.cutoff_hz)));
        let mask = motion_mask(&d, &prep, &light);
        let moving = prep.valid.iter().filter(|v| **v).count();
        let kept = (0..n).filter(|&k| prep.valid[k] && mask[k] > 0.0).count();
        assert!(moving > n / 2, "{moving} moving samples");
        assert!(kept * 20 < moving, "{kept} of {moving} kept");
        let own: Vec<f64> = prep.v.clone();
        let mut terms = vec![Term {
            name: "v".into(),
            free: true,
            value: 1.0,
            bounds: (0.0, 1.0),
            col: own.clone(),
            dry: None,
        }];
        in_motion(&d, &prep, &mut terms, &|light, t| {
            t.push(Term {
                name: "v".into(),
                free: true,
                value: 1.0,
                bounds: (0.0, 1.0),
                col: light.v.clone(),
                dry: None,
            });
            Ok(())
        })
        .expect("balance");
        assert!(
            terms[0].col == own,
            "the moving samples' columns were masked away"
        );
    }

    #[test]
    fn the_motion_mask_marks_the_hops_and_never_a_held_load() {
        // A load held between hops of 15 ms and 15 mrad, read by a sensor of 0.6 mrad quanta
        // with noise (a fixed pseudo-random sequence): held samples must never count as
        // sliding, the middle of each hop must.
        let (dt, n) = (1e-3, 3000);
        let mut d = Dataset {
            origin: "hops".into(),
            time: (0..n).map(|k| k as f64 * dt).collect(),
            input: vec![0.0; n],
            output: vec![0.0; n],
            supply: None,
            current: None,
        };
        let mut moving = vec![false; n];
        let (mut pos, mut noise) = (0.0f64, 12345u64);
        for (k, (out, mv)) in d.output.iter_mut().zip(moving.iter_mut()).enumerate() {
            let phase = k % 200;
            if (100..115).contains(&phase) {
                // A raised cosine of speed: 15 mrad in 15 samples.
                let s = (phase - 100) as f64 / 15.0;
                pos += 1e-3 * (1.0 - (std::f64::consts::TAU * s).cos());
                *mv = true;
            }
            noise = noise
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (noise >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            *out = ((pos + 4e-4 * r) / 6e-4).round() * 6e-4;
        }
        let prep = prepare(&d, None);
        let light = prepare(&d, Some(LIGHT_CORNER_PER_RATE / dt));
        let mask = motion_mask(&d, &prep, &light);
        for (k, m) in mask.iter().enumerate() {
            let near = (k.saturating_sub(1)..(k + 2).min(n)).any(|j| moving[j]);
            if !near {
                assert_eq!(*m, 0.0, "held load taken as sliding at {k}");
            }
        }
        for hop in (100..n).step_by(200) {
            assert_eq!(mask[hop + 7], 1.0, "middle of the hop at {hop}");
        }
    }
}
