//! What is left in a residual and where it lives: the residual mapped against the signals a
//! force can depend on (position, velocity, acceleration, command, command rate, supply, time)
//! and searched for the shapes no effect of the catalogue makes, a force periodic in position
//! (cogging, a ripple, an eccentric gear), an oscillation in time and a slow drift.
//!
//! The diagnosis uses it to say "none of the catalogue, and here is where the error lives": a
//! structure holding at least [`MIN_SHARE`] of the residual's variance makes the verdict
//! `unexplained` when no candidate is significant, or when the best candidate only imitates it
//! ([`imitates`]: the structure's own model fits the error better, and most of what the
//! candidate removes is the structure). A candidate that removes an effect of its own and leaves
//! the structure keeps its verdict, and the structure is named beside it (two causes).
//!
//! A periodic structure is a sinusoid in the signal on top of a cubic polynomial in it (so that
//! a slow trend, a spring or a payload, does not read as a long period); its period is searched
//! on the residual's means over fine bins of the signal, then refined on the samples.

use nalgebra::{Matrix2, Matrix4, Matrix4x2, Vector2, Vector4};
use serde::Serialize;

use super::data::Dataset;
use super::signals::Prepared;

/// Smallest share of the residual's variance a structure must hold to count.
pub const MIN_SHARE: f64 = 0.3;

/// A candidate imitates a structure when at least this share of what it removes from the
/// residual's mean square is the structure's.
pub const IMITATION_SHARE: f64 = 0.5;

/// Share of the position's variance at a period from which the period counts as the motion's.
const MOTION_SHARE: f64 = 0.02;

/// How close to an exact multiple of a motion's component an oscillation must peak to be its
/// harmonic (relative).
const HARMONIC_MATCH: f64 = 0.005;

/// Fewest periods a periodic structure shows over the signal's range: fewer read as a trend.
const MIN_PERIODS: f64 = 3.0;

/// Bins of the period search.
const SEARCH_BINS: usize = 2048;

/// Shortest period searched, in bins of the search.
const MIN_PERIOD_BINS: f64 = 16.0;

/// Step of the period grid (relative); the refinement closes it on the samples.
const PERIOD_STEP: f64 = 0.004;

/// Bins of the residual map, of equal count.
const MAP_BINS: usize = 16;

/// A signal the residual is mapped against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Against {
    Position,
    Velocity,
    Acceleration,
    Command,
    CommandRate,
    Supply,
    Time,
}

impl Against {
    /// Every signal, in the order of the map.
    pub const ALL: [Against; 7] = [
        Against::Position,
        Against::Velocity,
        Against::Acceleration,
        Against::Command,
        Against::CommandRate,
        Against::Supply,
        Against::Time,
    ];

    /// The name in `--json` and the report.
    pub fn name(self) -> &'static str {
        match self {
            Against::Position => "position",
            Against::Velocity => "velocity",
            Against::Acceleration => "acceleration",
            Against::Command => "command",
            Against::CommandRate => "command_rate",
            Against::Supply => "supply",
            Against::Time => "time",
        }
    }

    /// The signal at the residual's samples, or `None` when the record lacks it.
    fn series(self, index: &[usize], data: &Dataset, d: &Prepared) -> Option<Vec<f64>> {
        let at = |x: &[f64]| index.iter().map(|&k| x[k]).collect();
        match self {
            Against::Position => Some(at(&d.y)),
            Against::Velocity => Some(at(&d.v)),
            Against::Acceleration => Some(at(&d.a)),
            Against::Command => Some(at(&d.u)),
            Against::CommandRate => {
                let n = d.u.len();
                Some(
                    index
                        .iter()
                        .map(|&k| {
                            let (lo, hi) = (k.saturating_sub(1), (k + 1).min(n - 1));
                            // u' ≈ (u_{k+1} - u_{k-1}) / (t_{k+1} - t_{k-1})
                            (d.u[hi] - d.u[lo]) / (((hi - lo) as f64) * d.dt).max(f64::MIN_POSITIVE)
                        })
                        .collect(),
                )
            }
            Against::Supply => d.supply.as_ref().map(|s| at(s)),
            Against::Time => Some(at(&data.time)),
        }
    }
}

