//! Direction-dependent ARX models (Isermann & Raab 1993, direction-dependent models).
//!
//! One linear model per direction of motion, each with its own constant offset that absorbs the
//! Coulomb friction:
//! `y(k) = -Σ_{i=1..na} a_i± y(k-i) + Σ_{j=1..nb} b_j± u(k-d-j) + C±`,
//! identified only from samples of monotone motion, `y(k) > y(k-1) > ... > y(k-n)` for `+` and
//! `y(k) < y(k-1) < ... < y(k-n)` for `-`. Standstill and reversals, which the model does not
//! cover, are left out. The regressor is `ψ(k) = [-y(k-1) .. -y(k-na), u(k-d-1) .. u(k-d-nb), 1]`
//! and `θ± = [a_1 .. a_na, b_1 .. b_nb, C±]`.
//!
//! Batch use: [`split_by_direction`] and [`fit_directional`]. Online use (feeding two recursive
//! estimators in the daemon): [`DirectionalRegressor`], which allocates only when constructed.

use nalgebra::{DMatrix, DVector};

use super::error::{check_finite, check_len, IdentError};
use super::ls::{least_squares, LsFit};

/// Direction of motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Increasing output, `y(k) > y(k-1)`.
    Positive,
    /// Decreasing output, `y(k) < y(k-1)`.
    Negative,
}

/// Structure of the ARX-with-offset model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArxOrder {
    /// Number of output lags `na`.
    pub na: usize,
    /// Number of input lags `nb`.
    pub nb: usize,
    /// Dead time `d` in samples (in addition to the one-sample delay of `u(k-1)`).
    pub delay: usize,
}

impl ArxOrder {
    /// Length of the regressor, `na + nb + 1`.
    pub fn regressor_len(&self) -> usize {
        self.na + self.nb + 1
    }

    /// Number of past samples a regressor reaches back, `max(na, d + nb)`.
    pub fn history(&self) -> usize {
        self.na.max(self.delay + self.nb)
    }
}

/// How samples are selected for the direction-dependent estimation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalSelection {
    /// Model structure.
    pub order: ArxOrder,
    /// Number `n` of successive monotone differences required, `y(k) > ... > y(k-n)`;
    /// the paper uses the model order. At least 1.
    pub window: usize,
    /// Each difference must exceed this (same unit as `y`, e.g. m) so that sensor noise at
    /// standstill is not taken for motion. 0 for exact data.
    pub min_step: f64,
}

impl DirectionalSelection {
    /// Selection with the monotone window equal to `na` (at least 1) and no dead band.
    pub fn new(order: ArxOrder) -> Self {
        Self {
            order,
            window: order.na.max(1),
            min_step: 0.0,
        }
    }

    fn validate(&self) -> Result<(), IdentError> {
        if self.window == 0 {
            return Err(IdentError::InvalidParameter {
                name: "window",
                reason: "monotone window must be at least 1 sample".into(),
            });
        }
        if !(self.min_step >= 0.0 && self.min_step.is_finite()) {
            return Err(IdentError::InvalidParameter {
                name: "min_step",
                reason: format!("must be finite and >= 0, got {}", self.min_step),
            });
        }
        Ok(())
    }

    /// First sample index that has a full history.
    pub fn first_sample(&self) -> usize {
        self.order.history().max(self.window)
    }
}

/// Direction of monotone motion ending at sample `k`: `Positive` if
/// `y(k) - y(k-1) > min_step, ..., y(k-window+1) - y(k-window) > min_step`, `Negative` for the
/// mirror case, `None` otherwise (or if `k < window`).
pub fn monotone_direction(y: &[f64], k: usize, window: usize, min_step: f64) -> Option<Direction> {
    if window == 0 || k < window || k >= y.len() {
        return None;
    }
    let diffs = (0..window).map(|i| y[k - i] - y[k - i - 1]);
    if diffs.clone().all(|d| d > min_step) {
        Some(Direction::Positive)
    } else if diffs.clone().all(|d| d < -min_step) {
        Some(Direction::Negative)
    } else {
        None
    }
}

/// Fills `out` with `ψ(k) = [-y(k-1) .. -y(k-na), u(k-d-1) .. u(k-d-nb), 1]`.
pub fn arx_regressor(
    y: &[f64],
    u: &[f64],
    k: usize,
    order: &ArxOrder,
    out: &mut [f64],
) -> Result<(), IdentError> {
    check_len("regressor buffer", order.regressor_len(), out.len())?;
    check_len("input sequence", y.len(), u.len())?;
    if k < order.history() || k >= y.len() {
        return Err(IdentError::InvalidParameter {
            name: "k",
            reason: format!(
                "sample {k} needs {} past samples within a sequence of {}",
                order.history(),
                y.len()
            ),
        });
    }
    for i in 0..order.na {
        out[i] = -y[k - i - 1];
    }
    for j in 0..order.nb {
        out[order.na + j] = u[k - order.delay - j - 1];
    }
    out[order.na + order.nb] = 1.0;
    Ok(())
}

