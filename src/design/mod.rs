//! Design-time tools that work on simulated plants: robust controller design from a plant
//! file and the paper's controller comparison. Uses `physics` and `control`; no I/O beyond
//! reading a plant file and writing a controller file.

pub mod comparison;
pub mod robust;

pub use comparison::{
    run_comparison, ComparisonConfig, ComparisonRow, ComparisonTable, PidFcTuning,
};
pub use robust::{design_robust, design_robust_with, write_controller_toml, RobustDesign};
