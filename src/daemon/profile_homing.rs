//! The daemon's side of a CiA 402 drive's homing, in the cycle before the axis is enabled for
//! motion: homing mode (6060h = 6) until the drive shows it in "operation enabled", then the
//! start bit (controlword bit 4) until the statusword says attained (bits 12 and 10) or error
//! (bit 13), or the configured time passes; then cyclic synchronous position. Sans-I/O, one call
//! per cycle.

use crate::device::profile::cia402::{status, Mode, State};

/// EMCY error code of a failed homing (CiA 301: positioning controller).
pub const HOMING_FAILED: u16 = 0x8600;

/// Cycles after the start bit before the statusword counts: the drive takes the bit at the
/// next SYNC and answers the one after, so an answer from before the start (a drive homed
/// earlier still shows "attained") is not taken for this homing's.
const ACKNOWLEDGE_CYCLES: u32 = 3;

/// Why homing failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HomingFailure {
    /// The drive set statusword bit 13 (homing error).
    DriveError,
    /// Not attained within the configured time.
    Timeout { timeout_s: f64 },
}

impl std::fmt::Display for HomingFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HomingFailure::DriveError => {
                f.write_str("the drive reports a homing error (statusword 6041h bit 13)")
            }
            HomingFailure::Timeout { timeout_s } => write!(
                f,
                "homing not attained within timeout_s = {timeout_s} s (statusword 6041h bit 12 never set)"
            ),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Waiting for the drive in "operation enabled" showing homing mode.
    Waiting,
    /// The start bit is on since `cycles` cycles.
    Running {
        cycles: u32,
    },
    Attained,
    Failed(HomingFailure),
}

/// One axis' homing sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomingSequence {
    phase: Phase,
    timeout_cycles: u32,
    timeout_s: f64,
    require_homing: bool,
}

impl HomingSequence {
    pub fn new(timeout_s: f64, period_s: f64, require_homing: bool) -> Self {
        Self {
            phase: Phase::Waiting,
            // The timeout counted in cycles of the period.
            timeout_cycles: (timeout_s / period_s).ceil().min(f64::from(u32::MAX)) as u32,
            timeout_s,
            require_homing,
        }
    }

    /// Take this cycle's statusword and mode display (6061h).
    pub fn step(&mut self, state: Option<State>, statusword: u16, mode_display: i8) {
        let enabled = state == Some(State::OperationEnabled);
        let homing_shown = mode_display == Mode::Homing.code();
        self.phase = match self.phase {
            Phase::Waiting if enabled && homing_shown => Phase::Running { cycles: 0 },
            // The drive left operation (a fault, a quick stop): start again once it is back.
            Phase::Running { .. } if !enabled => Phase::Waiting,
            Phase::Running { cycles } => {
                let cycles = cycles.saturating_add(1);
                let bits = statusword
                    & (status::HOMING_ERROR | status::HOMING_ATTAINED | status::TARGET_REACHED);
                if cycles < ACKNOWLEDGE_CYCLES {
                    Phase::Running { cycles }
                } else if bits & status::HOMING_ERROR != 0 {
                    Phase::Failed(HomingFailure::DriveError)
                } else if bits == status::HOMING_ATTAINED | status::TARGET_REACHED {
                    Phase::Attained
                } else if cycles > self.timeout_cycles {
                    Phase::Failed(HomingFailure::Timeout {
                        timeout_s: self.timeout_s,
                    })
                } else {
                    Phase::Running { cycles }
                }
            }
            other => other,
        };
    }

    /// The mode of operation to ask for this cycle.
    pub fn mode(&self) -> Mode {
        match self.phase {
            Phase::Waiting | Phase::Running { .. } => Mode::Homing,
            Phase::Failed(_) if self.require_homing => Mode::Homing,
            _ => Mode::CyclicSynchronousPosition,
        }
    }

    /// Controlword bit 4 this cycle.
    pub fn start_bit(&self) -> bool {
        matches!(self.phase, Phase::Running { .. })
    }

    /// The axis may move: homed, or homing failed where it is not required.
    pub fn ready_for_motion(&self) -> bool {
        match self.phase {
            Phase::Attained => true,
            Phase::Failed(_) => !self.require_homing,
            _ => false,
        }
    }

    pub fn attained(&self) -> bool {
        self.phase == Phase::Attained
    }

