//! A simulated actuator node, sans-I/O: on every SYNC it advances its plant by one period with
//! the last command held and answers with its sensor frames, as a real node's firmware would.

use super::profile::ProfileNode;
use crate::bus::Frame;
use crate::canopen::{
    decode_heartbeat, decode_sync, encode_heartbeat, is_heartbeat, NmtCommand, NmtState,
};
use crate::device::{messages, CommandPdo, SensorPdo, SupplyPressurePdo};
use crate::physics::{Family, Plant, ScheduledFault};

/// What the node did, for the runtime to log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SimEvent {
    FaultInjected {
        fault: ScheduledFault,
        plant_time_s: f64,
        /// SYNC frames seen before the fault started: latency is counted from here in periods.
        sync_count: u64,
    },
    StateChanged(NmtState),
    /// The node rebooted as scheduled (`--reboot-at`): boot-up sent, factory values.
    Rebooted {
        plant_time_s: f64,
    },
    Malformed(Frame),
    /// The bus failed (interface down or gone, ...): the node waits for it, it does not exit.
    BusLost(crate::bus::BusFault),
    /// The bus carries frames again after `outage_s`.
    BusRestored {
        cause: crate::bus::BusFault,
        outage_s: f64,
    },
}

/// Counters since boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimCounters {
    pub syncs: u64,
    pub commands: u64,
    pub malformed: u64,
    /// Commands answering an older SYNC than the last one (arrived late).
    pub late_commands: u64,
}

pub struct SimNode {
    node_id: u8,
    plant: Box<dyn Plant>,
    period_s: f64,
    state: NmtState,
    command: f64,
    schedule: Vec<ScheduledFault>,
    next_fault: usize,
    last_sync_counter: Option<u8>,
    counters: SimCounters,
    /// A standard profile instead of the actuatord frames.
    profile: Option<Box<ProfileNode>>,
    /// The node's own clock (s since it started), as the runtime last gave it: what a
    /// standard node's heartbeat consumer times the master with.
    clock_s: f64,
    /// Plant time at which the node reboots (a brown-out of its electronics; the mechanics
    /// keep moving), once.
    reboot_at_s: Option<f64>,
}

impl SimNode {
    /// `faults` are started when the plant's time reaches their `at_s`.
    pub fn new(
        node_id: u8,
        plant: Box<dyn Plant>,
        period_s: f64,
        mut faults: Vec<ScheduledFault>,
    ) -> Self {
        faults.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        Self {
            node_id,
            plant,
            period_s,
            state: NmtState::Initialising,
            command: 0.0,
            schedule: faults,
            next_fault: 0,
            last_sync_counter: None,
            counters: SimCounters::default(),
            profile: None,
            clock_s: 0.0,
            reboot_at_s: None,
        }
    }

    /// Reboot once the plant's time reaches `at_s`: the boot-up message, pre-operational, the
    /// dictionary back to its factory values (a standard node loses its mapping and home).
    pub fn with_reboot_at(mut self, at_s: f64) -> Self {
        self.reboot_at_s = Some(at_s);
        self
    }

    /// Speak a standard profile (CiA 402 drive, CiA 401 I/O module) instead of our frames.
    pub fn with_profile(mut self, profile: ProfileNode) -> Self {
        self.profile = Some(Box::new(profile));
        self
    }

    /// The standard profile's side, when the node speaks one.
    pub fn profile(&self) -> Option<&ProfileNode> {
        self.profile.as_deref()
    }

    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    pub fn state(&self) -> NmtState {
        self.state
    }

    pub fn counters(&self) -> SimCounters {
        self.counters
    }

    pub fn plant(&self) -> &dyn Plant {
        self.plant.as_ref()
    }

    /// Power-on: the boot-up message, then pre-operational until an NMT start.
    pub fn boot(&mut self, send: &mut dyn FnMut(&Frame)) {
        send(&encode_heartbeat(self.node_id, NmtState::Initialising));
        self.state = NmtState::PreOperational;
        self.command = 0.0;
        if let Some(p) = self.profile.as_mut() {
            p.reset();
        }
    }

