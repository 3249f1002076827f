//! Emergency (EMCY) frames: one when a fault is raised, one with error code 0 when faults are reset.

use super::codec::{pack, unpack, DecodeError};
use super::messages::EMCY;
use super::pdo::{
    diagnosed_fault_code, diagnosed_fault_from_code, supervised_from, supervised_values,
};
use crate::bus::BusFault;
use crate::canopen::{EmcyFrame, ErrorEntry, Frame};
use crate::supervise::{FaultFlags, FaultKind, FaultState, SupervisedFault, SupervisedFaults};

/// CiA 301 "error reset or no error".
pub const ERROR_RESET: u16 = 0x0000;
/// RPDO timeout (CiA 301 Table 21): no set-point from the commander within its timeout.
pub const SETPOINT_TIMEOUT: u16 = 0x8250;

/// The error code announced for a fault (CiA 301 / CiA 402 code ranges).
pub fn error_code(kind: FaultKind) -> u16 {
    match kind {
        FaultKind::FollowingError => 0x8611,
        FaultKind::EndOfRange => 0x8612,
        FaultKind::Overcurrent => 0x2310,
        FaultKind::SupplyVoltage => 0x3100,
        // No standard code for a pneumatic supply: manufacturer-specific range.
        FaultKind::SupplyPressure => 0xFF01,
        FaultKind::SensorTimeout => 0x8100,
        FaultKind::HeartbeatLost => 0x8130,
        FaultKind::NodeState => 0x8140,
    }
}

/// The error code announced for a latched supervised fault: manufacturer-specific range, one code
/// per fault; a limit violation is announced with the limit's own code instead.
pub fn supervised_error_code(fault: SupervisedFault) -> u16 {
    match fault {
        SupervisedFault::SpringPretension => 0xFF11,
        SupervisedFault::SpringStiffness => 0xFF12,
        SupervisedFault::FrictionIncrease => 0xFF13,
        SupervisedFault::CurrentGain => 0xFF14,
        SupervisedFault::ObserverFriction => 0xFF15,
        SupervisedFault::EstimatorImplausible => 0xFF16,
        SupervisedFault::LimitViolation => 0xFF17,
        SupervisedFault::SensorOffset => 0xFF18,
    }
}

/// The error code of a warning for a supply outside its scheduled band (the loop goes on):
/// CiA 301 "mains under-voltage" / "mains over-voltage" for a voltage, manufacturer-specific
/// for a pressure. `low` is true below the band.
pub fn supply_band_code(pressure: bool, low: bool) -> u16 {
    match (pressure, low) {
        (false, true) => 0x3120,
        (false, false) => 0x3110,
        (true, true) => 0xFF02,
        (true, false) => 0xFF03,
    }
}

impl Emcy {
    /// The EMCY warning that the supply left its scheduled band while `flags` are active.
    pub fn supply_band(axis_node_id: u8, pressure: bool, low: bool, flags: FaultFlags) -> Self {
        Self {
            error_code: supply_band_code(pressure, low),
            // Generic error, plus "voltage" (bit 2) for a voltage supply.
            error_register: error_register(flags) | if pressure { 0x01 } else { 0x05 },
            axis_node_id,
            flags,
            ..Default::default()
        }
    }
}

/// What the pre-defined error field (1003h) keeps of an EMCY `controller_node` sent: its error
/// code, and as additional information its error register (bits 16..23 of the entry) and axis
/// node id (bits 24..31; 0 for the daemon itself or its bus). An "error reset" is no error and
/// is not kept; nor is any other frame.
pub fn error_field_entry(frame: &Frame, controller_node: u8, time_s: f64) -> Option<ErrorEntry> {
    let e = EmcyFrame::decode(frame, controller_node)?;
    (e.error_code != ERROR_RESET).then_some(ErrorEntry {
        error_code: e.error_code,
        additional_info: u16::from_le_bytes([e.error_register, e.manufacturer[0]]),
        time_s,
    })
}

