//! `[axis.limits]`, declared once: the TOML section, its ranges, and the limits the dictionary
//! offers for writing in pre-operational. A limit left out is not watched; the dictionary shows
//! it as an infinite bound, and writing an infinite bound leaves it out again.

use crate::declare_section;

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
