//! `[axis.limits]`, declared once: the TOML section, its ranges, and the limits the dictionary
//! offers for writing in pre-operational. A limit left out is not watched; the dictionary shows
//! it as an infinite bound, and writing an infinite bound leaves it out again.

use super::{Band, Limits};
use crate::declare_section;
use crate::param::cycles;

/// The smallest value the dictionary takes for "> 0".
const POSITIVE_MIN: f64 = 1e-9;
/// Supervision times: at least 100 µs, at most an hour.
const TIME_MIN_S: f64 = 1e-4;
const TIME_MAX_S: f64 = 3600.0;
const INF: f64 = f64::INFINITY;

declare_section! {
    /// `[axis.limits]`: the limit checks of the supervision and their persistence times.
    pub struct LimitsSection {
        /// Largest |setpoint - position| before `following_error` is raised, m.
        following_error_m: Option<f64> = {
            unit: "m", min: POSITIVE_MIN, max: INF, access: PreOperational,
            doc: "largest |setpoint - position| before following_error is raised; inf = not watched",
            absent: INF,
        },
        following_error_time_s: f64 = {
            unit: "s", min: TIME_MIN_S, max: TIME_MAX_S, access: PreOperational, doc: "",
            default: 0.25,
        },
        /// Travel, m.
        position_min_m: Option<f64> = {
            unit: "m", access: PreOperational, doc: "-inf = not watched", absent: -INF,
        },
        position_max_m: Option<f64> = {
            unit: "m", access: PreOperational, doc: "inf = not watched", absent: INF,
        },
        current_max_a: Option<f64> = {
            unit: "A", min: POSITIVE_MIN, max: INF, access: PreOperational,
            doc: "inf = not watched", absent: INF,
        },
        current_time_s: f64 = {
            unit: "s", min: TIME_MIN_S, max: TIME_MAX_S, access: PreOperational, doc: "",
            default: 0.01,
        },
        /// The hard supply band: outside it the axis goes to its safe state.
        supply_voltage_min_v: Option<f64> = {
            unit: "V", access: PreOperational, doc: "", absent: -INF,
        },
        supply_voltage_max_v: Option<f64> = {
            unit: "V", access: PreOperational, doc: "", absent: INF,
        },
        supply_pressure_min_pa: Option<f64> = {
            unit: "Pa", access: PreOperational, doc: "", absent: -INF,
        },
        supply_pressure_max_pa: Option<f64> = {
            unit: "Pa", access: PreOperational, doc: "", absent: INF,
        },
        /// The scheduled band, inside the band above: outside it the axis warns (EMCY, fault
        /// state `warning`) and goes on with the schedule's gains and command limits.
        supply_voltage_scheduled_min_v: Option<f64> = {
            unit: "V", access: Restart, doc: "",
        },
        supply_voltage_scheduled_max_v: Option<f64> = {
            unit: "V", access: Restart, doc: "",
        },
        supply_pressure_scheduled_min_pa: Option<f64> = {
            unit: "Pa", access: Restart, doc: "",
        },
        supply_pressure_scheduled_max_pa: Option<f64> = {
            unit: "Pa", access: Restart, doc: "",
        },
        /// Persistence of the supply checks, hard band and scheduled band alike.
        supply_time_s: f64 = {
            unit: "s", min: TIME_MIN_S, max: TIME_MAX_S, access: PreOperational, doc: "",
            default: 0.01,
        },
        /// Time without sensor frames before `sensor_timeout` latches.
        sensor_timeout_s: f64 = {
            unit: "s", min: TIME_MIN_S, max: TIME_MAX_S, access: PreOperational, doc: "",
            default: 0.02,
        },
        /// Time without the actuator node's heartbeat before `heartbeat_lost` latches; absent:
        /// not watched.
        heartbeat_timeout_s: Option<f64> = {
            unit: "s", min: TIME_MIN_S, max: INF, access: PreOperational,
            doc: "time without the actuator node's heartbeat before heartbeat_lost; inf = not watched",
            absent: INF,
        },
    }
}

impl LimitsSection {
    /// The supervisor's limits for a cycle of `period_s`: a band per watched quantity (one
    /// side may be open) with its persistence in cycles.
    pub fn limits(&self, period_s: f64) -> Limits {
        let l = self;
        let band = |lo: Option<f64>, hi: Option<f64>, time_s: f64| {
            if lo.is_none() && hi.is_none() {
                return None;
            }
            Some(Band {
                low: lo.unwrap_or(f64::NEG_INFINITY),
                high: hi.unwrap_or(f64::INFINITY),
                persistence_cycles: cycles(time_s, period_s),
            })
        };
        Limits {
            following_error: l.following_error_m.map(|e| Band {
                low: -e,
                high: e,
                persistence_cycles: cycles(l.following_error_time_s, period_s),
            }),
            // End of range trips at once: a reading outside the travel is a broken sensor or a crash.
            position: band(l.position_min_m, l.position_max_m, period_s),
            current_a: l.current_max_a.map(|i| Band {
                low: -i,
                high: i,
                persistence_cycles: cycles(l.current_time_s, period_s),
            }),
            supply_voltage_v: band(
                l.supply_voltage_min_v,
                l.supply_voltage_max_v,
                l.supply_time_s,
            ),
            supply_pressure_pa: band(
                l.supply_pressure_min_pa,
                l.supply_pressure_max_pa,
                l.supply_time_s,
            ),
            sensor_timeout_cycles: cycles(l.sensor_timeout_s, period_s),
            heartbeat_timeout_s: l.heartbeat_timeout_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_become_cycles_and_a_limit_left_out_is_not_checked() {
        let section = LimitsSection {
            following_error_m: Some(1e-3),
            position_max_m: Some(0.02),
            ..LimitsSection::defaults().expect("every key has a default or may be left out")
        };
        let l = section.limits(0.0025);
        let f = l.following_error.expect("watched");
        // 0.25 s of the default persistence at 400 Hz.
        assert_eq!((f.low, f.high, f.persistence_cycles), (-1e-3, 1e-3, 100));
        let p = l.position.expect("one side given");
        assert_eq!(
            (p.low, p.high, p.persistence_cycles),
            (f64::NEG_INFINITY, 0.02, 1)
        );
        assert!(l.current_a.is_none() && l.supply_voltage_v.is_none());
        assert_eq!(l.sensor_timeout_cycles, 8, "0.02 s");
        assert_eq!(l.heartbeat_timeout_s, None);
    }
}
