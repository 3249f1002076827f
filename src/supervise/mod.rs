//! Supervision: limit checks, fault states, and (later) model-based fault detection.

mod fault;
mod limits;
mod limits_section;

pub use fault::{FaultFlags, FaultKind, FaultState};
pub use limits::{Band, LimitSupervisor, Limits, SupervisionInput, SupervisionOutput};
pub use limits_section::LimitsSection;
mod estimator_supervisor;
mod fault_machine;
mod fault_reactions_section;
pub mod fault_table;
mod observer;
mod observer_section;
mod param_diagnosis;
mod parameter_estimation_section;
mod setpoint_timeout;

pub use estimator_supervisor::{
    EstimatorHealth, EstimatorSupervisor, EstimatorSupervisorConfig, MAX_SUPERVISED,
};
pub use fault_machine::{
    DriveStop, FaultMachine, FaultMachineConfig, FaultMachineOutput, FaultPolicy, Reaction,
    SupervisedFault, SupervisedFaults, SupervisionLevel,
};
pub use fault_reactions_section::{FaultReactionsSection, ReactionName};
pub use fault_table::{FaultSymptomTable, FaultTableError, TableRow};
pub use observer::{Deviation, DisturbanceObserver, ObserverConfig, ObserverOutput};
pub use observer_section::ObserverSection;
pub use param_diagnosis::{
    diagnose, physical_from_theta, symptom_bound, symptoms, DiagnosedFault, Diagnosis, Nominal,
    NominalLearner, ParameterEstimator, ParameterEstimatorConfig, PhysicalEstimate,
    PhysicalParameters, Symptom, SymptomThresholds, PHYSICAL_NAMES, PHYSICAL_PARAMS,
};
pub use parameter_estimation_section::{NominalParameters, ParameterEstimationSection};
pub use setpoint_timeout::{
    SetpointSourceEvent, SetpointTimeoutReaction, SetpointTimeoutSection, SetpointWatchdog,
};
