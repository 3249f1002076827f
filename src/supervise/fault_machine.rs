//! The decision level of the supervision (Isermann & Raab, inference part: "decisions for fault
//! handling: request maintenance, fail safe, switch off a faulty actuator"): a fault state machine
//! `ok → warning → maintenance requested → fail-safe` with a configurable reaction per fault.
//!
//! A fault present for `persistence` consecutive cycles latches until [`FaultMachine::reset`];
//! while present but not yet latched it is pending and the state is at least `Warning`. The state
//! is the most severe reaction among the latched faults; it never falls back on its own.

use crate::param::ParamError;

/// Faults found by the model-based supervision (and the limit checks as one entry).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum SupervisedFault {
    /// F1, from the parameter diagnosis.
    SpringPretension,
    /// F2.
    SpringStiffness,
    /// F3.
    FrictionIncrease,
    /// F4.
    CurrentGain,
    /// The disturbance observer's `x4` left its bands (friction rise).
    ObserverFriction,
    /// The adaptive controller's estimator is implausible (it runs on scheduled gains).
    EstimatorImplausible,
    /// A limit check latched (following error, end of range, current, supply, timeouts).
    LimitViolation,
    /// F5, from the parameter diagnosis: the position sensor reads with an offset.
    SensorOffset,
}

impl SupervisedFault {
    /// Bit order of [`SupervisedFaults`].
    pub const ALL: [SupervisedFault; 8] = [
        SupervisedFault::SpringPretension,
        SupervisedFault::SpringStiffness,
        SupervisedFault::FrictionIncrease,
        SupervisedFault::CurrentGain,
        SupervisedFault::ObserverFriction,
        SupervisedFault::EstimatorImplausible,
        SupervisedFault::LimitViolation,
        SupervisedFault::SensorOffset,
    ];

    pub fn bit(self) -> u16 {
        1 << (self as u16)
    }

    /// The fault's name: its reaction key in `[axis.fault_reactions]`, and the name the logs
    /// and the DBC's value table give it.
    pub fn name(self) -> &'static str {
        use super::FaultReactionsSection as R;
        use crate::param_key;
        match self {
            SupervisedFault::SpringPretension => param_key!(R, spring_pretension),
            SupervisedFault::SpringStiffness => param_key!(R, spring_stiffness),
            SupervisedFault::FrictionIncrease => param_key!(R, friction_increase),
            SupervisedFault::CurrentGain => param_key!(R, current_gain),
            SupervisedFault::ObserverFriction => param_key!(R, observer_friction),
            SupervisedFault::EstimatorImplausible => param_key!(R, estimator_implausible),
            SupervisedFault::LimitViolation => param_key!(R, limit_violation),
            SupervisedFault::SensorOffset => param_key!(R, sensor_offset),
        }
    }
}

/// A set of [`SupervisedFault`]s, one bit each (the symptom bits on the bus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct SupervisedFaults(pub u16);

impl SupervisedFaults {
    pub fn contains(self, f: SupervisedFault) -> bool {
        self.0 & f.bit() != 0
    }
    pub fn insert(&mut self, f: SupervisedFault) {
        self.0 |= f.bit();
    }
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }
    pub fn iter(self) -> impl Iterator<Item = SupervisedFault> {
        SupervisedFault::ALL
            .into_iter()
            .filter(move |f| self.contains(*f))
    }
}

/// The reaction to a latched fault, in increasing severity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Reaction {
    /// Report only.
    Warning,
    /// Keep working, ask for maintenance.
    Maintenance,
    /// A CiA 402 drive stops on its profile deceleration 6084h (controlword bit 8) and holds,
    /// enabled; the axis is out of work as in fail-safe.
    Halt,
    /// A CiA 402 drive gets the command "quick stop": it stops as its quick stop option code
    /// 605Ah says; the axis is out of work as in fail-safe.
    QuickStop,
    /// Drive the actuator to its safe state and hold it there.
    FailSafe,
}

impl Reaction {
    /// The stop a CiA 402 drive is told to make for this reaction, if any.
    pub fn drive_stop(self) -> DriveStop {
        match self {
            Reaction::Halt => DriveStop::Halt,
            Reaction::QuickStop => DriveStop::QuickStop,
            _ => DriveStop::None,
        }
    }
}

