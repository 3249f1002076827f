//! Supervision: limit checks, fault states, and (later) model-based fault detection.

mod fault;
mod limits;

pub use fault::{FaultFlags, FaultKind, FaultState};
pub use limits::{Band, LimitSupervisor, Limits, SupervisionInput, SupervisionOutput};
mod estimator_supervisor;
mod fault_machine;
mod observer;
mod param_diagnosis;

pub use estimator_supervisor::{
    EstimatorHealth, EstimatorSupervisor, EstimatorSupervisorConfig, MAX_SUPERVISED,
};
pub use fault_machine::{
    FaultMachine, FaultMachineConfig, FaultMachineOutput, FaultPolicy, Reaction, SupervisedFault,
    SupervisedFaults, SupervisionLevel,
};
pub use observer::{Deviation, DisturbanceObserver, ObserverConfig, ObserverOutput};
pub use param_diagnosis::{
    diagnose, physical_from_theta, symptoms, DiagnosedFault, Diagnosis, ParameterEstimator,
    ParameterEstimatorConfig, PhysicalParameters, Symptom, FAULT_SYMPTOM_TABLE, PHYSICAL_NAMES,
    PHYSICAL_PARAMS,
};
