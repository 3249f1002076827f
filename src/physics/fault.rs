//! Faults: the four of Isermann & Raab (F1 pretension, F2 spring drop, F3 friction, F4 current
//! circuit) plus supply drop, backlash growth, jamming and sensor faults. Each starts abruptly or
//! drifts linearly to full size over `ramp_s`.

use std::fmt;
use std::str::FromStr;

use super::PhysicsError;

/// What goes wrong, with its size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultKind {
    /// F1: spring pretension times k (`spring_pretension_x1.5`).
    SpringPretension(f64),
    /// F2: spring stiffness times k (`spring_x0.73`, 1650 → 1200 N/m).
    Spring(f64),
    /// F3: every friction effect (viscous, Coulomb, Stribeck, stiction) times k (`friction_x3`).
    Friction(f64),
    /// F4: gain of the power stage / current circuit times k (`current_gain_x0.5`).
    CurrentGain(f64),
    /// Supply voltage, or available pressure difference to atmosphere, times k (`supply_x0.5`).
    Supply(f64),
    /// Backlash gap times k, wear (`backlash_x2`).
    Backlash(f64),
    /// The moving body seizes: dry friction rises beyond what the drive can give (`jamming`).
    Jamming,
    /// Position sensor offset in m or rad (`sensor_offset_0.001`).
    SensorOffset(f64),
    /// Position sensor frozen at its last reading (`sensor_stuck`).
    SensorStuck,
    /// Position sensor noise standard deviation times k (`sensor_noise_x10`).
    SensorNoise(f64),
}

/// A fault and how fast it develops: `ramp_s = 0` is abrupt, otherwise a linear drift to full
/// size over `ramp_s` seconds. Text form: `friction_x3`, `friction_x3~10s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fault {
    /// What goes wrong.
    pub kind: FaultKind,
    /// Duration of the drift to full size in s; 0 for abrupt.
    pub ramp_s: f64,
}

/// A fault with a start time. Text form: `friction_x3@5s`, `friction_x3~10s@500ms`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduledFault {
    /// Start time in s of simulated time.
    pub at_s: f64,
    /// The fault.
    pub fault: Fault,
}

/// Constructor of a fault kind from its factor.
type MakeKind = fn(f64) -> FaultKind;

const MULTIPLIERS: [(&str, MakeKind); 7] = [
    ("spring_pretension_x", FaultKind::SpringPretension),
    ("spring_x", FaultKind::Spring),
    ("friction_x", FaultKind::Friction),
    ("current_gain_x", FaultKind::CurrentGain),
    ("supply_x", FaultKind::Supply),
    ("backlash_x", FaultKind::Backlash),
    ("sensor_noise_x", FaultKind::SensorNoise),
];

fn syntax(text: &str, reason: impl Into<String>) -> PhysicsError {
    PhysicsError::FaultSyntax {
        text: text.to_string(),
        reason: reason.into(),
    }
}

/// Parse a duration: `5s`, `5.5s`, `500ms`.
fn parse_duration(text: &str, whole: &str) -> Result<f64, PhysicsError> {
    let (num, scale) = if let Some(n) = text.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = text.strip_suffix('s') {
        (n, 1.0)
    } else {
        return Err(syntax(
            whole,
            format!("duration \"{text}\" needs a unit, s or ms"),
        ));
    };
    let v: f64 = num
        .parse()
        .map_err(|_| syntax(whole, format!("\"{num}\" is not a number")))?;
    if !v.is_finite() || v < 0.0 {
        return Err(syntax(whole, format!("duration must be >= 0, got {v}")));
    }
    Ok(v * scale)
}

