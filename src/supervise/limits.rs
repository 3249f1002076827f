//! Limit checks with persistence: the monitoring level of the supervision (Isermann & Raab).

use super::fault::{FaultFlags, FaultKind, FaultState};

/// A band a signal must stay in, and for how many consecutive cycles it may leave it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    pub low: f64,
    pub high: f64,
    /// Cycles outside the band before the fault trips; 1 trips at once.
    pub persistence_cycles: u32,
}

impl Band {
    pub fn contains(&self, x: f64) -> bool {
        x >= self.low && x <= self.high
    }
}

/// One limit check with its persistence counter.
#[derive(Debug, Clone, Copy)]
struct Check {
    kind: FaultKind,
    band: Option<Band>,
    count: u32,
}

/// What the supervision sees each cycle, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SupervisionInput {
    pub setpoint: f64,
    pub position: f64,
    pub current_a: f64,
    pub supply_voltage_v: f64,
    pub supply_pressure_pa: f64,
    /// A sensor frame arrived in time this cycle; the other readings are fresh only then.
    pub sensor_fresh: bool,
    /// Consecutive cycles without a sensor frame.
    pub sensor_missing_cycles: u32,
    /// Seconds since the actuator node's last heartbeat.
    pub heartbeat_age_s: f64,
    /// The actuator node reports operational.
    pub node_operational: bool,
}

/// Limits of one axis. A `None` band is not checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Band for setpoint - position.
    pub following_error: Option<Band>,
    pub position: Option<Band>,
    pub current_a: Option<Band>,
    pub supply_voltage_v: Option<Band>,
    pub supply_pressure_pa: Option<Band>,
    /// Consecutive cycles without a sensor frame that trip `sensor_timeout`.
    pub sensor_timeout_cycles: u32,
    /// Heartbeat age that trips `heartbeat_lost`; `None` when heartbeats are not consumed.
    pub heartbeat_timeout_s: Option<f64>,
}

/// What the supervision decided this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SupervisionOutput {
    pub state: FaultState,
    /// Latched faults.
    pub latched: FaultFlags,
    /// Faults latched in this very cycle (each one gets an EMCY).
    pub raised: FaultFlags,
    /// Limits exceeded now but not yet for their persistence time.
    pub pending: FaultFlags,
}

/// Limit supervision: checks, persistence, latching until reset.
#[derive(Debug, Clone)]
pub struct LimitSupervisor {
    checks: [Check; 5],
    limits: Limits,
    latched: FaultFlags,
}

impl LimitSupervisor {
    pub fn new(limits: Limits) -> Self {
        let check = |kind, band| Check {
            kind,
            band,
            count: 0,
        };
        Self {
            checks: [
                check(FaultKind::FollowingError, limits.following_error),
                check(FaultKind::EndOfRange, limits.position),
                check(FaultKind::Overcurrent, limits.current_a),
                check(FaultKind::SupplyVoltage, limits.supply_voltage_v),
                check(FaultKind::SupplyPressure, limits.supply_pressure_pa),
            ],
            limits,
            latched: FaultFlags::default(),
        }
    }

    /// One supervision step. Readings are judged only when fresh; missing ones count as a timeout.
    pub fn step(&mut self, input: &SupervisionInput) -> SupervisionOutput {
        let before = self.latched;
        let mut pending = FaultFlags::default();
        if input.sensor_fresh {
            for check in self.checks.iter_mut() {
                let Some(band) = check.band else { continue };
                let value = match check.kind {
                    FaultKind::FollowingError => input.setpoint - input.position,
                    FaultKind::EndOfRange => input.position,
                    FaultKind::Overcurrent => input.current_a,
                    FaultKind::SupplyVoltage => input.supply_voltage_v,
                    _ => input.supply_pressure_pa,
                };
                if band.contains(value) {
                    check.count = 0;
                    continue;
                }
                check.count = check.count.saturating_add(1);
                if check.count >= band.persistence_cycles.max(1) {
                    self.latched.insert(check.kind);
                } else {
                    pending.insert(check.kind);
                }
            }
        }
        if input.sensor_missing_cycles >= self.limits.sensor_timeout_cycles.max(1) {
            self.latched.insert(FaultKind::SensorTimeout);
        } else if input.sensor_missing_cycles > 0 {
            pending.insert(FaultKind::SensorTimeout);
        }
        if let Some(timeout) = self.limits.heartbeat_timeout_s {
            if input.heartbeat_age_s > timeout {
                self.latched.insert(FaultKind::HeartbeatLost);
            }
            if !input.node_operational {
                self.latched.insert(FaultKind::NodeState);
            }
        }
        let state = if !self.latched.is_empty() {
            FaultState::Fault
        } else if !pending.is_empty() {
            FaultState::Warning
        } else {
            FaultState::Ok
        };
        SupervisionOutput {
            state,
            latched: self.latched,
            raised: self.latched.added_since(before),
            pending,
        }
    }

