//! A standard node that reboots while the daemon runs (a brown-out in a cranking dip, a drive
//! reset) comes back in pre-operational with its factory layout: its PDOs are not the ones the
//! axis reads, its watchdogs and homing are gone. [`Rejoin`] runs the start-up's plan
//! ([`super::profile_setup::plan`]) again on the cycle thread, sans-I/O and allocation-free:
//! one expedited SDO transfer in flight, the next request sent with the cycle after its answer,
//! so the other axes' cycles go on untouched; then the node is started.

use super::profile_setup::{SetupStep, StepAction};
use crate::bus::Frame;
use crate::canopen::sdo::{Answer, Expedited, SDO_TX_FUNCTION};
use crate::canopen::NmtCommand;
use crate::recording::RejoinFailure;

/// An answer later than this is a node that is not there (the start-up's SDO timeout).
pub const ANSWER_TIMEOUT_S: f64 = 0.5;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Idle,
    /// Step `step` goes out with the next poll.
    Due {
        step: usize,
    },
    /// Step `step` waits for its answer, asked at `since_s`.
    Waiting {
        step: usize,
        transfer: Expedited,
        since_s: f64,
    },
    /// Every step passed: the NMT start goes out with the next poll.
    Start,
    /// A step failed; the node stays as it is until it reboots again or the axis is reset.
    Failed,
}

/// What [`Rejoin::poll`] has to tell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RejoinProgress {
    Nothing,
    /// Every step passed and the node was told to start.
    Started {
        steps: u32,
    },
    /// Step `step` (from 0) failed.
    Failed {
        step: u32,
        failure: RejoinFailure,
    },
}

/// The configuration of one node, run again after it rebooted.
#[derive(Debug, Clone)]
pub struct Rejoin {
    node_id: u8,
    steps: Vec<SetupStep>,
    phase: Phase,
    /// An abort for the node's server, sent with the next poll.
    abort: Option<Frame>,
    /// A failure seen in [`Rejoin::handle`], told by the next poll.
    failed: Option<(u32, RejoinFailure)>,
}

impl Rejoin {
    pub fn new(node_id: u8, steps: Vec<SetupStep>) -> Self {
        Self {
            node_id,
            steps,
            phase: Phase::Idle,
            abort: None,
            failed: None,
        }
    }

    /// The steps it runs.
    pub fn steps(&self) -> &[SetupStep] {
        &self.steps
    }

    /// The node booted: configure it again from the first step (a run under way starts over).
    pub fn begin(&mut self) {
        self.phase = Phase::Due { step: 0 };
        self.failed = None;
    }

    /// A run failed earlier (the axis' fault reset tries again).
    pub fn has_failed(&self) -> bool {
        self.phase == Phase::Failed
    }

    /// The node is being configured: its PDOs mean nothing yet.
    pub fn is_running(&self) -> bool {
        matches!(
            self.phase,
            Phase::Due { .. } | Phase::Waiting { .. } | Phase::Start
        )
    }

    /// Take a frame: true when it was the node's answer to the transfer in flight (or a late
    /// answer of the node's server while a run is under way), which is nobody else's.
    pub fn handle(&mut self, frame: &Frame) -> bool {
        if frame.is_extended() || frame.id() != SDO_TX_FUNCTION + u32::from(self.node_id) {
            return false;
        }
        let Phase::Waiting { step, transfer, .. } = self.phase else {
            return self.is_running();
        };
        let Some(answer) = transfer.answer(frame) else {
            return true;
        };
        let object = transfer.object();
        let failure = match (answer, self.steps.get(step).map(|s| s.action)) {
            (Answer::Failed(e, abort), _) => {
                self.abort = abort;
                Some(RejoinFailure::Refused {
                    object,
                    code: e.code(),
                })
            }
            (Answer::Done(got), Some(StepAction::Check { expected, mask }))
                if got & mask != expected & mask =>
            {
                Some(RejoinFailure::Mismatch {
                    object,
                    expected,
                    got,
                })
            }
            _ => None,
        };
        match failure {
            Some(f) => self.fail(step, f),
            None if step + 1 < self.steps.len() => self.phase = Phase::Due { step: step + 1 },
            None => self.phase = Phase::Start,
        }
        true
    }

    /// Once per cycle: the next request, a timeout, the NMT start at the end.
    pub fn poll(&mut self, now_s: f64, send: &mut dyn FnMut(&Frame)) -> RejoinProgress {
        if let Some(abort) = self.abort.take() {
            send(&abort);
        }
        if let Some((step, failure)) = self.failed.take() {
            return RejoinProgress::Failed { step, failure };
        }
        match self.phase {
            Phase::Due { step } => match self.steps.get(step) {
                Some(s) => {
                    let (transfer, request) = match s.action {
                        StepAction::Write { bytes, len } => {
                            Expedited::write(self.node_id, s.id, &bytes[..usize::from(len)])
                        }
                        StepAction::Check { .. } => Expedited::read(self.node_id, s.id),
                    };
                    send(&request);
                    self.phase = Phase::Waiting {
                        step,
                        transfer,
                        since_s: now_s,
                    };
                }
                None => self.phase = Phase::Start,
            },
            Phase::Waiting {
                step,
                transfer,
                since_s,
            } if now_s - since_s > ANSWER_TIMEOUT_S || (now_s - since_s).is_nan() => {
                let (e, abort) = transfer.timeout();
                send(&abort);
                self.phase = Phase::Failed;
                return RejoinProgress::Failed {
                    step: step as u32,
                    failure: RejoinFailure::Refused {
                        object: transfer.object(),
                        code: e.code(),
                    },
                };
            }
            Phase::Start => {
                send(&NmtCommand::Start.encode(self.node_id));
                self.phase = Phase::Idle;
                return RejoinProgress::Started {
                    steps: self.steps.len() as u32,
                };
            }
            _ => {}
        }
        RejoinProgress::Nothing
    }