    /// The identifiers this node takes from the bus (SYNC, NMT, its command): what a real
    /// node's CAN controller lets through its acceptance filter.
    /// The node's clock moved on to `now_s` (s since it started; it runs without SYNC): a
    /// standard node's heartbeat consumer looks at it.
    pub fn poll(&mut self, now_s: f64, send: &mut dyn FnMut(&Frame)) {
        self.clock_s = now_s;
        if let Some(p) = self.profile.as_mut() {
            p.poll(now_s, send);
        }
    }

    /// When [`SimNode::poll`] must run next for a heartbeat consumer (node clock, s).
    pub fn deadline_s(&self) -> Option<f64> {
        self.profile.as_ref().and_then(|p| p.consumer_deadline_s())
    }

    pub fn accepted_ids(&self) -> [u32; 3] {
        [
            messages::SYNC.cob_id(0),
            messages::NMT.cob_id(0),
            messages::COMMAND.cob_id(self.node_id),
        ]
    }

    pub fn heartbeat(&self) -> Frame {
        encode_heartbeat(self.node_id, self.state)
    }

    /// Take one frame from the bus; answers go out through `send`.
    pub fn handle(
        &mut self,
        frame: &Frame,
        send: &mut dyn FnMut(&Frame),
        event: &mut dyn FnMut(SimEvent),
    ) {
        if frame.is_extended() {
            return;
        }
        let id = frame.id();
        if id == messages::SYNC.cob_id(0) {
            match decode_sync(frame) {
                Ok(counter) => self.on_sync(counter, send, event),
                Err(_) => self.malformed(frame, event),
            }
        } else if id == messages::NMT.cob_id(0) {
            match NmtCommand::decode(frame) {
                Ok((cmd, target)) if NmtCommand::addresses(target, self.node_id) => {
                    if matches!(cmd, NmtCommand::ResetNode | NmtCommand::ResetCommunication) {
                        self.boot(send);
                    } else {
                        self.state = self.state.on_command(cmd);
                    }
                    event(SimEvent::StateChanged(self.state));
                }
                Ok(_) => {}
                Err(_) => self.malformed(frame, event),
            }
        } else if is_heartbeat(frame) {
            if let (Some(p), Ok((node, _))) = (self.profile.as_mut(), decode_heartbeat(frame)) {
                p.on_heartbeat(node, self.clock_s, send);
            }
        } else if let Some(p) = self.profile.as_mut() {
            if !p.handle(frame, self.state, send) {
                return;
            }
            // Its PDOs are the commands; SDO requests are not.
            if id != crate::canopen::sdo::request_cob_id(self.node_id) {
                self.counters.commands += 1;
            }
        } else if id == messages::COMMAND.cob_id(self.node_id) {
            match CommandPdo::decode(frame) {
                // PDOs count only in operational (CiA 301).
                Ok(c) if self.state == NmtState::Operational => {
                    self.counters.commands += 1;
                    if self.last_sync_counter.is_some_and(|s| s != c.sync_counter) {
                        self.counters.late_commands += 1;
                    }
                    self.command = match self.plant.family() {
                        Family::Pneumatic => c.duty,
                        _ => c.voltage_v,
                    };
                }
                Ok(_) => {}
                Err(_) => self.malformed(frame, event),
            }
        }
    }

    fn malformed(&mut self, frame: &Frame, event: &mut dyn FnMut(SimEvent)) {
        self.counters.malformed += 1;
        event(SimEvent::Malformed(*frame));
    }

