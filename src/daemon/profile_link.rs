//! The cycle's side of a standard actuator node, sans-I/O and allocation-free per cycle: the
//! node's TPDOs (as mapped) become the axis' readings, the axis' command becomes its RPDO, and
//! for a CiA 402 drive the power state machine is driven and supervised.

use super::config::AxisConfig;
use super::profile_config::{drive_mode, ProfileKind};
use super::profile_homing::{HomingFailure, HomingSequence, HOMING_FAILED};
use crate::bus::Frame;
use crate::canopen::emcy::EMCY_FUNCTION_CODE;
use crate::canopen::EmcyFrame;
use crate::device::profile::cia401::{self, Scaling};
use crate::device::profile::cia402::{self, Mode, PowerDriver, State, Target};
use crate::device::profile::mapping::{sign_extend, to_raw_signed, Direction, Pdo};
use crate::device::SensorPdo;
use crate::supervise::DriveStop;

/// Generic error (CiA 301): a drive in fault whose EMCY was not seen.
pub const UNKNOWN_DRIVE_ERROR: u16 = 0x1000;

/// Cycles a fault reset may take before a drive still in fault counts as faulty again.
const RESET_GRACE_CYCLES: u32 = 40;

/// The layout a node runs with, as configured and checked at start-up.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeLayout {
    pub pdos: Vec<Pdo>,
    /// 6076h in N·m (N), CiA 402 only.
    pub rated_torque_nm: f64,
    /// 603Fh read at start-up: a drive already in fault names it before any EMCY is seen.
    pub error_code: u16,
    /// What configures the node again when it reboots while the daemon runs: its device type
    /// checked, then the start-up's plan ([`super::profile_setup::plan`]). Empty: the node is
    /// only started again.
    pub rejoin: Vec<super::profile_setup::SetupStep>,
}

/// What a received frame was to the link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Received {
    /// Not from this node, or not a PDO or EMCY of it.
    NotMine,
    /// Taken; the cycle's readings are not complete yet.
    Taken,
    /// The last feedback PDO of this cycle: the readings are complete.
    Complete(SensorPdo),
    /// A PDO of this node shorter than its mapping (`expected` bytes).
    Malformed { expected: usize },
}

enum Device {
    Drive {
        driver: PowerDriver,
        mode: Mode,
        position_m_per_inc: f64,
        velocity_per_unit: f64,
        dc_link_v_per_unit: f64,
        rated_torque_nm: f64,
        statusword: u16,
        /// The code of the drive's last EMCY, 0 after its reset.
        emcy_code: u16,
        reset_grace: u32,
        /// 6064h as last received, raw: a position drive's target until it may move.
        position_raw: i64,
        /// 6061h as last received.
        mode_display: i8,
        /// A position drive's homing at start-up, when configured.
        homing: Option<HomingSequence>,
        /// Controlword bit 8 goes out with "enable operation": a fault reaction's halt.
        halt: bool,
    },
    Io {
        position: (u8, Scaling),
        current: Option<(u8, Scaling)>,
        supply: Option<(u8, Scaling)>,
        command: (u8, Scaling),
    },
}

pub struct ProfileLink {
    node_id: u8,
    device: Device,
    /// The node's RPDOs that are enabled (we send them).
    rx: Vec<Pdo>,
    /// The node's TPDOs that are enabled (we receive them).
    tx: Vec<Pdo>,
    /// Bit i: TPDO i is sent on every SYNC, so a cycle waits for it.
    cyclic_mask: u32,
    got_mask: u32,
    sensor: SensorPdo,
}

