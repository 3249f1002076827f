//! The controller as a CAN node, sans-I/O: frames in through [`ControllerNode::handle`], frames
//! and records out through callbacks once per cycle. The cycle thread owns the I/O around it.

use super::axis::{Axis, AxisStep};
use super::config::{cycles, BusLossPolicy, CommandKind, Config};
use super::dictionary::{self, LiveObjects, LoopFigures, WriteEffect};
use super::profile_link::{NodeLayout, ProfileLink, Received};
use super::profile_rejoin::{Rejoin, RejoinProgress};
use super::reconfigure::{build_parameters, BuildInput, BuildKind, Built};
use super::record::{CycleRecord, Event, Record, RejoinStage};
use super::slot::{Axes, AxesMut, AxisSlot};
use crate::bus::{BusFault, Frame};
use crate::canopen::od::PendingWrite;
use crate::canopen::{
    decode_heartbeat, decode_sync, encode_heartbeat, is_heartbeat, NmtCommand, NmtState,
    SyncCounter,
};
use crate::canopen::{ErrorField, ObjectDictionary, SdoServer};
use crate::control::{BandStatus, ControllerError};
use crate::device::{
    messages, CommandPdo, Emcy, FaultResetPdo, LoopStatusPdo, SensorPdo, SetpointPdo,
    SupplyPressurePdo,
};
use crate::supervise::{FaultKind, FaultState, ReactionName, SetpointSourceEvent};
use hdrhistogram::Histogram;
use std::sync::mpsc::{SyncSender, TrySendError};

/// Counters of the node since start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NodeCounters {
    pub cycles: u64,
    pub sensor_missed: u64,
    pub frames_malformed: u64,
    pub frames_unknown: u64,
    pub overruns: u64,
    pub bus_errors: u64,
    pub faults_raised: u64,
    /// Bus faults raised: losses and controller reports, each named in the recording.
    pub bus_faults: u64,
    /// Cycles run while the bus could not carry frames.
    pub bus_lost_cycles: u64,
}

/// A bus loss in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BusLoss {
    cause: BusFault,
    since_s: f64,
    cycles: u64,
}

/// A bus fault of the same cause that does not stop the bus is raised again only after this
/// long, so a controller reporting every error frame cannot flood the log and the bus.
const BUS_FAULT_REPEAT_S: f64 = 1.0;

/// Timing facts the cycle thread measured for the cycle just run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CycleTiming {
    /// Delay from the release time to waking up, this cycle.
    pub wake_latency_s: f64,
    /// Delay from release to the last frame sent, previous cycle (this one is not over yet).
    pub previous_cycle_latency_s: f64,
}

pub use crate::recording::{Stage, STAGES};

/// Splits a cycle into stage durations with the runtime's clock; does nothing without one.
struct StageTimer {
    clock: Option<fn() -> u64>,
    since: u64,
    stage_ns: [u32; STAGES],
}

impl StageTimer {
    fn start(clock: Option<fn() -> u64>) -> Self {
        Self {
            clock,
            since: clock.map_or(0, |c| c()),
            stage_ns: [0; STAGES],
        }
    }

    fn mark(&mut self, stage: Stage) {
        if let Some(c) = self.clock {
            let now = c();
            let spent = now.saturating_sub(self.since).min(u64::from(u32::MAX)) as u32;
            self.stage_ns[stage as usize] = self.stage_ns[stage as usize].saturating_add(spent);
            self.since = now;
        }
    }
}

/// Unknown ids are logged at most this often, so a busy foreign bus cannot flood the log.
const UNKNOWN_LOG_INTERVAL_S: f64 = 1.0;

pub struct ControllerNode {
    node_id: u8,
    state: NmtState,
    /// One slot per axis: the axis and what the node keeps of it between cycles.
    slots: Vec<AxisSlot>,
    sync: SyncCounter,
    heartbeat_every: u32,
    status_every: u32,
    counters: NodeCounters,
    latency_max_s: f64,
    last_unknown_log_s: f64,
    pending_reset: bool,
    period_s: f64,
    stage_clock: Option<fn() -> u64>,
    /// The configuration in force; a reload or SDO parameter writes replace it, built apart
    /// ([`super::reconfigure`]) and swapped in at a boundary.
    config: Config,
    od: ObjectDictionary,
    sdo: SdoServer,
    live: LiveObjects,
    /// SDO answers, sent with the cycle's frames (one request, one answer: a few suffice).
    sdo_out: [Option<Frame>; 4],
    /// Release-to-command latency over the current status period, for its p99.
    latency: Histogram<u64>,
    wake_latency_max_s: f64,
    overruns_at_window_start: u64,
    timing_warning: bool,
    /// Leaving operational: the actuators get their safe command with the next cycle.
    pending_safe: bool,
    bus_loss: Option<BusLoss>,
    /// EMCY of a bus fault, sent with the next cycle's frames (once the bus carries them).
    pending_bus_emcy: Option<(BusFault, FaultState)>,
    last_bus_fault: Option<(BusFault, f64)>,
    /// The builder that makes new configurations off this thread ([`super::reconfigure`]);
    /// without one (tests, lock-step runs) the node builds at the boundary itself.
    builder: Option<SyncSender<BuildInput>>,
    /// Room for the staged writes of one parameter build; away while a build is out.
    batch: Option<Vec<PendingWrite>>,
    /// The EMCYs sent, for 1003h and the state file.
    error_field: ErrorField,
    /// The field's change count the dictionary shows; None after the dictionary was replaced.
    error_field_published: Option<u64>,
    /// Unix time of the node's time 0, s: the time the error field gives each entry.
    wall_clock_at_start_s: f64,
}

/// A configuration with its dictionary and axes built, ready to be swapped in at a cycle
/// boundary; after [`ControllerNode::apply_reload`] it holds what was replaced.
pub struct PreparedReload {
    config: Config,
    od: ObjectDictionary,
    live: LiveObjects,
    axes: Vec<Axis>,
}

impl PreparedReload {
    /// The configuration it was built from.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Build everything a reload needs (this allocates: not on the cycle thread).
    pub fn build(config: Config) -> Result<Self, String> {
        let od = dictionary::build(&config).map_err(|e| e.to_string())?;
        let axes = config
            .axis
            .iter()
            .map(|a| Axis::new(a, config.cycle.period_s))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        let live = LiveObjects::new(&od, axes.len());
        Ok(Self {
            config,
            od,
            live,
            axes,
        })
    }
}

