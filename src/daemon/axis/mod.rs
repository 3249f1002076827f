//! One axis' pipeline per cycle, in stages the node times separately:
//! scheduling (setpoint, reference, gains from the measured supply) → estimation (parameter
//! windows, diagnosis) → observer (x4 bands) → supervision (limit checks and model-based findings
//! into the fault machine) → control (controller, static correction, friction compensation,
//! dither; or the scheduled / adaptive direction P controller of a duty axis).
//! Sans-I/O: the node feeds it decoded frames and takes the command back. Everything is built in
//! [`Axis::new`]; the stages allocate nothing.

use super::config::{AxisConfig, CommandKind, SetpointStep};
mod commander;
mod estimation;
mod friction;
mod law;
mod observer;
mod schedule;
mod supervision;

use super::learned::AxisLearned;
use crate::canopen::NmtState;
use crate::control::{BandStatus, ControllerError, GainSource, LearnedTable, ParamError};
use crate::device::{
    Emcy, FaultDiagnosisPdo, FaultStatePdo, SensorPdo, TunedGainsPdo, TunedParametersPdo,
};
use crate::recording::Stage;
use crate::supervise::{
    EstimatorHealth, FaultMachineOutput, PhysicalParameters, SetpointSourceEvent,
    SetpointTimeoutSection, SetpointWatchdog, SupervisedFault, SupervisionInput, SupervisionOutput,
    Symptom, PHYSICAL_PARAMS,
};
use estimation::Estimation;
use friction::FrictionCompensation;
pub use law::ControlLaw;
use observer::Observer;
use schedule::SupplySchedule;
use supervision::{Findings, Supervision};

/// What the axis has learned or runs with this cycle (the tuned-parameter frames).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuned {
    /// `U_comp+`, `U_comp-`: learned by the adaptive friction compensation, or the feed-forward
    /// values; command unit.
    pub friction_compensation_pos: f64,
    pub friction_compensation_neg: f64,
    /// Factor on the controller gains from the supply schedule (1 without one).
    pub gain_schedule_factor: f64,
    /// Dither added this cycle, command unit.
    pub dither: f64,
    /// Direction P gains `q01`, `q02` in use (duty per m), 0 without a direction P controller.
    pub gain_down_per_m: f64,
    pub gain_up_per_m: f64,
    /// Estimated `K_I1`, `K_I2` (m/s), 0 without one.
    pub drive_gain_down_m_per_s: f64,
    pub drive_gain_up_m_per_s: f64,
    /// The gain in use comes from the estimate, not the schedule.
    pub adapted_down: bool,
    pub adapted_up: bool,
    /// Smoothed observer `x4` per direction (m), NaN until the direction has been seen.
    pub observer_x4_pos: f64,
    pub observer_x4_neg: f64,
    pub observer_learned: bool,
}

impl Default for Tuned {
    fn default() -> Self {
        Self {
            friction_compensation_pos: 0.0,
            friction_compensation_neg: 0.0,
            gain_schedule_factor: 1.0,
            dither: 0.0,
            gain_down_per_m: 0.0,
            gain_up_per_m: 0.0,
            drive_gain_down_m_per_s: 0.0,
            drive_gain_up_m_per_s: 0.0,
            adapted_down: false,
            adapted_up: false,
            observer_x4_pos: f64::NAN,
            observer_x4_neg: f64::NAN,
            observer_learned: false,
        }
    }
}

/// What the model-based supervision decided this cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelSupervision {
    pub machine: FaultMachineOutput,
    /// The latest latched supervised fault, until reset.
    pub diagnosed_fault: Option<SupervisedFault>,
    /// Its confidence: the diagnosis' `1 - distance / 6` for F1-F4, 1 for the others.
    pub confidence: f64,
    /// Symptoms of the last estimation window compared with the nominal parameters.
    pub symptoms: [Symptom; PHYSICAL_PARAMS],
    pub nominal_learned: bool,
    /// Physical parameters of the last usable estimation window.
    pub estimate: Option<PhysicalParameters>,
}

