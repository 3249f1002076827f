//! Start-up of a standard actuator node, before the cycle runs (it blocks on SDO answers, so
//! never on the cycle thread): wait for the node, check its device type, put it in
//! pre-operational, give it the PDO layout the axis needs over SDO and read every parameter
//! back, or take the layout from the node's EDS and check the node has it; give it the
//! daemon's heartbeat to watch (1016h) and, for a drive, what to do when it stops (6007h);
//! for a drive, set and check the mode of operation and read the rated torque.
//!
//! The writes and read-backs are one plan ([`SetupStep`]s), made from the configuration before
//! the node is asked anything: run here at start-up, and kept in the [`NodeLayout`] for the
//! cycle to run again, without blocking, when the node reboots
//! ([`super::profile_rejoin::Rejoin`]).

use super::config::AxisConfig;
use super::node_sections::NodeConfig;
use super::profile_config::{desired_pdos, drive_mode, Cia402Section, HomingSection, ProfileKind};
use super::profile_link::NodeLayout;
use crate::bus::{Bus, BusError, BusEvent};
use crate::canopen::heartbeat::{encode_consumer_entry, CONSUMER_HEARTBEAT_TIME};
use crate::canopen::od::ObjectId;
use crate::canopen::sdo::{AbortCode, SdoClient, SdoError, SdoOutcome};
use crate::canopen::NmtCommand;
use crate::device::profile::cia401;
use crate::device::profile::cia402;
use crate::device::profile::eds::pdos_from_eds;
use crate::device::profile::mapping::{Direction, Pdo};
use std::time::{Duration, Instant};

/// SDO answer timeout for each transfer once the node has answered once.
const SDO_TIMEOUT: Duration = Duration::from_millis(500);

/// Why a node could not be set up; each names the axis, the node and the object at fault.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    #[error("axis {axis}: node {node} did not answer SDO (1000h) within {timeout_s} s: is it powered and on the bus?")]
    NoAnswer {
        axis: String,
        node: u8,
        timeout_s: f64,
    },
    #[error(
        "axis {axis}: node {node} has device type 0x{device_type:08X}, not a CiA {profile} device"
    )]
    WrongDevice {
        axis: String,
        node: u8,
        device_type: u32,
        profile: u16,
    },
    #[error("axis {axis}: node {node} refused {object} ({what}): SDO abort {code}")]
    Refused {
        axis: String,
        node: u8,
        object: ObjectId,
        what: String,
        code: AbortCode,
    },
    #[error(
        "axis {axis}: node {node} reads 0x{got:X} at {object} ({what}), expected 0x{expected:X}"
    )]
    Mismatch {
        axis: String,
        node: u8,
        object: ObjectId,
        what: String,
        expected: u32,
        got: u32,
    },
    #[error("axis {axis}: {reason}")]
    Layout { axis: String, reason: String },
    #[error("axis {axis}: bus: {source}")]
    Bus {
        axis: String,
        #[source]
        source: BusError,
    },
}

/// One step of a node's configuration over SDO: a value written, or a value read back and
/// compared under a mask. Every value the daemon configures fits an expedited transfer.
#[derive(Debug, Clone, PartialEq)]
pub struct SetupStep {
    pub id: ObjectId,
    pub action: StepAction,
    /// What the object is, for messages ("TPDO1 (1800h/1A00h) COB-ID").
    pub what: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepAction {
    /// Write the first `len` bytes (1 to 4, little-endian).
    Write { bytes: [u8; 4], len: u8 },
    /// Read and compare: `got & mask == expected & mask`.
    Check { expected: u32, mask: u32 },
}

impl SetupStep {
    /// Write `bytes` (at most 4: longer values are not configured by the daemon).
    pub fn write(id: ObjectId, bytes: &[u8], what: impl Into<String>) -> Self {
        let mut b = [0u8; 4];
        let len = bytes.len().min(4);
        b[..len].copy_from_slice(&bytes[..len]);
        Self {
            id,
            action: StepAction::Write {
                bytes: b,
                len: len as u8,
            },
            what: what.into(),
        }
    }

