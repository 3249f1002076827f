//! The controller node and a simulated node in lock step (`actuatord::lockstep`), with every
//! frame the controller sent and every record it wrote kept, for tests that judge a run by its
//! frames and records.

use actuatord::bus::{Bus, BusError, BusEvent, Frame};
use actuatord::daemon::record::CycleRecord;
use actuatord::daemon::Config;
use actuatord::device::{messages, Emcy};
use actuatord::lockstep::LockStep;
use actuatord::physics::{Plant, ScheduledFault};
use actuatord::simnode::SimNode;
use std::collections::VecDeque;
use std::time::Instant;

pub struct Rig {
    pub lockstep: LockStep,
    /// Every frame the controller sent, with the cycle it was sent in.
    pub sent: Vec<(u64, Frame)>,
    /// Every axis' record of every cycle.
    pub records: Vec<CycleRecord>,
}

impl Rig {
    /// The first axis of `config` against `plant`, with faults written as on the command line
    /// (`friction_x3@5s`).
    pub fn new(config: &Config, plant: Box<dyn Plant>, faults: &[&str]) -> Self {
        let faults: Vec<ScheduledFault> =
            faults.iter().map(|f| f.parse().expect("fault")).collect();
        Rig {
            lockstep: LockStep::new(config, plant, faults).expect("controller"),
            sent: vec![],
            records: vec![],
        }
    }

    pub fn cycle(&mut self) {
        self.lockstep.cycle();
        let k = self.lockstep.cycles() - 1;
        self.sent
            .extend(self.lockstep.sent().iter().map(|f| (k, *f)));
        self.records.extend_from_slice(self.lockstep.records());
    }

    /// Run the cycles whose time lies before `t_s`.
    pub fn run_until(&mut self, t_s: f64) {
        while self.lockstep.time_s() < t_s - 1e-9 {
            self.cycle();
        }
    }

    /// A frame from another node reaches the controller before the next cycle.
    pub fn inject(&mut self, frame: Frame) {
        self.lockstep.inject(&frame);
    }

    pub fn period_s(&self) -> f64 {
        self.lockstep.period_s()
    }

    /// The frames with `id` the controller sent, decoded, with their cycle.
    pub fn frames<T>(&self, id: u32, decode: fn(&Frame) -> T) -> Vec<(u64, T)> {
        self.sent
            .iter()
            .filter(|(_, f)| f.id() == id)
            .map(|(k, f)| (*k, decode(f)))
            .collect()
    }

    /// The controller's emergency messages (node 1), with their cycle.
    pub fn emcys(&self) -> Vec<(u64, Emcy)> {
        self.frames(messages::EMCY.cob_id(1), |f| {
            Emcy::decode(f).expect("emcy decodes")
        })
    }
}

/// A bus whose only other node is one simulated node: every frame sent reaches it at once, and
/// its answers wait to be received (a start-up over SDO without clocks).
pub struct SimBus<'a> {
    sim: &'a mut SimNode,
    answers: VecDeque<Frame>,
}

impl<'a> SimBus<'a> {
    pub fn new(sim: &'a mut SimNode) -> Self {
        SimBus {
            sim,
            answers: VecDeque::new(),
        }
    }
}

impl Bus for SimBus<'_> {
    fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        let answers = &mut self.answers;
        self.sim
            .handle(frame, &mut |f| answers.push_back(*f), &mut |_| {});
        Ok(())
    }

    fn recv_until(&mut self, _deadline: Instant) -> Result<Option<BusEvent>, BusError> {
        Ok(self.answers.pop_front().map(BusEvent::Frame))
    }

    fn name(&self) -> &str {
        "sim"
    }
}
