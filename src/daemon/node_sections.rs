//! The node-wide sections `[bus]`, `[node]`, `[cycle]`, `[record]` and `[state]`, declared
//! once: their keys, units, ranges, defaults and the wording of their errors. None is in the
//! dictionary (`Restart`); a reload takes what `ControllerNode::swap_in` allows (not the node
//! id, not the period, not the bus).

use std::path::PathBuf;

use crate::{declare_choice, declare_section};

/// "> 0" for a time: finite and positive.
const POSITIVE: f64 = f64::MIN_POSITIVE;
/// The largest finite value: a time must not be infinite.
const FINITE: f64 = f64::MAX;

declare_section! {
    /// `[bus]`: the CAN interface and what the node does when it is lost.
    pub struct BusConfig {
        /// SocketCAN interface, e.g. "can0" or "vcan0" (must not be empty: a rule of its own).
        iface: String = { unit: "", access: Restart, doc: "SocketCAN interface" },
        /// Bit rate of the bus, for the load check (vcan has none; it is checked all the same).
        bitrate_bps: u32 = {
            unit: "bit/s", min: 1.0, access: Restart, doc: "bit rate of the bus", words: "> 0",
            default: 500_000,
        },
        /// At start-up, how long to wait for the interface to exist and be up before giving up.
        startup_wait_s: f64 = {
            unit: "s", min: 0.0, max: FINITE, access: Restart,
            doc: "wait for the interface at start-up", words: ">= 0 s", default: 30.0,
        },
        /// Largest share of the bit rate the periodic traffic may take; above it the daemon
        /// refuses to start.
        max_load: f64 = {
            unit: "", min: POSITIVE, max: 1.0, access: Restart,
            doc: "largest share of the bit rate the periodic traffic may take",
            words: "in (0, 1]", default: 0.7,
        },
        /// What the axes do when the bus is lost (interface down or gone, bus-off).
        on_loss: BusLossPolicy = {
            unit: "", access: Restart, doc: "what the axes do when the bus is lost",
            default: BusLossPolicy::SafeState,
        },
    }
}

declare_choice! {
    /// The axes' policy when the bus is lost, after CiA 301's error behaviour (object 1029h).
    pub enum BusLossPolicy {
        /// The controller leaves operational: when the bus is back every axis gets its safe
        /// command, and control resumes only on an NMT start (or reset) from the operator.
        SafeState = safe_state,
        /// Control resumes by itself with the first sensor frames after the bus is back.
        Continue = continue,
    }
}

declare_section! {
    /// `[node]`: the daemon's own node on the bus.
    pub struct NodeConfig {
        /// The daemon's own CANopen node id, 1..=127.
        node_id: u8 = {
            unit: "", min: 1.0, max: 127.0, access: Restart, doc: "the daemon's node id",
            words: "a node id in 1..=127", default: 1,
        },
        heartbeat_period_s: f64 = {
            unit: "s", min: POSITIVE, max: FINITE, access: Restart, doc: "heartbeat period",
            words: "> 0", default: 0.1,
        },
        /// What the standard nodes (CiA 402, CiA 401) allow on top of `heartbeat_period_s`
        /// before they take the daemon for lost: their consumer heartbeat time 1016h is the
        /// sum, written at start-up.
        heartbeat_consumer_margin_s: f64 = {
            unit: "s", min: 0.0, max: FINITE, access: Restart,
            doc: "margin of the standard nodes' consumer heartbeat time 1016h over the heartbeat period",
            words: ">= 0", default: 0.1,
        },
        /// Period of the fault_state, tuned_parameters and loop_status frames.
        status_period_s: f64 = {
            unit: "s", min: POSITIVE, max: FINITE, access: Restart,
            doc: "period of the status frames", words: "> 0", default: 0.05,
        },
    }
}

