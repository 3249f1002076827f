//! The simulated drive's homing (CiA 402 homing mode, 6060h = 6): on the rising edge of
//! controlword bit 4 the drive moves by the method of 6098h at the speeds of 6099h with the
//! acceleration of 609Ah until it finds its home point, then stops. The simulated axis has a
//! limit switch at each end of its search and an encoder with an index pulse every
//! [`INDEX_PERIOD_COUNTS`] counts. Sans-I/O: each period takes the measured position and gives
//! the position reference the drive's own position loop tracks.

use super::DRIVE_POSITION_UNIT;

/// The simulated axis' negative limit switch: active at and below this position (plant m).
pub const NEGATIVE_LIMIT_SWITCH_M: f64 = -0.025;
/// The positive limit switch: active at and above this position (plant m).
pub const POSITIVE_LIMIT_SWITCH_M: f64 = 0.025;
/// The encoder's index pulse comes every this many counts of 6064h's unit (4.096 mm).
pub const INDEX_PERIOD_COUNTS: i64 = 4096;
/// The drive gives up a homing that has not found its home point in this time (homing error).
pub const HOMING_TIMEOUT_S: f64 = 20.0;

/// The methods the simulated drive offers (6098h): 1/2 limit switch then index pulse,
/// 17/18 limit switch, 33/34 index pulse, 35/37 the current position.
pub const METHODS: [i8; 8] = [1, 2, 17, 18, 33, 34, 35, 37];

/// The index pulse period in plant metres.
fn index_period_m() -> f64 {
    INDEX_PERIOD_COUNTS as f64 * DRIVE_POSITION_UNIT
}

/// One homing's parameters in SI, from 6098h, 6099h and 609Ah.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomingParameters {
    pub method: i8,
    /// 6099h sub 1, m/s.
    pub speed_switch_m_per_s: f64,
    /// 6099h sub 2, m/s.
    pub speed_zero_m_per_s: f64,
    /// 609Ah, m/s².
    pub acceleration_m_per_s2: f64,
    pub timeout_s: f64,
}

/// What the statusword shows in homing mode (bits 13, 12, 10; CiA 402 Table "homing").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomingStatus {
    /// Not started, or interrupted (bit 10).
    NotStarted,
    /// Under way (no bit).
    InProgress,
    /// Home found and the axis stopped (bits 12 and 10).
    Attained,
    /// Homing error (bit 13; bit 10 once the axis stopped).
    Error { stopped: bool },
}

impl HomingStatus {
    /// Bits 10, 12 and 13 of the statusword.
    pub fn statusword_bits(self) -> u16 {
        use crate::device::profile::cia402::status::{
            HOMING_ATTAINED, HOMING_ERROR, TARGET_REACHED,
        };
        match self {
            HomingStatus::NotStarted => TARGET_REACHED,
            HomingStatus::InProgress => 0,
            HomingStatus::Attained => HOMING_ATTAINED | TARGET_REACHED,
            HomingStatus::Error { stopped: false } => HOMING_ERROR,
            HomingStatus::Error { stopped: true } => HOMING_ERROR | TARGET_REACHED,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Idle,
    /// Moving toward a limit switch (direction -1 or +1) until it is active.
    SearchSwitch {
        direction: f64,
    },
    /// Moving off the active switch (`direction`) until it is no longer active; then the
    /// switch edge is home, or the next index pulse when `then_index`.
    LeaveSwitch {
        direction: f64,
        then_index: bool,
    },
    /// Moving at the zero search speed until the next index pulse.
    SearchIndex {
        direction: f64,
    },
    /// Braking to standstill after the home point was found, or after an error.
    Stopping {
        error: bool,
    },
}

/// One period's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomingStep {
    /// Where the position loop is to hold the axis, plant m.
    pub reference_m: f64,
    /// The reference's velocity, m/s (the loop's feed-forward).
    pub velocity_m_per_s: f64,
    /// The home point found this period, plant m (once per homing).
    pub home_m: Option<f64>,
}

/// The homing procedure of the simulated drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homing {
    phase: Phase,
    status: HomingStatus,
    parameters: HomingParameters,
    reference_m: f64,
    velocity_m_per_s: f64,
    last_position_m: f64,
    elapsed_s: f64,
}

impl Default for Homing {
    fn default() -> Self {
        Self::new()
    }
}

/// The switch a method searches, and whether the index pulse after it is home: `None` for a
/// method without a switch.
fn switch_of(method: i8) -> Option<(f64, bool)> {
    match method {
        1 => Some((-1.0, true)),
        2 => Some((1.0, true)),
        17 => Some((-1.0, false)),
        18 => Some((1.0, false)),
        _ => None,
    }
}

/// The limit switch on the `direction` side is active at `position_m`.
fn switch_active(direction: f64, position_m: f64) -> bool {
    if direction < 0.0 {
        position_m <= NEGATIVE_LIMIT_SWITCH_M
    } else {
        position_m >= POSITIVE_LIMIT_SWITCH_M
    }
}

