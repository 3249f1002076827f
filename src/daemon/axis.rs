//! One axis' pipeline per cycle: setpoint → controller + friction compensation → supervision
//! → command. Sans-I/O: the node feeds it decoded frames and takes the command back.

use super::config::{cycles, AxisConfig, CommandKind, SetpointStep};
use crate::canopen::{NmtState, SensorPdo};
use crate::control::{ControllerError, DiscreteController, FrictionFeedForward};
use crate::supervise::{Band, LimitSupervisor, Limits, SupervisionInput, SupervisionOutput};

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
    pub supervision: SupervisionOutput,
}

/// The state of one axis between cycles.
pub struct Axis {
    pub name: String,
    pub actuator_node_id: u8,
    pub command_kind: CommandKind,
    pub start_node: bool,
    safe_command: f64,
    controller: DiscreteController,
    friction: Option<FrictionFeedForward>,
    supervisor: LimitSupervisor,
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
    last_command: f64,
    last_compensation: f64,
}

impl Axis {
    pub fn new(cfg: &AxisConfig, period_s: f64) -> Result<Self, ControllerError> {
        let c = &cfg.controller;
        let mut controller = DiscreteController::new(&c.p, &c.q_per_m, c.output_min, c.output_max)?;
        controller.preset(cfg.safe_command);
        let friction = cfg.friction_compensation.as_ref().map(|f| {
            FrictionFeedForward::from_forces(
                f.alpha,
                f.coulomb_pos_n,
                f.coulomb_neg_n,
                f.force_gain_n_per_command,
                f.deadband_m,
            )
        });
        let l = &cfg.limits;
        let band = |lo: Option<f64>, hi: Option<f64>, time_s: f64| {
            if lo.is_none() && hi.is_none() {
                return None;
            }
            Some(Band {
                low: lo.unwrap_or(f64::NEG_INFINITY),
                high: hi.unwrap_or(f64::INFINITY),
                persistence_cycles: cycles(time_s, period_s),
            })
        };
        let limits = Limits {
            following_error: l.following_error_m.map(|e| Band {
                low: -e,
                high: e,
                persistence_cycles: cycles(l.following_error_time_s, period_s),
            }),
            // End of range trips at once: a reading outside the travel is a broken sensor or a crash.
            position: band(l.position_min_m, l.position_max_m, period_s),
            current_a: l.current_max_a.map(|i| Band {
                low: -i,
                high: i,
                persistence_cycles: cycles(l.current_time_s, period_s),
            }),
            supply_voltage_v: band(
                l.supply_voltage_min_v,
                l.supply_voltage_max_v,
                l.supply_time_s,
            ),
            supply_pressure_pa: band(
                l.supply_pressure_min_pa,
                l.supply_pressure_max_pa,
                l.supply_time_s,
            ),
            sensor_timeout_cycles: cycles(l.sensor_timeout_s, period_s),
            heartbeat_timeout_s: l.heartbeat_timeout_s,
        };
        Ok(Self {
            name: cfg.name.clone(),
            actuator_node_id: cfg.actuator_node_id,
            command_kind: cfg.command,
            start_node: cfg.start_node,
            safe_command: cfg.safe_command,
            controller,
            friction,
            supervisor: LimitSupervisor::new(limits),
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
            node_was_operational: false,
            last_command: cfg.safe_command,
            last_compensation: 0.0,
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
            self.setpoint = position.clamp(self.travel.0, self.travel.1);
        }
    }

    pub fn setpoint(&self) -> f64 {
        self.setpoint
    }

    /// Clear latched faults; the controller restarts bumplessly from the safe command.
    pub fn reset_faults(&mut self) {
        self.supervisor.reset();
        self.controller.preset(self.safe_command);
        self.node_was_operational = self.node_state == Some(NmtState::Operational);
        self.last_command = self.safe_command;
        // Resume from where the axis rests; with a rate limit it then ramps back to the setpoint.
        if self.reference_step_max.is_finite() {
            self.reference = self.sensor.position;
        }
    }

    /// Run one cycle at `now_s` with whatever arrived since the last one.
    pub fn step(&mut self, now_s: f64) -> AxisStep {
        self.schedule(now_s);
        let supervision = self.supervise(now_s);
        self.control(supervision)
    }

    /// Stage "scheduling": setpoint schedule, reference ramp, freshness of the readings.
    pub fn schedule(&mut self, now_s: f64) {
        while let Some(s) = self.schedule.get(self.next_step) {
            if s.at_s > now_s {
                break;
            }
            let position = s.position_m;
            self.next_step += 1;
            self.set_setpoint(position);
        }
        self.fresh = self.sensor_fresh;
        self.sensor_fresh = false;
        self.missing_cycles = if self.fresh {
            0
        } else {
            self.missing_cycles + 1
        };
        // r(k) = r(k-1) + clamp(w - r(k-1), ±rate·T0): a ramp instead of a step, so a large step
        // does not saturate the output and kick the derivative part the wrong way.
        self.reference += (self.setpoint - self.reference)
            .clamp(-self.reference_step_max, self.reference_step_max);
        self.error = self.reference - self.sensor.position;
    }

    /// Stage "supervision": limit checks on this cycle's readings.
    pub fn supervise(&mut self, now_s: f64) -> SupervisionOutput {
        let node_operational =
            !self.node_was_operational || self.node_state == Some(NmtState::Operational);
        self.supervisor.step(&SupervisionInput {
            setpoint: self.reference,
            position: self.sensor.position,
            current_a: self.sensor.current_a,
            supply_voltage_v: self.sensor.supply_voltage_v,
            supply_pressure_pa: self.supply_pressure_pa,
            sensor_fresh: self.fresh,
            sensor_missing_cycles: self.missing_cycles,
            heartbeat_age_s: now_s - self.last_heartbeat_s,
            node_operational,
        })
    }

    /// Stage "control": the command, or the safe command while a fault is latched.
    pub fn control(&mut self, supervision: SupervisionOutput) -> AxisStep {
        let e = self.error;
        if !supervision.latched.is_empty() {
            self.last_command = self.safe_command;
            self.last_compensation = 0.0;
        } else if self.fresh {
            let comp = self.friction.map_or(0.0, |f| f.compensation(e));
            let (lo, hi) = self.controller.limits();
            let u = (self.controller.propose(e) + comp).clamp(lo, hi);
            // The controller's own share of what was applied: feeding it back is the anti-windup.
            self.controller.commit(e, u - comp);
            self.last_command = u;
            self.last_compensation = comp;
        }
        AxisStep {
            command: self.last_command,
            friction_compensation: self.last_compensation,
            setpoint: self.setpoint,
            reference: self.reference,
            following_error: e,
            sensor: self.sensor,
            supply_pressure_pa: self.supply_pressure_pa,
            sensor_fresh: self.fresh,
            supervision,
        }
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
            include_str!("../../config/solenoid.toml"),
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