    /// Clear latched faults (NMT reset or a fault_reset frame). Faults still present trip again.
    pub fn reset(&mut self) {
        self.latched = FaultFlags::default();
        for c in self.checks.iter_mut() {
            c.count = 0;
        }
    }

    /// Carry latched faults over to a supervisor built anew (a configuration reload).
    pub fn keep_latched(&mut self, latched: FaultFlags) {
        self.latched = self.latched.union(latched);
    }

    pub fn latched(&self) -> FaultFlags {
        self.latched
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> Limits {
        Limits {
            following_error: Some(Band {
                low: -1e-3,
                high: 1e-3,
                persistence_cycles: 3,
            }),
            position: Some(Band {
                low: 0.0,
                high: 0.025,
                persistence_cycles: 1,
            }),
            current_a: None,
            supply_voltage_v: Some(Band {
                low: 18.0,
                high: 30.0,
                persistence_cycles: 2,
            }),
            supply_pressure_pa: None,
            sensor_timeout_cycles: 4,
            heartbeat_timeout_s: Some(0.5),
        }
    }

    fn healthy() -> SupervisionInput {
        SupervisionInput {
            setpoint: 0.01,
            position: 0.01,
            supply_voltage_v: 24.0,
            sensor_fresh: true,
            node_operational: true,
            ..Default::default()
        }
    }

    #[test]
    fn a_limit_warns_first_then_latches_after_its_persistence() {
        let mut s = LimitSupervisor::new(limits());
        let mut input = healthy();
        assert_eq!(s.step(&input).state, FaultState::Ok);
        input.position = 0.0085;
        assert_eq!(s.step(&input).state, FaultState::Warning);
        assert_eq!(s.step(&input).state, FaultState::Warning);
        let out = s.step(&input);
        assert_eq!(out.state, FaultState::Fault);
        assert!(out.raised.contains(FaultKind::FollowingError));
        // Latched: back in the band, still a fault, raised only once.
        let out = s.step(&healthy());
        assert_eq!(out.state, FaultState::Fault);
        assert!(out.raised.is_empty());
        s.reset();
        assert_eq!(s.step(&healthy()).state, FaultState::Ok);
    }

    #[test]
    fn a_short_excursion_does_not_latch() {
        let mut s = LimitSupervisor::new(limits());
        let mut bad = healthy();
        bad.supply_voltage_v = 12.0;
        s.step(&bad);
        s.step(&healthy());
        s.step(&bad);
        assert_eq!(s.step(&healthy()).state, FaultState::Ok);
    }

    #[test]
    fn stale_readings_are_not_judged_but_their_absence_is() {
        let mut s = LimitSupervisor::new(limits());
        let mut input = healthy();
        input.position = 1.0;
        input.sensor_fresh = false;
        for missing in 1..4 {
            input.sensor_missing_cycles = missing;
            assert_eq!(s.step(&input).state, FaultState::Warning);
        }
        input.sensor_missing_cycles = 4;
        let out = s.step(&input);
        assert_eq!(out.latched, FaultFlags(FaultKind::SensorTimeout.bit()));
    }

    #[test]
    fn lost_heartbeat_and_a_node_leaving_operational_latch() {
        let mut s = LimitSupervisor::new(limits());
        let mut input = healthy();
        input.heartbeat_age_s = 0.6;
        input.node_operational = false;
        let out = s.step(&input);
        assert!(out.latched.contains(FaultKind::HeartbeatLost));
        assert!(out.latched.contains(FaultKind::NodeState));
    }
}