    /// Read `id` back and compare it with `expected` under `mask`.
    pub fn check(id: ObjectId, expected: u32, mask: u32, what: impl Into<String>) -> Self {
        Self {
            id,
            action: StepAction::Check { expected, mask },
            what: what.into(),
        }
    }

    /// A value written and then read back whole (`expected` under `mask`).
    fn write_checked(
        id: ObjectId,
        bytes: &[u8],
        expected: u32,
        mask: u32,
        what: &str,
    ) -> [Self; 2] {
        [
            Self::write(id, bytes, what),
            Self::check(id, expected, mask, what),
        ]
    }
}

/// One SDO transfer on `bus`, answered or timed out.
fn transfer(
    bus: &mut dyn Bus,
    client: &mut SdoClient,
    first: crate::bus::Frame,
) -> Result<SdoOutcome, BusError> {
    let start = Instant::now();
    bus.send(&first)?;
    loop {
        if let Some(outcome) = client.outcome() {
            return Ok(outcome.clone());
        }
        if let Some(f) = client.poll(start.elapsed().as_secs_f64()) {
            bus.send(&f)?;
            continue;
        }
        if let Some(BusEvent::Frame(frame)) =
            bus.recv_until(Instant::now() + Duration::from_millis(10))?
        {
            if let Some(next) = client.handle(&frame, start.elapsed().as_secs_f64()) {
                bus.send(&next)?;
            }
        }
    }
}

struct Session<'a> {
    bus: &'a mut dyn Bus,
    axis: String,
    node: u8,
}

impl Session<'_> {
    fn bus_error(&self, source: BusError) -> SetupError {
        SetupError::Bus {
            axis: self.axis.clone(),
            source,
        }
    }

    fn read(&mut self, id: ObjectId, what: &str) -> Result<u32, SetupError> {
        let mut c = SdoClient::new(self.node).with_timeout(SDO_TIMEOUT.as_secs_f64());
        let first = c.start_upload(id, 0.0);
        let outcome = transfer(self.bus, &mut c, first).map_err(|e| self.bus_error(e))?;
        match outcome {
            Ok(bytes) => {
                let mut b = [0u8; 4];
                let n = bytes.len().min(4);
                b[..n].copy_from_slice(&bytes[..n]);
                Ok(u32::from_le_bytes(b))
            }
            Err(e) => Err(self.refused(id, what, e)),
        }
    }

    fn write(&mut self, id: ObjectId, bytes: &[u8], what: &str) -> Result<(), SetupError> {
        let mut c = SdoClient::new(self.node).with_timeout(SDO_TIMEOUT.as_secs_f64());
        let first = c.start_download(id, bytes, 0.0);
        let outcome = transfer(self.bus, &mut c, first).map_err(|e| self.bus_error(e))?;
        outcome.map(drop).map_err(|e| self.refused(id, what, e))
    }

    fn refused(&self, object: ObjectId, what: &str, e: SdoError) -> SetupError {
        SetupError::Refused {
            axis: self.axis.clone(),
            node: self.node,
            object,
            what: what.to_string(),
            code: e.code(),
        }
    }

    fn check(
        &mut self,
        id: ObjectId,
        what: &str,
        expected: u32,
        mask: u32,
    ) -> Result<(), SetupError> {
        let got = self.read(id, what)?;
        if got & mask != expected & mask {
            return Err(SetupError::Mismatch {
                axis: self.axis.clone(),
                node: self.node,
                object: id,
                what: what.to_string(),
                expected,
                got,
            });
        }
        Ok(())
    }

    /// Run `steps` in order; the first refusal or mismatch ends the setup.
    fn run(&mut self, steps: &[SetupStep]) -> Result<(), SetupError> {
        for step in steps {
            match step.action {
                StepAction::Write { bytes, len } => {
                    self.write(step.id, &bytes[..usize::from(len)], &step.what)?
                }
                StepAction::Check { expected, mask } => {
                    self.check(step.id, &step.what, expected, mask)?
                }
            }
        }
        Ok(())
    }

    /// Ask for the device type until the node answers or `timeout` passes (it may still be
    /// booting).
    fn wait_for_node(&mut self, timeout: Duration) -> Result<u32, SetupError> {
        let start = Instant::now();
        loop {
            match self.read(ObjectId::new(0x1000, 0), "device type") {
                Ok(v) => return Ok(v),
                Err(SetupError::Refused { code, .. })
                    if code == AbortCode::TIMEOUT && start.elapsed() < timeout => {}
                Err(SetupError::Refused { code, .. }) if code == AbortCode::TIMEOUT => {
                    return Err(SetupError::NoAnswer {
                        axis: self.axis.clone(),
                        node: self.node,
                        timeout_s: timeout.as_secs_f64(),
                    })
                }
                Err(e) => return Err(e),
            }
        }
    }
}