impl FaultKind {
    fn parse(text: &str, whole: &str) -> Result<Self, PhysicsError> {
        match text {
            "jamming" => return Ok(FaultKind::Jamming),
            "sensor_stuck" => return Ok(FaultKind::SensorStuck),
            _ => {}
        }
        if let Some(v) = text.strip_prefix("sensor_offset_") {
            let x: f64 = v
                .parse()
                .map_err(|_| syntax(whole, format!("\"{v}\" is not a number")))?;
            if !x.is_finite() {
                return Err(syntax(whole, "offset must be finite"));
            }
            return Ok(FaultKind::SensorOffset(x));
        }
        for (prefix, make) in MULTIPLIERS {
            if let Some(v) = text.strip_prefix(prefix) {
                let k: f64 = v
                    .parse()
                    .map_err(|_| syntax(whole, format!("factor \"{v}\" is not a number")))?;
                if !k.is_finite() || k < 0.0 {
                    return Err(syntax(whole, format!("factor must be >= 0, got {k}")));
                }
                return Ok(make(k));
            }
        }
        Err(syntax(
            whole,
            "expected spring_pretension_xK, spring_xK, friction_xK, current_gain_xK, supply_xK, \
             backlash_xK, jamming, sensor_offset_V, sensor_stuck or sensor_noise_xK",
        ))
    }
}

impl fmt::Display for FaultKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            FaultKind::SpringPretension(k) => write!(f, "spring_pretension_x{k}"),
            FaultKind::Spring(k) => write!(f, "spring_x{k}"),
            FaultKind::Friction(k) => write!(f, "friction_x{k}"),
            FaultKind::CurrentGain(k) => write!(f, "current_gain_x{k}"),
            FaultKind::Supply(k) => write!(f, "supply_x{k}"),
            FaultKind::Backlash(k) => write!(f, "backlash_x{k}"),
            FaultKind::Jamming => f.write_str("jamming"),
            FaultKind::SensorOffset(v) => write!(f, "sensor_offset_{v}"),
            FaultKind::SensorStuck => f.write_str("sensor_stuck"),
            FaultKind::SensorNoise(k) => write!(f, "sensor_noise_x{k}"),
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.kind)?;
        if self.ramp_s > 0.0 {
            write!(f, "~{}s", self.ramp_s)?;
        }
        Ok(())
    }
}

impl FromStr for Fault {
    type Err = PhysicsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let text = s.trim();
        let (kind_text, ramp_s) = match text.split_once('~') {
            Some((k, r)) => (k, parse_duration(r, s)?),
            None => (text, 0.0),
        };
        Ok(Fault {
            kind: FaultKind::parse(kind_text, s)?,
            ramp_s,
        })
    }
}

impl fmt::Display for ScheduledFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}@{}s", self.fault, self.at_s)
    }
}

impl FromStr for ScheduledFault {
    type Err = PhysicsError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let text = s.trim();
        let (fault_text, at) = text
            .rsplit_once('@')
            .ok_or_else(|| syntax(s, "expected FAULT@TIME, e.g. friction_x3@5s"))?;
        let fault: Fault = fault_text.parse().map_err(|e| match e {
            PhysicsError::FaultSyntax { reason, .. } => syntax(s, reason),
            other => other,
        })?;
        Ok(ScheduledFault {
            at_s: parse_duration(at, s)?,
            fault,
        })
    }
}

/// How the active faults change the plant at one instant; all factors are 1 when healthy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultModifiers {
    /// Spring pretension factor (F1).
    pub pretension: f64,
    /// Spring stiffness factor (F2).
    pub stiffness: f64,
    /// Friction factor (F3).
    pub friction: f64,
    /// Power stage / current circuit gain factor (F4).
    pub drive_gain: f64,
    /// Supply factor.
    pub supply: f64,
    /// Backlash gap factor.
    pub backlash: f64,
    /// Jamming progress 0..1.
    pub jam: f64,
    /// Position sensor offset (m or rad).
    pub sensor_offset: f64,
    /// Position noise factor.
    pub sensor_noise: f64,
    /// Position sensor stuck.
    pub sensor_stuck: bool,
}

impl Default for FaultModifiers {
    fn default() -> Self {
        FaultModifiers {
            pretension: 1.0,
            stiffness: 1.0,
            friction: 1.0,
            drive_gain: 1.0,
            supply: 1.0,
            backlash: 1.0,
            jam: 0.0,
            sensor_offset: 0.0,
            sensor_noise: 1.0,
            sensor_stuck: false,
        }
    }
}

/// The faults injected into one plant, with their start times.
#[derive(Debug, Clone, Default)]
pub struct FaultSet {
    active: Vec<(f64, Fault)>,
    pending: Vec<ScheduledFault>,
    next_pending: usize,
}

