//! `[axis.fault_reactions]`, declared once: which reaction each supervised fault gets when it
//! latches, as the file names it. A fault left out keeps the fault machine's default (see
//! [`FaultMachineConfig::default`]). Part of the structure of the supervision: changed by a
//! reload, not in the dictionary.

use super::{FaultMachineConfig, Reaction, SupervisedFault};
use crate::{declare_choice, declare_section};

declare_choice! {
    /// A reaction to a latched supervised fault, in increasing severity.
    pub enum ReactionName {
        Warning = warning,
        MaintenanceRequested = maintenance_requested,
        /// A CiA 402 drive stops on its profile deceleration 6084h (controlword bit 8, halt)
        /// and holds there, enabled; the safe command goes out beside it.
        Halt = halt,
        /// A CiA 402 drive gets the command "quick stop" and stops as its quick stop option
        /// code 605Ah says; the safe command goes out beside it.
        QuickStop = quick_stop,
        FailSafe = fail_safe,
    }
}

impl ReactionName {
    /// The fault machine's reaction.
    pub fn reaction(self) -> Reaction {
        match self {
            ReactionName::Warning => Reaction::Warning,
            ReactionName::MaintenanceRequested => Reaction::Maintenance,
            ReactionName::Halt => Reaction::Halt,
            ReactionName::QuickStop => Reaction::QuickStop,
            ReactionName::FailSafe => Reaction::FailSafe,
        }
    }

    /// The name of a fault machine's reaction.
    pub fn of(reaction: Reaction) -> Self {
        match reaction {
            Reaction::Warning => ReactionName::Warning,
            Reaction::Maintenance => ReactionName::MaintenanceRequested,
            Reaction::Halt => ReactionName::Halt,
            Reaction::QuickStop => ReactionName::QuickStop,
            Reaction::FailSafe => ReactionName::FailSafe,
        }
    }

    /// The reaction is a stop a CiA 402 drive makes (it fits no other node).
    pub fn is_drive_stop(self) -> bool {
        self.reaction().drive_stop() != super::DriveStop::None
    }
}

declare_section! {
    /// `[axis.fault_reactions]`: one reaction per supervised fault; unnamed faults keep the
    /// default (diagnosed F1-F3, F5 sensor offset and the observer's friction rise:
    /// maintenance_requested; F4 current gain and limit violations: fail_safe; an implausible
    /// estimator: warning).
    pub struct FaultReactionsSection {
        spring_pretension: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to F1, a changed spring pretension",
        },
        spring_stiffness: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to F2, a changed spring stiffness",
        },
        friction_increase: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to F3, a friction increase",
        },
        current_gain: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to F4, a changed current gain",
        },
        observer_friction: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to the observer's friction rise",
        },
        estimator_implausible: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to an implausible estimator",
        },
        limit_violation: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to a limit violation",
        },
        sensor_offset: Option<ReactionName> = {
            unit: "", access: Restart, doc: "reaction to F5, a sensor offset",
        },
    }
}

impl Default for FaultReactionsSection {
    /// Every fault with the fault machine's default reaction.
    fn default() -> Self {
        Self::defaults().expect("every reaction may be left out")
    }
}

impl FaultReactionsSection {
    /// The first fault whose configured reaction is a drive stop, with its reaction.
    pub fn drive_stop(&self) -> Option<(SupervisedFault, ReactionName)> {
        SupervisedFault::ALL
            .into_iter()
            .find_map(|f| self.named(f).filter(|r| r.is_drive_stop()).map(|r| (f, r)))
    }

    /// The reaction configured for `fault`, if any.
    pub fn named(&self, fault: SupervisedFault) -> Option<ReactionName> {
        match fault {
            SupervisedFault::SpringPretension => self.spring_pretension,
            SupervisedFault::SpringStiffness => self.spring_stiffness,
            SupervisedFault::FrictionIncrease => self.friction_increase,
            SupervisedFault::CurrentGain => self.current_gain,
            SupervisedFault::ObserverFriction => self.observer_friction,
            SupervisedFault::EstimatorImplausible => self.estimator_implausible,
            SupervisedFault::LimitViolation => self.limit_violation,
            SupervisedFault::SensorOffset => self.sensor_offset,
        }
    }

    /// The fault machine's policies: the defaults with the configured reactions.
    pub fn machine_config(&self) -> FaultMachineConfig {
        let mut config = FaultMachineConfig::default();
        for policy in config.policies.iter_mut() {
            if let Some(n) = self.named(policy.fault) {
                policy.reaction = n.reaction();
            }
        }
        config
    }
}