/// Regression data for one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionData {
    /// Regressor rows `ψᵀ(k)`.
    pub psi: DMatrix<f64>,
    /// Outputs `y(k)`.
    pub y: DVector<f64>,
    /// Sample indices `k` that were selected.
    pub samples: Vec<usize>,
}

/// Selected samples of both directions.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionalData {
    /// Samples of increasing output.
    pub positive: DirectionData,
    /// Samples of decreasing output.
    pub negative: DirectionData,
}

/// Splits `y, u` into the monotone-motion samples of each direction and builds their regressors.
pub fn split_by_direction(
    y: &[f64],
    u: &[f64],
    selection: &DirectionalSelection,
) -> Result<DirectionalData, IdentError> {
    selection.validate()?;
    check_len("input sequence", y.len(), u.len())?;
    check_finite("output sequence", y)?;
    check_finite("input sequence", u)?;
    let p = selection.order.regressor_len();
    let mut rows = [Vec::new(), Vec::new()];
    let mut idx = [Vec::new(), Vec::new()];
    let mut psi = vec![0.0; p];
    for k in selection.first_sample()..y.len() {
        let Some(dir) = monotone_direction(y, k, selection.window, selection.min_step) else {
            continue;
        };
        let side = match dir {
            Direction::Positive => 0,
            Direction::Negative => 1,
        };
        arx_regressor(y, u, k, &selection.order, &mut psi)?;
        rows[side].extend_from_slice(&psi);
        idx[side].push(k);
    }
    let build = |rows: &[f64], idx: Vec<usize>| DirectionData {
        psi: DMatrix::from_row_slice(idx.len(), p, rows),
        y: DVector::from_iterator(idx.len(), idx.iter().map(|&k| y[k])),
        samples: idx,
    };
    let [rows_pos, rows_neg] = rows;
    let [idx_pos, idx_neg] = idx;
    Ok(DirectionalData {
        positive: build(&rows_pos, idx_pos),
        negative: build(&rows_neg, idx_neg),
    })
}

/// Parameters of one direction's model, unpacked from `θ`.
#[derive(Debug, Clone, PartialEq)]
pub struct ArxParameters {
    /// `a_1 .. a_na`.
    pub a: Vec<f64>,
    /// `b_1 .. b_nb`.
    pub b: Vec<f64>,
    /// Offset `C±` (unit of y).
    pub offset: f64,
}

impl ArxParameters {
    /// Unpacks `θ = [a, b, C]`.
    pub fn from_theta(theta: &[f64], order: &ArxOrder) -> Result<Self, IdentError> {
        check_len("parameter vector", order.regressor_len(), theta.len())?;
        Ok(Self {
            a: theta[..order.na].to_vec(),
            b: theta[order.na..order.na + order.nb].to_vec(),
            offset: theta[order.na + order.nb],
        })
    }

    /// Static gain `Σb / (1 + Σa)`; infinite for an integrating model.
    pub fn static_gain(&self) -> f64 {
        self.b.iter().sum::<f64>() / (1.0 + self.a.iter().sum::<f64>())
    }
}

/// Least-squares fits of both directions.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionalFit {
    /// Increasing output.
    pub positive: LsFit,
    /// Decreasing output.
    pub negative: LsFit,
    /// Sample indices used for the positive direction.
    pub positive_samples: Vec<usize>,
    /// Sample indices used for the negative direction.
    pub negative_samples: Vec<usize>,
    /// The model structure.
    pub order: ArxOrder,
}

impl DirectionalFit {
    /// The fit of one direction.
    pub fn fit(&self, direction: Direction) -> &LsFit {
        match direction {
            Direction::Positive => &self.positive,
            Direction::Negative => &self.negative,
        }
    }

    /// Unpacked parameters of one direction.
    pub fn parameters(&self, direction: Direction) -> Result<ArxParameters, IdentError> {
        ArxParameters::from_theta(self.fit(direction).theta.as_slice(), &self.order)
    }
}

/// Separate least-squares estimation for each direction of motion.
pub fn fit_directional(
    y: &[f64],
    u: &[f64],
    selection: &DirectionalSelection,
) -> Result<DirectionalFit, IdentError> {
    let data = split_by_direction(y, u, selection)?;
    let positive = least_squares(&data.positive.psi, &data.positive.y)?;
    let negative = least_squares(&data.negative.psi, &data.negative.y)?;
    Ok(DirectionalFit {
        positive,
        negative,
        positive_samples: data.positive.samples,
        negative_samples: data.negative.samples,
        order: selection.order,
    })
}