/// The index pulse passed between two positions, if one did (the encoder latches its exact
/// position).
fn index_between(from_m: f64, to_m: f64) -> Option<f64> {
    let period = index_period_m();
    // Index pulse k sits at k·period: one was passed when the two lie in different periods.
    let (a, b) = ((from_m / period).floor(), (to_m / period).floor());
    (a != b).then(|| a.max(b) * period)
}

impl Homing {
    pub fn new() -> Self {
        Self {
            phase: Phase::Idle,
            status: HomingStatus::NotStarted,
            parameters: HomingParameters {
                method: 37,
                speed_switch_m_per_s: 0.0,
                speed_zero_m_per_s: 0.0,
                acceleration_m_per_s2: 0.0,
                timeout_s: HOMING_TIMEOUT_S,
            },
            reference_m: 0.0,
            velocity_m_per_s: 0.0,
            last_position_m: 0.0,
            elapsed_s: 0.0,
        }
    }

    pub fn status(&self) -> HomingStatus {
        self.status
    }

    /// The procedure moves the axis (the drive's loop follows its reference).
    pub fn is_moving(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// Start at `position_m`. Methods 35 and 37 are done at once: the home point is returned.
    pub fn start(&mut self, parameters: HomingParameters, position_m: f64) -> Option<f64> {
        self.parameters = parameters;
        self.reference_m = position_m;
        self.velocity_m_per_s = 0.0;
        self.last_position_m = position_m;
        self.elapsed_s = 0.0;
        self.status = HomingStatus::InProgress;
        self.phase = match (parameters.method, switch_of(parameters.method)) {
            (35 | 37, _) => {
                self.status = HomingStatus::Attained;
                self.phase = Phase::Idle;
                return Some(position_m);
            }
            (_, Some((direction, then_index))) if switch_active(direction, position_m) => {
                Phase::LeaveSwitch {
                    direction: -direction,
                    then_index,
                }
            }
            (_, Some((direction, _))) => Phase::SearchSwitch { direction },
            (33, None) => Phase::SearchIndex { direction: -1.0 },
            (34, None) => Phase::SearchIndex { direction: 1.0 },
            _ => {
                self.status = HomingStatus::Error { stopped: true };
                Phase::Idle
            }
        };
        None
    }

    /// Controlword bit 4 fell, or the drive left "operation enabled": stop where it is.
    pub fn interrupt(&mut self) {
        if self.status == HomingStatus::InProgress {
            self.status = HomingStatus::NotStarted;
        }
        self.phase = Phase::Idle;
        self.velocity_m_per_s = 0.0;
    }

    /// One drive period of `dt` with the axis measured at `position_m`.
    pub fn step(&mut self, position_m: f64, dt: f64) -> HomingStep {
        let p = self.parameters;
        let from = std::mem::replace(&mut self.last_position_m, position_m);
        let mut home_m = None;
        if self.status == HomingStatus::InProgress {
            self.elapsed_s += dt;
        }
        let speed = match self.phase {
            Phase::Idle => {
                return HomingStep {
                    reference_m: self.reference_m,
                    velocity_m_per_s: 0.0,
                    home_m: None,
                }
            }
            Phase::SearchSwitch { direction } => {
                if switch_active(direction, position_m) {
                    let then_index = switch_of(p.method).is_some_and(|(_, i)| i);
                    self.phase = Phase::LeaveSwitch {
                        direction: -direction,
                        then_index,
                    };
                    -direction * p.speed_zero_m_per_s
                } else {
                    direction * p.speed_switch_m_per_s
                }
            }
            Phase::LeaveSwitch {
                direction,
                then_index,
            } => {
                if switch_active(-direction, position_m) {
                    direction * p.speed_zero_m_per_s
                } else if then_index {
                    self.phase = Phase::SearchIndex { direction };
                    direction * p.speed_zero_m_per_s
                } else {
                    // The switch's edge, as sampled this period.
                    home_m = Some(position_m);
                    self.phase = Phase::Stopping { error: false };
                    0.0
                }
            }
            Phase::SearchIndex { direction } => match index_between(from, position_m) {
                Some(index) => {
                    home_m = Some(index);
                    self.phase = Phase::Stopping { error: false };
                    0.0
                }
                None => direction * p.speed_zero_m_per_s,
            },
            Phase::Stopping { .. } => 0.0,
        };
        if self.status == HomingStatus::InProgress && self.elapsed_s > p.timeout_s {
            self.phase = Phase::Stopping { error: true };
            self.status = HomingStatus::Error { stopped: false };
        }
        let speed = if matches!(self.phase, Phase::Stopping { .. }) {
            0.0
        } else {
            speed
        };
        // The reference's velocity approaches the search speed at the homing acceleration.
        let dv_max = p.acceleration_m_per_s2 * dt;
        self.velocity_m_per_s += (speed - self.velocity_m_per_s).clamp(-dv_max, dv_max);
        // The reference moves by its velocity over the period.
        self.reference_m += self.velocity_m_per_s * dt;
        if let Phase::Stopping { error } = self.phase {
            if self.velocity_m_per_s == 0.0 {
                self.phase = Phase::Idle;
                self.status = if error {
                    HomingStatus::Error { stopped: true }
                } else {
                    HomingStatus::Attained
                };
            }
        }
        HomingStep {
            reference_m: self.reference_m,
            velocity_m_per_s: self.velocity_m_per_s,
            home_m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parameters(method: i8) -> HomingParameters {
        HomingParameters {
            method,
            speed_switch_m_per_s: 0.02,
            speed_zero_m_per_s: 0.002,
            acceleration_m_per_s2: 0.5,
            timeout_s: HOMING_TIMEOUT_S,
        }
    }

    /// An ideal axis that follows the reference exactly: the home point found, and where the
    /// axis stood still.
    fn run(method: i8, start_m: f64) -> (Option<f64>, f64, HomingStatus) {
        let dt = 0.001;
        let mut h = Homing::new();
        let mut home = h.start(parameters(method), start_m);
        let mut position = start_m;
        for _ in 0..20_000 {
            if h.status() != HomingStatus::InProgress {
                break;
            }
            let s = h.step(position, dt);
            if s.home_m.is_some() {
                assert!(home.is_none(), "home found twice");
                home = s.home_m;
            }
            position = s.reference_m;
        }
        (home, position, h.status())
    }

    #[test]
    fn current_position_methods_are_home_at_once() {
        for method in [35, 37] {
            let mut h = Homing::new();
            assert_eq!(h.start(parameters(method), 0.0123), Some(0.0123));
            assert_eq!(h.status(), HomingStatus::Attained);
            assert_eq!(h.status().statusword_bits(), 0x1400);
            assert!(!h.is_moving());
        }
    }

    #[test]
    fn limit_switch_methods_home_on_the_switch_edge() {
        // Zero search speed 2 mm/s at 1 ms: the edge is sampled within 2 µm.
        for (method, switch) in [(17, NEGATIVE_LIMIT_SWITCH_M), (18, POSITIVE_LIMIT_SWITCH_M)] {
            let (home, stopped, status) = run(method, 0.003);
            assert_eq!(status, HomingStatus::Attained, "method {method}");
            let home = home.expect("home found");
            assert!(
                (home - switch).abs() <= 2.5e-6,
                "{method}: {home} vs {switch}"
            );
            // Off the switch, on the side it was left to.
            assert!(!switch_active(switch.signum(), home), "{method}: {home}");
            // Stopped within v²/2a of the home point.
            assert!((stopped - home).abs() < 10e-6, "{method}: {stopped}");
        }
        // Started on the switch: it leaves it first.
        let (home, _, status) = run(17, -0.03);
        assert_eq!(status, HomingStatus::Attained);
        assert!((home.expect("home") - NEGATIVE_LIMIT_SWITCH_M).abs() <= 2.5e-6);
    }

    #[test]
    fn index_methods_home_on_the_first_index_pulse() {
        let period = INDEX_PERIOD_COUNTS as f64 * 1e-6;
        // 33/34: the next pulse below / above the start, at its exact (latched) position.
        let (home, _, status) = run(33, 0.003);
        assert_eq!(status, HomingStatus::Attained);
        assert_eq!(home, Some(0.0));
        let (home, _, _) = run(34, 0.003);
        assert_eq!(home, Some(period));
        // 1/2: the switch, then the first pulse inside of it.
        let (home, _, _) = run(1, 0.003);
        let expected = (NEGATIVE_LIMIT_SWITCH_M / period).ceil() * period;
        assert!((home.expect("home") - expected).abs() < 1e-12, "{home:?}");
        assert!(expected > NEGATIVE_LIMIT_SWITCH_M);
        let (home, _, _) = run(2, 0.003);
        let expected = (POSITIVE_LIMIT_SWITCH_M / period).floor() * period;
        assert!((home.expect("home") - expected).abs() < 1e-12, "{home:?}");
    }

    #[test]
    fn a_homing_that_does_not_find_home_in_time_is_a_homing_error() {
        let mut h = Homing::new();
        let mut p = parameters(17);
        p.timeout_s = 0.1;
        h.start(p, 0.0);
        // An axis that does not move (blocked): the switch is never reached.
        let mut bits = vec![];
        for _ in 0..200 {
            h.step(0.0, 0.001);
            bits.push(h.status().statusword_bits());
        }
        bits.dedup();
        assert_eq!(bits, [0x0000, 0x2000, 0x2400], "{bits:x?}");
        assert_eq!(h.status(), HomingStatus::Error { stopped: true });
    }

    #[test]
    fn an_interrupted_homing_stops_and_says_so() {
        let mut h = Homing::new();
        h.start(parameters(17), 0.0);
        h.step(0.0, 0.001);
        h.interrupt();
        assert_eq!(h.status(), HomingStatus::NotStarted);
        assert_eq!(h.status().statusword_bits(), 0x0400);
        let s = h.step(0.0, 0.001);
        assert_eq!(s.velocity_m_per_s, 0.0);
    }
}
