//! The axis' own keys that have a writable dictionary entry, declared here, in the device
//! profile that makes the entries, rather than with the rest of `[[axis]]` in the daemon's
//! configuration, which this layer may not import. `[[axis]]` borrows them (`from:` in
//! `declare_section!`), so the key, its range, its entry and its SDO write still come from one
//! declaration. One section per object the entries sit in: the axis' own (00h) and its
//! setpoint's (04h).

use crate::declare_section;
use crate::param::COMMAND_UNIT;

/// The smallest rate the dictionary takes for "> 0".
const RATE_MIN: f64 = 1e-9;

declare_section! {
    /// The writable keys of the axis object.
    pub struct AxisKeys {
        /// Command sent while a fault is latched (V or duty, as `command`); the spring-return
        /// rest for a solenoid.
        safe_command: f64 = {
            unit: COMMAND_UNIT, access: PreOperational, doc: "command while a fault is latched",
            command_bound: true, default: 0.0,
        },
    }
}

declare_section! {
    /// The writable keys of the setpoint object, beside the live setpoint.
    pub struct SetpointKeys {
        /// Rate limit of the reference the loop tracks (m/s, rad/s on a rotary axis); absent:
        /// steps.
        setpoint_rate_max_m_per_s: Option<f64> = {
            unit: "m/s", min: RATE_MIN, max: f64::INFINITY, access: PreOperational,
            doc: "rate limit of the reference the loop tracks, inf = steps", words: "> 0",
            absent: f64::INFINITY,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_lent_key_has_a_value_when_left_out() {
        // A section that borrows these keys takes a missing one from here.
        assert!(AxisKeys::defaults().is_some());
        assert!(SetpointKeys::defaults().is_some());
    }
}