/// Online selection: keeps the recent history in fixed buffers and, per sample, hands out the
/// regressor when the motion is monotone, for the estimator of that direction.
#[derive(Debug, Clone)]
pub struct DirectionalRegressor {
    selection: DirectionalSelection,
    /// `y_hist[i] = y(k-i)`.
    y_hist: Vec<f64>,
    /// `u_hist[i] = u(k-i)`.
    u_hist: Vec<f64>,
    filled: usize,
    psi: Vec<f64>,
}

impl DirectionalRegressor {
    /// Allocates the history buffers.
    pub fn new(selection: DirectionalSelection) -> Result<Self, IdentError> {
        selection.validate()?;
        let order = selection.order;
        Ok(Self {
            selection,
            y_hist: vec![0.0; order.na.max(selection.window) + 1],
            u_hist: vec![0.0; order.delay + order.nb + 1],
            filled: 0,
            psi: vec![0.0; order.regressor_len()],
        })
    }

    /// Forgets the history (e.g. after a fault or a restart of estimation).
    pub fn reset(&mut self) {
        self.filled = 0;
    }

    /// Takes `y(k)` and `u(k)`; returns the direction and `ψ(k)` (the measurement to pair it
    /// with is `y(k)`) when the last `window` differences are monotone, else `None`.
    /// Non-finite samples clear the history.
    pub fn push(&mut self, y: f64, u: f64) -> Option<(Direction, &[f64])> {
        if !(y.is_finite() && u.is_finite()) {
            self.filled = 0;
            return None;
        }
        let ly = self.y_hist.len();
        self.y_hist.copy_within(0..ly - 1, 1);
        self.y_hist[0] = y;
        let lu = self.u_hist.len();
        self.u_hist.copy_within(0..lu - 1, 1);
        self.u_hist[0] = u;
        self.filled = (self.filled + 1).min(usize::MAX - 1);
        let s = &self.selection;
        if self.filled <= s.first_sample() {
            return None;
        }
        let diffs = (0..s.window).map(|i| self.y_hist[i] - self.y_hist[i + 1]);
        let dir = if diffs.clone().all(|d| d > s.min_step) {
            Direction::Positive
        } else if diffs.clone().all(|d| d < -s.min_step) {
            Direction::Negative
        } else {
            return None;
        };
        let o = s.order;
        for i in 0..o.na {
            self.psi[i] = -self.y_hist[i + 1];
        }
        for j in 0..o.nb {
            self.psi[o.na + j] = self.u_hist[o.delay + j + 1];
        }
        self.psi[o.na + o.nb] = 1.0;
        Some((dir, &self.psi))
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops read closer to the equations
mod tests {
    use super::*;
    use crate::ident::dsfi::{Dsfi, DsfiConfig};
    use crate::ident::recursive::RecursiveEstimator;
    use crate::ident::testutil::TestRng;

    const POS: [f64; 5] = [-1.5, 0.6, 0.08, 0.04, -0.010];
    const NEG: [f64; 5] = [-1.4, 0.5, 0.07, 0.05, 0.012];

    /// A plant that moves with the `+` model when that model moves it up, with the `-` model
    /// when that one moves it down, and sticks otherwise (Coulomb friction).
    fn simulate(seed: u64, n: usize, noise: f64) -> (Vec<f64>, Vec<f64>) {
        let mut rng = TestRng::new(seed);
        let mut u = vec![0.0; n];
        let mut level = 0.0;
        for (k, uk) in u.iter_mut().enumerate() {
            if k % 25 == 0 {
                level = 0.4 * (2.0 * rng.uniform() - 1.0);
            }
            *uk = (2.0 * std::f64::consts::PI * k as f64 / 400.0).sin() + level;
        }
        let mut y = vec![0.0; n];
        let model = |th: &[f64; 5], y: &[f64], u: &[f64], k: usize| {
            -th[0] * y[k - 1] - th[1] * y[k - 2] + th[2] * u[k - 1] + th[3] * u[k - 2] + th[4]
        };
        for k in 2..n {
            let up = model(&POS, &y, &u, k);
            let down = model(&NEG, &y, &u, k);
            y[k] = if up > y[k - 1] {
                up + noise * rng.normal()
            } else if down < y[k - 1] {
                down + noise * rng.normal()
            } else {
                y[k - 1]
            };
        }
        (y, u)
    }

    #[test]
    fn recovers_both_direction_models_from_noisy_data() {
        let order = ArxOrder {
            na: 2,
            nb: 2,
            delay: 0,
        };
        for seed in [1, 2, 3] {
            let (y, u) = simulate(seed, 20_000, 2e-4);
            let sel = DirectionalSelection {
                min_step: 5e-4,
                ..DirectionalSelection::new(order)
            };
            let fit = fit_directional(&y, &u, &sel).expect("both directions excited");
            assert!(fit.positive_samples.len() > 3000 && fit.negative_samples.len() > 3000);
            for (dir, truth) in [(Direction::Positive, POS), (Direction::Negative, NEG)] {
                let est = fit.fit(dir);
                for j in 0..5 {
                    let err = (est.theta[j] - truth[j]).abs();
                    eprintln!(
                        "seed {seed} {dir:?} theta[{j}] = {:.5} (true {}, err {err:.2e})",
                        est.theta[j], truth[j]
                    );
                    assert!(err < 0.01, "seed {seed} {dir:?} theta[{j}] err {err}");
                }
                // Offsets carry the direction's friction: distinct and with the right sign.
                let p = fit.parameters(dir).expect("order matches");
                assert!(
                    (p.offset - truth[4]).abs() < 2e-3,
                    "{dir:?} offset {}",
                    p.offset
                );
            }
            // A single model over all moving samples cannot explain both: larger residuals.
            let all = split_by_direction(&y, &u, &sel).expect("valid");
            let psi = DMatrix::from_rows(
                &all.positive
                    .psi
                    .row_iter()
                    .chain(all.negative.psi.row_iter())
                    .map(|r| r.into_owned())
                    .collect::<Vec<_>>(),
            );
            let ys = DVector::from_iterator(
                psi.nrows(),
                all.positive.y.iter().chain(all.negative.y.iter()).copied(),
            );
            let joint = least_squares(&psi, &ys).expect("full rank");
            let split_var = (fit.positive.rss + fit.negative.rss) / psi.nrows() as f64;
            assert!(joint.rss / psi.nrows() as f64 > 4.0 * split_var);
        }
    }

    #[test]
    fn online_selector_matches_batch_and_feeds_recursive_estimators() {
        let order = ArxOrder {
            na: 2,
            nb: 2,
            delay: 0,
        };
        let (y, u) = simulate(9, 20_000, 2e-4);
        let sel = DirectionalSelection {
            min_step: 5e-4,
            ..DirectionalSelection::new(order)
        };
        let batch = split_by_direction(&y, &u, &sel).expect("valid");
        let mut online = DirectionalRegressor::new(sel).expect("valid");
        let cfg = DsfiConfig {
            forgetting: 1.0,
            ..DsfiConfig::default()
        };
        let mut est = [
            Dsfi::new(5, cfg).expect("valid"),
            Dsfi::new(5, cfg).expect("valid"),
        ];
        let (mut n_pos, mut n_neg) = (0, 0);
        for k in 0..y.len() {
            if let Some((dir, psi)) = online.push(y[k], u[k]) {
                let (side, data, count) = match dir {
                    Direction::Positive => (0, &batch.positive, &mut n_pos),
                    Direction::Negative => (1, &batch.negative, &mut n_neg),
                };
                assert_eq!(data.samples[*count], k);
                assert_eq!(
                    data.psi.row(*count).iter().copied().collect::<Vec<_>>(),
                    psi.to_vec()
                );
                *count += 1;
                est[side].step(psi, y[k]).expect("finite");
            }
        }
        assert_eq!(n_pos, batch.positive.samples.len());
        assert_eq!(n_neg, batch.negative.samples.len());
        for j in 0..5 {
            assert!((est[0].theta()[j] - POS[j]).abs() < 0.01);
            assert!((est[1].theta()[j] - NEG[j]).abs() < 0.01);
        }
    }

    #[test]
    fn monotone_test_and_regressor_layout() {
        let y = [0.0, 1.0, 2.0, 3.0, 2.5, 2.0, 1.0];
        assert_eq!(monotone_direction(&y, 3, 3, 0.0), Some(Direction::Positive));
        assert_eq!(monotone_direction(&y, 4, 1, 0.0), Some(Direction::Negative));
        assert_eq!(monotone_direction(&y, 4, 2, 0.0), None);
        assert_eq!(monotone_direction(&y, 6, 2, 0.6), None);
        assert_eq!(monotone_direction(&y, 6, 1, 0.6), Some(Direction::Negative));
        assert_eq!(monotone_direction(&y, 1, 2, 0.0), None);
        let u = [10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0];
        let order = ArxOrder {
            na: 2,
            nb: 2,
            delay: 1,
        };
        let mut psi = [0.0; 5];
        arx_regressor(&y, &u, 5, &order, &mut psi).expect("enough history");
        assert_eq!(psi, [-2.5, -3.0, 13.0, 12.0, 1.0]);
        assert!(arx_regressor(&y, &u, 2, &order, &mut psi).is_err());
    }
}