impl FaultSet {
    /// A set with faults scheduled for later (sorted by start time here).
    pub fn with_schedule(mut schedule: Vec<ScheduledFault>) -> Self {
        schedule.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        FaultSet {
            active: Vec::with_capacity(schedule.len() + 4),
            pending: schedule,
            next_pending: 0,
        }
    }

    /// Start `fault` at time `now_s`.
    pub fn inject(&mut self, fault: Fault, now_s: f64) {
        self.active.push((now_s, fault));
    }

    /// Move scheduled faults whose time has come into the active set. Returns true when any
    /// fault is active and may still be changing, i.e. the modifiers must be recomputed.
    pub fn update(&mut self, now_s: f64) -> bool {
        while let Some(s) = self.pending.get(self.next_pending) {
            if s.at_s > now_s + 1e-12 {
                break;
            }
            self.active.push((s.at_s, s.fault));
            self.next_pending += 1;
        }
        !self.active.is_empty()
    }

    /// True when nothing has been injected.
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }

    /// Combined effect of the active faults at `now_s`.
    pub fn modifiers(&self, now_s: f64) -> FaultModifiers {
        let mut m = FaultModifiers::default();
        for &(start, fault) in &self.active {
            let frac = if now_s < start {
                0.0
            } else if fault.ramp_s > 0.0 {
                ((now_s - start) / fault.ramp_s).min(1.0)
            } else {
                1.0
            };
            let scale = |k: f64| 1.0 + (k - 1.0) * frac;
            match fault.kind {
                FaultKind::SpringPretension(k) => m.pretension *= scale(k),
                FaultKind::Spring(k) => m.stiffness *= scale(k),
                FaultKind::Friction(k) => m.friction *= scale(k),
                FaultKind::CurrentGain(k) => m.drive_gain *= scale(k),
                FaultKind::Supply(k) => m.supply *= scale(k),
                FaultKind::Backlash(k) => m.backlash *= scale(k),
                FaultKind::Jamming => m.jam = m.jam.max(frac),
                FaultKind::SensorOffset(v) => m.sensor_offset += v * frac,
                FaultKind::SensorStuck => m.sensor_stuck |= frac > 0.0,
                FaultKind::SensorNoise(k) => m.sensor_noise *= scale(k),
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for text in [
            "friction_x3",
            "spring_x0.73",
            "supply_x0.5",
            "sensor_stuck",
            "spring_pretension_x1.5",
            "current_gain_x0.5",
            "backlash_x2",
            "jamming",
            "sensor_offset_0.001",
            "sensor_offset_-0.002",
            "sensor_noise_x10",
            "friction_x3~10s",
            "friction_x3~0.5s",
        ] {
            let f: Fault = text.parse().unwrap();
            assert_eq!(f.to_string(), text);
        }
        let f: Fault = "friction_x3~500ms".parse().unwrap();
        assert_eq!(f.ramp_s, 0.5);
        assert_eq!(f.kind, FaultKind::Friction(3.0));
    }

    #[test]
    fn schedules_parse() {
        let s: ScheduledFault = "friction_x3@5s".parse().unwrap();
        assert_eq!(s.at_s, 5.0);
        assert_eq!(s.to_string(), "friction_x3@5s");
        let s: ScheduledFault = "friction_x3~10s@5.5s".parse().unwrap();
        assert_eq!((s.at_s, s.fault.ramp_s), (5.5, 10.0));
        assert_eq!(s.to_string(), "friction_x3~10s@5.5s");
        let s: ScheduledFault = "spring_x0.73@500ms".parse().unwrap();
        assert_eq!(s.at_s, 0.5);
        for bad in [
            "friction_x3",
            "friction_x@5s",
            "frobnicate@1s",
            "friction_x3@5",
            "spring_x-1@1s",
        ] {
            assert!(bad.parse::<ScheduledFault>().is_err(), "{bad}");
        }
    }

    #[test]
    fn drift_ramps_linearly() {
        let mut set = FaultSet::default();
        set.inject("friction_x3~10s".parse().unwrap(), 2.0);
        assert_eq!(set.modifiers(1.0).friction, 1.0);
        assert!((set.modifiers(7.0).friction - 2.0).abs() < 1e-12);
        assert_eq!(set.modifiers(20.0).friction, 3.0);
    }
}