    pub fn failure(&self) -> Option<HomingFailure> {
        match self.phase {
            Phase::Failed(f) => Some(f),
            _ => None,
        }
    }

    /// A failed homing as the axis' fault (only where homing is required).
    pub fn fault(&self) -> Option<HomingFailure> {
        self.failure().filter(|_| self.require_homing)
    }

    /// The drive rebooted: its home is lost, the sequence starts again (a failure included).
    pub fn restart(&mut self) {
        self.phase = Phase::Waiting;
    }

    /// A fault reset: a failed homing is tried again.
    pub fn retry(&mut self) {
        if matches!(self.phase, Phase::Failed(_)) {
            self.phase = Phase::Waiting;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ENABLED: Option<State> = Some(State::OperationEnabled);

    /// A drive that answers `lag` cycles late: its statusword and mode display as seen.
    fn run(
        seq: &mut HomingSequence,
        answers: &[(Option<State>, u16, i8)],
    ) -> Vec<(Mode, bool, bool)> {
        answers
            .iter()
            .map(|(state, sw, mode)| {
                seq.step(*state, *sw, *mode);
                (seq.mode(), seq.start_bit(), seq.ready_for_motion())
            })
            .collect()
    }

    #[test]
    fn homing_mode_then_the_start_bit_then_csp_once_attained() {
        let mut seq = HomingSequence::new(1.0, 0.002, true);
        let out = run(
            &mut seq,
            &[
                // Not enabled yet, then enabled still in CSP: homing mode asked, no start.
                (Some(State::SwitchedOn), 0x0400, 8),
                (ENABLED, 0x0400, 8),
                (ENABLED, 0x0400, 6),
                // A drive homed before still shows attained right after the start bit.
                (ENABLED, 0x1400, 6),
                (ENABLED, 0x0000, 6),
                (ENABLED, 0x0000, 6),
                (ENABLED, 0x1400, 6),
            ],
        );
        let homing = (Mode::Homing, false, false);
        let started = (Mode::Homing, true, false);
        assert_eq!(&out[..2], &[homing, homing]);
        assert_eq!(&out[2..6], &[started; 4], "{out:?}");
        assert_eq!(out[6], (Mode::CyclicSynchronousPosition, false, true));
        assert!(seq.attained());
    }

    #[test]
    fn a_homing_error_or_timeout_is_a_fault_and_a_reset_tries_again() {
        let mut seq = HomingSequence::new(0.01, 0.002, true);
        run(&mut seq, &[(ENABLED, 0x0400, 6); 4]);
        run(&mut seq, &[(ENABLED, 0x2000, 6)]);
        assert_eq!(seq.fault(), Some(HomingFailure::DriveError));
        assert_eq!(seq.mode(), Mode::Homing, "no CSP without home");
        assert!(!seq.ready_for_motion() && !seq.start_bit());
        seq.retry();
        // 5 cycles of 2 ms: the 10 ms timeout passes on the 6th without an answer.
        let out = run(&mut seq, &[(ENABLED, 0x0000, 6); 7]);
        assert!(out[..6].iter().all(|o| o.1), "{out:?}");
        assert_eq!(
            seq.fault(),
            Some(HomingFailure::Timeout { timeout_s: 0.01 })
        );
        assert!(seq.failure_text().contains("timeout_s = 0.01"));
        // Not required: reported, but the axis runs unhomed.
        let mut seq = HomingSequence::new(0.01, 0.002, false);
        run(&mut seq, &[(ENABLED, 0x2400, 6); 5]);
        assert_eq!(seq.failure(), Some(HomingFailure::DriveError));
        assert_eq!(seq.fault(), None);
        assert!(seq.ready_for_motion());
        assert_eq!(seq.mode(), Mode::CyclicSynchronousPosition);
    }

    #[test]
    fn a_drive_leaving_operation_while_homing_starts_over() {
        let mut seq = HomingSequence::new(1.0, 0.002, true);
        run(&mut seq, &[(ENABLED, 0x0400, 6), (ENABLED, 0x0000, 6)]);
        assert!(seq.start_bit());
        run(&mut seq, &[(Some(State::Fault), 0x0008, 6)]);
        assert!(!seq.start_bit());
        run(&mut seq, &[(ENABLED, 0x0400, 6)]);
        assert!(seq.start_bit());
    }

    impl HomingSequence {
        fn failure_text(&self) -> String {
            self.failure().map(|f| f.to_string()).unwrap_or_default()
        }
    }
}
