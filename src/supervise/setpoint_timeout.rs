//! The set-point source's watchdog: `[axis.setpoint_timeout]`, declared once, and the sans-I/O
//! watch on the age of the last set-point the commander sent (a `setpoint` frame, or an SDO
//! write of the set-point). A commander that goes quiet for longer than `timeout_s` gets the
//! configured reaction; its next set-point ends it. Armed by the commander's first set-point:
//! an axis nobody commands runs its configured schedule unwatched.

use crate::{declare_choice, declare_section};

declare_choice! {
    /// What the axis does when its commander goes quiet.
    pub enum SetpointTimeoutReaction {
        /// The set-point becomes the reference where it stands: the ramp stops, the loop holds.
        Hold = hold,
        /// The set-point becomes `safe_position_m`, reached through the set-point's rate limit.
        SafePosition = safe_position,
        /// The axis' `safe_command` goes out, as on a fault (a position drive holds where it
        /// stands).
        SafeCommand = safe_command,
    }
}

declare_section! {
    /// `[axis.setpoint_timeout]`: the commander's set-points must not be older than
    /// `timeout_s`; when they are, the reaction runs and an EMCY 8250h says so, until the next
    /// set-point (EMCY 0000h).
    pub struct SetpointTimeoutSection {
        /// The largest age of the last set-point before the reaction.
        timeout_s: f64 = {
            unit: "s", min: f64::MIN_POSITIVE, max: f64::MAX, access: Restart,
            doc: "largest age of the commander's last set-point", words: "> 0",
        },
        /// What the axis does while the commander is quiet: `hold`, `safe_position` or
        /// `safe_command`.
        reaction: SetpointTimeoutReaction = {
            unit: "", access: Restart, doc: "what the axis does when the commander is quiet",
            default: SetpointTimeoutReaction::Hold,
        },
        /// Where `reaction = "safe_position"` takes the axis.
        safe_position_m: Option<f64> = {
            unit: "m", min: f64::MIN, max: f64::MAX, access: Restart,
            doc: "set-point of reaction safe_position",
        },
    }
}

impl SetpointTimeoutSection {
    /// The rules between the keys: `safe_position_m` is given exactly for `reaction =
    /// "safe_position"`, within the travel `[position_min, position_max]`. The key at fault and
    /// the rule.
    pub fn check_reaction(
        &self,
        position_min: f64,
        position_max: f64,
    ) -> Result<(), (&'static str, String)> {
        const SAFE: &str = crate::param_key!(SetpointTimeoutSection, safe_position_m);
        const REACTION: &str = crate::param_key!(SetpointTimeoutSection, reaction);
        match (self.reaction, self.safe_position_m) {
            (SetpointTimeoutReaction::SafePosition, None) => {
                Err((SAFE, format!("is needed by {REACTION} = \"safe_position\"")))
            }
            (SetpointTimeoutReaction::SafePosition, Some(p))
                if !(position_min..=position_max).contains(&p) =>
            {
                Err((
                    SAFE,
                    format!(
                        "must lie within the travel [{position_min}, {position_max}] m, got {p}"
                    ),
                ))
            }
            (r, Some(_)) if r != SetpointTimeoutReaction::SafePosition => Err((
                SAFE,
                format!(
                    "is used by {REACTION} = \"safe_position\" only, not \"{}\"",
                    r.name()
                ),
            )),
            _ => Ok(()),
        }
    }
}

/// What a look at the watchdog found this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetpointSourceEvent {
    /// The last set-point grew older than the timeout: the reaction starts.
    Lost,
    /// A set-point after a loss: the reaction ends.
    Back,
}

/// The watch itself: times in, events out, nothing allocated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointWatchdog {
    timeout_s: f64,
    last_s: Option<f64>,
    lost: bool,
    /// The commander came back since the last [`SetpointWatchdog::poll`].
    back: bool,
}

impl SetpointWatchdog {
    pub fn new(timeout_s: f64) -> Self {
        Self {
            timeout_s,
            last_s: None,
            lost: false,
            back: false,
        }
    }

    /// The reaction is in force.
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// A set-point from the commander at `now_s`.
    pub fn on_setpoint(&mut self, now_s: f64) {
        self.last_s = Some(now_s);
        if std::mem::take(&mut self.lost) {
            self.back = true;
        }
    }

    /// Once per cycle: the loss when the last set-point is older than the timeout, or the
    /// return seen since the last look.
    pub fn poll(&mut self, now_s: f64) -> Option<SetpointSourceEvent> {
        if std::mem::take(&mut self.back) {
            return Some(SetpointSourceEvent::Back);
        }
        // Age of the last set-point: now - t_last > timeout.
        let stale = self.last_s.is_some_and(|t| now_s - t > self.timeout_s);
        if stale && !self.lost {
            self.lost = true;
            return Some(SetpointSourceEvent::Lost);
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(reaction: SetpointTimeoutReaction, safe: Option<f64>) -> SetpointTimeoutSection {
        SetpointTimeoutSection {
            timeout_s: 0.1,
            reaction,
            safe_position_m: safe,
        }
    }

    #[test]
    fn the_safe_position_goes_with_its_reaction_and_within_the_travel() {
        use SetpointTimeoutReaction as R;
        assert_eq!(
            section(R::SafePosition, Some(0.01)).check_reaction(-0.02, 0.02),
            Ok(())
        );
        assert_eq!(section(R::Hold, None).check_reaction(-0.02, 0.02), Ok(()));
        let err = |s: SetpointTimeoutSection| s.check_reaction(-0.02, 0.02).expect_err("refused");
        assert_eq!(
            err(section(R::SafePosition, None)),
            (
                "safe_position_m",
                "is needed by reaction = \"safe_position\"".into()
            )
        );
        assert_eq!(
            err(section(R::SafePosition, Some(0.03))).1,
            "must lie within the travel [-0.02, 0.02] m, got 0.03"
        );
        assert_eq!(
            err(section(R::Hold, Some(0.0))).1,
            "is used by reaction = \"safe_position\" only, not \"hold\""
        );
    }

    #[test]
    fn unarmed_until_the_first_setpoint() {
        let mut w = SetpointWatchdog::new(0.1);
        assert_eq!(w.poll(100.0), None);
        assert!(!w.is_lost());
    }

    #[test]
    fn lost_once_beyond_the_timeout_and_back_with_the_next_setpoint() {
        // Binary fractions: the ages are exact.
        let mut w = SetpointWatchdog::new(0.125);
        w.on_setpoint(1.0);
        assert_eq!(w.poll(1.0625), None);
        assert_eq!(w.poll(1.125), None, "at the timeout, not beyond it");
        assert_eq!(w.poll(1.126), Some(SetpointSourceEvent::Lost));
        assert!(w.is_lost());
        assert_eq!(w.poll(1.5), None, "announced once");
        w.on_setpoint(1.625);
        assert!(!w.is_lost());
        assert_eq!(w.poll(1.625), Some(SetpointSourceEvent::Back));
        assert_eq!(w.poll(1.75), None);
        assert_eq!(
            w.poll(1.751),
            Some(SetpointSourceEvent::Lost),
            "watched again"
        );
    }

    #[test]
    fn a_steady_commander_is_never_lost() {
        let mut w = SetpointWatchdog::new(0.02);
        for k in 0..10_000 {
            let t = f64::from(k) * 0.01;
            w.on_setpoint(t);
            assert_eq!(w.poll(t + 0.005), None);
        }
    }
}