impl ProfileLink {
    /// The link of `axis` with the layout its node was given; `None` for an actuatord axis.
    pub fn new(axis: &AxisConfig, layout: &NodeLayout, period_s: f64) -> Option<Self> {
        let device = match axis.profile {
            ProfileKind::Actuatord => return None,
            ProfileKind::Cia402 => {
                let d = axis.cia402.as_ref()?;
                let mut driver = PowerDriver::new();
                driver.set_target(Target::Enabled);
                Device::Drive {
                    driver,
                    mode: drive_mode(axis.command)?,
                    position_m_per_inc: d.position_m_per_inc,
                    velocity_per_unit: d.velocity_m_per_s_per_unit,
                    dc_link_v_per_unit: d.dc_link_v_per_unit,
                    rated_torque_nm: layout.rated_torque_nm,
                    statusword: 0,
                    emcy_code: layout.error_code,
                    reset_grace: 0,
                    position_raw: 0,
                    mode_display: 0,
                    homing: d
                        .homing
                        .as_ref()
                        .map(|h| HomingSequence::new(h.timeout_s, period_s, h.require_homing)),
                    halt: false,
                }
            }
            ProfileKind::Cia401 => {
                let io = axis.cia401.as_ref()?;
                Device::Io {
                    position: (io.position_input, io.position()),
                    current: io.current_input.map(|c| (c, io.current())),
                    supply: io.supply_input.map(|c| (c, io.supply())),
                    command: (io.command_output, io.command()),
                }
            }
        };
        let enabled = |d: Direction| {
            layout
                .pdos
                .iter()
                .filter(|p| p.direction == d && p.enabled && !p.objects.is_empty())
                .cloned()
                .collect::<Vec<_>>()
        };
        let tx = enabled(Direction::Transmit);
        let cyclic_mask = tx
            .iter()
            .enumerate()
            .filter(|(_, p)| p.transmission_type == 1)
            .fold(0u32, |m, (i, _)| m | (1 << i));
        Some(Self {
            node_id: axis.actuator_node_id,
            device,
            rx: enabled(Direction::Receive),
            tx,
            cyclic_mask,
            got_mask: 0,
            sensor: SensorPdo::default(),
        })
    }