/// What a PDO parameter is, for messages: "TPDO1 (1800h/1A00h) mapping entry 2".
fn what(pdo: &Pdo, id: ObjectId) -> String {
    let part = if id.index == pdo.communication_index() {
        match id.sub {
            1 => "COB-ID".to_string(),
            2 => "transmission type".to_string(),
            s => format!("sub {s}"),
        }
    } else {
        match id.sub {
            0 => "number of mapped objects".to_string(),
            s => format!("mapping entry {s}"),
        }
    };
    format!("{} {part}", pdo.label())
}

/// The objects a layout must carry for the axis, with where.
fn required(axis: &AxisConfig) -> Vec<(Direction, ObjectId)> {
    match axis.profile {
        ProfileKind::Actuatord => vec![],
        ProfileKind::Cia402 => {
            let target = match drive_mode(axis.command) {
                Some(cia402::Mode::CyclicSynchronousVelocity) => cia402::TARGET_VELOCITY,
                Some(cia402::Mode::CyclicSynchronousPosition) => cia402::TARGET_POSITION,
                _ => cia402::TARGET_TORQUE,
            };
            vec![
                (Direction::Receive, ObjectId::new(cia402::CONTROLWORD, 0)),
                (Direction::Receive, ObjectId::new(target, 0)),
                (Direction::Transmit, ObjectId::new(cia402::STATUSWORD, 0)),
                (
                    Direction::Transmit,
                    ObjectId::new(cia402::POSITION_ACTUAL, 0),
                ),
            ]
        }
        ProfileKind::Cia401 => {
            let Some(io) = &axis.cia401 else {
                return vec![];
            };
            let mut r = vec![
                (
                    Direction::Receive,
                    ObjectId::new(cia401::ANALOG_OUTPUTS_16, io.command_output),
                ),
                (
                    Direction::Transmit,
                    ObjectId::new(cia401::ANALOG_INPUTS_16, io.position_input),
                ),
            ];
            for ch in [io.current_input, io.supply_input].into_iter().flatten() {
                r.push((
                    Direction::Transmit,
                    ObjectId::new(cia401::ANALOG_INPUTS_16, ch),
                ));
            }
            r
        }
    }
}

/// The layout the axis' node will run with: from its EDS when the configuration names one,
/// else the daemon's own ([`desired_pdos`]). Checks that it carries what the axis needs, on
/// SYNC-driven feedback PDOs.
pub fn planned_layout(axis: &AxisConfig) -> Result<Vec<Pdo>, SetupError> {
    let layout_error = |reason: String| SetupError::Layout {
        axis: axis.name.clone(),
        reason,
    };
    let pdos = match &axis.eds {
        Some(file) => {
            let text = std::fs::read_to_string(file)
                .map_err(|e| layout_error(format!("{}: {e}", file.display())))?;
            pdos_from_eds(&text, axis.actuator_node_id)
                .map_err(|e| layout_error(format!("{}: {e}", file.display())))?
        }
        None => desired_pdos(axis),
    };
    let source = axis
        .eds
        .as_ref()
        .map_or("the daemon's layout".to_string(), |f| {
            f.display().to_string()
        });
    for (direction, id) in required(axis) {
        let found = pdos.iter().find(|p| {
            p.direction == direction && p.enabled && p.objects.iter().any(|o| o.id == id)
        });
        match found {
            None => {
                return Err(layout_error(format!(
                    "{source}: no enabled {} maps {id}",
                    direction.name()
                )))
            }
            Some(p) if direction == Direction::Transmit && p.transmission_type != 1 => {
                return Err(layout_error(format!(
                    "{source}: {} maps {id} with transmission type {}; the cycle needs it on every SYNC (type 1)",
                    p.label(),
                    p.transmission_type
                )))
            }
            Some(_) => {}
        }
    }
    Ok(pdos)
}

