//! Control algorithms, sans-I/O and allocation-free per cycle.

mod discrete;
mod friction_ff;

pub use discrete::{ControllerError, DiscreteController, MAX_ORDER};
pub use friction_ff::FrictionFeedForward;
pub mod robust;

mod adaptive_friction;
mod adaptive_friction_section;
mod adaptive_pneumatic;
mod adaptive_pneumatic_section;
mod arrival_relief;
mod controller_section;
mod direction_p;
mod dither;
mod dither_section;
mod friction_compensation_section;
mod integrator_design;
mod learned_table;
mod learned_table_section;
mod linear;
mod nonlinear_correction;
mod nonlinear_correction_section;
mod param_error;
mod scheduling;
mod scheduling_section;
mod state_feedback;

pub use adaptive_friction::{AdaptiveFriction, AdaptiveFrictionConfig, AdaptiveFrictionOutput};
pub use adaptive_friction_section::AdaptiveFrictionSection;
pub use adaptive_pneumatic::{
    GainSource, PneumaticAdaptive, PneumaticAdaptiveConfig, PneumaticStep,
};
pub use adaptive_pneumatic_section::PneumaticAdaptiveSection;
pub use arrival_relief::{ArrivalRelief, ArrivalReliefConfig, ArrivalReliefStep};
pub use controller_section::ControllerSection;
pub use direction_p::{DirectionalP, DirectionalPConfig};
pub use dither::{Dither, DitherConfig};
pub use dither_section::DitherSection;
pub use friction_compensation_section::FrictionCompensationSection;
pub use integrator_design::{effort_weight_for_pole, integrator_lq_gain};
pub use learned_table::{
    LearnedCellState, LearnedTable, LearnedTableConfig, LearnedTableState, OperatingPoint,
    LEARNED_TABLE_VERSION,
};
pub use learned_table_section::LearnedTableSection;
pub use linear::LinearController;
pub use nonlinear_correction::{NonlinearCorrection, NonlinearCorrectionConfig};
pub use nonlinear_correction_section::CorrectionSection;
pub use param_error::ParamError;
pub use scheduling::{BandStatus, GainSchedule, SchedulePoint, SupplyBand, MAX_SCHEDULED};
pub use scheduling_section::{ScheduleSection, ScheduleVariable};
pub use state_feedback::{StateFeedback, MAX_STATES};