/// What one axis decided in one cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AxisStep {
    /// The command to send, in the axis' command unit.
    pub command: f64,
    pub friction_compensation: f64,
    pub setpoint: f64,
    /// What the loop tracks this cycle: the setpoint, rate-limited when so configured.
    pub reference: f64,
    pub following_error: f64,
    pub sensor: SensorPdo,
    pub supply_pressure_pa: f64,
    pub sensor_fresh: bool,
    /// Limit supervision; its `state` is the published state (limits and fault machine).
    pub supervision: SupervisionOutput,
    pub model: ModelSupervision,
    pub tuned: Tuned,
    /// The measured supply against the scheduled band (inside without one).
    pub supply_band: BandStatus,
    /// Arrival relief taken out of the controller's stored output this cycle, command unit.
    pub arrival_relief: f64,
    /// The commander went quiet (or came back) this cycle (`[axis.setpoint_timeout]`).
    pub setpoint_source: Option<SetpointSourceEvent>,
}

impl AxisStep {
    /// The fault_state frame of this step.
    pub fn fault_state(&self, axis_node_id: u8) -> FaultStatePdo {
        FaultStatePdo {
            axis_node_id,
            state: self.supervision.state,
            flags: self.supervision.latched.union(self.supervision.pending),
            diagnosed_fault: self.model.diagnosed_fault,
            following_error: self.following_error,
        }
    }

    /// The fault_diagnosis frame of this step.
    pub fn fault_diagnosis(&self, axis_node_id: u8) -> FaultDiagnosisPdo {
        FaultDiagnosisPdo {
            axis_node_id,
            confidence: self.model.confidence,
            nominal_learned: self.model.nominal_learned,
            latched: self.model.machine.latched,
            observer_learned: self.tuned.observer_learned,
            symptoms: self.model.symptoms,
            observer_x4_pos: self.tuned.observer_x4_pos,
            observer_x4_neg: self.tuned.observer_x4_neg,
        }
    }

    /// The tuned_parameters frame of this step.
    pub fn tuned_parameters(&self, axis_node_id: u8) -> TunedParametersPdo {
        TunedParametersPdo {
            axis_node_id,
            friction_compensation_v: self.friction_compensation,
            gain_schedule_factor: self.tuned.gain_schedule_factor,
            friction_compensation_pos_v: self.tuned.friction_compensation_pos,
            friction_compensation_neg_v: self.tuned.friction_compensation_neg,
        }
    }

    /// The tuned_gains frame of this step.
    pub fn tuned_gains(&self, axis_node_id: u8) -> TunedGainsPdo {
        TunedGainsPdo {
            axis_node_id,
            gain_down_per_m: self.tuned.gain_down_per_m,
            gain_up_per_m: self.tuned.gain_up_per_m,
            drive_gain_down_m_per_s: self.tuned.drive_gain_down_m_per_s,
            drive_gain_up_m_per_s: self.tuned.drive_gain_up_m_per_s,
            adapted_down: self.tuned.adapted_down,
            adapted_up: self.tuned.adapted_up,
        }
    }

    /// Adds what the supervision says after this step to an EMCY.
    pub fn emcy(&self, emcy: Emcy) -> Emcy {
        emcy.with_supervision(
            self.supervision.state,
            self.model.diagnosed_fault,
            self.model.machine.latched,
        )
    }

    /// Supervised faults latched in this cycle that get an EMCY of their own (a limit violation
    /// is announced by the limit's own EMCY).
    pub fn supervised_raised(&self) -> impl Iterator<Item = SupervisedFault> {
        self.model
            .machine
            .raised
            .iter()
            .filter(|f| *f != SupervisedFault::LimitViolation)
    }
}

/// An algorithm that cannot be built from a configuration that skipped `Config::validate`,
/// which reports the same problem with its file and key.
fn unvalidated(e: ParamError) -> ControllerError {
    ControllerError::NotFinite(e.name)
}