/// A homing object's write: index, sub, bytes, the value read back and its mask, its name.
type HomingWrite = (u16, u8, Vec<u8>, u32, u32, &'static str);

/// The homing objects in the drive's units, each read back.
fn homing_steps(
    axis: &str,
    d: &Cia402Section,
    h: &HomingSection,
) -> Result<Vec<SetupStep>, SetupError> {
    let velocity = d.velocity_m_per_s_per_unit;
    let acceleration = d.acceleration_m_per_s2_per_unit.unwrap_or(velocity);
    let out_of_range = |key: &str, value: f64| SetupError::Layout {
        axis: axis.to_string(),
        reason: format!(
            "{}.{}.{key} = {value} does not fit the drive's object in its units",
            crate::param_key!(AxisConfig, cia402),
            crate::param_key!(Cia402Section, homing),
        ),
    };
    // Each value in the drive's units: SI over the unit, rounded.
    let unsigned = |key: &str, value: f64, unit: f64| {
        let raw = (value / unit).round();
        if (0.0..=f64::from(u32::MAX)).contains(&raw) {
            Ok(raw as u32)
        } else {
            Err(out_of_range(key, value))
        }
    };
    let speed_switch = unsigned("speed_switch_m_per_s", h.speed_switch_m_per_s, velocity)?;
    let speed_zero = unsigned("speed_zero_m_per_s", h.speed_zero_m_per_s, velocity)?;
    let acceleration = unsigned(
        "acceleration_m_per_s2",
        h.acceleration_m_per_s2,
        acceleration,
    )?;
    let offset = (h.offset_m / d.position_m_per_inc).round();
    if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&offset) {
        return Err(out_of_range("offset_m", h.offset_m));
    }
    let method = h.method as i8;
    let writes: [HomingWrite; 5] = [
        (
            cia402::HOMING_METHOD,
            0,
            method.to_le_bytes().to_vec(),
            method as u8 as u32,
            0xFF,
            "homing method",
        ),
        (
            cia402::HOMING_SPEEDS,
            1,
            speed_switch.to_le_bytes().to_vec(),
            speed_switch,
            u32::MAX,
            "homing speed during search for switch",
        ),
        (
            cia402::HOMING_SPEEDS,
            2,
            speed_zero.to_le_bytes().to_vec(),
            speed_zero,
            u32::MAX,
            "homing speed during search for zero",
        ),
        (
            cia402::HOMING_ACCELERATION,
            0,
            acceleration.to_le_bytes().to_vec(),
            acceleration,
            u32::MAX,
            "homing acceleration",
        ),
        (
            cia402::HOME_OFFSET,
            0,
            (offset as i32).to_le_bytes().to_vec(),
            offset as i32 as u32,
            u32::MAX,
            "home offset",
        ),
    ];
    Ok(writes
        .into_iter()
        .flat_map(|(index, sub, bytes, expected, mask, what)| {
            SetupStep::write_checked(ObjectId::new(index, sub), &bytes, expected, mask, what)
        })
        .collect())
}

