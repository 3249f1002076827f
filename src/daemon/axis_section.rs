//! `[[axis]]`, declared once: the axis' own keys (its name, its actuator node, what it
//! commands, where it starts, its safe command) with their units, ranges and defaults, and the
//! sections it is made of, each declared beside its algorithm. The two keys with a writable
//! dictionary entry (the safe command, the setpoint's rate limit) are declared in the device
//! profile, which makes their entries, and borrowed here. The rules between keys (the
//! safe command within the output limits, the setpoints within the travel, a section needing
//! another) are checked in [`Config::validate`](super::config::Config::validate).

use std::path::PathBuf;

use super::config::SetpointStep;
use super::profile_config::{Cia401Section, Cia402Section, HomingSection, ProfileKind};
use crate::control::{
    AdaptiveFrictionSection, ControllerSection, CorrectionSection, DitherSection,
    FrictionCompensationSection, LearnedTableSection, PneumaticAdaptiveSection, ScheduleSection,
};
use crate::declare_section;
pub use crate::device::objects::CommandKind;
use crate::device::objects::{AxisKeys, SetpointKeys};
use crate::param::{Kind, ParamError, ParamValue};
use crate::supervise::{
    FaultReactionsSection, LimitsSection, ObserverSection, ParameterEstimationSection,
    SetpointTimeoutSection,
};

/// A section of the axis, checked by its own declaration (with its keys' prefix) where the axis
/// is validated.
macro_rules! table_value {
    ($($t:ty),* $(,)?) => {
        $(
            impl ParamValue for $t {
                const KIND: Kind = Kind::Table;
                fn each(
                    &self,
                    _f: &mut dyn FnMut(f64) -> Result<(), ParamError>,
                ) -> Result<(), ParamError> {
                    Ok(())
                }
            }
        )*
    };
}

table_value!(
    ControllerSection,
    FrictionCompensationSection,
    AdaptiveFrictionSection,
    DitherSection,
    CorrectionSection,
    ScheduleSection,
    PneumaticAdaptiveSection,
    ObserverSection,
    ParameterEstimationSection,
    FaultReactionsSection,
    LearnedTableSection,
    LimitsSection,
    SetpointTimeoutSection,
    Vec<SetpointStep>,
    Cia402Section,
    HomingSection,
    Cia401Section,
);

declare_section! {
    /// `[[axis]]`: one axis of the node.
    pub struct AxisConfig {
        name: String = { unit: "", access: Restart, doc: "the axis' name" },
        /// Node id of the axis' actuator node (real or simulated), 1..=127.
        actuator_node_id: u8 = {
            unit: "", min: 1.0, max: 127.0, access: Restart,
            doc: "node id of the axis' actuator node", words: "a node id in 1..=127",
        },
        command: CommandKind = { unit: "", access: Restart, doc: "what the command means" },
        /// Send NMT start to the actuator node at start-up.
        start_node: bool = {
            unit: "", access: Restart, doc: "send NMT start to the actuator node",
            default: true,
        },
        /// Setpoint before any arrives, m.
        initial_setpoint_m: f64 = {
            unit: "m", access: Restart, doc: "setpoint before any arrives",
        },
        setpoint_rate_max_m_per_s: Option<f64> = { from: SetpointKeys },
        safe_command: f64 = { from: AxisKeys },
        controller: ControllerSection = { unit: "", access: Restart, doc: "" },
        friction_compensation: Option<FrictionCompensationSection> = {
            unit: "", access: Restart, doc: "",
        },
        /// Adaptive friction compensation with a reference model; replaces the feed-forward of
        /// `[axis.friction_compensation]`, whose values (when present) are its starting point.
        adaptive_friction: Option<AdaptiveFrictionSection> = {
            unit: "", access: Restart, doc: "",
        },
        /// A sine added to the command against stiction.
        dither: Option<DitherSection> = { unit: "", access: Restart, doc: "" },
        /// Inverse of the static force characteristic applied to the controller output.
        correction: Option<CorrectionSection> = { unit: "", access: Restart, doc: "" },
        /// Controller parameters as functions of the measured supply voltage or pressure.
        schedule: Option<ScheduleSection> = { unit: "", access: Restart, doc: "" },
        /// Online estimation of the drive gains of a duty axis and redesign of its P gains.
        pneumatic_adaptive: Option<PneumaticAdaptiveSection> = {
            unit: "", access: Restart, doc: "",
        },
        /// Disturbance observer with learned x4 bands (fault detection by state estimation).
        observer: Option<ObserverSection> = { unit: "", access: Restart, doc: "" },
        /// Parameter estimation, symptoms and diagnosis with the fault-symptom table.
        parameter_estimation: Option<ParameterEstimationSection> = {
            unit: "", access: Restart, doc: "",
        },
        /// Reaction per supervised fault; absent: the defaults of [`FaultReactionsSection`].
        fault_reactions: Option<FaultReactionsSection> = { unit: "", access: Restart, doc: "" },
        /// Adapted friction compensation stored by operating point (needs
        /// `[axis.adaptive_friction]`).
        learned_table: Option<LearnedTableSection> = { unit: "", access: Restart, doc: "" },
        limits: LimitsSection = { unit: "", access: Restart, doc: "" },
        /// The commander's set-points watched for their age, with a reaction when they stop.
        setpoint_timeout: Option<SetpointTimeoutSection> = {
            unit: "", access: Restart, doc: "",
        },
        /// A setpoint schedule; setpoint frames on the bus override it until its next entry.
        setpoints: Vec<SetpointStep> = {
            unit: "", access: Restart, doc: "", default: Vec::new(),
        },
        /// What the actuator node speaks: "actuatord" (default), "cia402" or "cia401".
        profile: ProfileKind = {
            unit: "", access: Restart, doc: "what the actuator node speaks",
            default: ProfileKind::Actuatord,
        },
        /// A CiA 402 drive's units (`profile = "cia402"`).
        cia402: Option<Cia402Section> = { unit: "", access: Restart, doc: "" },
        /// A CiA 401 module's channels and scaling (`profile = "cia401"`).
        cia401: Option<Cia401Section> = { unit: "", access: Restart, doc: "" },
        /// The node's EDS: its default PDO mapping is used (and checked on the node) instead of
        /// configuring one over SDO; relative to the configuration file.
        eds: Option<PathBuf> = { unit: "", access: Restart, doc: "" },
    }
}