    fn fail(&mut self, step: usize, failure: RejoinFailure) {
        self.phase = Phase::Failed;
        self.failed = Some((step as u32, failure));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::od::{EntrySpec, ObjectDictionary, ObjectId};
    use crate::canopen::sdo::AbortCode;
    use crate::canopen::{NmtState, SdoServer};

    /// A node's server with 1000h and a writable 2000h, as a rebooted node has them.
    fn node() -> (SdoServer, ObjectDictionary) {
        let od = ObjectDictionary::builder()
            .var(0x1000, EntrySpec::ro("device_type", 0x0002_0192u32))
            .var(0x2000, EntrySpec::rw("value", 0u16))
            .build()
            .expect("dictionary");
        (SdoServer::new(7), od)
    }

    fn plan() -> Vec<SetupStep> {
        vec![
            SetupStep::check(ObjectId::new(0x1000, 0), 402, 0xFFFF, "device type"),
            SetupStep::write(ObjectId::new(0x2000, 0), &500u16.to_le_bytes(), "value"),
            SetupStep::check(ObjectId::new(0x2000, 0), 500, 0xFFFF, "value"),
        ]
    }

    /// Cycles of the rejoin against the node's server, every answer back before the next
    /// cycle: the frames it sent per cycle and what it told.
    fn run(
        r: &mut Rejoin,
        server: &mut SdoServer,
        od: &mut ObjectDictionary,
        cycles: usize,
    ) -> (Vec<Vec<Frame>>, Vec<RejoinProgress>) {
        let mut sent = vec![];
        let mut told = vec![];
        for k in 0..cycles {
            let mut out = vec![];
            told.push(r.poll(k as f64 * 0.002, &mut |f| out.push(*f)));
            for f in &out {
                if let Some(a) = server.handle(f, 0.0, od, NmtState::PreOperational) {
                    assert!(r.handle(&a), "{a}");
                }
                // The server stages a write; the node applies it at once.
                od.take_pending_writes().for_each(drop);
            }
            sent.push(out);
        }
        (sent, told)
    }

    #[test]
    fn one_transfer_per_cycle_then_the_node_is_started() {
        let (mut server, mut od) = node();
        let mut r = Rejoin::new(7, plan());
        assert!(!r.is_running());
        r.begin();
        let (sent, told) = run(&mut r, &mut server, &mut od, 6);
        let per_cycle: Vec<usize> = sent.iter().map(Vec::len).collect();
        assert_eq!(per_cycle, [1, 1, 1, 1, 0, 0]);
        assert!(sent[..3].iter().flatten().all(|f| f.id() == 0x607));
        assert_eq!(sent[3][0].data(), [0x01, 7]);
        assert_eq!(told[3], RejoinProgress::Started { steps: 3 });
        assert!(told
            .iter()
            .enumerate()
            .all(|(k, t)| k == 3 || *t == RejoinProgress::Nothing));
        assert_eq!(
            od.value(od.handle(ObjectId::new(0x2000, 0)).expect("entry")),
            crate::canopen::Value::Unsigned16(500)
        );
        assert!(!r.is_running() && !r.has_failed());
    }

    #[test]
    fn a_wrong_device_a_refusal_and_silence_are_each_a_failure_naming_the_object() {
        let (mut server, mut od) = node();
        // A CiA 401 node where a drive was configured.
        let mut steps = plan();
        steps[0] = SetupStep::check(ObjectId::new(0x1000, 0), 401, 0xFFFF, "device type");
        let mut r = Rejoin::new(7, steps);
        r.begin();
        let (sent, told) = run(&mut r, &mut server, &mut od, 3);
        assert_eq!(
            told[1],
            RejoinProgress::Failed {
                step: 0,
                failure: RejoinFailure::Mismatch {
                    object: ObjectId::new(0x1000, 0),
                    expected: 401,
                    got: 0x0002_0192
                }
            }
        );
        assert!(r.has_failed() && !r.is_running());
        assert_eq!(
            sent.iter().flatten().count(),
            1,
            "nothing after the failure"
        );
        // An object the node does not have: the server's abort code.
        let mut steps = plan();
        steps[1] = SetupStep::write(ObjectId::new(0x2001, 0), &[1], "missing");
        let mut r = Rejoin::new(7, steps);
        r.begin();
        let (_, told) = run(&mut r, &mut server, &mut od, 4);
        assert_eq!(
            told[2],
            RejoinProgress::Failed {
                step: 1,
                failure: RejoinFailure::Refused {
                    object: ObjectId::new(0x2001, 0),
                    code: AbortCode::OBJECT_DOES_NOT_EXIST
                }
            }
        );
        // No answer within the timeout: the client's abort goes to the node.
        let mut r = Rejoin::new(7, plan());
        r.begin();
        let mut out = vec![];
        assert_eq!(r.poll(0.0, &mut |f| out.push(*f)), RejoinProgress::Nothing);
        assert_eq!(r.poll(0.4, &mut |f| out.push(*f)), RejoinProgress::Nothing);
        let told = r.poll(0.6, &mut |f| out.push(*f));
        assert_eq!(
            told,
            RejoinProgress::Failed {
                step: 0,
                failure: RejoinFailure::Refused {
                    object: ObjectId::new(0x1000, 0),
                    code: AbortCode::TIMEOUT
                }
            }
        );
        assert_eq!(out.len(), 2);
        assert_eq!(out[1].data()[0], 0x80);
        // A fault reset begins again.
        r.begin();
        assert!(r.is_running());
    }
}