/// How the drive stops, each as configured and read back: the quick stop option code 605Ah,
/// the quick stop deceleration 6085h and the profile deceleration 6084h (the halt's ramp), in
/// the drive's acceleration units. Objects left out of the configuration are not touched.
fn stop_steps(axis: &str, d: &Cia402Section) -> Result<Vec<SetupStep>, SetupError> {
    let unit = d
        .acceleration_m_per_s2_per_unit
        .unwrap_or(d.velocity_m_per_s_per_unit);
    let mut steps = Vec::new();
    if let Some(code) = d.quick_stop_option_code {
        let code = code as i16;
        steps.extend(SetupStep::write_checked(
            ObjectId::new(cia402::QUICK_STOP_OPTION, 0),
            &code.to_le_bytes(),
            code as u16 as u32,
            0xFFFF,
            "quick stop option code",
        ));
    }
    for (index, key, value, what) in [
        (
            cia402::QUICK_STOP_DECELERATION,
            crate::param_key!(Cia402Section, quick_stop_deceleration_m_per_s2),
            d.quick_stop_deceleration_m_per_s2,
            "quick stop deceleration",
        ),
        (
            cia402::PROFILE_DECELERATION,
            crate::param_key!(Cia402Section, profile_deceleration_m_per_s2),
            d.profile_deceleration_m_per_s2,
            "profile deceleration",
        ),
    ] {
        let Some(value) = value else { continue };
        // In the drive's units: SI over the unit, rounded.
        let raw = (value / unit).round();
        if !(1.0..=f64::from(u32::MAX)).contains(&raw) {
            return Err(SetupError::Layout {
                axis: axis.to_string(),
                reason: format!(
                    "{}.{key} = {value} does not fit {index:04X}h in the drive's units ({unit} m/s² each)",
                    crate::param_key!(AxisConfig, cia402),
                ),
            });
        }
        let raw = raw as u32;
        steps.extend(SetupStep::write_checked(
            ObjectId::new(index, 0),
            &raw.to_le_bytes(),
            raw,
            u32::MAX,
            what,
        ));
    }
    Ok(steps)
}

/// The consumer heartbeat time a standard node watches the daemon with, ms: the daemon's
/// heartbeat period plus the configured margin; an error names the keys when 1016h's 16 bits
/// cannot hold it.
pub fn consumer_heartbeat_ms(node: &NodeConfig) -> Result<u16, String> {
    // t_consumer = T_heartbeat + margin, in 1016h's ms.
    let ms = ((node.heartbeat_period_s + node.heartbeat_consumer_margin_s) * 1e3).round();
    if (1.0..=f64::from(u16::MAX)).contains(&ms) {
        Ok(ms as u16)
    } else {
        Err(format!(
            "[{node_key}] {period} + {margin} = {ms} ms does not fit the consumer heartbeat \
             time 1016h (1..=65535 ms)",
            node_key = crate::param_key!(super::config::Config, node),
            period = crate::param_key!(NodeConfig, heartbeat_period_s),
            margin = crate::param_key!(NodeConfig, heartbeat_consumer_margin_s),
        ))
    }
}

/// The node watches the daemon's heartbeat (1016h sub 1, CiA 301) and a drive is told what to
/// do when it stops (6007h, CiA 402); each written and read back.
fn watchdog_steps(node: &NodeConfig, axis: &AxisConfig) -> Result<Vec<SetupStep>, SetupError> {
    let time_ms = consumer_heartbeat_ms(node).map_err(|reason| SetupError::Layout {
        axis: axis.name.clone(),
        reason,
    })?;
    let entry = encode_consumer_entry(node.node_id, time_ms);
    let mut steps = SetupStep::write_checked(
        ObjectId::new(CONSUMER_HEARTBEAT_TIME, 1),
        &entry.to_le_bytes(),
        entry,
        u32::MAX,
        "consumer heartbeat time of the daemon's heartbeat",
    )
    .to_vec();
    if let (ProfileKind::Cia402, Some(d)) = (axis.profile, &axis.cia402) {
        let code = d.abort_connection_option.code();
        steps.extend(SetupStep::write_checked(
            ObjectId::new(cia402::ABORT_CONNECTION_OPTION, 0),
            &code.to_le_bytes(),
            code as u16 as u32,
            0xFFFF,
            "abort connection option code",
        ));
    }
    Ok(steps)
}