/// What an error code the daemon sends means: the fault, diagnosis, watchdog or bus fault it
/// announces (the axis node id tells a bus fault, axis 0, from an axis' fault of the same
/// code), else the CiA 301 class of the code (a drive's own code, 603Fh).
pub fn error_code_meaning(code: u16, axis_node_id: u8) -> String {
    const BUS_FAULTS: [BusFault; 9] = [
        BusFault::Overflow,
        BusFault::ErrorPassive,
        BusFault::BusOff,
        BusFault::InterfaceDown,
        BusFault::InterfaceGone,
        BusFault::TransmitQueueFull,
        BusFault::ErrorWarning,
        BusFault::NoAcknowledge,
        BusFault::Io(0),
    ];
    if axis_node_id == 0 {
        if let Some(f) = BUS_FAULTS.iter().find(|f| f.emcy_code() == code) {
            return format!("bus fault: {}", f.name());
        }
    }
    if let Some(k) = FaultKind::ALL.iter().find(|k| error_code(**k) == code) {
        return format!("fault: {}", k.name());
    }
    if let Some(f) = SupervisedFault::ALL
        .iter()
        .find(|f| supervised_error_code(**f) == code)
    {
        return format!("diagnosis: {}", f.name());
    }
    if code == SETPOINT_TIMEOUT {
        return "set-point timeout: no set-point from the commander".into();
    }
    for (pressure, low) in [(false, true), (false, false), (true, true), (true, false)] {
        if supply_band_code(pressure, low) == code {
            return format!(
                "warning: supply {} {} its scheduled band",
                if pressure { "pressure" } else { "voltage" },
                if low { "below" } else { "above" }
            );
        }
    }
    let class = match code >> 8 {
        0x00 => "error reset or no error",
        0x10 => "generic error",
        0x20..=0x2F => "current",
        0x30..=0x3F => "voltage",
        0x40..=0x4F => "temperature",
        0x50..=0x5F => "device hardware",
        0x60..=0x6F => "device software",
        0x70..=0x7F => "additional modules",
        0x80..=0x8F => "monitoring",
        0x90..=0x9F => "external error",
        0xF0..=0xFE => "additional functions",
        _ => "device specific",
    };
    format!("CiA 301 class: {class}")
}

/// CiA 301 error register (object 1001h) bits for a set of faults.
pub fn error_register(flags: FaultFlags) -> u8 {
    if flags.is_empty() {
        return 0;
    }
    let mut reg = 0x01; // generic error
    for kind in flags.iter() {
        reg |= match kind {
            FaultKind::Overcurrent => 0x02,
            FaultKind::SupplyVoltage => 0x04,
            FaultKind::HeartbeatLost | FaultKind::SensorTimeout | FaultKind::NodeState => 0x10,
            FaultKind::FollowingError | FaultKind::EndOfRange | FaultKind::SupplyPressure => 0x80,
        };
    }
    reg
}

/// One EMCY frame of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Emcy {
    pub error_code: u16,
    pub error_register: u8,
    pub axis_node_id: u8,
    /// Every fault active on the axis when the frame was sent.
    pub flags: FaultFlags,
    /// The axis' fault state after the event.
    pub state: FaultState,
    /// The latest latched supervised fault after the event.
    pub diagnosed_fault: Option<SupervisedFault>,
    /// Latched supervised faults after the event.
    pub supervised: SupervisedFaults,
}

impl Emcy {
    /// The EMCY for a newly raised fault `kind` while `flags` are active.
    pub fn raised(axis_node_id: u8, kind: FaultKind, flags: FaultFlags) -> Self {
        Self {
            error_code: error_code(kind),
            error_register: error_register(flags),
            axis_node_id,
            flags,
            ..Default::default()
        }
    }

    /// The EMCY for a newly latched supervised fault (a model-based diagnosis or the observer).
    pub fn supervised(axis_node_id: u8, fault: SupervisedFault, flags: FaultFlags) -> Self {
        Self {
            error_code: supervised_error_code(fault),
            // Generic error, plus "manufacturer specific" (bit 7) for the model-based findings.
            error_register: error_register(flags) | 0x81,
            axis_node_id,
            flags,
            ..Default::default()
        }
    }

    /// The same EMCY with the supervision's state after the event.
    pub fn with_supervision(
        mut self,
        state: FaultState,
        diagnosed_fault: Option<SupervisedFault>,
        supervised: SupervisedFaults,
    ) -> Self {
        self.state = state;
        self.diagnosed_fault = diagnosed_fault;
        self.supervised = supervised;
        self
    }

    /// The EMCY "error reset" for one cause gone while others remain (CiA 301: the remaining
    /// errors stay in the error register): `flags` are the limit faults still active,
    /// `supervised` whether a model-based finding is still latched.
    pub fn reset_leaving(axis_node_id: u8, flags: FaultFlags, supervised: bool) -> Self {
        Self {
            error_code: ERROR_RESET,
            error_register: error_register(flags) | if supervised { 0x81 } else { 0 },
            axis_node_id,
            flags,
            ..Default::default()
        }
    }

