//! The controller node and a simulated actuator node in lock-step, frame by frame, without
//! threads, clocks or a bus: offline data sets (`actuator sim --record`), benches and tests.
//! Every frame still goes through the codec, so what runs here is what runs on CAN.

pub mod figures;

pub use figures::{command_of, SideBySide, TourFigures};

use crate::bus::Frame;
use crate::daemon::config::{CommandKind, Config};
use crate::daemon::node::CycleTiming;
use crate::daemon::record::{CycleRecord, Record};
use crate::daemon::ControllerNode;
use crate::physics::{Measurement, Plant, ScheduledFault};
use crate::simnode::SimNode;

/// One cycle as seen from outside: what the controller recorded and the plant's true state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LockStepSample {
    pub record: CycleRecord,
    pub truth: Measurement,
}

pub struct LockStep {
    controller: ControllerNode,
    sim: SimNode,
    period_s: f64,
    heartbeat_every: u64,
    k: u64,
    records: Vec<CycleRecord>,
    /// The frames the controller sent in the last cycle.
    sent: Vec<Frame>,
}

impl LockStep {
    /// The first axis of `config` against `plant`; heartbeats every 100 ms as `actuator sim`.
    pub fn new(
        config: &Config,
        plant: Box<dyn Plant>,
        faults: Vec<ScheduledFault>,
    ) -> Result<Self, crate::daemon::node::NodeError> {
        let period_s = config.cycle.period_s;
        let node_id = config.axis.first().map_or(16, |a| a.actuator_node_id);
        let mut rig = Self {
            controller: ControllerNode::new(config)?,
            sim: SimNode::new(node_id, plant, period_s, faults),
            period_s,
            heartbeat_every: ((0.1 / period_s).round() as u64).max(1),
            k: 0,
            records: Vec::with_capacity(4),
            sent: Vec::with_capacity(16),
        };
        rig.sim.boot(&mut |_| {});
        let mut to_sim = Vec::new();
        rig.controller.boot(&mut |f| to_sim.push(*f), &mut |_| {});
        rig.deliver(&to_sim);
        Ok(rig)
    }

    fn deliver(&mut self, frames: &[Frame]) -> Vec<Frame> {
        let mut answers = Vec::new();
        for f in frames {
            self.sim.handle(f, &mut |a| answers.push(*a), &mut |_| {});
        }
        answers
    }

    /// Run one cycle; returns the first axis' sample.
    pub fn cycle(&mut self) -> Option<LockStepSample> {
        let t = self.k as f64 * self.period_s;
        if self.k % self.heartbeat_every == 0 {
            let hb = self.sim.heartbeat();
            self.controller.handle(&hb, t, &mut |_| {});
        }
        self.controller.begin_cycle();
        let sync = self.controller.sync_frame();
        for a in self.deliver(&[sync]) {
            self.controller.handle(&a, t, &mut |_| {});
        }
        self.records.clear();
        self.sent.clear();
        let (records, sent) = (&mut self.records, &mut self.sent);
        self.controller.finish_cycle(
            t,
            CycleTiming::default(),
            &mut |f| sent.push(*f),
            &mut |r| {
                if let Record::Cycle(c) = r {
                    records.push(c);
                }
            },
        );
        let sent = std::mem::take(&mut self.sent);
        self.deliver(&sent);
        self.sent = sent;
        self.k += 1;
        self.records.first().map(|record| LockStepSample {
            record: *record,
            truth: self.sim.plant().truth(),
        })
    }

    /// Run for `seconds`, handing every sample to `each`.
    pub fn run(&mut self, seconds: f64, each: &mut dyn FnMut(&LockStepSample)) {
        let cycles = (seconds / self.period_s).round() as u64;
        for _ in 0..cycles {
            if let Some(s) = self.cycle() {
                each(&s);
            }
        }
    }

    /// A frame another node sent (a commander, a tool) reaches the controller at the time of
    /// the cycle about to run.
    pub fn inject(&mut self, frame: &Frame) {
        let t = self.time_s();
        self.controller.handle(frame, t, &mut |_| {});
    }

    /// The frames the controller sent in the last cycle, in order.
    pub fn sent(&self) -> &[Frame] {
        &self.sent
    }

    /// Every axis' record of the last cycle.
    pub fn records(&self) -> &[CycleRecord] {
        &self.records
    }

    /// Cycles run so far.
    pub fn cycles(&self) -> u64 {
        self.k
    }

    /// The time of the cycle about to run: cycles run times the period.
    pub fn time_s(&self) -> f64 {
        self.k as f64 * self.period_s
    }

    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    pub fn controller(&self) -> &ControllerNode {
        &self.controller
    }

    pub fn controller_mut(&mut self) -> &mut ControllerNode {
        &mut self.controller
    }

    pub fn sim(&self) -> &SimNode {
        &self.sim
    }
}

/// Write samples as CSV for the lab: `time,u,y,supply,i,setpoint` in SI units; `u` is the
/// command (V, or duty for a "duty" axis), `supply` the supply voltage in V, or the supply
/// pressure in Pa for a pneumatic plant.
pub fn write_csv(
    out: &mut dyn std::io::Write,
    samples: &[LockStepSample],
    command: CommandKind,
    supply_is_pressure: bool,
) -> std::io::Result<()> {
    writeln!(out, "time,u,y,supply,i,setpoint")?;
    for s in samples {
        let r = &s.record;
        let u = command_of(r, command);
        let supply = if supply_is_pressure {
            r.supply_pressure
        } else {
            r.supply_voltage
        };
        writeln!(
            out,
            "{},{},{},{},{},{}",
            r.t_s, u, r.position, supply, r.current, r.setpoint_position
        )?;
    }
    Ok(())
}