    /// The identifiers of the node's PDOs that answer every SYNC.
    pub fn cyclic_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.tx
            .iter()
            .enumerate()
            .filter(|(i, _)| self.cyclic_mask & (1 << i) != 0)
            .map(|(_, p)| p.cob_id)
    }

    /// A new cycle: feedback from now on answers its SYNC.
    pub fn begin_cycle(&mut self) {
        self.got_mask = 0;
    }

    /// Take a frame; PDOs of the node update the readings, its EMCY the drive's error code.
    pub fn handle(&mut self, frame: &Frame) -> Received {
        let id = frame.id();
        if id == EMCY_FUNCTION_CODE + u32::from(self.node_id) {
            if let (Device::Drive { emcy_code, .. }, Some(emcy)) =
                (&mut self.device, EmcyFrame::decode(frame, self.node_id))
            {
                *emcy_code = emcy.error_code;
            }
            return Received::Taken;
        }
        let Some(index) = self.tx.iter().position(|p| p.cob_id == id) else {
            return Received::NotMine;
        };
        let Some(values) = self.tx[index].unpack(frame.data()) else {
            return Received::Malformed {
                expected: self.tx[index].len_bytes(),
            };
        };
        for (o, raw) in values {
            match &mut self.device {
                Device::Drive {
                    driver,
                    position_m_per_inc,
                    dc_link_v_per_unit,
                    statusword,
                    position_raw,
                    mode_display,
                    ..
                } => match o.id.index {
                    cia402::MODES_OF_OPERATION_DISPLAY => *mode_display = raw as u8 as i8,
                    cia402::STATUSWORD => {
                        *statusword = raw as u16;
                        driver.on_statusword(*statusword);
                    }
                    cia402::POSITION_ACTUAL => {
                        *position_raw = sign_extend(raw, o.bits);
                        self.sensor.position = *position_raw as f64 * *position_m_per_inc
                    }
                    cia402::DC_LINK_VOLTAGE => {
                        self.sensor.supply_voltage_v = raw as f64 * *dc_link_v_per_unit
                    }
                    _ => {}
                },
                Device::Io {
                    position,
                    current,
                    supply,
                    ..
                } => {
                    if o.id.index != cia401::ANALOG_INPUTS_16 {
                        continue;
                    }
                    let v = sign_extend(raw, o.bits) as i16;
                    if o.id.sub == position.0 {
                        self.sensor.position = position.1.to_si(v);
                    }
                    if let Some((ch, s)) = current {
                        if o.id.sub == *ch {
                            self.sensor.current_a = s.to_si(v);
                        }
                    }
                    if let Some((ch, s)) = supply {
                        if o.id.sub == *ch {
                            self.sensor.supply_voltage_v = s.to_si(v);
                        }
                    }
                }
            }
        }
        let cyclic = self.cyclic_mask;
        let complete = |m: u32| cyclic != 0 && m & cyclic == cyclic;
        let before = self.got_mask;
        self.got_mask |= 1 << index;
        // Once per cycle: a later copy of a feedback PDO is taken but not announced again.
        if complete(self.got_mask) && !complete(before) {
            return Received::Complete(self.sensor);
        }
        Received::Taken
    }

    /// The readings as last received (the supply in Pa for a duty axis' module).
    pub fn sensor(&self) -> SensorPdo {
        self.sensor
    }

    /// The drive's statusword as last received.
    pub fn statusword(&self) -> Option<u16> {
        match &self.device {
            Device::Drive { statusword, .. } => Some(*statusword),
            Device::Io { .. } => None,
        }
    }

    /// The drive's state as its statusword shows it.
    pub fn drive_state(&self) -> Option<State> {
        match &self.device {
            Device::Drive { driver, .. } => driver.state(),
            Device::Io { .. } => None,
        }
    }

    /// The error code of a drive in fault (its EMCY's, or generic when none was seen); `None`
    /// while the drive is not in fault or a reset is under way.
    pub fn drive_fault(&self) -> Option<u16> {
        match &self.device {
            Device::Drive {
                driver,
                emcy_code,
                reset_grace,
                ..
            } if driver.state().is_some_and(State::is_fault) && *reset_grace == 0 => {
                Some(if *emcy_code != 0 {
                    *emcy_code
                } else {
                    UNKNOWN_DRIVE_ERROR
                })
            }
            Device::Drive {
                homing: Some(h), ..
            } if h.fault().is_some() => Some(HOMING_FAILED),
            _ => None,
        }
    }

    /// Why the drive's homing failed, if it did (a fault of the axis when homing is required).
    pub fn homing_failure(&self) -> Option<HomingFailure> {
        match &self.device {
            Device::Drive {
                homing: Some(h), ..
            } => h.failure(),
            _ => None,
        }
    }

    /// The drive was homed (`None`: no homing configured).
    pub fn homed(&self) -> Option<bool> {
        match &self.device {
            Device::Drive {
                homing: Some(h), ..
            } => Some(h.attained()),
            _ => None,
        }
    }

    /// The axis may move: a position drive homed where homing is required and showing CSP;
    /// every other node at once.
    pub fn ready_for_motion(&self) -> bool {
        match &self.device {
            Device::Drive {
                mode: Mode::CyclicSynchronousPosition,
                homing,
                mode_display,
                ..
            } => {
                homing.is_none_or(|h| h.ready_for_motion())
                    && *mode_display == Mode::CyclicSynchronousPosition.code()
            }
            _ => true,
        }
    }

    /// The node rebooted: what the link knew of it is gone (the drive's state, its error code,
    /// its home); the power state machine and homing start again once it sends PDOs.
    pub fn rebooted(&mut self) {
        self.got_mask = 0;
        if let Device::Drive {
            driver,
            statusword,
            emcy_code,
            reset_grace,
            mode_display,
            homing,
            ..
        } = &mut self.device
        {
            let target = driver.target();
            *driver = PowerDriver::new();
            driver.set_target(target);
            *statusword = 0;
            *emcy_code = 0;
            *reset_grace = 0;
            *mode_display = 0;
            if let Some(h) = homing {
                h.restart();
            }
        }
    }

    /// The daemon's fault reset: the drive gets the fault reset edge and is brought back.
    pub fn request_fault_reset(&mut self) {
        if let Device::Drive {
            driver,
            reset_grace,
            homing,
            ..
        } = &mut self.device
        {
            if let Some(h) = homing {
                h.retry();
            }
            if driver.state().is_some_and(State::is_fault) {
                driver.request_fault_reset();
                *reset_grace = RESET_GRACE_CYCLES;
            }
        }
    }

    /// What the drive should do: enabled while the daemon runs, disabled when it leaves.
    pub fn set_target(&mut self, target: Target) {
        if let Device::Drive { driver, .. } = &mut self.device {
            driver.set_target(target);
        }
    }

    /// The stop the axis' latched faults ask of the drive, from this cycle's RPDO on: a quick
    /// stop leads the drive through "quick stop active", a halt sets bit 8; `None` brings an
    /// enabled drive back (after a fault reset). A drive being disabled stays so.
    pub fn set_stop(&mut self, stop: DriveStop) {
        if let Device::Drive { driver, halt, .. } = &mut self.device {
            match (stop, driver.target()) {
                (DriveStop::QuickStop, Target::Enabled) => driver.set_target(Target::QuickStop),
                (DriveStop::None | DriveStop::Halt, Target::QuickStop) => {
                    driver.set_target(Target::Enabled)
                }
                _ => {}
            }
            *halt = stop == DriveStop::Halt;
        }
    }

    /// This cycle's RPDOs with `command` in the axis' unit (N·m or N, m/s, V or duty).
    pub fn send_command(&mut self, command: f64, send: &mut dyn FnMut(&Frame)) {
        let io_channel = match &self.device {
            Device::Io { command, .. } => Some(command.0),
            Device::Drive { .. } => None,
        };
        let mut mode_code = 0i8;
        let (controlword, target) = match &mut self.device {
            Device::Drive {
                driver,
                mode,
                velocity_per_unit,
                position_m_per_inc,
                rated_torque_nm,
                reset_grace,
                statusword,
                position_raw,
                mode_display,
                homing,
                halt,
                ..
            } => {
                *reset_grace = reset_grace.saturating_sub(1);
                let mut cw = driver.controlword();
                // Halt rides on "enable operation" only: a drive on its way there is
                // enabled halted, one being disabled or quick-stopped is not held back.
                if *halt && cw == cia402::command::ENABLE_OPERATION {
                    cw |= cia402::control::HALT;
                }
                let enabled = driver.state() == Some(State::OperationEnabled)
                    && driver.target() == Target::Enabled;
                mode_code = mode.code();
                if let Some(h) = homing {
                    h.step(driver.state(), *statusword, *mode_display);
                    mode_code = h.mode().code();
                    if h.start_bit() && enabled {
                        cw |= cia402::control::HOMING_START;
                    }
                }
                let may_move = homing.is_none_or(|h| h.ready_for_motion())
                    && *mode_display == Mode::CyclicSynchronousPosition.code();
                let target = match mode {
                    // 607Ah in position units; where it stands until the axis may move, so
                    // neither homing nor the switch to CSP sees a step.
                    Mode::CyclicSynchronousPosition if enabled && may_move => {
                        to_raw_signed(command / *position_m_per_inc, 32)
                    }
                    Mode::CyclicSynchronousPosition => to_raw_signed(*position_raw as f64, 32),
                    // 6071h: per mille of the rated torque 6076h.
                    Mode::CyclicSynchronousTorque if *rated_torque_nm > 0.0 => {
                        to_raw_signed(command / *rated_torque_nm * 1000.0, 16)
                    }
                    Mode::CyclicSynchronousVelocity => {
                        to_raw_signed(command / *velocity_per_unit, 32)
                    }
                    _ => 0,
                };
                // Until the drive is enabled the target is 0: no torque step when it is.
                let csp = *mode == Mode::CyclicSynchronousPosition;
                (cw, if enabled || csp { target } else { 0 })
            }
            Device::Io { command: c, .. } => (0, c.1.to_raw(command) as u16 as u64),
        };
        for p in &self.rx {
            send(&p.pack(|id| match id.index {
                cia402::CONTROLWORD => u64::from(controlword),
                cia402::TARGET_TORQUE | cia402::TARGET_VELOCITY | cia402::TARGET_POSITION => target,
                cia402::MODES_OF_OPERATION => u64::from(mode_code as u8),
                cia401::ANALOG_OUTPUTS_16 if Some(id.sub) == io_channel => target,
                _ => 0,
            }));
        }
    }
}
