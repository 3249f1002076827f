//! Parameter scheduling (Isermann & Raab, "parameter scheduling: controller parameters as
//! functions of measured auxiliary variables V"): `θ_c = f(V)`, here piecewise linear between the
//! configured points `(V_i, θ_i)`, `θ_c = θ_i + (V - V_i) (θ_{i+1} - θ_i) / (V_{i+1} - V_i)`, held
//! constant beyond the first and last point. `V` is the measured supply voltage or pressure.

use super::param_error::{finite, ParamError};

/// Largest number of scheduled parameters.
pub const MAX_SCHEDULED: usize = 8;

/// One point of a schedule: the parameters at one value of the auxiliary variable.
#[derive(Debug, Clone, PartialEq)]
pub struct SchedulePoint {
    /// Auxiliary variable `V` (supply voltage in V or supply pressure in Pa).
    pub supply: f64,
    /// Controller parameters at `V`, in the order the user of the schedule defines.
    pub params: Vec<f64>,
}

/// A table `θ_c(V)` with linear interpolation. `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct GainSchedule {
    supply: Vec<f64>,
    /// Row-major, `n` per point.
    params: Vec<f64>,
    n: usize,
    out: [f64; MAX_SCHEDULED],
}

impl GainSchedule {
    /// At least one point, strictly increasing `supply`, equal-length finite parameter vectors
    /// (1 to [`MAX_SCHEDULED`]).
    pub fn new(points: &[SchedulePoint]) -> Result<Self, ParamError> {
        let first = points
            .first()
            .ok_or_else(|| ParamError::new("points", "needs at least one point"))?;
        let n = first.params.len();
        if n == 0 || n > MAX_SCHEDULED {
            return Err(ParamError::new(
                "params",
                format!("needs 1 to {MAX_SCHEDULED} parameters, got {n}"),
            ));
        }
        let mut supply = Vec::with_capacity(points.len());
        let mut params = Vec::with_capacity(points.len() * n);
        for (i, p) in points.iter().enumerate() {
            finite("supply", p.supply)?;
            if p.params.len() != n {
                return Err(ParamError::new(
                    "params",
                    format!(
                        "point {i} has {} parameters, point 0 has {n}",
                        p.params.len()
                    ),
                ));
            }
            for &v in &p.params {
                finite("params", v)?;
            }
            if let Some(&last) = supply.last() {
                if p.supply <= last {
                    return Err(ParamError::new(
                        "supply",
                        format!(
                            "must increase strictly, point {i} has {} after {last}",
                            p.supply
                        ),
                    ));
                }
            }
            supply.push(p.supply);
            params.extend_from_slice(&p.params);
        }
        let mut s = Self {
            supply,
            params,
            n,
            out: [0.0; MAX_SCHEDULED],
        };
        s.out[..n].copy_from_slice(&s.params[..n]);
        Ok(s)
    }

    /// Number of parameters per point.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a schedule has at least one parameter.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// `θ_c(V)` by linear interpolation, held at the ends; a non-finite `V` keeps the last result.
    pub fn step(&mut self, supply: f64) -> &[f64] {
        if supply.is_finite() {
            let n = self.n;
            let last = self.supply.len() - 1;
            let i = self.supply.partition_point(|&v| v <= supply);
            if i == 0 {
                self.out[..n].copy_from_slice(&self.params[..n]);
            } else if i > last {
                self.out[..n].copy_from_slice(&self.params[last * n..(last + 1) * n]);
            } else {
                let (v0, v1) = (self.supply[i - 1], self.supply[i]);
                let t = (supply - v0) / (v1 - v0);
                for j in 0..n {
                    let a = self.params[(i - 1) * n + j];
                    let b = self.params[i * n + j];
                    self.out[j] = a + t * (b - a);
                }
            }
        }
        &self.out[..self.n]
    }

    /// The last result.
    pub fn current(&self) -> &[f64] {
        &self.out[..self.n]
    }
}

/// Where the measured supply lies against the band the schedule is made for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BandStatus {
    #[default]
    Inside,
    /// Below the band for at least the persistence time.
    Below,
    /// Above the band for at least the persistence time.
    Above,
}