/// The shape of a structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A sinusoid in the signal.
    Periodic,
    /// A slow change over the record (a cubic in time).
    Drift,
}

/// One structure found in a residual.
#[derive(Debug, Clone, Serialize)]
pub struct Structure {
    /// The signal it lives on.
    pub against: Against,
    /// Its shape.
    pub kind: Kind,
    /// Period in the signal's unit (m, rad or s), for a periodic structure.
    pub period: Option<f64>,
    /// Amplitude in the residual's unit (N or N·m): the sinusoid's, or half the drift's span.
    pub amplitude: f64,
    /// Share of the residual's variance it holds.
    pub share: f64,
    /// Its mean square in the residual (the residual's unit squared): what a candidate must
    /// halve to explain it.
    pub mean_square: f64,
}

impl Structure {
    /// Where it lives, for a person: `periodic in position: period 12.5 mm, amplitude 30 N
    /// (41 % of the residual's variance)`.
    pub fn describe(&self, position_unit: &str, force_unit: &str) -> String {
        let share = 100.0 * self.share;
        match (self.kind, self.against, self.period) {
            (Kind::Periodic, Against::Time, Some(p)) => format!(
                "oscillation in time: period {p:.4} s ({:.2} Hz), amplitude {:.3} {force_unit} \
                 ({share:.0} % of the residual's variance)",
                1.0 / p,
                self.amplitude
            ),
            (Kind::Periodic, against, Some(p)) => format!(
                "periodic in {}: period {}, amplitude {:.3} {force_unit} ({share:.0} % of the \
                 residual's variance)",
                against.name().replace('_', " "),
                length(p, against, position_unit),
                self.amplitude
            ),
            _ => format!(
                "slow drift in {}: ±{:.3} {force_unit} over the record ({share:.0} % of the \
                 residual's variance)",
                self.against.name().replace('_', " "),
                self.amplitude
            ),
        }
    }

    /// What it may be, since no effect of the catalogue makes it.
    pub fn hint(&self) -> &'static str {
        match (self.kind, self.against) {
            (Kind::Periodic, Against::Position) => {
                "not an effect of the catalogue: a cogging force, a ripple of the drive, an \
                 eccentric gear or screw?"
            }
            (Kind::Periodic, Against::Time) => {
                "not an effect of the catalogue: a vibration from outside, a resonance the \
                 model lacks?"
            }
            (Kind::Drift, _) => {
                "not an effect of the catalogue: warming, a drifting supply or sensor, wear?"
            }
            _ => "not an effect of the catalogue",
        }
    }
}

/// A period in the unit of its signal, readable.
fn length(p: f64, against: Against, position_unit: &str) -> String {
    match (against, position_unit) {
        (Against::Position, "m") if p < 1.0 => format!("{:.3} mm", 1e3 * p),
        (Against::Position, "rad") => format!("{p:.4} rad ({:.2}°)", p.to_degrees()),
        (Against::Position, u) => format!("{p:.4} {u}"),
        _ => format!("{p:.4e}"),
    }
}

/// The residual's means over bins of one signal, and the share of its variance they hold.
#[derive(Debug, Clone, Serialize)]
pub struct MapRow {
    /// The signal.
    pub against: Against,
    /// Share of the residual's variance the bin means hold (between-bin over total).
    pub share: f64,
    /// Mean of the signal in each bin (bins of equal count).
    pub centres: Vec<f64>,
    /// Mean of the residual in each bin.
    pub means: Vec<f64>,
}

/// The residual mapped against every signal, and the structures found in it.
#[derive(Debug, Clone, Serialize, Default)]
pub struct ResidualMap {
    /// RMS of the residual.
    pub rms: f64,
    /// One row per signal the record has.
    pub rows: Vec<MapRow>,
    /// Structures holding at least [`MIN_SHARE`] of the residual's variance, largest first.
    pub structures: Vec<Structure>,
}

