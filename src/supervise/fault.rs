//! Fault kinds, the set of active faults, and the axis fault state.

/// A fault the supervision can raise. The names are the protocol's signal names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FaultKind {
    FollowingError,
    EndOfRange,
    Overcurrent,
    SupplyVoltage,
    SupplyPressure,
    SensorTimeout,
    HeartbeatLost,
    NodeState,
}

impl FaultKind {
    /// Bit order of the fault flags on the bus.
    pub const ALL: [FaultKind; 8] = [
        FaultKind::FollowingError,
        FaultKind::EndOfRange,
        FaultKind::Overcurrent,
        FaultKind::SupplyVoltage,
        FaultKind::SupplyPressure,
        FaultKind::SensorTimeout,
        FaultKind::HeartbeatLost,
        FaultKind::NodeState,
    ];

    pub fn bit(self) -> u16 {
        1 << (self as u16)
    }

    pub fn name(self) -> &'static str {
        match self {
            FaultKind::FollowingError => "following_error",
            FaultKind::EndOfRange => "end_of_range",
            FaultKind::Overcurrent => "overcurrent",
            FaultKind::SupplyVoltage => "supply_voltage",
            FaultKind::SupplyPressure => "supply_pressure",
            FaultKind::SensorTimeout => "sensor_timeout",
            FaultKind::HeartbeatLost => "heartbeat_lost",
            FaultKind::NodeState => "node_state",
        }
    }
}

impl std::fmt::Display for FaultKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of faults, one bit per [`FaultKind`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct FaultFlags(pub u16);

impl FaultFlags {
    pub fn contains(self, kind: FaultKind) -> bool {
        self.0 & kind.bit() != 0
    }

    pub fn insert(&mut self, kind: FaultKind) {
        self.0 |= kind.bit();
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    pub fn union(self, other: FaultFlags) -> FaultFlags {
        FaultFlags(self.0 | other.0)
    }

    /// Faults in `self` that are not in `before`.
    pub fn added_since(self, before: FaultFlags) -> FaultFlags {
        FaultFlags(self.0 & !before.0)
    }

    pub fn iter(self) -> impl Iterator<Item = FaultKind> {
        FaultKind::ALL
            .into_iter()
            .filter(move |k| self.contains(*k))
    }
}

impl std::fmt::Display for FaultFlags {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_empty() {
            return f.write_str("none");
        }
        for (i, k) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            f.write_str(k.name())?;
        }
        Ok(())
    }
}

/// The axis fault state published on the bus. The codes keep their first meaning (2 is still
/// "axis in its safe state") so older decoders stay right; 3 was added with the fault machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FaultState {
    /// All limits respected, nothing latched.
    #[default]
    Ok,
    /// A limit is exceeded but not yet for its persistence time, or a fault whose reaction is
    /// "warning" is latched.
    Warning,
    /// Fail-safe: a fault with that reaction is latched, the axis is in its safe state until a reset.
    Fault,
    /// A fault whose reaction is "maintenance_requested" is latched; the axis keeps working.
    MaintenanceRequested,
}

impl FaultState {
    pub fn code(self) -> u8 {
        match self {
            FaultState::Ok => 0,
            FaultState::Warning => 1,
            FaultState::Fault => 2,
            FaultState::MaintenanceRequested => 3,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(FaultState::Ok),
            1 => Some(FaultState::Warning),
            2 => Some(FaultState::Fault),
            3 => Some(FaultState::MaintenanceRequested),
            _ => None,
        }
    }

    /// The name in the DBC value table and the configuration's reactions.
    pub fn name(self) -> &'static str {
        match self {
            FaultState::Ok => "ok",
            FaultState::Warning => "warning",
            FaultState::Fault => "fail_safe",
            FaultState::MaintenanceRequested => "maintenance_requested",
        }
    }

    /// Severity order: ok < warning < maintenance_requested < fail_safe.
    pub fn severity(self) -> u8 {
        match self {
            FaultState::Ok => 0,
            FaultState::Warning => 1,
            FaultState::MaintenanceRequested => 2,
            FaultState::Fault => 3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_name_their_faults_in_bit_order() {
        let mut f = FaultFlags::default();
        f.insert(FaultKind::SensorTimeout);
        f.insert(FaultKind::FollowingError);
        assert_eq!(f.to_string(), "following_error,sensor_timeout");
        assert_eq!(f.0, 0b10_0001);
        let before = FaultFlags(FaultKind::FollowingError.bit());
        assert_eq!(f.added_since(before).to_string(), "sensor_timeout");
    }
}