/// The stop a CiA 402 drive makes on its own ramp, in increasing severity: the strongest
/// asked for by a latched fault is applied, beside the safe command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum DriveStop {
    #[default]
    None,
    /// Controlword bit 8: stop on 6084h, stay enabled.
    Halt,
    /// The device control command "quick stop" (controlword bit 2 low).
    QuickStop,
}

/// The state of the machine, in increasing severity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum SupervisionLevel {
    #[default]
    Ok,
    Warning,
    MaintenanceRequested,
    FailSafe,
}

impl SupervisionLevel {
    /// Code on the bus.
    pub fn code(self) -> u8 {
        self as u8
    }
    pub fn name(self) -> &'static str {
        match self {
            SupervisionLevel::Ok => "ok",
            SupervisionLevel::Warning => "warning",
            SupervisionLevel::MaintenanceRequested => "maintenance_requested",
            SupervisionLevel::FailSafe => "fail_safe",
        }
    }
}

/// Reaction and persistence of one fault.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultPolicy {
    pub fault: SupervisedFault,
    pub reaction: Reaction,
    /// Consecutive cycles present before it latches (at least 1).
    pub persistence_cycles: u32,
}

/// Policies for all faults; faults without a policy latch at once with `Warning`.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultMachineConfig {
    pub policies: Vec<FaultPolicy>,
}

impl Default for FaultMachineConfig {
    /// Slow multiplicative faults ask for maintenance, a current-circuit fault and limit
    /// violations go to the safe state, an implausible estimator only warns.
    fn default() -> Self {
        let p = |fault, reaction, persistence_cycles| FaultPolicy {
            fault,
            reaction,
            persistence_cycles,
        };
        use Reaction::*;
        use SupervisedFault::*;
        Self {
            policies: vec![
                p(SpringPretension, Maintenance, 1),
                p(SpringStiffness, Maintenance, 1),
                p(FrictionIncrease, Maintenance, 1),
                p(CurrentGain, FailSafe, 1),
                p(ObserverFriction, Maintenance, 1),
                p(EstimatorImplausible, Warning, 10),
                p(LimitViolation, FailSafe, 1),
                p(SensorOffset, Maintenance, 1),
            ],
        }
    }
}

/// What the machine decided this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FaultMachineOutput {
    pub level: SupervisionLevel,
    pub latched: SupervisedFaults,
    /// Latched in this very cycle (one EMCY each).
    pub raised: SupervisedFaults,
    pub pending: SupervisedFaults,
    /// The actuator must be in its safe state.
    pub fail_safe: bool,
    /// The drive stop the latched faults ask for.
    pub stop: DriveStop,
    /// The most severe reaction among the latched faults (`None` while nothing is latched).
    pub reaction: Option<Reaction>,
}

const N: usize = SupervisedFault::ALL.len();

/// The fault state machine. `step` is allocation-free.
#[derive(Debug, Clone)]
pub struct FaultMachine {
    reaction: [Reaction; N],
    persistence: [u32; N],
    count: [u32; N],
    latched: SupervisedFaults,
}

impl FaultMachine {
    pub fn new(config: &FaultMachineConfig) -> Result<Self, ParamError> {
        let mut reaction = [Reaction::Warning; N];
        let mut persistence = [1; N];
        let mut seen = SupervisedFaults::default();
        for p in &config.policies {
            if seen.contains(p.fault) {
                return Err(ParamError::new(
                    "policies",
                    format!("{} is given twice", p.fault.name()),
                ));
            }
            seen.insert(p.fault);
            reaction[p.fault as usize] = p.reaction;
            persistence[p.fault as usize] = p.persistence_cycles.max(1);
        }
        Ok(Self {
            reaction,
            persistence,
            count: [0; N],
            latched: SupervisedFaults::default(),
        })
    }