/// Map `residual` (on the samples `index`) and search it for structure.
pub fn analyse(residual: &[f64], index: &[usize], data: &Dataset, d: &Prepared) -> ResidualMap {
    let n = residual.len().min(index.len());
    if n < 4 * MAP_BINS {
        return ResidualMap::default();
    }
    let (residual, index) = (&residual[..n], &index[..n]);
    let mean = residual.iter().sum::<f64>() / n as f64;
    let r: Vec<f64> = residual.iter().map(|x| x - mean).collect();
    let total: f64 = r.iter().map(|x| x * x).sum();
    let mut map = ResidualMap {
        rms: (total / n as f64).sqrt(),
        ..ResidualMap::default()
    };
    if total <= 0.0 {
        return map;
    }
    for against in Against::ALL {
        let Some(s) = against.series(index, data, d) else {
            continue;
        };
        map.rows.push(map_row(against, &s, &r, total));
        if matches!(against, Against::Position | Against::Time) {
            if let Some((period, amplitude, explained)) = periodic(&s, &r)
                .filter(|&(p, _, _)| against != Against::Time || !at_motion(&s, index, d, p))
            {
                map.structures.push(Structure {
                    against,
                    kind: Kind::Periodic,
                    period: Some(period),
                    amplitude,
                    share: explained / total,
                    mean_square: explained / n as f64,
                });
            }
        }
        if against == Against::Time {
            let (amplitude, explained) = drift(&s, &r);
            map.structures.push(Structure {
                against,
                kind: Kind::Drift,
                period: None,
                amplitude,
                share: explained / total,
                mean_square: explained / n as f64,
            });
        }
    }
    map.structures.retain(|s| s.share >= MIN_SHARE);
    map.structures
        .sort_by(|a, b| b.mean_square.total_cmp(&a.mean_square));
    map
}

/// True when the motion itself has a component at period `p` in time, or at its double or
/// triple (the structure is a harmonic of it): an error of a term that follows the motion, which
/// the candidates judge, not an oscillation from outside. The motion's component must hold
/// [`MOTION_SHARE`] of the position's variance and peak within [`HARMONIC_MATCH`] of `n p`: a
/// harmonic sits at an exact multiple, an oscillation from outside only near one by chance.
fn at_motion(t: &[f64], index: &[usize], d: &Prepared, p: f64) -> bool {
    let y: Vec<f64> = index.iter().map(|&k| d.y[k]).collect();
    let mean = y.iter().sum::<f64>() / y.len().max(1) as f64;
    let y: Vec<f64> = y.iter().map(|v| v - mean).collect();
    let total: f64 = y.iter().map(|v| v * v).sum();
    let samples: Vec<(f64, f64, f64)> = t.iter().zip(&y).map(|(&ti, &yi)| (1.0, ti, yi)).collect();
    let Some(cubic) = Cubic::fit(Span::of(t), &samples) else {
        return false;
    };
    let explained = |p: f64| cubic.sinusoid(&samples, p).map_or(0.0, |f| f.1);
    total > 0.0
        && [1.0, 2.0, 3.0].iter().any(|n| {
            let (peak, e) = golden_max(&explained, n * p / 1.03, n * p * 1.03);
            e >= MOTION_SHARE * total && (peak / (n * p) - 1.0).abs() < HARMONIC_MATCH
        })
}

/// The maximum of `f` over `[lo, hi]` by golden section on a log scale: where and how much.
fn golden_max(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (lo.ln(), hi.ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1.exp()), f(x2.exp()));
    for _ in 0..20 {
        if f1 > f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1.exp());
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2.exp());
        }
    }
    if f1 > f2 {
        (x1.exp(), f1)
    } else {
        (x2.exp(), f2)
    }
}

/// The mean square that `structure` (same signal, shape and period; amplitude refitted) holds
/// in another residual: what is left of it after a candidate.
pub fn held(
    structure: &Structure,
    residual: &[f64],
    index: &[usize],
    data: &Dataset,
    d: &Prepared,
) -> f64 {
    let n = residual.len().min(index.len());
    if n == 0 {
        return 0.0;
    }
    let Some(s) = structure.against.series(&index[..n], data, d) else {
        return 0.0;
    };
    let mean = residual[..n].iter().sum::<f64>() / n as f64;
    let r: Vec<f64> = residual[..n].iter().map(|x| x - mean).collect();
    let explained = match (structure.kind, structure.period) {
        (Kind::Periodic, Some(p)) => sinusoid_at(&s, &r, p).map_or(0.0, |f| f.1),
        _ => drift(&s, &r).1,
    };
    explained / n as f64
}