/// The state of one axis between cycles.
pub struct Axis {
    pub name: String,
    pub actuator_node_id: u8,
    pub command_kind: CommandKind,
    pub start_node: bool,
    safe_command: f64,
    /// The controller (linear with its correction, or the pneumatic direction P controller).
    law: ControlLaw,
    /// Friction compensation (feed-forward or adaptive), its learned table and the dither.
    friction: FrictionCompensation,
    /// Gain and command-limit factors scheduled on the supply, and its scheduled band.
    supply_schedule: SupplySchedule,
    /// The disturbance observer and its last output.
    observer: Observer,
    estimation: Option<Estimation>,
    /// Limit checks and the fault machine with what the other parts found.
    supervision: Supervision,
    travel: (f64, f64),
    setpoint: f64,
    reference: f64,
    /// Largest reference change per cycle; infinite without a rate limit.
    reference_step_max: f64,
    schedule: Vec<SetpointStep>,
    next_step: usize,
    sensor: SensorPdo,
    supply_pressure_pa: f64,
    sensor_fresh: bool,
    /// This cycle's readings arrived in time (set by `schedule`).
    fresh: bool,
    /// reference - position this cycle, m.
    error: f64,
    missing_cycles: u32,
    last_heartbeat_s: f64,
    node_state: Option<NmtState>,
    node_was_operational: bool,
    /// The error code of a CiA 402 drive in fault: the node is out of operation.
    drive_fault: Option<u16>,
    /// The node lets the axis move (a position drive is homed and in CSP); until then the
    /// reference stays where the axis stands.
    motion_enabled: bool,
    last_command: f64,
    /// An arrival relief went into the command since the set-point last changed: the
    /// estimation leaves the samples out until it changes again.
    relief_hold: bool,
    /// The watch on the commander's set-points and its reaction, when configured.
    setpoint_timeout: Option<(SetpointWatchdog, SetpointTimeoutSection)>,
    /// What the watch found this cycle.
    setpoint_source: Option<SetpointSourceEvent>,
}

