//! What the cycle reports: one record per axis and cycle, and events. Plain `Copy` data, so the
//! real-time thread hands them over without allocating; the writer thread formats them.

use crate::bus::{BusErrorFrame, BusFault, Frame};
use crate::canopen::od::ObjectId;
use crate::canopen::sdo::AbortCode;
use crate::canopen::{DecodeError, NmtState};
use crate::supervise::{FaultKind, FaultState, ReactionName, SupervisedFault};
use serde::{Deserialize, Serialize};

/// One axis in one cycle. Field names are the protocol's signal names (`dbc/actuatord.dbc`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(default)]
pub struct CycleRecord {
    /// Seconds since the cycle started (the cycle's release time, not when it ran).
    pub t_s: f64,
    pub cycle: u64,
    pub axis_node_id: u8,
    pub setpoint_position: f64,
    /// The rate-limited setpoint the loop tracks this cycle, m.
    pub reference_position: f64,
    pub position: f64,
    pub current: f64,
    pub supply_voltage: f64,
    pub supply_pressure: f64,
    pub command_voltage: f64,
    pub command_duty: f64,
    /// Target torque of a CiA 402 axis in CST, N·m (N on a linear axis).
    pub command_torque: f64,
    /// Target velocity of a CiA 402 axis in CSV, m/s (rad/s).
    pub command_velocity: f64,
    /// Statusword (6041h) of a CiA 402 drive, 0 for other nodes.
    pub drive_statusword: u16,
    pub friction_compensation: f64,
    pub following_error: f64,
    pub fault_state: u8,
    pub fault_flags: u16,
    /// Latched supervised faults, bit per `supervise::SupervisedFault` in its order.
    pub supervised_faults: u16,
    /// 0 none, else the latest latched supervised fault (codes of the DBC value table).
    pub diagnosed_fault: u8,
    pub diagnosis_confidence: f64,
    /// -1, 0, +1 per `[T_I, D, ω0, K_P, F_C, F_0]` from the last estimation window.
    pub symptoms: [i8; 6],
    /// `U_comp+`, `U_comp-` in use or learned, command unit.
    pub friction_compensation_pos: f64,
    pub friction_compensation_neg: f64,
    pub gain_schedule_factor: f64,
    /// Dither added this cycle, command unit.
    pub dither: f64,
    /// Arrival relief taken out of the controller's stored output this cycle (0 but in the
    /// cycle of a relieved arrival), command unit: the command's step that does not come from
    /// the error, which the parameter estimation leaves out.
    pub arrival_relief: f64,
    /// Direction P gains in use, duty per m.
    pub gain_down: f64,
    pub gain_up: f64,
    /// Estimated drive gains `K_I1`, `K_I2`, m/s.
    pub drive_gain_down: f64,
    pub drive_gain_up: f64,
    /// Smoothed observer `x4` per direction, m (0 until the direction has been seen).
    pub observer_x4_pos: f64,
    pub observer_x4_neg: f64,
    /// The sensor frame of this cycle arrived before the sensor deadline.
    pub sensor_fresh: bool,
    /// Wake-up delay after the release time, s.
    pub wake_latency: f64,
    /// Delay from the release time to the command being sent, s.
    pub cycle_latency: f64,
    /// Delay from the last sensor frame of the cycle arriving to the command being sent, s
    /// (0 when the sensor frame did not come).
    pub sensor_to_command: f64,
    /// Compute time per stage, ns, in the order of `daemon::node::Stage::ALL`.
    pub stage_ns: [u32; STAGES],
}