    fn on_sync(
        &mut self,
        counter: Option<u8>,
        send: &mut dyn FnMut(&Frame),
        event: &mut dyn FnMut(SimEvent),
    ) {
        self.counters.syncs += 1;
        self.last_sync_counter = counter;
        while let Some(f) = self.schedule.get(self.next_fault) {
            if f.at_s > self.plant.time_s() + 1e-9 {
                break;
            }
            let f = *f;
            self.next_fault += 1;
            self.plant.inject(f.fault);
            event(SimEvent::FaultInjected {
                fault: f,
                plant_time_s: self.plant.time_s(),
                sync_count: self.counters.syncs - 1,
            });
        }
        if self
            .reboot_at_s
            .is_some_and(|t| t <= self.plant.time_s() + 1e-9)
        {
            self.reboot_at_s = None;
            self.boot(send);
            event(SimEvent::Rebooted {
                plant_time_s: self.plant.time_s(),
            });
        }
        if let Some(p) = self.profile.as_mut() {
            p.on_sync(self.plant.as_mut(), self.period_s, self.state, send);
            return;
        }
        // Physical time passes whatever the NMT state; only the PDOs wait for operational.
        self.plant.step(self.command, self.period_s);
        if self.state != NmtState::Operational {
            return;
        }
        let m = self.plant.measure();
        send(
            &SensorPdo {
                position: m.position,
                current_a: m.current_a,
                supply_voltage_v: m.supply_voltage_v,
            }
            .encode(self.node_id),
        );
        if self.plant.family() == Family::Pneumatic {
            send(
                &SupplyPressurePdo {
                    supply_pressure_pa: m.supply_pressure_pa,
                }
                .encode(self.node_id),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::SyncCounter;

    fn node(faults: &str) -> SimNode {
        let plant = crate::physics::plant_from_str(
            include_str!("../../config/plants/solenoid.toml"),
            "solenoid.toml",
        )
        .expect("plant");
        let faults = faults
            .split(',')
            .filter(|s| !s.is_empty())
            .map(|s| s.parse().expect("fault"))
            .collect();
        SimNode::new(16, plant, 0.0025, faults)
    }

    fn run(n: &mut SimNode, frame: &Frame) -> Vec<Frame> {
        let mut out = vec![];
        n.handle(frame, &mut |f| out.push(*f), &mut |_| {});
        out
    }

    #[test]
    fn answers_sync_only_when_operational() {
        let mut n = node("");
        let mut out = vec![];
        n.boot(&mut |f| out.push(*f));
        assert_eq!(out[0].to_string(), "710#00");
        let sync = SyncCounter::default().encode();
        assert!(run(&mut n, &sync).is_empty());
        run(&mut n, &NmtCommand::Start.encode(16));
        assert_eq!(n.state(), NmtState::Operational);
        let answer = run(&mut n, &sync);
        assert_eq!(answer.len(), 1);
        assert_eq!(answer[0].id(), 0x190);
        // NMT for another node changes nothing.
        run(&mut n, &NmtCommand::Stop.encode(17));
        assert_eq!(n.state(), NmtState::Operational);
    }

    #[test]
    fn a_held_voltage_pulls_the_armature_in() {
        let mut n = node("");
        n.boot(&mut |_| {});
        run(&mut n, &NmtCommand::Start.encode(16));
        let cmd = CommandPdo {
            voltage_v: 12.0,
            duty: 0.0,
            sync_counter: 1,
        };
        run(&mut n, &cmd.encode(16));
        let mut last = SensorPdo::default();
        for _ in 0..400 {
            let out = run(&mut n, &SyncCounter::default().encode());
            last = SensorPdo::decode(&out[0]).expect("sensor");
        }
        // Static: (1.63 N/V · 12 V - pretension 3 N) / 1650 N/m ≈ 10 mm, within friction.
        let expected = (1.63 * 12.0 - 3.0) / 1650.0;
        assert!(
            (last.position - expected).abs() < 3e-4,
            "{last:?} vs {expected}"
        );
    }

    #[test]
    fn scheduled_faults_start_at_their_sync() {
        let mut n = node("sensor_stuck@10ms");
        n.boot(&mut |_| {});
        let mut events = vec![];
        for _ in 0..10 {
            n.handle(&SyncCounter::default().encode(), &mut |_| {}, &mut |e| {
                events.push(e)
            });
        }
        let injected: Vec<_> = events
            .iter()
            .filter_map(|e| match e {
                SimEvent::FaultInjected { sync_count, .. } => Some(*sync_count),
                _ => None,
            })
            .collect();
        assert_eq!(injected, vec![4]);
    }
}