/// Why the controller node cannot be built from a configuration.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error(transparent)]
    Controller(#[from] ControllerError),
    #[error("object dictionary: {0}")]
    Dictionary(#[from] crate::canopen::od::BuildError),
}

impl ControllerNode {
    pub fn new(config: &Config) -> Result<Self, NodeError> {
        let period_s = config.cycle.period_s;
        let axes = config
            .axis
            .iter()
            .map(|a| Axis::new(a, period_s))
            .collect::<Result<Vec<_>, _>>()?;
        let od = dictionary::build(config)?;
        let live = LiveObjects::new(&od, axes.len());
        let writable = od.entries().iter().filter(|e| e.access.writable()).count();
        // The layout the daemon gives standard nodes at start-up; the runtime replaces it with
        // the one it configured and checked ([`ControllerNode::set_node_layout`]).
        let slots = config
            .axis
            .iter()
            .zip(axes)
            .map(|(a, axis)| {
                let layout = NodeLayout {
                    pdos: super::profile_config::desired_pdos(a),
                    rated_torque_nm: a
                        .cia402
                        .as_ref()
                        .and_then(|d| d.rated_torque_nm)
                        .unwrap_or(0.0),
                    error_code: 0,
                    rejoin: vec![],
                };
                AxisSlot::new(axis, ProfileLink::new(a, &layout, period_s))
            })
            .collect();
        Ok(Self {
            slots,
            builder: None,
            batch: Some(Vec::with_capacity(writable)),
            config: config.clone(),
            sdo: SdoServer::new(config.node.node_id),
            live,
            od,
            sdo_out: [None; 4],
            latency: Histogram::new_with_bounds(1, 10_000_000, 2)
                .expect("constant, valid histogram bounds"),
            wake_latency_max_s: 0.0,
            overruns_at_window_start: 0,
            timing_warning: false,
            pending_safe: false,
            bus_loss: None,
            pending_bus_emcy: None,
            last_bus_fault: None,
            node_id: config.node.node_id,
            state: NmtState::Initialising,
            sync: SyncCounter::default(),
            heartbeat_every: cycles(config.node.heartbeat_period_s, period_s),
            status_every: cycles(config.node.status_period_s, period_s),
            counters: NodeCounters::default(),
            latency_max_s: 0.0,
            last_unknown_log_s: f64::NEG_INFINITY,
            pending_reset: false,
            period_s,
            stage_clock: None,
            error_field: ErrorField::default(),
            error_field_published: None,
            wall_clock_at_start_s: 0.0,
        })
    }

    /// The wall clock's Unix time at the node's time 0, so the error field's entries carry a
    /// time a workshop can use; without it they carry the node's own time.
    pub fn set_wall_clock_at_start(&mut self, unix_time_s: f64) {
        self.wall_clock_at_start_s = unix_time_s;
    }

    /// The pre-defined error field (1003h): the EMCYs sent, newest first.
    pub fn error_field(&self) -> &ErrorField {
        &self.error_field
    }

    /// Take over the errors of an earlier run (the state file).
    pub fn restore_error_field(&mut self, field: ErrorField) {
        self.error_field = field;
        self.error_field_published = None;
    }

    /// The layout a standard node of axis `index` was given and checked at start-up
    /// ([`super::profile_setup::configure`]).
    pub fn set_node_layout(&mut self, index: usize, layout: &NodeLayout) {
        if let (Some(slot), Some(axis)) = (self.slots.get_mut(index), self.config.axis.get(index)) {
            slot.link = ProfileLink::new(axis, layout, self.period_s);
            slot.rejoin = (slot.link.is_some() && !layout.rejoin.is_empty())
                .then(|| Rejoin::new(axis.actuator_node_id, layout.rejoin.clone()));
        }
    }

    /// What configures axis `index`'s standard node again when it reboots, if anything.
    pub fn rejoin(&self, index: usize) -> Option<&Rejoin> {
        self.slots.get(index).and_then(|s| s.rejoin.as_ref())
    }

    /// The link to axis `index`'s standard node, if it has one.
    pub fn profile_link(&self, index: usize) -> Option<&ProfileLink> {
        self.slots.get(index).and_then(|s| s.link.as_ref())
    }

    /// Give the node a nanosecond clock, so it times each stage of the cycle.
    pub fn set_stage_clock(&mut self, clock: fn() -> u64) {
        self.stage_clock = Some(clock);
    }

    pub fn node_id(&self) -> u8 {
        self.node_id
    }

    pub fn state(&self) -> NmtState {
        self.state
    }

    pub fn counters(&self) -> NodeCounters {
        self.counters
    }

    pub fn counters_mut(&mut self) -> &mut NodeCounters {
        &mut self.counters
    }

    /// The axes, in configuration order.
    pub fn axes(&self) -> Axes<'_> {
        Axes(&self.slots)
    }

    /// Axis `index` (configuration order).
    pub fn axis(&self, index: usize) -> Option<&Axis> {
        self.slots.get(index).map(|s| &s.axis)
    }

    /// The standard identifiers of the frames that answer SYNC with an axis' readings: what
    /// the bus should deliver ahead of other traffic ([`crate::bus::Bus::prioritise`]).
    pub fn cycle_frame_ids(&self) -> Vec<u32> {
        let mut ids = Vec::new();
        for slot in self.slots.iter() {
            match slot.link.as_ref() {
                Some(link) => ids.extend(link.cyclic_ids()),
                None => {
                    let node = slot.axis.actuator_node_id;
                    ids.push(messages::SENSOR.cob_id(node));
                    ids.push(messages::SUPPLY_PRESSURE.cob_id(node));
                }
            }
        }
        ids
    }

    /// The axes, to give them what they learned before (a state file).
    pub fn axes_mut(&mut self) -> AxesMut<'_> {
        AxesMut(&mut self.slots)
    }

    /// A bus fault: counted, recorded with its cause, announced by EMCY as soon as frames go
    /// out again. A loss (the bus carries nothing) applies `[bus] on_loss` to the axes and
    /// lasts until [`ControllerNode::bus_restored`]; a second fault during a loss is the same
    /// outage.
    pub fn on_bus_fault(&mut self, cause: BusFault, now_s: f64, record: &mut dyn FnMut(Record)) {
        if self.bus_loss.is_some() {
            return;
        }
        let lost = cause.is_loss();
        if !lost {
            let repeat = self
                .last_bus_fault
                .is_some_and(|(c, t)| c == cause && now_s - t < BUS_FAULT_REPEAT_S && now_s >= t);
            if repeat {
                return;
            }
        }
        self.last_bus_fault = Some((cause, now_s));
        self.counters.bus_faults += 1;
        let policy = self.config.bus.on_loss;
        record(Record::Event(Event::BusFault {
            t_s: now_s,
            cause,
            lost,
            policy: policy.name(),
        }));
        if !lost {
            self.pending_bus_emcy = Some((cause, FaultState::Warning));
            return;
        }
        self.bus_loss = Some(BusLoss {
            cause,
            since_s: now_s,
            cycles: 0,
        });
        let state = match policy {
            BusLossPolicy::SafeState => {
                // CiA 301 error behaviour "pre-operational": PDOs stop, the safe command goes
                // out first thing when the bus is back, an NMT start resumes control.
                if self.state == NmtState::Operational {
                    self.state = NmtState::PreOperational;
                    self.pending_safe = true;
                    record(Record::Event(Event::OwnState {
                        t_s: now_s,
                        state: self.state,
                    }));
                }
                FaultState::Fault
            }
            BusLossPolicy::Continue => FaultState::Warning,
        };
        self.pending_bus_emcy = Some((cause, state));
    }

    /// The cause of the bus loss in progress, if any.
    pub fn bus_lost(&self) -> Option<BusFault> {
        self.bus_loss.map(|l| l.cause)
    }

    /// One period passed without a bus: counted, the axes wait (nothing to control them with).
    pub fn bus_lost_cycle(&mut self) {
        self.counters.bus_lost_cycles += 1;
        if let Some(loss) = self.bus_loss.as_mut() {
            loss.cycles += 1;
        }
        self.sync = self.sync.next();
    }

    /// The bus carries frames again: the EMCY naming the outage goes out with this cycle.
    pub fn bus_restored(&mut self, now_s: f64, record: &mut dyn FnMut(Record)) {
        if let Some(loss) = self.bus_loss.take() {
            for slot in self.slots.iter_mut() {
                slot.axis.on_bus_restored(now_s);
            }
            record(Record::Event(Event::BusRestored {
                t_s: now_s,
                cause: loss.cause,
                outage_s: (now_s - loss.since_s).max(0.0),
                cycles_lost: loss.cycles,
            }));
        }
    }

    /// Boot: announce ourselves, start the actuator nodes, go operational (we are the NMT master).
    pub fn boot(&mut self, send: &mut dyn FnMut(&Frame), record: &mut dyn FnMut(Record)) {
        send(&encode_heartbeat(self.node_id, NmtState::Initialising));
        for axis in self.axes().iter() {
            if axis.start_node {
                send(&NmtCommand::Start.encode(axis.actuator_node_id));
            }
        }
        self.state = NmtState::Operational;
        record(Record::Event(Event::OwnState {
            t_s: 0.0,
            state: self.state,
        }));
    }

    /// Open a cycle: from now on only sensor frames answering this cycle's SYNC count as fresh.
    pub fn begin_cycle(&mut self) {
        for slot in self.slots.iter_mut() {
            slot.axis.begin_cycle();
            if let Some(link) = slot.link.as_mut() {
                link.begin_cycle();
            }
        }
    }

    /// The SYNC that opens a cycle.
    pub fn sync_frame(&mut self) -> Frame {
        self.sync.encode()
    }

    /// True once every axis has its sensor frame for this cycle.
    pub fn all_sensors_in(&self) -> bool {
        self.axes().iter().all(Axis::has_fresh_sensor)
    }

    /// Take one received frame.
    pub fn handle(&mut self, frame: &Frame, now_s: f64, record: &mut dyn FnMut(Record)) {
        let id = frame.id();
        if frame.is_extended() {
            self.unknown(frame, now_s, record);
            return;
        }
        let mut malformed = |node: &mut Self, error| {
            node.counters.frames_malformed += 1;
            record(Record::Event(Event::Malformed {
                t_s: now_s,
                frame: *frame,
                error,
            }));
        };
        if id == messages::NMT.cob_id(0) {
            match NmtCommand::decode(frame) {
                Ok((cmd, target)) if NmtCommand::addresses(target, self.node_id) => {
                    self.on_nmt(cmd, now_s, record)
                }
                Ok(_) => {}
                Err(e) => malformed(self, e),
            }
            return;
        }
        if id == crate::canopen::sdo::request_cob_id(self.node_id) {
            if let Some(answer) = self.sdo.handle(frame, now_s, &mut self.od, self.state) {
                match self.sdo_out.iter_mut().find(|s| s.is_none()) {
                    Some(slot) => *slot = Some(answer),
                    // A client that does not wait for answers: drop the surplus, it will time out.
                    None => self.counters.frames_unknown += 1,
                }
            }
            return;
        }
        if id == messages::SYNC.cob_id(0) {
            // Another SYNC producer on the bus; ours is the one that counts. Check it decodes.
            if let Err(e) = decode_sync(frame) {
                malformed(self, e);
            }
            return;
        }
        if id == messages::SETPOINT.cob_id(self.node_id) {
            match SetpointPdo::decode(frame) {
                Ok(sp) => {
                    if let Some(axis) = self.axis_mut(sp.axis_node_id) {
                        axis.on_commanded_setpoint(sp.position, now_s);
                    }
                }
                Err(e) => malformed(self, e),
            }
            return;
        }
        if id == messages::FAULT_RESET.cob_id(self.node_id) {
            match FaultResetPdo::decode(frame) {
                Ok(r) => self.reset_faults(r.axis_node_id, now_s, record),
                Err(e) => malformed(self, e),
            }
            return;
        }
        if is_heartbeat(frame) {
            match decode_heartbeat(frame) {
                Ok((node, state)) => {
                    if let Some(index) = self.axis_index(node) {
                        let slot = &mut self.slots[index];
                        slot.axis.on_heartbeat(state, now_s);
                        if state == NmtState::Initialising {
                            record(Record::Event(Event::NodeState {
                                t_s: now_s,
                                node_id: node,
                                state,
                            }));
                            if let (Some(rejoin), Some(link)) =
                                (slot.rejoin.as_mut(), slot.link.as_mut())
                            {
                                // A standard node is back with its factory layout: configure
                                // it again before it is started.
                                link.rebooted();
                                rejoin.begin();
                                slot.resume = false;
                                record(Record::Event(Event::NodeRejoin {
                                    t_s: now_s,
                                    node_id: node,
                                    stage: RejoinStage::Rebooted {
                                        steps: rejoin.steps().len() as u32,
                                    },
                                }));
                            } else if slot.axis.start_node {
                                // A rebooted node waits in pre-operational: start it again.
                                self.pending_reset = true;
                            }
                        }
                    }
                }
                Err(e) => malformed(self, e),
            }
            return;
        }
        if id & !0x7F == crate::canopen::sdo::SDO_TX_FUNCTION
            && self
                .slots
                .iter_mut()
                .filter_map(|s| s.rejoin.as_mut())
                .any(|r| r.handle(frame))
        {
            return;
        }
        for slot in self.slots.iter_mut() {
            let Some(link) = slot.link.as_mut() else {
                continue;
            };
            match link.handle(frame) {
                Received::NotMine => continue,
                Received::Taken => {}
                Received::Complete(sensor) => slot.axis.on_sensor(sensor),
                Received::Malformed { expected } => {
                    self.counters.frames_malformed += 1;
                    record(Record::Event(Event::Malformed {
                        t_s: now_s,
                        frame: *frame,
                        error: crate::canopen::DecodeError::WrongLength {
                            name: "mapped_pdo",
                            id,
                            got: frame.len(),
                            expected,
                        },
                    }));
                }
            }
            return;
        }
        for index in 0..self.slots.len() {
            if self.slots[index].link.is_some() {
                continue;
            }
            let node = self.slots[index].axis.actuator_node_id;
            if id == messages::SENSOR.cob_id(node) {
                match SensorPdo::decode(frame) {
                    Ok(s) => self.slots[index].axis.on_sensor(s),
                    Err(e) => malformed(self, e),
                }
                return;
            }
            if id == messages::SUPPLY_PRESSURE.cob_id(node) {
                match SupplyPressurePdo::decode(frame) {
                    Ok(p) => self.slots[index]
                        .axis
                        .on_supply_pressure(p.supply_pressure_pa),
                    Err(e) => malformed(self, e),
                }
                return;
            }
            if id == messages::COMMAND.cob_id(node) {
                // Our own command echoed by a second controller would be a configuration error;
                // on vcan we never see our own frames, so this is another master.
                self.unknown(frame, now_s, record);
                return;
            }
        }
        self.unknown(frame, now_s, record);
    }

    fn unknown(&mut self, frame: &Frame, now_s: f64, record: &mut dyn FnMut(Record)) {
        self.counters.frames_unknown += 1;
        if now_s - self.last_unknown_log_s >= UNKNOWN_LOG_INTERVAL_S {
            self.last_unknown_log_s = now_s;
            record(Record::Event(Event::UnknownFrame {
                t_s: now_s,
                frame: *frame,
            }));
        }
    }

    fn axis_index(&self, node: u8) -> Option<usize> {
        self.axes().iter().position(|a| a.actuator_node_id == node)
    }

    fn axis_mut(&mut self, node: u8) -> Option<&mut Axis> {
        self.slots
            .iter_mut()
            .map(|s| &mut s.axis)
            .find(|a| a.actuator_node_id == node)
    }

    fn on_nmt(&mut self, cmd: NmtCommand, now_s: f64, record: &mut dyn FnMut(Record)) {
        let was_operational = self.state == NmtState::Operational;
        match cmd {
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                self.reset_faults(0, now_s, record);
                self.sdo.reset();
                // We are the NMT master: after a reset we boot again and start our nodes.
                self.pending_reset = true;
            }
            other => {
                self.state = self.state.on_command(other);
                if self.state == NmtState::Stopped {
                    self.sdo.reset();
                }
            }
        }
        // PDOs stop outside operational: the actuators must not keep the last command.
        if was_operational && self.state != NmtState::Operational {
            self.pending_safe = true;
        }
        record(Record::Event(Event::OwnState {
            t_s: now_s,
            state: self.state,
        }));
    }

    /// Rebooted standard nodes: the next SDO transfer of their configuration, and an axis
    /// whose node is back (started, operational, readings fresh this cycle) resumes with its
    /// faults reset, as a fault reset frame for it would.
    fn poll_rejoins(
        &mut self,
        now_s: f64,
        send: &mut dyn FnMut(&Frame),
        record: &mut dyn FnMut(Record),
    ) {
        for index in 0..self.slots.len() {
            let slot = &mut self.slots[index];
            let node_id = slot.axis.actuator_node_id;
            let Some(rejoin) = slot.rejoin.as_mut() else {
                continue;
            };
            let stage = match rejoin.poll(now_s, send) {
                RejoinProgress::Nothing => None,
                RejoinProgress::Started { steps } => {
                    slot.resume = true;
                    Some(RejoinStage::Started { steps })
                }
                RejoinProgress::Failed { step, failure } => {
                    Some(RejoinStage::Failed { step, failure })
                }
            };
            if let Some(stage) = stage {
                record(Record::Event(Event::NodeRejoin {
                    t_s: now_s,
                    node_id,
                    stage,
                }));
            }
            let back = slot.axis.node_state() == Some(NmtState::Operational)
                && slot.axis.has_fresh_sensor();
            if slot.resume && back {
                slot.resume = false;
                self.reset_faults(node_id, now_s, record);
                record(Record::Event(Event::NodeRejoin {
                    t_s: now_s,
                    node_id,
                    stage: RejoinStage::Resumed,
                }));
            }
        }
    }

    fn reset_faults(&mut self, axis_node: u8, now_s: f64, record: &mut dyn FnMut(Record)) {
        for slot in self.slots.iter_mut() {
            let axis = &mut slot.axis;
            if axis_node == 0 || axis.actuator_node_id == axis_node {
                if let Some(rejoin) = slot.rejoin.as_mut().filter(|r| r.has_failed()) {
                    // A node that could not be configured again is tried once more.
                    rejoin.begin();
                }
                if let Some(link) = slot.link.as_mut() {
                    // The drive's own fault is reset through its state machine.
                    link.request_fault_reset();
                    axis.set_drive_fault(link.drive_fault());
                }
                axis.reset_faults();
                record(Record::Event(Event::FaultsReset {
                    t_s: now_s,
                    axis_node_id: axis.actuator_node_id,
                }));
                // An EMCY "error reset" goes out with the next cycle's frames if it had faults.
                if slot.last_fault_state.0 != FaultState::Ok {
                    slot.announce_reset = true;
                }
            }
        }
    }

    /// Close the cycle: control every axis, send commands, EMCY and status, and record. Every
    /// EMCY sent goes into the pre-defined error field, which the dictionary then shows.
    pub fn finish_cycle(
        &mut self,
        now_s: f64,
        timing: CycleTiming,
        send: &mut dyn FnMut(&Frame),
        record: &mut dyn FnMut(Record),
    ) {
        // Noted apart while the cycle runs (the node is borrowed), then added in order: a ring
        // as large as the field holds every EMCY of the cycle that the field could keep.
        let mut sent = ErrorField::default();
        let (node_id, time_s) = (self.node_id, self.wall_clock_at_start_s + now_s);
        let mut noting = |f: &Frame| {
            if let Some(e) = crate::device::error_field_entry(f, node_id, time_s) {
                sent.push(e);
            }
            send(f);
        };
        self.run_cycle(now_s, timing, &mut noting, record);
        for e in sent.iter().rev() {
            self.error_field.push(e);
        }
        if self.error_field_published != Some(self.error_field.changes()) {
            self.live
                .publish_error_field(&mut self.od, &self.error_field);
            self.error_field_published = Some(self.error_field.changes());
        }
    }

    fn run_cycle(
        &mut self,
        now_s: f64,
        timing: CycleTiming,
        send: &mut dyn FnMut(&Frame),
        record: &mut dyn FnMut(Record),
    ) {
        let cycle = self.counters.cycles;
        self.counters.cycles += 1;
        self.latency_max_s = self.latency_max_s.max(timing.previous_cycle_latency_s);
        self.wake_latency_max_s = self.wake_latency_max_s.max(timing.wake_latency_s);
        if timing.previous_cycle_latency_s > 0.0 {
            let _ = self
                .latency
                .record(((timing.previous_cycle_latency_s * 1e6) as u64).max(1));
        }
        if self.pending_reset {
            self.pending_reset = false;
            self.boot(send, record);
        }
        if std::mem::take(&mut self.pending_safe) {
            self.send_safe_commands(send);
        }
        if let Some((cause, state)) = self.pending_bus_emcy.take() {
            send(&bus_fault_emcy(cause, state).encode(self.node_id));
        }
        if let Some(abort) = self.sdo.poll(now_s) {
            send(&abort);
        }
        for slot in self.sdo_out.iter_mut() {
            if let Some(f) = slot.take() {
                send(&f);
            }
        }
        self.apply_sdo_writes(now_s, record);
        self.poll_rejoins(now_s, send, record);
        let operational = self.state == NmtState::Operational;
        let sync_counter = self.sync.value();
        let status_due = cycle % u64::from(self.status_every) == 0;
        for index in 0..self.slots.len() {
            let mut timer = StageTimer::start(self.stage_clock);
            let slot = &mut self.slots[index];
            let axis = &mut slot.axis;
            if let Some(link) = &slot.link {
                axis.set_drive_fault(link.drive_fault());
                axis.set_motion_enabled(link.ready_for_motion());
            }
            let step = axis.step_marked(now_s, &mut |stage| timer.mark(stage));
            let node = slot.axis.actuator_node_id;
            if !step.sensor_fresh {
                self.counters.sensor_missed += 1;
                slot.sensor_missed += 1;
            }
            let rejoining = slot.rejoin.as_ref().is_some_and(Rejoin::is_running);
            let reaction = step.model.machine.reaction;
            if reaction > slot.last_reaction {
                if let Some(r) = reaction {
                    record(Record::Event(Event::ReactionApplied {
                        t_s: now_s,
                        axis_node_id: node,
                        reaction: ReactionName::of(r),
                        cycle,
                    }));
                }
            }
            slot.last_reaction = reaction;
            if let Some(link) = slot.link.as_mut() {
                // Every axis' stop goes into its RPDO of this very cycle: drives whose faults
                // latch together stop in the same SYNC period.
                link.set_stop(step.model.machine.stop);
            }
            if let (true, Some(link)) = (operational, slot.link.as_mut()) {
                // A node being configured again gets its PDOs once it is started.
                if !rejoining {
                    link.send_command(step.command, send);
                }
            } else if operational {
                let command = match slot.axis.command_kind {
                    CommandKind::Duty => CommandPdo {
                        voltage_v: 0.0,
                        duty: step.command,
                        sync_counter,
                    },
                    _ => CommandPdo {
                        voltage_v: step.command,
                        duty: 0.0,
                        sync_counter,
                    },
                };
                send(&command.encode(node));
            }
            for kind in step.supervision.raised.iter() {
                self.counters.faults_raised += 1;
                slot.faults_raised += 1;
                let mut emcy = step.emcy(Emcy::raised(node, kind, step.supervision.latched));
                // A drive that went to fault: its own error code (603Fh, from its EMCY).
                if let (crate::supervise::FaultKind::NodeState, Some(code)) =
                    (kind, slot.axis.drive_fault())
                {
                    emcy.error_code = code;
                }
                send(&emcy.encode(self.node_id));
                record(Record::Event(Event::FaultRaised {
                    t_s: now_s,
                    axis_node_id: node,
                    kind,
                    cycle,
                }));
            }
            for fault in step.supervised_raised() {
                self.counters.faults_raised += 1;
                slot.faults_raised += 1;
                let emcy = step.emcy(Emcy::supervised(node, fault, step.supervision.latched));
                send(&emcy.encode(self.node_id));
                record(Record::Event(Event::Diagnosed {
                    t_s: now_s,
                    axis_node_id: node,
                    fault,
                    confidence: step.model.confidence,
                    state: step.supervision.state,
                    cycle,
                }));
            }
            if let Some(event) = step.setpoint_source {
                let emcy = match event {
                    SetpointSourceEvent::Lost => {
                        step.emcy(Emcy::setpoint_timeout(node, step.supervision.latched))
                    }
                    // Back: "error reset", with what is still active (CiA 301).
                    SetpointSourceEvent::Back => {
                        let (limits, model) =
                            (step.supervision.latched, step.model.machine.latched);
                        if limits.is_empty() && model.is_empty() {
                            Emcy::reset(node)
                        } else {
                            step.emcy(Emcy::reset_leaving(node, limits, !model.is_empty()))
                        }
                    }
                };
                send(&emcy.encode(self.node_id));
                record(Record::Event(Event::SetpointSource {
                    t_s: now_s,
                    axis_node_id: node,
                    lost: event == SetpointSourceEvent::Lost,
                    cycle,
                }));
            }
            if step.supply_band != slot.last_supply_band {
                slot.last_supply_band = step.supply_band;
                match step.supply_band {
                    // Back inside: "error reset", with what is still active in the error
                    // register (CiA 301) when something else is.
                    BandStatus::Inside => {
                        let (limits, model) =
                            (step.supervision.latched, step.model.machine.latched);
                        let emcy = if limits.is_empty() && model.is_empty() {
                            Emcy::reset(node)
                        } else {
                            step.emcy(Emcy::reset_leaving(node, limits, !model.is_empty()))
                        };
                        send(&emcy.encode(self.node_id));
                    }
                    // A supply past the hard band has its own EMCY and the safe state.
                    _ if step.supervision.latched.contains(FaultKind::SupplyVoltage)
                        || step.supervision.latched.contains(FaultKind::SupplyPressure) => {}
                    band => {
                        let emcy = step.emcy(Emcy::supply_band(
                            node,
                            slot.axis.supply_band_is_pressure(),
                            band == BandStatus::Below,
                            step.supervision.latched,
                        ));
                        send(&emcy.encode(self.node_id));
                    }
                }
            }
            let now_state = (
                step.supervision.state,
                step.supervision.latched.0,
                step.model.machine.latched.0,
            );
            let last = slot.last_fault_state;
            if std::mem::take(&mut slot.announce_reset) {
                send(&Emcy::reset(node).encode(self.node_id));
            }
            if operational && (status_due || now_state != last) {
                let mut fault_state = step.fault_state(node);
                // A cycle that misses its deadlines too often is a warning on every axis.
                if self.timing_warning && fault_state.state == FaultState::Ok {
                    fault_state.state = FaultState::Warning;
                }
                send(&fault_state.encode(self.node_id));
                send(&step.fault_diagnosis(node).encode(self.node_id));
            }
            slot.last_fault_state = now_state;
            if operational && status_due {
                send(&step.tuned_parameters(node).encode(self.node_id));
                send(&step.tuned_gains(node).encode(self.node_id));
            }
            timer.mark(Stage::EncodeSend);
            let mut rec = cycle_record(now_s, cycle, node, &slot.axis, &step, timing);
            if let Some(sw) = slot.link.as_ref().and_then(ProfileLink::statusword) {
                rec.drive_statusword = sw;
            }
            rec.stage_ns = timer.stage_ns;
            if status_due {
                self.live.publish_axis(
                    &mut self.od,
                    index,
                    &rec,
                    slot.faults_raised,
                    slot.sensor_missed,
                );
                let axis = &slot.axis;
                self.live.publish_diagnosis(
                    &mut self.od,
                    index,
                    &rec,
                    &step,
                    &axis.learned(),
                    axis.learned_table().map_or(0, |t| t.populated_cells()),
                );
            }
            record(Record::Cycle(rec));
        }
        if status_due {
            self.close_status_window(now_s, record);
        }
        if operational && status_due {
            send(
                &LoopStatusPdo {
                    overruns: self.counters.overruns as u16,
                    sensor_missed: self.counters.sensor_missed as u16,
                    frames_malformed: self.counters.frames_malformed as u8,
                    bus_faults: self.counters.bus_faults as u8,
                    cycle_latency_max_s: self.latency_max_s,
                }
                .encode(self.node_id),
            );
        }
        if status_due {
            self.latency_max_s = 0.0;
            self.wake_latency_max_s = 0.0;
            self.latency.reset();
        }
        if cycle % u64::from(self.heartbeat_every) == 0 {
            send(&encode_heartbeat(self.node_id, self.state));
        }
        self.sync = self.sync.next();
    }

    /// The statistics of the status period just ended: published, and judged for the warning.
    fn close_status_window(&mut self, now_s: f64, record: &mut dyn FnMut(Record)) {
        let overruns = self.counters.overruns - self.overruns_at_window_start;
        self.overruns_at_window_start = self.counters.overruns;
        let ratio = overruns as f64 / f64::from(self.status_every);
        let warning = ratio > self.config.cycle.overrun_warning_ratio;
        if warning != self.timing_warning {
            record(Record::Event(Event::Timing {
                t_s: now_s,
                overrun_ratio: ratio,
                warning,
            }));
        }
        self.timing_warning = warning;
        let p99 = if self.latency.is_empty() {
            0.0
        } else {
            self.latency.value_at_quantile(0.99) as f64 * 1e-6
        };
        // CiA 301 error register: bit 0 any error, bit 7 manufacturer-specific (timing).
        let any_fault = self
            .slots
            .iter()
            .any(|s| s.last_fault_state.0 != FaultState::Ok);
        let error_register = u8::from(any_fault) | if warning { 0x80 } else { 0 };
        self.live.publish_loop(
            &mut self.od,
            &LoopFigures {
                error_register,
                cycles: self.counters.cycles,
                overruns: self.counters.overruns,
                frames_malformed: self.counters.frames_malformed,
                frames_unknown: self.counters.frames_unknown,
                bus_errors: self.counters.bus_errors,
                bus_faults: self.counters.bus_faults,
                bus_lost_cycles: self.counters.bus_lost_cycles,
                cycle_latency_max_s: self.latency_max_s,
                cycle_latency_p99_s: p99,
                wake_latency_max_s: self.wake_latency_max_s,
            },
        );
    }

    /// Staged SDO writes take effect together, or not at all. Setpoints and fault resets alone
    /// apply at this boundary, in place. Parameters go to the builder
    /// ([`super::reconfigure`]), which applies them to the configuration in force, validates
    /// and builds it off this thread; a later boundary swaps the result in ([`Self::apply_built`]).
    /// Without a builder (tests, lock-step runs) the node builds here, through the same function.
    fn apply_sdo_writes(&mut self, now_s: f64, record: &mut dyn FnMut(Record)) {
        let staged = self.od.pending_writes().len();
        if staged == 0 {
            return;
        }
        if self
            .od
            .pending_writes()
            .iter()
            .all(|w| dictionary::live_effect(w).is_some())
        {
            for i in 0..staged {
                if let Some(effect) = self
                    .od
                    .pending_writes()
                    .get(i)
                    .and_then(dictionary::live_effect)
                {
                    self.apply_effect(effect, now_s, record);
                }
            }
            self.od.take_pending_writes().for_each(drop);
            record(Record::Event(Event::ParametersApplied {
                t_s: now_s,
                writes: staged as u32,
            }));
            return;
        }
        // Parameters: the configuration in force changes. The builder makes the new one off
        // this thread; until it is swapped in, the dictionary shows the one the node runs with.
        // While a build is out, new writes stay staged for the next.
        let Some(mut batch) = self.batch.take() else {
            return;
        };
        batch.clear();
        batch.extend_from_slice(self.od.pending_writes());
        self.od.discard_pending_writes();
        match &self.builder {
            Some(builder) => {
                if let Err(e) = builder.try_send(BuildInput::Writes(batch)) {
                    if let TrySendError::Full(BuildInput::Writes(batch))
                    | TrySendError::Disconnected(BuildInput::Writes(batch)) = e
                    {
                        self.batch = Some(batch);
                    }
                    record(Record::Event(Event::ParametersRefused {
                        t_s: now_s,
                        reason: "the configuration builder does not answer".into(),
                    }));
                }
            }
            None => {
                let built = Box::new(build_parameters(&self.config, batch));
                drop(self.apply_built(built, now_s, record));
            }
        }
    }

    /// Use the builder of [`super::reconfigure`] for SDO parameter writes, and hand back to it
    /// what a swap replaced.
    pub fn attach_builder(&mut self, builder: SyncSender<BuildInput>) {
        self.builder = Some(builder);
    }

    /// Swap in a build (a reload, or SDO parameter writes) at this cycle boundary, and record
    /// what happened. Allocation-free; what was replaced goes back to the builder to be dropped
    /// there (returned instead when the node has no builder).
    pub fn apply_built(
        &mut self,
        mut built: Box<Built>,
        now_s: f64,
        record: &mut dyn FnMut(Record),
    ) -> Option<Box<Built>> {
        let applied = match (built.kind, &mut built.result) {
            (BuildKind::Reload, Ok(prepared)) => self.swap_in(prepared, now_s, record).is_some(),
            (BuildKind::Reload, Err(reason)) => {
                record(Record::Event(Event::ReloadRefused {
                    t_s: now_s,
                    reason: reason.as_str().into(),
                }));
                false
            }
            (BuildKind::Parameters, Ok(prepared)) => {
                let applied = self.swap_in(prepared, now_s, &mut |_| {}).is_some();
                if applied {
                    // Setpoints and fault resets that came with the parameters, in order.
                    for i in 0..built.batch.len() {
                        if let Some(effect) = dictionary::live_effect(&built.batch[i]) {
                            self.apply_effect(effect, now_s, record);
                        }
                    }
                    record(Record::Event(Event::ParametersApplied {
                        t_s: now_s,
                        writes: built.batch.len() as u32,
                    }));
                } else {
                    record(Record::Event(Event::ParametersRefused {
                        t_s: now_s,
                        reason: "the writes change what needs a restart".into(),
                    }));
                }
                applied
            }
            (BuildKind::Parameters, Err(reason)) => {
                record(Record::Event(Event::ParametersRefused {
                    t_s: now_s,
                    reason: reason.as_str().into(),
                }));
                false
            }
        };
        if built.kind == BuildKind::Parameters {
            self.batch = Some(std::mem::take(&mut built.batch));
        }
        match &self.builder {
            Some(builder) => {
                // A full queue only drops the replaced parts here instead of on the builder.
                let _ = builder.try_send(BuildInput::Done { built, applied });
                None
            }
            None => Some(built),
        }
    }

    /// What one accepted write does at the cycle boundary, the configuration already in force.
    fn apply_effect(&mut self, effect: WriteEffect, now_s: f64, record: &mut dyn FnMut(Record)) {
        match effect {
            WriteEffect::Setpoint { axis, position } => {
                if let Some(slot) = self.slots.get_mut(axis) {
                    slot.axis.on_commanded_setpoint(position, now_s);
                }
            }
            WriteEffect::FaultReset { axis } => {
                if let Some(node) = self.axis(axis).map(|a| a.actuator_node_id) {
                    self.reset_faults(node, now_s, record);
                }
            }
            WriteEffect::Node => {
                self.heartbeat_every = cycles(self.config.node.heartbeat_period_s, self.period_s);
            }
            WriteEffect::ClearErrorField => self.error_field.clear(),
            WriteEffect::Rebuild { .. } => {}
        }
    }

    fn send_safe_commands(&mut self, send: &mut dyn FnMut(&Frame)) {
        let sync_counter = self.sync.value();
        for slot in self.slots.iter_mut() {
            let axis = &slot.axis;
            let safe = axis.safe_command();
            if let Some(link) = slot.link.as_mut() {
                link.send_command(safe, send);
                continue;
            }
            let (voltage_v, duty) = match axis.command_kind {
                CommandKind::Duty => (0.0, safe),
                _ => (safe, 0.0),
            };
            send(
                &CommandPdo {
                    voltage_v,
                    duty,
                    sync_counter,
                }
                .encode(axis.actuator_node_id),
            );
        }
    }

    /// Take a new configuration at this cycle boundary (SIGHUP). Only parameters may change:
    /// node ids, axes, commands, period and bus stay; a structural change is refused whole.
    /// Builds everything here; the daemon builds it off the cycle thread instead
    /// ([`super::reconfigure::Builder`], then [`ControllerNode::apply_built`]).
    pub fn reload(&mut self, new: Config, now_s: f64, record: &mut dyn FnMut(Record)) {
        match PreparedReload::build(new) {
            Ok(prepared) => {
                self.apply_reload(Box::new(prepared), now_s, record);
            }
            Err(reason) => record(Record::Event(Event::ReloadRefused {
                t_s: now_s,
                reason: reason.as_str().into(),
            })),
        }
    }

    /// Swap in a configuration built off the cycle thread. Axes whose configuration changed
    /// take over from the ones they replace (setpoint, command, what they learned); the rest
    /// keep running untouched. Allocation-free: what was replaced comes back in the returned
    /// box, to be dropped off the cycle thread.
    pub fn apply_reload(
        &mut self,
        mut prepared: Box<PreparedReload>,
        now_s: f64,
        record: &mut dyn FnMut(Record),
    ) -> Box<PreparedReload> {
        self.swap_in(&mut prepared, now_s, record);
        prepared
    }

    /// Exchange the node's configuration, dictionary and axes with `prepared`'s, if only
    /// parameters changed; `prepared` then holds what was replaced. Returns the number of axes
    /// rebuilt, or None (and records why) when the change needs a restart.
    fn swap_in(
        &mut self,
        prepared: &mut PreparedReload,
        now_s: f64,
        record: &mut dyn FnMut(Record),
    ) -> Option<u32> {
        let (old, new) = (&self.config, &prepared.config);
        let same_axes = old.axis.len() == new.axis.len()
            && old.axis.iter().zip(&new.axis).all(|(a, b)| {
                a.actuator_node_id == b.actuator_node_id
                    && a.command == b.command
                    && a.profile == b.profile
                    && a.cia402 == b.cia402
                    && a.cia401 == b.cia401
                    && a.eds == b.eds
            });
        if old.node.node_id != new.node.node_id
            || old.bus != new.bus
            || old.cycle.period_s != new.cycle.period_s
            || !same_axes
            || prepared.axes.len() != self.slots.len()
        {
            record(Record::Event(Event::ReloadRefused {
                t_s: now_s,
                reason: "bus, node ids, axes, commands or the period changed: that needs a restart"
                    .into(),
            }));
            return None;
        }
        let mut rebuilt = 0;
        for i in 0..self.slots.len() {
            if self.config.axis[i] != prepared.config.axis[i] {
                let axis = &mut self.slots[i].axis;
                std::mem::swap(axis, &mut prepared.axes[i]);
                axis.continue_from(&prepared.axes[i]);
                rebuilt += 1;
            }
        }
        self.heartbeat_every = cycles(prepared.config.node.heartbeat_period_s, self.period_s);
        self.status_every = cycles(prepared.config.node.status_period_s, self.period_s);
        std::mem::swap(&mut self.live, &mut prepared.live);
        std::mem::swap(&mut self.od, &mut prepared.od);
        // What was published stays readable, and writes staged meanwhile stay staged.
        self.od.carry_over_from(&mut prepared.od);
        std::mem::swap(&mut self.config, &mut prepared.config);
        self.error_field_published = None;
        record(Record::Event(Event::Reloaded {
            t_s: now_s,
            axes_rebuilt: rebuilt,
        }));
        Some(rebuilt)
    }

    /// The object dictionary, as SDO clients see it.
    pub fn dictionary(&self) -> &ObjectDictionary {
        &self.od
    }

    /// Leave operation: every axis gets its safe command once.
    pub fn shutdown(&mut self, send: &mut dyn FnMut(&Frame)) {
        for link in self.slots.iter_mut().filter_map(|s| s.link.as_mut()) {
            // Power stage off (disable voltage): the drive holds no torque once we are gone.
            link.set_target(crate::device::profile::cia402::Target::Disabled);
        }
        self.send_safe_commands(send);
        if self.slots.iter().any(|s| s.link.is_some()) {
            // Synchronous RPDOs take effect at the next SYNC: give them one.
            send(&self.sync.encode());
        }
        self.state = NmtState::Stopped;
        send(&encode_heartbeat(self.node_id, self.state));
    }

    pub fn period_s(&self) -> f64 {
        self.period_s
    }
}