/// Every SDO write and read-back that configures the node of `axis` for `pdos`, in order: the
/// PDO layout (unless the node has it from its EDS), the watchdogs, and for a drive homing
/// and the mode of operation. Made from the configuration alone, before the node is asked.
pub fn plan(
    node: &NodeConfig,
    axis: &AxisConfig,
    pdos: &[Pdo],
) -> Result<Vec<SetupStep>, SetupError> {
    let mut steps = Vec::new();
    if axis.eds.is_none() {
        for pdo in pdos {
            for w in pdo.configuration_writes() {
                steps.push(SetupStep::write(w.id, &w.bytes(), what(pdo, w.id)));
            }
        }
    }
    for pdo in pdos {
        for (id, expected, mask) in pdo.expected_reads() {
            steps.push(SetupStep::check(id, expected, mask, what(pdo, id)));
        }
    }
    steps.extend(watchdog_steps(node, axis)?);
    if let (ProfileKind::Cia402, Some(d)) = (axis.profile, &axis.cia402) {
        steps.extend(stop_steps(&axis.name, d)?);
        let mut mode = drive_mode(axis.command).map_or(0, |m| m.code());
        if let Some(h) = &d.homing {
            steps.extend(homing_steps(&axis.name, d, h)?);
            mode = cia402::Mode::Homing.code();
        }
        steps.push(SetupStep::write(
            ObjectId::new(cia402::MODES_OF_OPERATION, 0),
            &mode.to_le_bytes(),
            "modes of operation",
        ));
        steps.push(SetupStep::check(
            ObjectId::new(cia402::MODES_OF_OPERATION_DISPLAY, 0),
            mode as u8 as u32,
            0xFF,
            "modes of operation display",
        ));
    }
    Ok(steps)
}

/// Set up the standard node of `axis` on `bus`, whose master is the daemon's `node` (see the
/// module documentation).
pub fn configure(
    bus: &mut dyn Bus,
    node: &NodeConfig,
    axis: &AxisConfig,
) -> Result<NodeLayout, SetupError> {
    let (profile, timeout_s) = match axis.profile {
        ProfileKind::Actuatord => {
            return Ok(NodeLayout {
                pdos: vec![],
                rated_torque_nm: 0.0,
                error_code: 0,
                rejoin: vec![],
            })
        }
        ProfileKind::Cia402 => (
            402u16,
            axis.cia402.as_ref().map_or(5.0, |d| d.startup_timeout_s),
        ),
        ProfileKind::Cia401 => (
            401u16,
            axis.cia401.as_ref().map_or(5.0, |d| d.startup_timeout_s),
        ),
    };
    let pdos = planned_layout(axis)?;
    let steps = plan(node, axis, &pdos)?;
    let mut s = Session {
        bus,
        axis: axis.name.clone(),
        node: axis.actuator_node_id,
    };
    let device_type = s.wait_for_node(Duration::from_secs_f64(timeout_s))?;
    if device_type & 0xFFFF != u32::from(profile) {
        return Err(SetupError::WrongDevice {
            axis: s.axis.clone(),
            node: s.node,
            device_type,
            profile,
        });
    }
    // CiA 302: a slave is configured in pre-operational, where its PDOs are silent.
    let pre_op = NmtCommand::EnterPreOperational.encode(s.node);
    s.bus.send(&pre_op).map_err(|e| s.bus_error(e))?;
    s.run(&steps)?;
    let mut rated_torque_nm = 0.0;
    let mut error_code = 0;
    if let (ProfileKind::Cia402, Some(d)) = (axis.profile, &axis.cia402) {
        rated_torque_nm = match d.rated_torque_nm {
            Some(t) => t,
            None => {
                let mnm = s.read(ObjectId::new(cia402::RATED_TORQUE, 0), "motor rated torque")?;
                if mnm == 0 {
                    return Err(SetupError::Layout {
                        axis: s.axis.clone(),
                        reason: format!(
                            "node {} reports a rated torque (6076h) of 0: set {}.{}",
                            s.node,
                            crate::param_key!(AxisConfig, cia402),
                            crate::param_key!(Cia402Section, rated_torque_nm)
                        ),
                    });
                }
                f64::from(mnm) * 1e-3
            }
        };
        // A drive that is in fault already announced it before we listened.
        error_code = s.read(ObjectId::new(cia402::ERROR_CODE, 0), "error code")? as u16;
    }
    // A node that reboots while the daemon runs is first asked what it is, then set up again.
    let mut rejoin = vec![SetupStep::check(
        ObjectId::new(0x1000, 0),
        u32::from(profile),
        0xFFFF,
        "device type",
    )];
    rejoin.extend(steps);
    Ok(NodeLayout {
        pdos,
        rated_torque_nm,
        error_code,
        rejoin,
    })
}