/// Something worth a log line and a place in the recording.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    Started {
        realtime_requested: bool,
        realtime: bool,
        lock_requested: bool,
        memory_locked: bool,
    },
    FaultRaised {
        t_s: f64,
        axis_node_id: u8,
        kind: FaultKind,
        cycle: u64,
    },
    /// The fault machine latched a model-based finding (diagnosis, observer, estimator).
    Diagnosed {
        t_s: f64,
        axis_node_id: u8,
        fault: SupervisedFault,
        confidence: f64,
        state: FaultState,
        cycle: u64,
    },
    FaultsReset {
        t_s: f64,
        axis_node_id: u8,
    },
    /// The reaction the axis' latched faults call for became more severe and is applied from
    /// this cycle on (`[axis.fault_reactions]`): for a drive stop, its controlword goes out in
    /// this cycle's RPDO.
    ReactionApplied {
        t_s: f64,
        axis_node_id: u8,
        reaction: ReactionName,
        cycle: u64,
    },
    /// A frame with a known id but a layout that does not decode.
    Malformed {
        t_s: f64,
        frame: Frame,
        error: DecodeError,
    },
    /// A frame with an id nobody here uses (rate-limited by the sender of the event).
    UnknownFrame {
        t_s: f64,
        frame: Frame,
    },
    BusError {
        t_s: f64,
        error: BusErrorFrame,
    },
    /// A bus fault: a send or receive failed, or the controller reported one. With `lost` the
    /// bus carries no frames until [`Event::BusRestored`].
    BusFault {
        t_s: f64,
        cause: BusFault,
        lost: bool,
        /// The policy applied to the axes (`[bus] on_loss`), when the bus is lost.
        policy: &'static str,
    },
    /// The bus carries frames again after a loss: SYNC resumed at this cycle.
    BusRestored {
        t_s: f64,
        cause: BusFault,
        outage_s: f64,
        cycles_lost: u64,
    },
    /// The commander of an axis went quiet beyond `[axis.setpoint_timeout] timeout_s` (`lost`),
    /// or sent a set-point again.
    SetpointSource {
        t_s: f64,
        axis_node_id: u8,
        lost: bool,
        cycle: u64,
    },
    NodeState {
        t_s: f64,
        node_id: u8,
        state: NmtState,
    },
    /// A standard node rebooted while the daemon ran, and what became of configuring it again.
    NodeRejoin {
        t_s: f64,
        node_id: u8,
        stage: RejoinStage,
    },
    OwnState {
        t_s: f64,
        state: NmtState,
    },
    Overrun {
        t_s: f64,
        cycle: u64,
        late_s: f64,
    },
    /// The overrun rate of a status period crossed `[cycle] overrun_warning_ratio`.
    Timing {
        t_s: f64,
        overrun_ratio: f64,
        warning: bool,
    },
    /// Staged SDO writes took effect at a cycle boundary.
    ParametersApplied {
        t_s: f64,
        writes: u32,
    },
    /// A new configuration (SIGHUP) took effect at a cycle boundary.
    Reloaded {
        t_s: f64,
        axes_rebuilt: u32,
    },
    /// A new configuration was refused; the running one stays.
    ReloadRefused {
        t_s: f64,
        reason: ReasonText,
    },
    /// Staged SDO writes were refused as a whole (the configuration would be invalid).
    ParametersRefused {
        t_s: f64,
        reason: ReasonText,
    },
}

/// Where a rebooted standard node is on its way back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RejoinStage {
    /// Its boot-up was seen: its configuration of `steps` SDO transfers runs again.
    Rebooted { steps: u32 },
    /// Every step passed; the node was told to start.
    Started { steps: u32 },
    /// Operational with fresh readings: the axis' faults were reset and it runs again.
    Resumed,
    /// Step `step` (from 0) failed: the axis stays in fault.
    Failed { step: u32, failure: RejoinFailure },
}

/// Why a rebooted node could not be configured again.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RejoinFailure {
    /// The node aborted the transfer (or did not answer: abort code 0504 0000h).
    Refused { object: ObjectId, code: AbortCode },
    /// The node holds another value than the one configured.
    Mismatch {
        object: ObjectId,
        expected: u32,
        got: u32,
    },
}

impl std::fmt::Display for RejoinFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RejoinFailure::Refused { object, code } => write!(f, "{object}: SDO abort {code}"),
            RejoinFailure::Mismatch {
                object,
                expected,
                got,
            } => write!(f, "{object} reads 0x{got:X}, expected 0x{expected:X}"),
        }
    }
}

/// A short message carried by value, so events stay `Copy` (cut at 120 bytes).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct ReasonText {
    bytes: [u8; 120],
    len: u8,
}

impl From<&str> for ReasonText {
    fn from(text: &str) -> Self {
        let mut end = text.len().min(120);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let mut bytes = [0u8; 120];
        bytes[..end].copy_from_slice(&text.as_bytes()[..end]);
        Self {
            bytes,
            len: end as u8,
        }
    }
}

impl From<String> for ReasonText {
    fn from(text: String) -> Self {
        Self::from(text.as_str())
    }
}

impl std::fmt::Display for ReasonText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(std::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or("?"))
    }
}

impl std::fmt::Debug for ReasonText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.to_string())
    }
}

/// Everything the cycle sends to the writer thread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Record {
    Cycle(CycleRecord),
    Event(Event),
    /// A CAN frame the controller received (`received`) or sent, at cycle time `t_s`.
    Frame {
        t_s: f64,
        frame: Frame,
        received: bool,
    },
}