declare_section! {
    /// `[cycle]`: the real-time cycle.
    pub struct CycleConfig {
        /// Control period; 2.5 ms (400 Hz) is the paper's solenoid.
        period_s: f64 = {
            unit: "s", min: POSITIVE, max: FINITE, access: Restart, doc: "control period",
            words: "> 0", default: 0.0025,
        },
        /// How long after SYNC the cycle waits for the sensor frames before it runs without them.
        sensor_deadline_s: f64 = {
            unit: "s", min: POSITIVE, max: FINITE, access: Restart,
            doc: "wait for the sensor frames after SYNC", words: "> 0", default: 0.0015,
        },
        /// SCHED_FIFO priority to ask for (1..=99); 0 runs with the normal scheduler.
        realtime_priority: i32 = {
            unit: "", min: 0.0, max: 99.0, access: Restart, doc: "SCHED_FIFO priority",
            words: "0..=99", default: 80,
        },
        /// Lock all memory (mlockall) so a page fault cannot stall the cycle.
        lock_memory: bool = {
            unit: "", access: Restart, doc: "mlockall", default: true,
        },
        /// Share of a status period's cycles that may overrun before the timing warning is raised.
        overrun_warning_ratio: f64 = {
            unit: "", min: 0.0, max: 1.0, access: Restart,
            doc: "share of overrun cycles that raises the timing warning", default: 0.05,
        },
    }
}

declare_section! {
    /// `[record]`: what the recorder is given.
    pub struct RecordConfig {
        /// Records the cycle can queue for the writer before it drops (and counts) them.
        queue_depth: usize = {
            unit: "", min: 1.0, access: Restart,
            doc: "records queued for the writer", words: "> 0", default: 8192,
        },
        /// Record every CAN frame sent and received too (MCAP topic /actuatord/can).
        can_frames: bool = {
            unit: "", access: Restart, doc: "record every CAN frame", default: true,
        },
    }
}

declare_section! {
    /// `[state]`: where what the axes learn is kept across restarts.
    pub struct StateConfig {
        /// State file (TOML, written atomically: temporary file, fsync, rename); absent: nothing
        /// is kept and every start learns again. Under systemd: `/var/lib/actuatord/<name>.toml`.
        file: Option<PathBuf> = {
            unit: "", access: Restart, doc: "state file",
        },
        /// How often the learned values are offered to the writer; the file is rewritten only
        /// when they changed. They are also written when the daemon stops.
        save_interval_s: f64 = {
            unit: "s", min: POSITIVE, max: FINITE, access: Restart,
            doc: "how often the learned values are offered", words: "> 0", default: 10.0,
        },
    }
}

/// A node-wide section with every key at its declared default (each has one).
macro_rules! default_from_declaration {
    ($($section:ty),*) => {
        $(
            impl Default for $section {
                fn default() -> Self {
                    match Self::defaults() {
                        Some(s) => s,
                        None => unreachable!("every key of a node-wide section declares a default"),
                    }
                }
            }
        )*
    };
}

default_from_declaration!(NodeConfig, CycleConfig, RecordConfig, StateConfig);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::param::Declared;

    #[test]
    fn defaults_are_the_documented_ones() {
        let c = CycleConfig::default();
        assert_eq!(c.period_s, 0.0025);
        assert_eq!(c.realtime_priority, 80);
        assert_eq!(NodeConfig::default().node_id, 1);
        assert_eq!(RecordConfig::default().queue_depth, 8192);
        assert_eq!(StateConfig::default().file, None);
        assert_eq!(StateConfig::default().save_interval_s, 10.0);
    }

    #[test]
    fn ranges_keep_the_wording_of_the_rules() {
        let n = NodeConfig {
            node_id: 0,
            ..Default::default()
        };
        assert_eq!(
            n.check().expect_err("node id 0").to_string(),
            "node_id: must be a node id in 1..=127, got 0"
        );
        let bad_cycle = |c: CycleConfig| c.check().expect_err("out of range").to_string();
        assert_eq!(
            bad_cycle(CycleConfig {
                realtime_priority: 100,
                ..Default::default()
            }),
            "realtime_priority: must be 0..=99, got 100"
        );
        assert_eq!(
            bad_cycle(CycleConfig {
                period_s: f64::INFINITY,
                ..Default::default()
            }),
            "period_s: must be > 0, got inf"
        );
        assert_eq!(
            bad_cycle(CycleConfig {
                overrun_warning_ratio: 1.5,
                ..Default::default()
            }),
            "overrun_warning_ratio: must be a number in [0, 1], got 1.5"
        );
    }
}