/// True when a candidate only imitates `structure`: the structure's own model (a sinusoid on its
/// signal, a drift) leaves less error than the candidate does (`MS_base - S < MS_cand`), and at
/// least [`IMITATION_SHARE`] of what the candidate removes is the structure
/// (`S - S_held ≥ ½ (MS_base - MS_cand)`), as a play or a dead zone in a loop that fights an
/// oscillation makes a square wave at its frequency. `held` is what the structure keeps in the
/// candidate's residual ([`held`]), the mean squares are the residuals' before and after.
pub fn imitates(structure: &Structure, held: f64, ms_base: f64, ms_candidate: f64) -> bool {
    let fits_better = ms_base - structure.mean_square < ms_candidate;
    let removed = (ms_base - ms_candidate).max(0.0);
    fits_better && structure.mean_square - held >= IMITATION_SHARE * removed
}

fn map_row(against: Against, s: &[f64], r: &[f64], total: f64) -> MapRow {
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
    let per = order.len() / MAP_BINS;
    let (mut centres, mut means) = (Vec::new(), Vec::new());
    let mut between = 0.0;
    for b in 0..MAP_BINS {
        let end = if b + 1 == MAP_BINS {
            order.len()
        } else {
            (b + 1) * per
        };
        let bin = &order[b * per..end];
        let m = bin.len().max(1) as f64;
        let c = bin.iter().map(|&i| s[i]).sum::<f64>() / m;
        let mean = bin.iter().map(|&i| r[i]).sum::<f64>() / m;
        between += m * mean * mean;
        centres.push(c);
        means.push(mean);
    }
    MapRow {
        against,
        share: between / total,
        centres,
        means,
    }
}

/// The range of a signal, mapped to [-1, 1] for the polynomial's columns.
struct Span {
    mid: f64,
    half: f64,
}

impl Span {
    fn of(s: &[f64]) -> Span {
        let lo = s.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Span {
            mid: 0.5 * (lo + hi),
            half: (0.5 * (hi - lo)).max(f64::MIN_POSITIVE),
        }
    }
    fn x(&self, s: f64) -> f64 {
        (s - self.mid) / self.half
    }
}

/// The cubic in a signal, fitted by weighted least squares once per signal; the sinusoids of the
/// search are fitted beyond it by the partial regression (its Schur complement), so that a
/// period costs a few sums, not a new solve.
struct Cubic {
    span: Span,
    /// Inverse of `Σ w p pᵀ`, `p = [1, x, x², x³]`.
    inverse: Matrix4<f64>,
    /// `Σ w p y`.
    moment: Vector4<f64>,
    /// Coefficients of the cubic.
    theta: Vector4<f64>,
}

/// `[1, x, x², x³]`.
fn powers(x: f64) -> Vector4<f64> {
    Vector4::new(1.0, x, x * x, x * x * x)
}

impl Cubic {
    /// Fit on `(weight, signal, value)`.
    fn fit(span: Span, rows: &[(f64, f64, f64)]) -> Option<Cubic> {
        let mut gram = Matrix4::zeros();
        let mut moment = Vector4::zeros();
        for &(w, s, y) in rows {
            let p = powers(span.x(s));
            for i in 0..4 {
                moment[i] += w * p[i] * y;
                for j in 0..4 {
                    gram[(i, j)] += w * p[i] * p[j];
                }
            }
        }
        let inverse = gram.try_inverse()?;
        let theta = inverse * moment;
        Some(Cubic {
            span,
            inverse,
            moment,
            theta,
        })
    }

