//! The axis' commander: set-points from the bus (the `setpoint` frame, an SDO write) watched
//! by `[axis.setpoint_timeout]`, and the reaction while the commander is quiet.

use super::Axis;
use crate::supervise::{SetpointSourceEvent, SetpointTimeoutReaction};

impl Axis {
    /// A set-point from the commander (not from the configured schedule) at `now_s`: it feeds
    /// the watchdog, and ends its reaction.
    pub fn on_commanded_setpoint(&mut self, position: f64, now_s: f64) {
        if let Some((watch, _)) = self.setpoint_timeout.as_mut() {
            watch.on_setpoint(now_s);
        }
        self.set_setpoint(position);
    }

    /// The commander's set-points are older than the timeout: its reaction is in force.
    pub fn commander_lost(&self) -> bool {
        self.setpoint_timeout
            .as_ref()
            .is_some_and(|(watch, _)| watch.is_lost())
    }

    /// The loss reaction is the safe command.
    pub(super) fn commander_safe_command(&self) -> bool {
        self.setpoint_timeout.as_ref().is_some_and(|(watch, s)| {
            watch.is_lost() && s.reaction == SetpointTimeoutReaction::SafeCommand
        })
    }

    /// Stage "scheduling": the watchdog's look at the clock, and the set-point of the reaction
    /// when the commander has just gone quiet.
    pub(super) fn watch_commander(&mut self, now_s: f64) {
        self.setpoint_source = None;
        let Some((watch, section)) = self.setpoint_timeout.as_mut() else {
            return;
        };
        let event = watch.poll(now_s);
        self.setpoint_source = event;
        if event != Some(SetpointSourceEvent::Lost) {
            return;
        }
        match (section.reaction, section.safe_position_m) {
            // Where the ramp stands now; the axis' position while it may not move yet.
            (SetpointTimeoutReaction::Hold, _) => {
                let here = if self.motion_enabled {
                    self.reference
                } else {
                    self.sensor.position
                };
                self.set_setpoint(here);
            }
            (SetpointTimeoutReaction::SafePosition, Some(p)) => self.set_setpoint(p),
            // Validation requires the position; the safe command is the other reaction.
            (SetpointTimeoutReaction::SafePosition, None)
            | (SetpointTimeoutReaction::SafeCommand, _) => {}
        }
    }
}
