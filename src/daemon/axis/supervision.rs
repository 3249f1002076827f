//! The axis' supervision as one part: the limit checks of `[axis.limits]` and the fault machine
//! of `[axis.fault_reactions]`, fed with what the other parts found this cycle (the observer's
//! friction rise, the estimation's confirmed diagnosis, an implausible drive-gain estimate).
//! Built once from its sections, stepped in the supervision stage; a rebuilt axis keeps the
//! latched limit faults.

use super::super::config::AxisConfig;
use super::estimation::Estimation;
use super::{unvalidated, ModelSupervision};
use crate::control::ControllerError;
use crate::supervise::{
    DiagnosedFault, FaultFlags, FaultMachine, FaultMachineOutput, FaultState, LimitSupervisor,
    SupervisedFault, SupervisedFaults, SupervisionInput, SupervisionLevel, SupervisionOutput,
};

/// What the other parts found this cycle.
pub struct Findings<'a> {
    /// The observer's `x4` left its band: friction rose.
    pub observer_friction: bool,
    /// The estimation, for its confirmed diagnosis, confidence, symptoms and estimate.
    pub estimation: Option<&'a Estimation>,
    /// A drive-gain estimate of the pneumatic law is implausible.
    pub estimator_implausible: bool,
    /// The supply is outside its scheduled band: the loop goes on with a warning.
    pub off_band: bool,
}

pub struct Supervision {
    limits: LimitSupervisor,
    machine: FaultMachine,
    model: ModelSupervision,
}

impl Supervision {
    /// The part `[axis.limits]` and `[axis.fault_reactions]` ask for.
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        Ok(Self {
            limits: LimitSupervisor::new(cfg.limits.limits(period_s)),
            machine: FaultMachine::new(&cfg.fault_machine_config()).map_err(unvalidated)?,
            model: ModelSupervision {
                confidence: 1.0,
                ..Default::default()
            },
        })
    }

    /// The limit checks on this cycle's readings and the fault machine on what was found. The
    /// published state is the fault machine's decision, at least "warning" while a limit is
    /// exceeded but not yet latched or the supply is off its scheduled band.
    pub fn step(&mut self, input: &SupervisionInput, found: &Findings) -> SupervisionOutput {
        let mut limits = self.limits.step(input);
        let mut present = SupervisedFaults::default();
        if !limits.latched.is_empty() {
            present.insert(SupervisedFault::LimitViolation);
        }
        if found.observer_friction {
            present.insert(SupervisedFault::ObserverFriction);
        }
        if let Some(f) = found
            .estimation
            .and_then(Estimation::present)
            .and_then(supervised)
        {
            present.insert(f);
        }
        if found.estimator_implausible {
            present.insert(SupervisedFault::EstimatorImplausible);
        }
        let machine = self.machine.step(present);
        if let Some(f) = machine.raised.iter().next() {
            self.model.diagnosed_fault = Some(f);
            self.model.confidence = match (f, found.estimation) {
                (
                    SupervisedFault::SpringPretension
                    | SupervisedFault::SpringStiffness
                    | SupervisedFault::FrictionIncrease
                    | SupervisedFault::CurrentGain
                    | SupervisedFault::SensorOffset,
                    Some(e),
                ) => e.confidence(),
                _ => 1.0,
            };
        }
        self.model.machine = machine;
        if let Some(e) = found.estimation {
            self.model.symptoms = e.symptoms();
            self.model.nominal_learned = e.nominal().is_some();
            self.model.estimate = e.last();
        }
        let mut state = state_of(machine.level);
        if (found.off_band || !limits.pending.is_empty())
            && state.severity() < FaultState::Warning.severity()
        {
            state = FaultState::Warning;
        }
        limits.state = state;
        limits
    }

    /// What the model-based supervision decided in the last cycle.
    pub fn model(&self) -> &ModelSupervision {
        &self.model
    }

    /// The fault machine holds the axis in its safe state.
    pub fn fail_safe(&self) -> bool {
        self.model.machine.fail_safe
    }

    /// The latched limit faults.
    pub fn limits_latched(&self) -> FaultFlags {
        self.limits.latched()
    }

    /// Keep the limit faults `old` has latched (a rebuilt axis does not forget a fault).
    pub fn keep_latched(&mut self, old: &Supervision) {
        self.limits.keep_latched(old.limits.latched());
    }

    /// Clear latched faults and the diagnosis.
    pub fn reset(&mut self) {
        self.limits.reset();
        self.machine.reset();
        self.model.diagnosed_fault = None;
        self.model.confidence = 1.0;
        self.model.machine = FaultMachineOutput::default();
    }
}

/// The supervised fault of a diagnosis; `None` for a fault the fault machine has no entry for
/// (its symptoms would still be on the bus).
fn supervised(fault: DiagnosedFault) -> Option<SupervisedFault> {
    match fault {
        DiagnosedFault::SpringPretension => Some(SupervisedFault::SpringPretension),
        DiagnosedFault::SpringStiffness => Some(SupervisedFault::SpringStiffness),
        DiagnosedFault::FrictionIncrease => Some(SupervisedFault::FrictionIncrease),
        DiagnosedFault::CurrentGain => Some(SupervisedFault::CurrentGain),
        DiagnosedFault::SensorOffset => Some(SupervisedFault::SensorOffset),
    }
}

fn state_of(level: SupervisionLevel) -> FaultState {
    match level {
        SupervisionLevel::Ok => FaultState::Ok,
        SupervisionLevel::Warning => FaultState::Warning,
        SupervisionLevel::MaintenanceRequested => FaultState::MaintenanceRequested,
        SupervisionLevel::FailSafe => FaultState::Fault,
    }
}