    /// The part of `Σ w y²` the cubic explains beyond the weighted mean.
    fn explained_beyond_mean(&self, rows: &[(f64, f64, f64)]) -> f64 {
        let (sw, swy) = rows
            .iter()
            .fold((0.0, 0.0), |(a, b), &(w, _, y)| (a + w, b + w * y));
        // θᵀ Xᵀ W y is what a least-squares fit explains of Σ w y².
        self.theta.dot(&self.moment) - swy * swy / sw.max(f64::MIN_POSITIVE)
    }

    /// The sinusoid of period `p` fitted beyond the cubic: its amplitude and the part of the sum
    /// of squares it explains.
    fn sinusoid(&self, rows: &[(f64, f64, f64)], p: f64) -> Option<(f64, f64)> {
        let k = std::f64::consts::TAU / p;
        // Σ w z zᵀ, Σ w p zᵀ and Σ w z y with z = [sin, cos](2π s / P).
        let (mut ss, mut sc, mut cc) = (0.0, 0.0, 0.0);
        let mut pz = Matrix4x2::zeros();
        let (mut sy, mut cy) = (0.0, 0.0);
        for &(w, s, y) in rows {
            let (sn, cs) = (k * s).sin_cos();
            let x = self.span.x(s);
            let mut xi = w;
            for i in 0..4 {
                pz[(i, 0)] += xi * sn;
                pz[(i, 1)] += xi * cs;
                xi *= x;
            }
            ss += w * sn * sn;
            sc += w * sn * cs;
            cc += w * cs * cs;
            sy += w * sn * y;
            cy += w * cs * y;
        }
        // The sinusoid's columns after the cubic is taken out of them (Schur complement).
        let a = Matrix2::new(ss, sc, sc, cc) - pz.transpose() * self.inverse * pz;
        let b = Vector2::new(sy, cy) - pz.transpose() * self.theta;
        let coef = a.try_inverse()? * b;
        Some((coef[0].hypot(coef[1]), coef.dot(&b).max(0.0)))
    }
}

/// The best sinusoid in `s` on top of a cubic: its period, amplitude and the part of the
/// residual's sum of squares it explains beyond the cubic; `None` when the signal spans too
/// little for [`MIN_PERIODS`].
fn periodic(s: &[f64], r: &[f64]) -> Option<(f64, f64, f64)> {
    let span = Span::of(s);
    let range = 2.0 * span.half;
    let width = range / SEARCH_BINS as f64;
    let (p_min, p_max) = (MIN_PERIOD_BINS * width, range / MIN_PERIODS);
    if p_max <= p_min {
        return None;
    }
    // The means over fine bins: the search costs bins, not samples.
    let mut count = vec![0.0; SEARCH_BINS];
    let mut sum_r = vec![0.0; SEARCH_BINS];
    let mut sum_s = vec![0.0; SEARCH_BINS];
    for (&si, &ri) in s.iter().zip(r) {
        let b = (((si - span.mid + span.half) / width) as usize).min(SEARCH_BINS - 1);
        count[b] += 1.0;
        sum_r[b] += ri;
        sum_s[b] += si;
    }
    let bins: Vec<(f64, f64, f64)> = (0..SEARCH_BINS)
        .filter(|&b| count[b] > 0.0)
        .map(|b| (count[b], sum_s[b] / count[b], sum_r[b] / count[b]))
        .collect();
    let binned = Cubic::fit(Span::of(s), &bins)?;
    let steps = ((p_max / p_min).ln() / PERIOD_STEP.ln_1p()).ceil() as usize;
    let mut best: Option<(f64, f64)> = None;
    for i in 0..=steps {
        let p = p_min * (1.0 + PERIOD_STEP).powi(i as i32);
        if let Some((_, e)) = binned.sinusoid(&bins, p) {
            if best.is_none_or(|(_, b)| e > b) {
                best = Some((p, e));
            }
        }
    }
    let (p0, _) = best?;
    // Golden section over two grid steps each side, on the samples.
    let samples: Vec<(f64, f64, f64)> = s.iter().zip(r).map(|(&si, &ri)| (1.0, si, ri)).collect();
    let cubic = Cubic::fit(span, &samples)?;
    let on_samples = |p: f64| cubic.sinusoid(&samples, p).map_or(0.0, |f| f.1);
    let step = (1.0 + PERIOD_STEP).powi(2);
    let (p, _) = golden_max(&on_samples, p0 / step, p0 * step);
    let (amplitude, e) = cubic.sinusoid(&samples, p)?;
    Some((p, amplitude, e))
}