fn cycle_record(
    t_s: f64,
    cycle: u64,
    node: u8,
    axis: &Axis,
    step: &AxisStep,
    timing: CycleTiming,
) -> CycleRecord {
    let (command_voltage, command_duty) = match axis.command_kind {
        CommandKind::Voltage => (step.command, 0.0),
        CommandKind::Duty => (0.0, step.command),
        _ => (0.0, 0.0),
    };
    let (command_torque, command_velocity) = match axis.command_kind {
        CommandKind::Torque => (step.command, 0.0),
        CommandKind::Velocity => (0.0, step.command),
        _ => (0.0, 0.0),
    };
    CycleRecord {
        t_s,
        cycle,
        axis_node_id: node,
        setpoint_position: step.setpoint,
        reference_position: step.reference,
        position: step.sensor.position,
        current: step.sensor.current_a,
        supply_voltage: step.sensor.supply_voltage_v,
        supply_pressure: step.supply_pressure_pa,
        command_voltage,
        command_duty,
        command_torque,
        command_velocity,
        drive_statusword: 0,
        friction_compensation: step.friction_compensation,
        following_error: step.following_error,
        fault_state: step.supervision.state.code(),
        fault_flags: step.supervision.latched.0,
        supervised_faults: step.model.machine.latched.0,
        diagnosed_fault: crate::device::diagnosed_fault_code(step.model.diagnosed_fault),
        diagnosis_confidence: step.model.confidence,
        symptoms: step.model.symptoms.map(|s| match s {
            crate::supervise::Symptom::Minus => -1,
            crate::supervise::Symptom::Zero => 0,
            crate::supervise::Symptom::Plus => 1,
        }),
        friction_compensation_pos: step.tuned.friction_compensation_pos,
        friction_compensation_neg: step.tuned.friction_compensation_neg,
        gain_schedule_factor: step.tuned.gain_schedule_factor,
        dither: step.tuned.dither,
        arrival_relief: step.arrival_relief,
        gain_down: step.tuned.gain_down_per_m,
        gain_up: step.tuned.gain_up_per_m,
        drive_gain_down: step.tuned.drive_gain_down_m_per_s,
        drive_gain_up: step.tuned.drive_gain_up_m_per_s,
        // JSON has no NaN: a direction not seen yet is recorded as 0.
        observer_x4_pos: finite_or_zero(step.tuned.observer_x4_pos),
        observer_x4_neg: finite_or_zero(step.tuned.observer_x4_neg),
        sensor_fresh: step.sensor_fresh,
        wake_latency: timing.wake_latency_s,
        // Stamped by the cycle thread once the command is out.
        cycle_latency: 0.0,
        sensor_to_command: 0.0,
        stage_ns: [0; STAGES],
    }
}

/// The EMCY of a bus fault: axis 0 (the bus itself), the cause's error code, the error
/// register's communication bit (CiA 301 bit 4), and the state the policy left the axes in.
fn bus_fault_emcy(cause: BusFault, state: FaultState) -> Emcy {
    Emcy {
        error_code: cause.emcy_code(),
        error_register: 0x11,
        axis_node_id: 0,
        state,
        ..Default::default()
    }
}

fn finite_or_zero(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}