    /// One cycle with the faults present now.
    pub fn step(&mut self, present: SupervisedFaults) -> FaultMachineOutput {
        let before = self.latched;
        let mut pending = SupervisedFaults::default();
        for f in SupervisedFault::ALL {
            let i = f as usize;
            if present.contains(f) {
                self.count[i] = self.count[i].saturating_add(1);
                if self.count[i] >= self.persistence[i] {
                    self.latched.insert(f);
                } else {
                    pending.insert(f);
                }
            } else {
                self.count[i] = 0;
            }
        }
        let mut level = SupervisionLevel::Ok;
        let mut stop = DriveStop::None;
        let mut reaction = None;
        for f in self.latched.iter() {
            let r = self.reaction[f as usize];
            let l = match r {
                Reaction::Warning => SupervisionLevel::Warning,
                Reaction::Maintenance => SupervisionLevel::MaintenanceRequested,
                // The drive stops itself; to the axis it is the safe state.
                Reaction::Halt | Reaction::QuickStop | Reaction::FailSafe => {
                    SupervisionLevel::FailSafe
                }
            };
            level = level.max(l);
            stop = stop.max(r.drive_stop());
            reaction = reaction.max(Some(r));
        }
        if !pending.is_empty() {
            level = level.max(SupervisionLevel::Warning);
        }
        FaultMachineOutput {
            level,
            latched: self.latched,
            raised: SupervisedFaults(self.latched.0 & !before.0),
            pending,
            fail_safe: level == SupervisionLevel::FailSafe,
            stop,
            reaction,
        }
    }

    /// Clear everything latched (a reset from the automation system or after maintenance).
    pub fn reset(&mut self) {
        self.latched = SupervisedFaults::default();
        self.count = [0; N];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(faults: &[SupervisedFault]) -> SupervisedFaults {
        let mut s = SupervisedFaults::default();
        for f in faults {
            s.insert(*f);
        }
        s
    }

    #[test]
    fn escalates_by_reaction_latches_and_resets() {
        let mut m = FaultMachine::new(&FaultMachineConfig::default()).expect("valid");
        assert_eq!(m.step(set(&[])).level, SupervisionLevel::Ok);
        let out = m.step(set(&[SupervisedFault::EstimatorImplausible]));
        assert_eq!(out.level, SupervisionLevel::Warning);
        assert!(out.latched.is_empty());
        let out = m.step(set(&[SupervisedFault::FrictionIncrease]));
        assert_eq!(out.level, SupervisionLevel::MaintenanceRequested);
        assert!(out.raised.contains(SupervisedFault::FrictionIncrease));
        // Latched: gone from the input, still requested, not raised again.
        let out = m.step(set(&[]));
        assert_eq!(out.level, SupervisionLevel::MaintenanceRequested);
        assert!(out.raised.is_empty());
        let out = m.step(set(&[SupervisedFault::CurrentGain]));
        assert_eq!(out.level, SupervisionLevel::FailSafe);
        assert!(out.fail_safe);
        m.reset();
        assert_eq!(m.step(set(&[])).level, SupervisionLevel::Ok);
    }

    #[test]
    fn reaction_is_configurable_and_duplicates_are_refused() {
        let mut cfg = FaultMachineConfig::default();
        cfg.policies[3].reaction = Reaction::Warning;
        let mut m = FaultMachine::new(&cfg).expect("valid");
        assert_eq!(
            m.step(set(&[SupervisedFault::CurrentGain])).level,
            SupervisionLevel::Warning
        );
        cfg.policies.push(cfg.policies[0]);
        assert!(FaultMachine::new(&cfg).is_err());
    }

    #[test]
    fn a_drive_stop_is_fail_safe_and_the_strongest_stop_wins() {
        let mut cfg = FaultMachineConfig::default();
        cfg.policies[2].reaction = Reaction::Halt; // friction increase
        cfg.policies[6].reaction = Reaction::QuickStop; // limit violation
        let mut m = FaultMachine::new(&cfg).expect("valid");
        let out = m.step(set(&[SupervisedFault::FrictionIncrease]));
        assert_eq!(out.level, SupervisionLevel::FailSafe);
        assert!(out.fail_safe);
        assert_eq!(out.stop, DriveStop::Halt);
        assert_eq!(out.reaction, Some(Reaction::Halt));
        let out = m.step(set(&[SupervisedFault::LimitViolation]));
        assert_eq!(out.stop, DriveStop::QuickStop);
        assert_eq!(out.reaction, Some(Reaction::QuickStop));
        // A fail-safe fault beside it: the safe command, and the drive's stop stays.
        let out = m.step(set(&[SupervisedFault::CurrentGain]));
        assert_eq!(out.stop, DriveStop::QuickStop);
        assert_eq!(out.reaction, Some(Reaction::FailSafe));
        m.reset();
        let out = m.step(set(&[]));
        assert_eq!((out.stop, out.reaction), (DriveStop::None, None));
    }
}