/// The scheduled band of the supply: inside it the schedule holds the loop's behaviour; outside
/// it (a cranking dip, a load-dump surge) the loop goes on with the schedule's gains and command
/// limits, but the axis warns, because the plant is where its tests did not reach. The band is
/// left after `persistence_cycles` readings outside it and re-entered at the first reading inside
/// (a warning must not flicker off and on again in noise, and must not linger once the supply is
/// back). Allocation-free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyBand {
    low: f64,
    high: f64,
    persistence_cycles: u32,
    count: u32,
    status: BandStatus,
}

impl SupplyBand {
    /// `low < high`, both finite; `persistence_cycles` at least 1.
    pub fn new(low: f64, high: f64, persistence_cycles: u32) -> Result<Self, ParamError> {
        finite("low", low)?;
        finite("high", high)?;
        if low >= high {
            return Err(ParamError::new(
                "high",
                format!("must be above low ({low}), got {high}"),
            ));
        }
        Ok(Self {
            low,
            high,
            persistence_cycles: persistence_cycles.max(1),
            count: 0,
            status: BandStatus::Inside,
        })
    }

    /// One fresh reading of the supply; a non-finite reading changes nothing.
    pub fn step(&mut self, supply: f64) -> BandStatus {
        if !supply.is_finite() {
            return self.status;
        }
        let outside = if supply < self.low {
            BandStatus::Below
        } else if supply > self.high {
            BandStatus::Above
        } else {
            BandStatus::Inside
        };
        if outside == BandStatus::Inside {
            self.count = 0;
            self.status = BandStatus::Inside;
        } else {
            self.count = self.count.saturating_add(1);
            if self.count >= self.persistence_cycles {
                self.status = outside;
            }
        }
        self.status
    }

    pub fn status(&self) -> BandStatus {
        self.status
    }

    /// `(low, high)`.
    pub fn band(&self) -> (f64, f64) {
        (self.low, self.high)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_is_left_after_its_persistence_and_reentered_at_once() {
        let mut b = SupplyBand::new(18.0, 32.0, 3).expect("band");
        assert_eq!(b.step(24.0), BandStatus::Inside);
        assert_eq!(b.step(12.0), BandStatus::Inside);
        assert_eq!(b.step(12.0), BandStatus::Inside);
        assert_eq!(b.step(12.0), BandStatus::Below);
        assert_eq!(b.step(f64::NAN), BandStatus::Below);
        assert_eq!(b.step(18.0), BandStatus::Inside);
        for _ in 0..2 {
            assert_eq!(b.step(36.0), BandStatus::Inside);
        }
        // A single reading inside restarts the count.
        assert_eq!(b.step(30.0), BandStatus::Inside);
        assert_eq!(b.step(36.0), BandStatus::Inside);
        assert_eq!(b.step(36.0), BandStatus::Inside);
        assert_eq!(b.step(36.0), BandStatus::Above);
        assert!(SupplyBand::new(32.0, 18.0, 1).is_err());
        assert!(SupplyBand::new(f64::NAN, 18.0, 1).is_err());
    }

    fn table() -> GainSchedule {
        GainSchedule::new(&[
            SchedulePoint {
                supply: 40_000.0,
                params: vec![10.0, 1.0],
            },
            SchedulePoint {
                supply: 80_000.0,
                params: vec![50.0, 3.0],
            },
        ])
        .expect("valid")
    }

    #[test]
    fn interpolates_between_points_and_holds_at_the_ends() {
        let mut s = table();
        assert_eq!(s.step(60_000.0), &[30.0, 2.0]);
        assert_eq!(s.step(10_000.0), &[10.0, 1.0]);
        assert_eq!(s.step(1e6), &[50.0, 3.0]);
        assert_eq!(s.step(f64::NAN), &[50.0, 3.0]);
        assert_eq!(s.step(40_000.0), &[10.0, 1.0]);
    }

    #[test]
    fn rejects_unsorted_points_and_ragged_rows() {
        let p = |supply: f64, params: Vec<f64>| SchedulePoint { supply, params };
        assert!(GainSchedule::new(&[p(2.0, vec![1.0]), p(1.0, vec![1.0])]).is_err());
        assert!(GainSchedule::new(&[p(1.0, vec![1.0]), p(2.0, vec![1.0, 2.0])]).is_err());
        assert!(GainSchedule::new(&[]).is_err());
    }
}