impl Axis {
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        let law = ControlLaw::new(cfg, period_s)?;
        let friction = FrictionCompensation::new(cfg, period_s).map_err(unvalidated)?;
        let l = &cfg.limits;
        let schedule = SupplySchedule::new(cfg, period_s)?;
        let observer = Observer::new(cfg, period_s)?;
        let estimation = Estimation::new(cfg, period_s)?;
        let supervision = Supervision::new(cfg, period_s)?;
        Ok(Self {
            name: cfg.name.clone(),
            actuator_node_id: cfg.actuator_node_id,
            command_kind: cfg.command,
            start_node: cfg.start_node,
            safe_command: cfg.safe_command,
            law,
            friction,
            supply_schedule: schedule,
            observer,
            estimation,
            supervision,
            travel: (
                l.position_min_m.unwrap_or(f64::NEG_INFINITY),
                l.position_max_m.unwrap_or(f64::INFINITY),
            ),
            setpoint: cfg.initial_setpoint_m,
            reference: cfg.initial_setpoint_m,
            reference_step_max: cfg
                .setpoint_rate_max_m_per_s
                .map_or(f64::INFINITY, |r| r * period_s),
            schedule: cfg.setpoints.clone(),
            next_step: 0,
            sensor: SensorPdo::default(),
            supply_pressure_pa: 0.0,
            sensor_fresh: false,
            fresh: false,
            error: 0.0,
            missing_cycles: 0,
            last_heartbeat_s: 0.0,
            node_state: None,
            drive_fault: None,
            motion_enabled: true,
            node_was_operational: false,
            last_command: cfg.safe_command,
            relief_hold: false,
            setpoint_timeout: cfg
                .setpoint_timeout
                .as_ref()
                .map(|s| (SetpointWatchdog::new(s.timeout_s), s.clone())),
            setpoint_source: None,
        })
    }

    pub fn on_sensor(&mut self, sensor: SensorPdo) {
        self.sensor = sensor;
        self.sensor_fresh = true;
    }

    pub fn on_supply_pressure(&mut self, pa: f64) {
        self.supply_pressure_pa = pa;
    }

    pub fn on_heartbeat(&mut self, state: NmtState, now_s: f64) {
        self.last_heartbeat_s = now_s;
        self.node_state = Some(state);
        if state == NmtState::Operational {
            self.node_was_operational = true;
        }
    }

    /// The node's state as its last heartbeat gave it.
    pub fn node_state(&self) -> Option<NmtState> {
        self.node_state
    }

    /// The bus is back after a loss: the node's heartbeats could not reach us meanwhile, so its
    /// heartbeat timeout starts again now instead of firing on the outage itself.
    pub fn on_bus_restored(&mut self, now_s: f64) {
        self.last_heartbeat_s = self.last_heartbeat_s.max(now_s);
    }

    /// A CiA 402 drive's fault as its statusword shows it (`None`: not in fault). Supervised
    /// like a node leaving operational (`node_state`).
    pub fn set_drive_fault(&mut self, code: Option<u16>) {
        self.drive_fault = code;
    }

    pub fn drive_fault(&self) -> Option<u16> {
        self.drive_fault
    }

    /// Whether the node lets the axis move this cycle (see [`Axis::step`]).
    pub fn set_motion_enabled(&mut self, enabled: bool) {
        self.motion_enabled = enabled;
    }

    /// A new cycle: the readings held so far are from before its SYNC.
    pub fn begin_cycle(&mut self) {
        self.sensor_fresh = false;
    }

    pub fn has_fresh_sensor(&self) -> bool {
        self.sensor_fresh
    }

    /// A new setpoint, clipped to the travel so a bad frame cannot drive the axis into its stop.
    pub fn set_setpoint(&mut self, position: f64) {
        if position.is_finite() {
            let setpoint = position.clamp(self.travel.0, self.travel.1);
            if setpoint != self.setpoint {
                self.relief_hold = false;
            }
            self.setpoint = setpoint;
        }
    }

    pub fn setpoint(&self) -> f64 {
        self.setpoint
    }

    /// A freshly built axis takes over from the one it replaces (a configuration reload): the
    /// setpoint and its schedule position, the readings, the node's state and the command, so
    /// the controller goes on from the output it was giving instead of jumping to the safe one.
    /// Latched faults are kept: a reload is not a reset.
    pub fn continue_from(&mut self, old: &Axis) {
        self.setpoint = old.setpoint.clamp(self.travel.0, self.travel.1);
        self.reference = old.reference;
        self.next_step = old.next_step.min(self.schedule.len());
        self.sensor = old.sensor;
        self.supply_pressure_pa = old.supply_pressure_pa;
        self.sensor_fresh = old.sensor_fresh;
        self.missing_cycles = old.missing_cycles;
        self.last_heartbeat_s = old.last_heartbeat_s;
        self.node_state = old.node_state;
        self.drive_fault = old.drive_fault;
        self.node_was_operational = old.node_was_operational;
        self.supervision.keep_latched(&old.supervision);
        // What the axis learned is kept: a new parameter is no reason to forget the friction.
        self.restore_learned(&old.learned());
        self.friction.continue_from(&old.friction);
        if old.supervision.limits_latched().is_empty() {
            self.last_command = old.last_command;
            self.law.preset(old.last_command);
        }
    }

    /// What this axis has learned so far (the fixed-size part; see [`Axis::learned_table`]).
    pub fn learned(&self) -> AxisLearned {
        AxisLearned {
            friction_compensation: self.friction.learned(),
            observer_bands: self.observer.bands(),
            nominal: self.estimation.as_ref().and_then(Estimation::nominal),
        }
    }

    /// Start from values learned before (a state file, or the axis this one replaces). Values
    /// this axis has no algorithm for are ignored; a nominal set in the configuration wins.
    pub fn restore_learned(&mut self, learned: &AxisLearned) {
        if let Some(levels) = learned.friction_compensation {
            self.friction.restore(levels);
        }
        if let Some(bands) = learned.observer_bands {
            self.observer.restore_bands(bands);
        }
        if let (Some(e), Some(nominal)) = (self.estimation.as_mut(), learned.nominal) {
            e.restore_nominal(nominal);
        }
    }

    /// The learned table of tuned parameters by operating point, when configured.
    pub fn learned_table(&self) -> Option<&LearnedTable> {
        self.friction.learned_table()
    }

    /// Take a stored learned table; false when this axis has none or another grid.
    pub fn restore_learned_table(&mut self, table: &LearnedTable) -> bool {
        self.friction.restore_learned_table(table)
    }

    /// Clear latched faults; the controller restarts bumplessly from the safe command.
    pub fn reset_faults(&mut self) {
        self.supervision.reset();
        // The reference model restarts from where the axis rests; what was learned stays.
        self.friction.reset_model();
        self.law.preset(self.safe_command);
        self.node_was_operational = self.node_state == Some(NmtState::Operational);
        self.last_command = self.safe_command;
        // Resume from where the axis rests; with a rate limit it then ramps back to the setpoint.
        if self.reference_step_max.is_finite() {
            self.reference = self.sensor.position;
        }
    }

    /// Run one cycle at `now_s` with whatever arrived since the last one.
    pub fn step(&mut self, now_s: f64) -> AxisStep {
        self.step_marked(now_s, &mut |_| {})
    }

    /// [`Axis::step`], calling `mark` as each stage ends (the node times the stages with it):
    /// the one place that says in which order the stages run.
    pub fn step_marked(&mut self, now_s: f64, mark: &mut dyn FnMut(Stage)) -> AxisStep {
        self.schedule(now_s);
        mark(Stage::Scheduling);
        self.estimate();
        mark(Stage::Estimation);
        self.observe();
        mark(Stage::Observer);
        let supervision = self.supervise(now_s);
        mark(Stage::Supervision);
        let step = self.control(supervision);
        mark(Stage::Control);
        step
    }

    /// Stage "scheduling": setpoint schedule, reference ramp, freshness of the readings.
    pub fn schedule(&mut self, now_s: f64) {
        while let Some(s) = self.schedule.get(self.next_step) {
            if s.at_s > now_s {
                break;
            }
            let position = s.position_m;
            self.next_step += 1;
            // The commander's loss reaction holds over the schedule until it is back.
            if !self.commander_lost() {
                self.set_setpoint(position);
            }
        }
        self.watch_commander(now_s);
        self.fresh = self.sensor_fresh;
        self.sensor_fresh = false;
        self.missing_cycles = if self.fresh {
            0
        } else {
            self.missing_cycles + 1
        };
        if self.motion_enabled {
            // r(k) = r(k-1) + clamp(w - r(k-1), ±rate·T0): a ramp instead of a step, so a large
            // step does not saturate the output and kick the derivative part the wrong way.
            self.reference += (self.setpoint - self.reference)
                .clamp(-self.reference_step_max, self.reference_step_max);
        } else {
            // Not yet allowed to move (homing): the ramp starts from where the axis stands.
            self.reference = self.sensor.position;
        }
        self.error = self.reference - self.sensor.position;
        self.supply_schedule.step(
            self.sensor.supply_voltage_v,
            self.supply_pressure_pa,
            self.fresh,
        );
    }

    /// Stage "estimation": this cycle's position with the command applied during the period
    /// that led to it, into the parameter estimation windows and, on a duty axis, into the
    /// drive-gain estimators (not while the axis rests in its safe state: nothing to learn).
    pub fn estimate(&mut self) {
        if !self.fresh {
            return;
        }
        if let Some(e) = self.estimation.as_mut() {
            if self.relief_hold {
                e.exclude_disturbed();
            }
            e.step(self.sensor.position, self.last_command);
        }
        self.law
            .estimate(self.sensor.position, self.supervision.fail_safe());
    }

    /// Stage "observer": the disturbance observer with this cycle's position and the command
    /// applied during the period that led to it.
    pub fn observe(&mut self) {
        if !self.fresh {
            return;
        }
        self.observer.step(self.sensor.position, self.last_command);
    }

    /// Stage "supervision": limit checks on this cycle's readings.
    pub fn supervise(&mut self, now_s: f64) -> SupervisionOutput {
        let node_operational = (!self.node_was_operational
            || self.node_state == Some(NmtState::Operational))
            && self.drive_fault.is_none();
        let input = SupervisionInput {
            setpoint: self.reference,
            position: self.sensor.position,
            current_a: self.sensor.current_a,
            supply_voltage_v: self.sensor.supply_voltage_v,
            supply_pressure_pa: self.supply_pressure_pa,
            sensor_fresh: self.fresh,
            sensor_missing_cycles: self.missing_cycles,
            heartbeat_age_s: now_s - self.last_heartbeat_s,
            node_operational,
        };
        let p = self.law.pneumatic_step();
        let findings = Findings {
            observer_friction: self.observer.output().friction_rise,
            estimation: self.estimation.as_ref(),
            estimator_implausible: p.health_down == EstimatorHealth::Implausible
                || p.health_up == EstimatorHealth::Implausible,
            // Outside the scheduled band of the supply the loop goes on, and says so.
            off_band: self.supply_schedule.band() != BandStatus::Inside,
        };
        self.supervision.step(&input, &findings)
    }

    /// Stage "control": the command, or the safe command while the fault machine says fail-safe.
    pub fn control(&mut self, supervision: SupervisionOutput) -> AxisStep {
        let e = self.error;
        let y = self.sensor.position;
        let mut arrival_relief = 0.0;
        if self.command_kind == CommandKind::Position {
            // The drive closes the loop: its target is the reference, corrected by the
            // controller's output; fail-safe or not yet free to move, where the axis stands.
            self.last_command = if self.supervision.fail_safe()
                || self.commander_safe_command()
                || !self.motion_enabled
            {
                self.law.preset(0.0);
                y
            } else if self.fresh {
                self.reference
                    + self
                        .law
                        .command(e, y, 0.0, 0.0, self.supply_schedule.command_limit_factor())
            } else {
                self.last_command
            };
        } else if self.supervision.fail_safe() || self.commander_safe_command() {
            self.last_command = self.safe_command;
            self.friction.idle();
        } else if self.fresh {
            // Scheduled (and, when configured, adapted) direction P gains on the supply.
            if let Some(duty) = self
                .law
                .direction_p(self.reference, y, self.supply_pressure_pa)
            {
                self.last_command = duty;
                self.friction.no_compensation();
            } else {
                let e_scaled = self.supply_schedule.gain_factor() * e;
                // A drive's supply is its DC link voltage.
                let supply = match self.command_kind {
                    CommandKind::Duty => self.supply_pressure_pa,
                    _ => self.sensor.supply_voltage_v,
                };
                let (comp, dither) = self.friction.step(
                    self.reference,
                    y,
                    e,
                    supply,
                    self.supply_schedule.gain_factor(),
                );
                // R± is stored output at the nominal supply, scaled as the compensation is.
                arrival_relief = self.supply_schedule.gain_factor()
                    * self.friction.arrival_relief(self.setpoint, y);
                self.law.shift_output(arrival_relief);
                self.relief_hold |= arrival_relief != 0.0;
                self.last_command = self.law.command(
                    e_scaled,
                    y,
                    comp,
                    dither,
                    self.supply_schedule.command_limit_factor(),
                );
            }
        }
        let (comp_pos, comp_neg) = self.friction.levels();
        let (compensation, dither) = self.friction.applied();
        let p = self.law.pneumatic_step();
        let tuned = Tuned {
            friction_compensation_pos: comp_pos,
            friction_compensation_neg: comp_neg,
            gain_schedule_factor: self.supply_schedule.gain_factor(),
            dither,
            gain_down_per_m: p.gain_down_per_m,
            gain_up_per_m: p.gain_up_per_m,
            drive_gain_down_m_per_s: p.estimate_down_m_per_s,
            drive_gain_up_m_per_s: p.estimate_up_m_per_s,
            adapted_down: p.source_down == GainSource::Adapted,
            adapted_up: p.source_up == GainSource::Adapted,
            observer_x4_pos: self.observer.output().x4_pos,
            observer_x4_neg: self.observer.output().x4_neg,
            observer_learned: self.observer.output().learned,
        };
        AxisStep {
            command: self.last_command,
            friction_compensation: compensation,
            setpoint: self.setpoint,
            reference: self.reference,
            following_error: e,
            sensor: self.sensor,
            supply_pressure_pa: self.supply_pressure_pa,
            sensor_fresh: self.fresh,
            supervision,
            model: *self.supervision.model(),
            tuned,
            supply_band: self.supply_schedule.band(),
            arrival_relief,
            setpoint_source: self.setpoint_source,
        }
    }

    /// The scheduled band watches the supply pressure (else the supply voltage).
    pub fn supply_band_is_pressure(&self) -> bool {
        self.supply_schedule.band_is_pressure()
    }

    /// The command for leaving operation: the safe value.
    pub fn safe_command(&self) -> f64 {
        self.safe_command
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::config::Config;
    use crate::supervise::{FaultKind, FaultState};
    use std::path::Path;

    fn axis() -> Axis {
        let c = Config::from_toml(
            include_str!("../../../config/solenoid.toml"),
            Path::new("config/solenoid.toml"),
        )
        .expect("valid config");
        Axis::new(&c.axis[0], c.cycle.period_s).expect("valid axis")
    }

    fn sensor(position: f64) -> SensorPdo {
        SensorPdo {
            position,
            current_a: 1.0,
            supply_voltage_v: 24.0,
        }
    }

    /// Sensor readings ramping from `from` to `to` in steps of 25 µm (10 mm/s), then held
    /// there for `hold` cycles; the steps' arrival reliefs.
    fn approach(a: &mut Axis, t: &mut f64, from: f64, to: f64, hold: usize) -> Vec<f64> {
        let n = ((to - from).abs() / 25e-6).round() as usize;
        let mut reliefs = Vec::new();
        for k in 0..=n + hold {
            let y = from + (to - from) * (k.min(n) as f64 / n as f64);
            a.on_heartbeat(NmtState::Operational, *t);
            a.on_sensor(sensor(y));
            reliefs.push(a.step(*t).arrival_relief);
            *t += 0.0025;
        }
        reliefs
    }

    #[test]
    fn a_relieved_arrival_keeps_the_estimation_out_until_the_setpoint_changes() {
        // The shipped configuration relieves arrivals.
        let mut a = axis();
        let mut t = 0.0;
        // First arrival: nothing learned yet, no relief; it ends 20 µm past, which teaches R+.
        a.set_setpoint(0.005);
        let first = approach(&mut a, &mut t, 0.004, 0.00502, 60);
        assert!(first.iter().all(|&r| r == 0.0), "{first:?}");
        assert!(!a.relief_hold);
        // Second arrival upwards: relieved once, the estimation held out from then on.
        a.set_setpoint(0.006);
        let second = approach(&mut a, &mut t, 0.00502, 0.006, 20);
        let relieved: Vec<f64> = second.iter().copied().filter(|&r| r != 0.0).collect();
        assert_eq!(relieved.len(), 1, "{second:?}");
        assert!(relieved[0] < 0.0, "{relieved:?}");
        assert!(a.relief_hold);
        // The same set-point again changes nothing; a new one ends the hold.
        a.set_setpoint(0.006);
        assert!(a.relief_hold);
        a.set_setpoint(0.004);
        assert!(!a.relief_hold);
    }

    #[test]
    fn positive_error_pushes_the_command_up_and_holds_it_without_a_sensor() {
        let mut a = axis();
        a.on_heartbeat(NmtState::Operational, 0.0);
        a.on_sensor(sensor(0.004));
        let s1 = a.step(0.0025);
        assert!(s1.command > 0.0, "{s1:?}");
        assert!(s1.friction_compensation > 0.0);
        let s2 = a.step(0.005);
        assert!(!s2.sensor_fresh);
        assert_eq!(s2.command, s1.command);
    }

    #[test]
    fn a_latched_fault_commands_the_safe_value_until_reset() {
        let mut a = axis();
        a.on_heartbeat(NmtState::Operational, 0.0);
        a.on_sensor(SensorPdo {
            supply_voltage_v: 9.0,
            ..sensor(0.005)
        });
        let mut t = 0.0;
        let mut raised = None;
        for k in 0..10 {
            t += 0.0025;
            a.on_sensor(SensorPdo {
                supply_voltage_v: 9.0,
                ..sensor(0.004)
            });
            let s = a.step(t);
            if s.supervision.raised.contains(FaultKind::SupplyVoltage) {
                raised = Some(k);
            }
        }
        // supply_time_s = 10 ms at 2.5 ms: the fourth low reading latches.
        assert_eq!(raised, Some(3));
        a.on_sensor(sensor(0.004));
        let s = a.step(t + 0.0025);
        assert_eq!(s.supervision.state, FaultState::Fault);
        assert_eq!(s.command, 0.0);
        a.reset_faults();
        a.on_sensor(sensor(0.004));
        let s = a.step(t + 0.005);
        assert_eq!(s.supervision.state, FaultState::Ok);
        assert!(s.command > 0.0);
    }

    #[test]
    fn setpoints_follow_the_schedule_and_stay_in_the_travel() {
        let mut a = axis();
        assert_eq!(a.step(0.5).setpoint, 0.005);
        assert_eq!(a.step(1.0).setpoint, 0.010);
        a.set_setpoint(1.0);
        assert_eq!(a.setpoint(), 0.0255);
        a.set_setpoint(f64::NAN);
        assert_eq!(a.setpoint(), 0.0255);
    }
}