impl Event {
    pub fn t_s(&self) -> f64 {
        match *self {
            Event::Started { .. } => 0.0,
            Event::FaultRaised { t_s, .. }
            | Event::Diagnosed { t_s, .. }
            | Event::FaultsReset { t_s, .. }
            | Event::ReactionApplied { t_s, .. }
            | Event::Malformed { t_s, .. }
            | Event::UnknownFrame { t_s, .. }
            | Event::BusError { t_s, .. }
            | Event::BusFault { t_s, .. }
            | Event::BusRestored { t_s, .. }
            | Event::SetpointSource { t_s, .. }
            | Event::NodeState { t_s, .. }
            | Event::NodeRejoin { t_s, .. }
            | Event::OwnState { t_s, .. }
            | Event::Overrun { t_s, .. }
            | Event::Timing { t_s, .. }
            | Event::ParametersApplied { t_s, .. }
            | Event::ParametersRefused { t_s, .. }
            | Event::Reloaded { t_s, .. }
            | Event::ReloadRefused { t_s, .. } => t_s,
        }
    }

    /// Short machine-readable kind, the `kind` field of the MCAP `events` channel.
    pub fn kind(&self) -> &'static str {
        match self {
            Event::Started { .. } => "started",
            Event::FaultRaised { .. } => "fault_raised",
            Event::Diagnosed { .. } => "diagnosed",
            Event::FaultsReset { .. } => "faults_reset",
            Event::ReactionApplied { .. } => "reaction_applied",
            Event::Malformed { .. } => "frame_malformed",
            Event::UnknownFrame { .. } => "frame_unknown",
            Event::BusError { .. } => "bus_error",
            Event::BusFault { .. } => "bus_fault",
            Event::BusRestored { .. } => "bus_restored",
            Event::SetpointSource { lost: true, .. } => "setpoint_timeout",
            Event::SetpointSource { lost: false, .. } => "setpoint_back",
            Event::NodeState { .. } => "node_state",
            Event::NodeRejoin { stage, .. } => match stage {
                RejoinStage::Rebooted { .. } => "node_rebooted",
                RejoinStage::Started { .. } => "node_reconfigured",
                RejoinStage::Resumed => "node_resumed",
                RejoinStage::Failed { .. } => "node_reconfiguration_failed",
            },
            Event::OwnState { .. } => "own_state",
            Event::Overrun { .. } => "overrun",
            Event::Timing { .. } => "timing",
            Event::ParametersApplied { .. } => "parameters_applied",
            Event::ParametersRefused { .. } => "parameters_refused",
            Event::Reloaded { .. } => "reloaded",
            Event::ReloadRefused { .. } => "reload_refused",
        }
    }
}