/// The sinusoid of period `p` in `s` on top of a cubic, fitted on the samples: its amplitude
/// and the part of the sum of squares it explains beyond the cubic.
fn sinusoid_at(s: &[f64], r: &[f64], p: f64) -> Option<(f64, f64)> {
    let samples: Vec<(f64, f64, f64)> = s.iter().zip(r).map(|(&si, &ri)| (1.0, si, ri)).collect();
    Cubic::fit(Span::of(s), &samples)?.sinusoid(&samples, p)
}

/// The slow drift of a residual over time: a cubic in time beyond the mean; half its span over
/// the record and the part of the sum of squares it explains.
fn drift(t: &[f64], r: &[f64]) -> (f64, f64) {
    let samples: Vec<(f64, f64, f64)> = t.iter().zip(r).map(|(&ti, &ri)| (1.0, ti, ri)).collect();
    let Some(cubic) = Cubic::fit(Span::of(t), &samples) else {
        return (0.0, 0.0);
    };
    let th = cubic.theta;
    let values: Vec<f64> = (0..=64)
        .map(|i| th.dot(&powers(-1.0 + i as f64 / 32.0)))
        .collect();
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (
        0.5 * (hi - lo),
        cubic.explained_beyond_mean(&samples).max(0.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prepared(y: Vec<f64>, dt: f64) -> (Dataset, Prepared) {
        let n = y.len();
        let time: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let data = Dataset {
            origin: "t".into(),
            time,
            input: y.iter().map(|x| 3.0 * x).collect(),
            output: y.clone(),
            supply: None,
            current: None,
        };
        let d = crate::lab::signals::prepare(&data, None);
        (data, d)
    }

    /// A deterministic noise, independent of the signals.
    fn noise(k: usize) -> f64 {
        let x = ((k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11) as f64 / (1u64 << 53) as f64;
        2.0 * x - 1.0
    }

    #[test]
    fn a_force_periodic_in_position_is_found_with_its_period_and_amplitude() {
        let dt = 1e-3;
        let y: Vec<f64> = (0..20_000)
            .map(|k| 0.1 * (0.7 * k as f64 * dt).sin() + 0.03 * (1.9 * k as f64 * dt).sin())
            .collect();
        let (data, d) = prepared(y, dt);
        let index: Vec<usize> = (200..19_800).collect();
        let pitch = 0.0125;
        let r: Vec<f64> = index
            .iter()
            .map(|&k| 30.0 * (std::f64::consts::TAU * d.y[k] / pitch + 0.4).sin() + 20.0 * noise(k))
            .collect();
        let map = analyse(&r, &index, &data, &d);
        let s = map.structures.first().expect("a structure");
        assert_eq!((s.against, s.kind), (Against::Position, Kind::Periodic));
        let p = s.period.expect("period");
        assert!((p / pitch - 1.0).abs() < 0.01, "period {p}");
        assert!(
            (s.amplitude / 30.0 - 1.0).abs() < 0.05,
            "amplitude {}",
            s.amplitude
        );
        // 450 of 450 + 133 (the noise's variance) is the sinusoid's share.
        assert!(
            (s.share - 450.0 / (450.0 + 400.0 / 3.0)).abs() < 0.05,
            "{}",
            s.share
        );
        // The same structure in a residual where it is gone: nothing held.
        let clean: Vec<f64> = index.iter().map(|&k| 20.0 * noise(k)).collect();
        assert!(held(s, &clean, &index, &data, &d) < 0.02 * s.mean_square);
        assert!(held(s, &r, &index, &data, &d) > 0.95 * s.mean_square);
        assert!(
            s.describe("m", "N").contains("period 12.5"),
            "{}",
            s.describe("m", "N")
        );
    }

    #[test]
    fn a_candidate_imitates_a_structure_only_where_the_structure_fits_better_and_is_what_it_removed(
    ) {
        let s = Structure {
            against: Against::Time,
            kind: Kind::Periodic,
            period: Some(0.2),
            amplitude: 0.8,
            share: 0.98,
            mean_square: 0.317,
        };
        // A play fighting an oscillation (measured on the independent simulator): the sinusoid
        // leaves 0.0065, the play 0.044, and what the play removed was the oscillation.
        assert!(imitates(&s, 0.0286, 0.3238, 0.0442));
        // The effect that makes the structure: it leaves less than the sinusoid does.
        assert!(!imitates(&s, 0.001, 0.3238, 0.002));
        // Two causes: the candidate removes an effect of its own and keeps the structure.
        assert!(!imitates(&s, 0.31, 0.6, 0.33));
    }

    #[test]
    fn noise_and_a_trend_in_position_hold_no_structure() {
        let dt = 1e-3;
        let y: Vec<f64> = (0..20_000)
            .map(|k| 0.1 * (0.7 * k as f64 * dt).sin())
            .collect();
        let (data, d) = prepared(y, dt);
        let index: Vec<usize> = (200..19_800).collect();
        // A spring's force (a trend in position) and a Coulomb step: catalogue shapes.
        let r: Vec<f64> = index
            .iter()
            .map(|&k| 400.0 * d.y[k] + 5.0 * d.v[k].signum() + 2.0 * noise(k))
            .collect();
        let map = analyse(&r, &index, &data, &d);
        assert!(
            map.structures
                .iter()
                .all(|s| s.against != Against::Position),
            "{:?}",
            map.structures
        );
        // The map shows the step against velocity and the trend against position.
        let share = |a: Against| map.rows.iter().find(|r| r.against == a).map(|r| r.share);
        assert!(share(Against::Position).is_some_and(|s| s > 0.5));
        let noise_only: Vec<f64> = index.iter().map(|&k| noise(k)).collect();
        assert!(analyse(&noise_only, &index, &data, &d)
            .structures
            .is_empty());
    }

    #[test]
    fn an_oscillation_in_time_and_a_drift_are_told_apart() {
        let dt = 1e-3;
        let y: Vec<f64> = (0..10_000)
            .map(|k| 0.1 * (0.9 * k as f64 * dt).sin())
            .collect();
        let (data, d) = prepared(y, dt);
        let index: Vec<usize> = (100..9_900).collect();
        let t = |k: usize| k as f64 * dt;
        let osc: Vec<f64> = index
            .iter()
            .map(|&k| 2.0 * (std::f64::consts::TAU * 4.3 * t(k)).sin() + noise(k))
            .collect();
        let map = analyse(&osc, &index, &data, &d);
        let s = map.structures.first().expect("oscillation");
        assert_eq!((s.against, s.kind), (Against::Time, Kind::Periodic));
        assert!((s.period.expect("period") * 4.3 - 1.0).abs() < 0.01);
        // At the motion's own frequency (a term that follows the motion, misfitted) or at its
        // third harmonic (a dry friction's square wave), the oscillation is not one from outside.
        let times: Vec<f64> = index.iter().map(|&k| t(k)).collect();
        let motion = std::f64::consts::TAU / 0.9;
        assert!(at_motion(&times, &index, &d, motion));
        assert!(at_motion(&times, &index, &d, motion / 3.0));
        assert!(!at_motion(&times, &index, &d, 1.0 / 4.3));
        let third: Vec<f64> = index
            .iter()
            .map(|&k| 2.0 * (3.0 * 0.9 * t(k)).sin() + noise(k))
            .collect();
        let map = analyse(&third, &index, &data, &d);
        assert!(
            map.structures.iter().all(|s| s.kind != Kind::Periodic),
            "{:?}",
            map.structures
        );
        let slow: Vec<f64> = index.iter().map(|&k| 0.4 * t(k) + noise(k)).collect();
        let map = analyse(&slow, &index, &data, &d);
        let s = map.structures.first().expect("drift");
        assert_eq!((s.against, s.kind), (Against::Time, Kind::Drift));
        assert!(
            (s.amplitude - 0.4 * 9.8 / 2.0).abs() < 0.1,
            "{}",
            s.amplitude
        );
    }
}