    /// The EMCY for an axis whose commander went quiet (`[axis.setpoint_timeout]`): CiA 301's
    /// "RPDO timeout" (the set-point frame is the controller's RPDO1), in the communication bit
    /// of the error register, with the faults active besides.
    pub fn setpoint_timeout(axis_node_id: u8, flags: FaultFlags) -> Self {
        Self {
            error_code: SETPOINT_TIMEOUT,
            error_register: error_register(flags) | 0x11,
            axis_node_id,
            flags,
            ..Default::default()
        }
    }

    /// The EMCY announcing that an axis' faults were reset.
    pub fn reset(axis_node_id: u8) -> Self {
        Self {
            error_code: ERROR_RESET,
            error_register: 0,
            axis_node_id,
            ..Default::default()
        }
    }

    pub fn encode(&self, controller_node: u8) -> Frame {
        let mut values = [0.0; 20];
        values[0] = f64::from(self.error_code);
        values[1] = f64::from(self.error_register);
        values[2] = f64::from(self.axis_node_id);
        for (slot, kind) in values[3..11].iter_mut().zip(FaultKind::ALL) {
            *slot = if self.flags.contains(kind) { 1.0 } else { 0.0 };
        }
        values[11] = f64::from(self.state.code());
        values[12] = f64::from(diagnosed_fault_code(self.diagnosed_fault));
        values[13..].copy_from_slice(&supervised_values(self.supervised));
        pack(&EMCY, controller_node, &values).0
    }

    pub fn decode(frame: &Frame) -> Result<Self, DecodeError> {
        let v: [f64; 20] = unpack(&EMCY, frame)?;
        let mut flags = FaultFlags::default();
        for (value, kind) in v[3..11].iter().zip(FaultKind::ALL) {
            if *value != 0.0 {
                flags.insert(kind);
            }
        }
        let bad = |signal: &'static str, value: f64| DecodeError::BadValue {
            name: EMCY.name,
            id: frame.id(),
            signal,
            value: value as i64,
        };
        Ok(Self {
            error_code: v[0] as u16,
            error_register: v[1] as u8,
            axis_node_id: v[2] as u8,
            flags,
            state: FaultState::from_code(v[11] as u8).ok_or_else(|| bad("fault_state", v[11]))?,
            diagnosed_fault: diagnosed_fault_from_code(v[12] as u8)
                .ok_or_else(|| bad("diagnosed_fault", v[12]))?,
            supervised: supervised_from(&v[13..20]),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raised_emcy_names_the_fault_and_round_trips() {
        let mut flags = FaultFlags::default();
        flags.insert(FaultKind::SupplyVoltage);
        let e = Emcy::raised(0x10, FaultKind::SupplyVoltage, flags);
        let f = e.encode(1);
        assert_eq!(f.id(), 0x81);
        assert_eq!(&f.data()[..2], &[0x00, 0x31]);
        assert_eq!(e.error_register, 0x05);
        assert_eq!(Emcy::decode(&f), Ok(e));
        assert_eq!(
            Emcy::decode(&Emcy::reset(0x10).encode(1)).map(|e| e.error_code),
            Ok(0)
        );
    }

    #[test]
    fn supervised_emcy_carries_state_and_diagnosis() {
        let mut latched = SupervisedFaults::default();
        latched.insert(SupervisedFault::SpringStiffness);
        let e = Emcy::supervised(
            0x10,
            SupervisedFault::SpringStiffness,
            FaultFlags::default(),
        )
        .with_supervision(
            FaultState::MaintenanceRequested,
            Some(SupervisedFault::SpringStiffness),
            latched,
        );
        let d = Emcy::decode(&e.encode(1)).expect("decodes");
        assert_eq!(d, e);
        assert_eq!(d.error_code, 0xFF12);
        let mut codes: Vec<_> = SupervisedFault::ALL
            .iter()
            .map(|f| supervised_error_code(*f))
            .chain(FaultKind::ALL.iter().map(|k| error_code(*k)))
            .collect();
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(
            codes.len(),
            SupervisedFault::ALL.len() + FaultKind::ALL.len()
        );
    }

    #[test]
    fn every_fault_has_its_own_code() {
        let mut codes: Vec<_> = FaultKind::ALL.iter().map(|k| error_code(*k)).collect();
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), FaultKind::ALL.len());
    }
}