impl std::fmt::Display for Event {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Event::Started {
                realtime_requested,
                realtime,
                lock_requested,
                memory_locked,
            } => write!(
                f,
                "cycle started: SCHED_FIFO {}, memory {}",
                match (realtime_requested, realtime) {
                    (false, _) => "not requested",
                    (true, true) => "granted",
                    (true, false) =>
                        "NOT granted (needs CAP_SYS_NICE or LimitRTPRIO; normal scheduler, expect jitter)",
                },
                match (lock_requested, memory_locked) {
                    (false, _) => "lock not requested",
                    (true, true) => "locked",
                    (true, false) =>
                        "NOT locked (needs CAP_IPC_LOCK or LimitMEMLOCK; page faults can stall the cycle)",
                }
            ),
            Event::FaultRaised {
                t_s,
                axis_node_id,
                kind,
                cycle,
            } => write!(
                f,
                "t={t_s:.4}s axis {axis_node_id}: fault {kind} raised (cycle {cycle}), axis to safe state"
            ),
            Event::Diagnosed {
                t_s,
                axis_node_id,
                fault,
                confidence,
                state,
                cycle,
            } => write!(
                f,
                "t={t_s:.4}s axis {axis_node_id}: {} latched (cycle {cycle}, confidence {confidence:.2}), state {}",
                fault.name(),
                state.name()
            ),
            Event::FaultsReset { t_s, axis_node_id } => {
                write!(f, "t={t_s:.4}s axis {axis_node_id}: faults reset")
            }
            Event::ReactionApplied {
                t_s,
                axis_node_id,
                reaction,
                cycle,
            } => write!(
                f,
                "t={t_s:.4}s cycle {cycle}: axis {axis_node_id}: reaction {} applied{}",
                reaction.name(),
                match reaction {
                    ReactionName::Halt =>
                        ": the drive halts (controlword bit 8) on its profile deceleration 6084h",
                    ReactionName::QuickStop =>
                        ": the drive gets the command quick stop (605Ah, 6085h)",
                    ReactionName::FailSafe => ": the safe command goes out",
                    _ => "",
                }
            ),
            Event::Malformed { t_s, frame, error } => {
                write!(f, "t={t_s:.4}s malformed frame {frame}: {error}")
            }
            Event::UnknownFrame { t_s, frame } => {
                write!(f, "t={t_s:.4}s frame with unused id ignored: {frame}")
            }
            Event::BusError { t_s, error } => write!(f, "t={t_s:.4}s {error}"),
            Event::BusFault {
                t_s,
                cause,
                lost: true,
                policy,
            } => write!(
                f,
                "t={t_s:.4}s bus fault: {cause}; bus lost, the cycle keeps its period and retries every period; axes: {policy}"
            ),
            Event::BusFault { t_s, cause, .. } => {
                write!(f, "t={t_s:.4}s bus fault: {cause}; the bus still carries frames")
            }
            Event::BusRestored {
                t_s,
                cause,
                outage_s,
                cycles_lost,
            } => write!(
                f,
                "t={t_s:.4}s bus back after {outage_s:.3} s ({cycles_lost} cycles) of {cause}: SYNC resumed, EMCY 0x{:04X} sent",
                cause.emcy_code()
            ),
            Event::SetpointSource {
                t_s,
                axis_node_id,
                lost: true,
                cycle,
            } => write!(
                f,
                "t={t_s:.4}s cycle {cycle}: axis {axis_node_id}: no set-point from its commander within [axis.setpoint_timeout] timeout_s: its reaction runs, EMCY 0x8250"
            ),
            Event::SetpointSource {
                t_s,
                axis_node_id,
                cycle,
                ..
            } => write!(
                f,
                "t={t_s:.4}s cycle {cycle}: axis {axis_node_id}: set-points from its commander again, EMCY 0x0000"
            ),
            Event::NodeState {
                t_s,
                node_id,
                state,
            } => write!(f, "t={t_s:.4}s node {node_id} is {}", state.name()),
            Event::NodeRejoin {
                t_s,
                node_id,
                stage,
            } => match stage {
                RejoinStage::Rebooted { steps } => write!(
                    f,
                    "t={t_s:.4}s node {node_id} rebooted: its axis is in fault, its configuration ({steps} SDO transfers) runs again"
                ),
                RejoinStage::Started { steps } => write!(
                    f,
                    "t={t_s:.4}s node {node_id} configured again ({steps} SDO transfers checked) and started"
                ),
                RejoinStage::Resumed => write!(
                    f,
                    "t={t_s:.4}s node {node_id} operational with fresh readings: its axis' faults reset, the axis runs again"
                ),
                RejoinStage::Failed { step, failure } => write!(
                    f,
                    "t={t_s:.4}s node {node_id} rebooted and could not be configured again (step {}): {failure}; its axis stays in fault until a fault reset or its next boot-up",
                    step + 1
                ),
            },
            Event::OwnState { t_s, state } => write!(f, "t={t_s:.4}s controller is {}", state.name()),
            Event::Timing {
                t_s,
                overrun_ratio,
                warning,
            } => write!(
                f,
                "t={t_s:.4}s {:.1} % of the last status period's cycles overran: timing warning {}",
                overrun_ratio * 100.0,
                if *warning { "raised" } else { "cleared" }
            ),
            Event::ParametersApplied { t_s, writes } => {
                write!(f, "t={t_s:.4}s {writes} SDO write(s) applied at the cycle boundary")
            }
            Event::Reloaded { t_s, axes_rebuilt } => write!(
                f,
                "t={t_s:.4}s configuration reloaded at the cycle boundary ({axes_rebuilt} axis/axes rebuilt)"
            ),
            Event::ReloadRefused { t_s, reason } => write!(
                f,
                "t={t_s:.4}s configuration reload refused, the running one stays: {reason}"
            ),
            Event::ParametersRefused { t_s, reason } => {
                write!(f, "t={t_s:.4}s SDO writes refused, nothing applied: {reason}")
            }
            Event::Overrun { t_s, cycle, late_s } => write!(
                f,
                "t={t_s:.4}s cycle {cycle} overran its period by {:.3} ms",
                late_s * 1e3
            ),
        }
    }
}

/// The stages of an axis' cycle, timed separately when the runtime gives the node a clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Scheduling,
    Control,
    Estimation,
    Observer,
    Supervision,
    EncodeSend,
}

/// Number of [`Stage`]s.
pub const STAGES: usize = 6;

impl Stage {
    pub const ALL: [Stage; STAGES] = [
        Stage::Scheduling,
        Stage::Control,
        Stage::Estimation,
        Stage::Observer,
        Stage::Supervision,
        Stage::EncodeSend,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Scheduling => "scheduling",
            Stage::Control => "control",
            Stage::Estimation => "estimation",
            Stage::Observer => "observer",
            Stage::Supervision => "supervision",
            Stage::EncodeSend => "encode_send",
        }
    }
}
