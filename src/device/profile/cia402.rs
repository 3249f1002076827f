//! CiA 402 (IEC 61800-7-201) drives: object numbers, the power drive system state machine as the
//! drive runs it ([`DriveStateMachine`]), and the controlling side that leads a drive to
//! "operation enabled", resets its faults and stops it ([`PowerDriver`]). Sans-I/O.

/// Error code of the last fault (UNSIGNED16, CiA 402 §6.4.1, same codes as EMCY).
pub const ERROR_CODE: u16 = 0x603F;
/// Controlword (UNSIGNED16).
pub const CONTROLWORD: u16 = 0x6040;
/// Statusword (UNSIGNED16).
pub const STATUSWORD: u16 = 0x6041;
/// Quick stop option code (INTEGER16).
pub const QUICK_STOP_OPTION: u16 = 0x605A;
/// Profile deceleration (UNSIGNED32, acceleration units): the ramp of a halt, and of quick stop
/// option codes 1 and 5.
pub const PROFILE_DECELERATION: u16 = 0x6084;
/// Quick stop deceleration (UNSIGNED32, acceleration units): the ramp of quick stop option
/// codes 2 and 6.
pub const QUICK_STOP_DECELERATION: u16 = 0x6085;
/// Abort connection option code (INTEGER16, CiA 402 §6.3.1): what the drive does when its
/// connection to the master is lost (a heartbeat event, bus-off): [`abort_connection`].
pub const ABORT_CONNECTION_OPTION: u16 = 0x6007;
/// Modes of operation (INTEGER8).
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// Modes of operation display (INTEGER8).
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// Position actual value (INTEGER32, position units).
pub const POSITION_ACTUAL: u16 = 0x6064;
/// Velocity actual value (INTEGER32, velocity units).
pub const VELOCITY_ACTUAL: u16 = 0x606C;
/// Target position (INTEGER32, position units): the set-point of CSP, every SYNC.
pub const TARGET_POSITION: u16 = 0x607A;
/// Home offset (INTEGER32, position units): the application's zero lies this far beyond the
/// home point, so the home point reads minus the offset once homing is attained.
pub const HOME_OFFSET: u16 = 0x607C;
/// Homing method (INTEGER8).
pub const HOMING_METHOD: u16 = 0x6098;
/// Homing speeds (record of UNSIGNED32, velocity units): sub 1 during the search for the
/// switch, sub 2 during the search for zero (the switch edge or the index pulse).
pub const HOMING_SPEEDS: u16 = 0x6099;
/// Homing acceleration (UNSIGNED32, acceleration units).
pub const HOMING_ACCELERATION: u16 = 0x609A;
/// Target torque (INTEGER16, per thousand of the rated torque).
pub const TARGET_TORQUE: u16 = 0x6071;
/// Max torque (UNSIGNED16, per thousand of the rated torque).
pub const MAX_TORQUE: u16 = 0x6072;
/// Motor rated torque (UNSIGNED32, mN·m; mN for a linear motor's force).
pub const RATED_TORQUE: u16 = 0x6076;
/// Torque actual value (INTEGER16, per thousand of the rated torque).
pub const TORQUE_ACTUAL: u16 = 0x6077;
/// DC link circuit voltage (UNSIGNED32, mV).
pub const DC_LINK_VOLTAGE: u16 = 0x6079;
/// Target velocity (INTEGER32, velocity units).
pub const TARGET_VELOCITY: u16 = 0x60FF;
/// Supported drive modes (UNSIGNED32, bit n-1 for mode n).
pub const SUPPORTED_DRIVE_MODES: u16 = 0x6502;
/// Device type 1000h of a drive: profile 402 in the low 16 bits (servo drive: 0x0002 above).
pub const DEVICE_TYPE: u32 = 0x0002_0192;

/// Modes of operation (6060h) used here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Homing: the drive finds its home point by 6098h's method on controlword bit 4.
    Homing = 6,
    /// Cyclic synchronous position: 607Ah every SYNC, the drive closes the position loop.
    CyclicSynchronousPosition = 8,
    /// Cyclic synchronous velocity: 60FFh every SYNC.
    CyclicSynchronousVelocity = 9,
    /// Cyclic synchronous torque: 6071h every SYNC.
    CyclicSynchronousTorque = 10,
}

impl Mode {
    pub fn code(self) -> i8 {
        self as i8
    }

    pub fn from_code(code: i8) -> Option<Self> {
        match code {
            6 => Some(Mode::Homing),
            8 => Some(Mode::CyclicSynchronousPosition),
            9 => Some(Mode::CyclicSynchronousVelocity),
            10 => Some(Mode::CyclicSynchronousTorque),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Mode::Homing => "homing",
            Mode::CyclicSynchronousPosition => "CSP",
            Mode::CyclicSynchronousVelocity => "CSV",
            Mode::CyclicSynchronousTorque => "CST",
        }
    }
}

/// The states of the power drive system state machine (CiA 402 §6.2, Figure 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum State {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
}

/// Statusword bits (CiA 402 Table 6).
pub mod status {
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    pub const SWITCHED_ON: u16 = 1 << 1;
    pub const OPERATION_ENABLED: u16 = 1 << 2;
    pub const FAULT: u16 = 1 << 3;
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Active low: 0 while a quick stop is in progress.
    pub const QUICK_STOP: u16 = 1 << 5;
    pub const SWITCH_ON_DISABLED: u16 = 1 << 6;
    pub const WARNING: u16 = 1 << 7;
    pub const REMOTE: u16 = 1 << 9;
    pub const TARGET_REACHED: u16 = 1 << 10;
    pub const INTERNAL_LIMIT_ACTIVE: u16 = 1 << 11;
    /// Homing mode: homing attained. CSP: the drive follows the target position.
    pub const HOMING_ATTAINED: u16 = 1 << 12;
    /// Homing mode: homing error.
    pub const HOMING_ERROR: u16 = 1 << 13;
}

/// Values of the abort connection option code 6007h (CiA 402 §6.3.1).
pub mod abort_connection {
    pub const NO_ACTION: i16 = 0;
    /// Fault signal: the drive goes to "fault reaction active", then "fault".
    pub const FAULT: i16 = 1;
    /// The device control command "disable voltage": the power stage off at once.
    pub const DISABLE_VOLTAGE: i16 = 2;
    /// The device control command "quick stop": stop on the quick stop ramp as 605Ah says.
    pub const QUICK_STOP: i16 = 3;
}

/// Controlword bits (CiA 402 Table 4).
pub mod control {
    pub const SWITCH_ON: u16 = 1 << 0;
    pub const ENABLE_VOLTAGE: u16 = 1 << 1;
    /// Active low: 0 commands a quick stop.
    pub const QUICK_STOP: u16 = 1 << 2;
    pub const ENABLE_OPERATION: u16 = 1 << 3;
    /// A rising edge resets a fault.
    pub const FAULT_RESET: u16 = 1 << 7;
    pub const HALT: u16 = 1 << 8;
    /// Homing mode: a rising edge starts homing, a falling edge interrupts it.
    pub const HOMING_START: u16 = 1 << 4;
}

/// The device control commands (CiA 402 Table 5), as controlword values.
pub mod command {
    /// Transitions 2, 6, 8.
    pub const SHUTDOWN: u16 = 0x0006;
    /// Transition 3 (and "disable operation", transition 5).
    pub const SWITCH_ON: u16 = 0x0007;
    /// Transitions 4 and 16; from "ready to switch on" 3 then 4.
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Transitions 7, 9, 10, 12.
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Transitions 7, 10, 11.
    pub const QUICK_STOP: u16 = 0x0002;
    /// Transition 15, on the rising edge of bit 7.
    pub const FAULT_RESET: u16 = 0x0080;
}

impl State {
    /// The state a statusword shows (CiA 402 Table 7); `None` for a combination the standard
    /// does not define.
    pub fn from_statusword(sw: u16) -> Option<Self> {
        Some(match (sw & 0x4F, sw & 0x6F) {
            (0x00, _) => State::NotReadyToSwitchOn,
            (0x40, _) => State::SwitchOnDisabled,
            (0x0F, _) => State::FaultReactionActive,
            (0x08, _) => State::Fault,
            (_, 0x21) => State::ReadyToSwitchOn,
            (_, 0x23) => State::SwitchedOn,
            (_, 0x27) => State::OperationEnabled,
            (_, 0x07) => State::QuickStopActive,
            _ => return None,
        })
    }

    /// The state bits of the statusword (bits 0, 1, 2, 3, 5, 6), as Table 7 gives them.
    pub fn statusword_bits(self) -> u16 {
        match self {
            State::NotReadyToSwitchOn => 0x00,
            State::SwitchOnDisabled => 0x40,
            State::ReadyToSwitchOn => 0x21,
            State::SwitchedOn => 0x23,
            State::OperationEnabled => 0x27,
            State::QuickStopActive => 0x07,
            State::FaultReactionActive => 0x0F,
            State::Fault => 0x08,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            State::NotReadyToSwitchOn => "not_ready_to_switch_on",
            State::SwitchOnDisabled => "switch_on_disabled",
            State::ReadyToSwitchOn => "ready_to_switch_on",
            State::SwitchedOn => "switched_on",
            State::OperationEnabled => "operation_enabled",
            State::QuickStopActive => "quick_stop_active",
            State::FaultReactionActive => "fault_reaction_active",
            State::Fault => "fault",
        }
    }

    /// The power stage drives the motor (torque may be applied).
    pub fn is_enabled(self) -> bool {
        matches!(self, State::OperationEnabled)
    }

    pub fn is_fault(self) -> bool {
        matches!(self, State::Fault | State::FaultReactionActive)
    }
}

/// A controlword decoded to its device control command (CiA 402 Table 5), without the fault
/// reset edge, which needs the previous word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    Shutdown,
    SwitchOn,
    SwitchOnEnableOperation,
    DisableVoltage,
    QuickStop,
}

impl Command {
    /// Bits 3..0: disable voltage when bit 1 is 0; quick stop when bit 2 is 0; shutdown when
    /// bit 0 is 0; switch on (= disable operation) when bit 3 is 0; else enable operation.
    pub fn decode(cw: u16) -> Self {
        if cw & control::ENABLE_VOLTAGE == 0 {
            Command::DisableVoltage
        } else if cw & control::QUICK_STOP == 0 {
            Command::QuickStop
        } else if cw & control::SWITCH_ON == 0 {
            Command::Shutdown
        } else if cw & control::ENABLE_OPERATION == 0 {
            Command::SwitchOn
        } else {
            Command::SwitchOnEnableOperation
        }
    }
}

/// The drive's state machine (CiA 402 §6.2, Figure 4 and Table 3): the controlword moves it,
/// a fault moves it to "fault reaction active" and then "fault".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveStateMachine {
    state: State,
    last_controlword: u16,
    /// Quick stop option code 605Ah: 0..=4 end in "switch on disabled" (transition 12), 5..=8
    /// stay in "quick stop active" until enabled again (transition 16) or disabled.
    quick_stop_option: i16,
    error_code: u16,
}

impl Default for DriveStateMachine {
    fn default() -> Self {
        Self::new()
    }
}

impl DriveStateMachine {
    /// Power on (transition 0): "not ready to switch on" until [`Self::initialised`].
    pub fn new() -> Self {
        Self {
            state: State::NotReadyToSwitchOn,
            last_controlword: 0,
            quick_stop_option: 2,
            error_code: 0,
        }
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// 603Fh: the code of the fault that is or was last active, 0 after a reset.
    pub fn error_code(&self) -> u16 {
        self.error_code
    }

    pub fn set_quick_stop_option(&mut self, option: i16) {
        self.quick_stop_option = option;
    }

    /// The controlword last received.
    pub fn last_controlword(&self) -> u16 {
        self.last_controlword
    }

    /// Transition 1: self-test and initialisation done.
    pub fn initialised(&mut self) {
        if self.state == State::NotReadyToSwitchOn {
            self.state = State::SwitchOnDisabled;
        }
    }

    /// The statusword for the present state; `remote` is bit 9 (controlled over the bus).
    pub fn statusword(&self) -> u16 {
        let mut sw = self.state.statusword_bits() | status::REMOTE;
        if matches!(
            self.state,
            State::ReadyToSwitchOn
                | State::SwitchedOn
                | State::OperationEnabled
                | State::QuickStopActive
                | State::FaultReactionActive
        ) {
            sw |= status::VOLTAGE_ENABLED;
        }
        sw
    }

    /// A fault in the drive (transition 13, from any state): the fault reaction runs, then the
    /// drive rests in "fault" ([`Self::tick`]). A second fault keeps the first code.
    pub fn fault(&mut self, error_code: u16) {
        if !self.state.is_fault() {
            self.error_code = error_code;
        }
        self.state = State::FaultReactionActive;
    }

    /// Automatic transitions of a drive without motion to wait for: [`Self::step`] at
    /// standstill.
    pub fn tick(&mut self) {
        self.step(true);
    }

    /// Automatic transitions, once per drive cycle: 14 (fault reaction done) and 12 (quick stop
    /// done: option code 0 at once, 1..=4 once the axis stands still).
    pub fn step(&mut self, standstill: bool) {
        match self.state {
            State::FaultReactionActive => self.state = State::Fault,
            State::QuickStopActive
                if self.quick_stop_option == 0
                    || ((1..=4).contains(&self.quick_stop_option) && standstill) =>
            {
                self.state = State::SwitchOnDisabled
            }
            _ => {}
        }
    }

    /// Quick stop option code 605Ah as last set.
    pub fn quick_stop_option(&self) -> i16 {
        self.quick_stop_option
    }

    /// A controlword received (SDO or RPDO). Returns the transition number taken, if any.
    pub fn on_controlword(&mut self, cw: u16) -> Option<u8> {
        let reset_edge =
            cw & control::FAULT_RESET != 0 && self.last_controlword & control::FAULT_RESET == 0;
        self.last_controlword = cw;
        use State as S;
        let (next, transition) = match (self.state, Command::decode(cw)) {
            (S::Fault, _) if reset_edge => (S::SwitchOnDisabled, 15),
            (S::Fault | S::FaultReactionActive | S::NotReadyToSwitchOn, _) => return None,
            // Bit 7 set without an edge: the other bits are ignored while it is high.
            _ if cw & control::FAULT_RESET != 0 => return None,
            (S::SwitchOnDisabled, Command::Shutdown) => (S::ReadyToSwitchOn, 2),
            (S::ReadyToSwitchOn, Command::SwitchOn) => (S::SwitchedOn, 3),
            // 3 and 4 in one step, as Table 5 allows.
            (S::ReadyToSwitchOn, Command::SwitchOnEnableOperation) => (S::OperationEnabled, 4),
            (S::SwitchedOn, Command::SwitchOnEnableOperation) => (S::OperationEnabled, 4),
            (S::OperationEnabled, Command::SwitchOn) => (S::SwitchedOn, 5),
            (S::SwitchedOn, Command::Shutdown) => (S::ReadyToSwitchOn, 6),
            (S::ReadyToSwitchOn, Command::DisableVoltage | Command::QuickStop) => {
                (S::SwitchOnDisabled, 7)
            }
            (S::OperationEnabled, Command::Shutdown) => (S::ReadyToSwitchOn, 8),
            (S::OperationEnabled, Command::DisableVoltage) => (S::SwitchOnDisabled, 9),
            (S::SwitchedOn, Command::DisableVoltage | Command::QuickStop) => {
                (S::SwitchOnDisabled, 10)
            }
            (S::OperationEnabled, Command::QuickStop) => (S::QuickStopActive, 11),
            (S::QuickStopActive, Command::DisableVoltage) => (S::SwitchOnDisabled, 12),
            (S::QuickStopActive, Command::SwitchOnEnableOperation)
                if (5..=8).contains(&self.quick_stop_option) =>
            {
                (S::OperationEnabled, 16)
            }
            _ => return None,
        };
        if transition == 15 {
            self.error_code = 0;
        }
        self.state = next;
        Some(transition)
    }
}

/// What the controlling side wants from a drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// Torque off, power stage disabled ("switch on disabled").
    Disabled,
    /// "Operation enabled".
    Enabled,
    /// Stop with the drive's quick stop ramp, then stay disabled.
    QuickStop,
}

/// Cycles bit 7 stays high after its rising edge while the drive still shows "fault": a drive
/// whose statusword answers a cycle or two late must not see the bit fall before it has reset.
/// After that the bit drops for a cycle, so a fault that would not clear gets a fresh edge.
const FAULT_RESET_HOLD_CYCLES: u8 = 4;

/// The controlling side of the state machine: from each statusword, the controlword that moves
/// the drive one transition toward the target; a fault is reset only when asked, with a rising
/// edge of bit 7 after a cycle with bit 7 low.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PowerDriver {
    target: Target,
    reset_requested: bool,
    last_controlword: u16,
    /// Cycles bit 7 is still held high after its edge.
    reset_hold: u8,
    state: Option<State>,
}

impl Default for PowerDriver {
    fn default() -> Self {
        Self::new()
    }
}

impl PowerDriver {
    pub fn new() -> Self {
        Self {
            target: Target::Disabled,
            reset_requested: false,
            last_controlword: command::DISABLE_VOLTAGE,
            reset_hold: 0,
            state: None,
        }
    }

    pub fn set_target(&mut self, target: Target) {
        self.target = target;
    }

    pub fn target(&self) -> Target {
        self.target
    }

    /// Ask for a fault reset: sent on the next cycles while the drive shows "fault".
    pub fn request_fault_reset(&mut self) {
        self.reset_requested = true;
    }

    /// The drive state last seen.
    pub fn state(&self) -> Option<State> {
        self.state
    }

    /// Take a statusword (from the drive's TPDO).
    pub fn on_statusword(&mut self, sw: u16) {
        self.state = State::from_statusword(sw);
        if self.state.is_some_and(|s| !s.is_fault()) {
            // A drive out of fault needs no more resets (one may have come from elsewhere).
            self.reset_requested = false;
        }
    }

    /// The controlword for this cycle.
    pub fn controlword(&mut self) -> u16 {
        use State as S;
        let cw = match (self.state, self.target) {
            (None | Some(S::NotReadyToSwitchOn | S::FaultReactionActive), _) => {
                command::DISABLE_VOLTAGE
            }
            (Some(S::Fault), _) => {
                // Bit 7 low for a cycle, then high: the edge the drive resets on, held high
                // while the drive's answer may still be on its way.
                let high = self.last_controlword & control::FAULT_RESET != 0;
                if self.reset_requested && !high {
                    self.reset_hold = FAULT_RESET_HOLD_CYCLES;
                    command::FAULT_RESET
                } else if self.reset_requested && self.reset_hold > 0 {
                    self.reset_hold -= 1;
                    command::FAULT_RESET
                } else {
                    command::DISABLE_VOLTAGE
                }
            }
            (Some(S::OperationEnabled), Target::QuickStop) => command::QUICK_STOP,
            (Some(S::QuickStopActive), Target::QuickStop) => command::QUICK_STOP,
            (Some(_), Target::Disabled | Target::QuickStop) => command::DISABLE_VOLTAGE,
            (Some(S::SwitchOnDisabled), Target::Enabled) => command::SHUTDOWN,
            (Some(S::ReadyToSwitchOn), Target::Enabled) => command::SWITCH_ON,
            (Some(S::SwitchedOn | S::OperationEnabled), Target::Enabled) => {
                command::ENABLE_OPERATION
            }
            // Leave a quick stop through "switch on disabled": works for every option code.
            (Some(S::QuickStopActive), Target::Enabled) => command::DISABLE_VOLTAGE,
        };
        self.last_controlword = cw;
        cw
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use State as S;

    /// CiA 402 Table 3, every transition driven by a command: (from, controlword, to, number).
    const TRANSITIONS: [(State, u16, State, u8); 14] = [
        (S::SwitchOnDisabled, 0x06, S::ReadyToSwitchOn, 2),
        (S::ReadyToSwitchOn, 0x07, S::SwitchedOn, 3),
        (S::SwitchedOn, 0x0F, S::OperationEnabled, 4),
        (S::OperationEnabled, 0x07, S::SwitchedOn, 5),
        (S::SwitchedOn, 0x06, S::ReadyToSwitchOn, 6),
        (S::ReadyToSwitchOn, 0x00, S::SwitchOnDisabled, 7),
        (S::ReadyToSwitchOn, 0x02, S::SwitchOnDisabled, 7),
        (S::OperationEnabled, 0x06, S::ReadyToSwitchOn, 8),
        (S::OperationEnabled, 0x00, S::SwitchOnDisabled, 9),
        (S::SwitchedOn, 0x00, S::SwitchOnDisabled, 10),
        (S::SwitchedOn, 0x02, S::SwitchOnDisabled, 10),
        (S::OperationEnabled, 0x02, S::QuickStopActive, 11),
        (S::QuickStopActive, 0x00, S::SwitchOnDisabled, 12),
        (S::Fault, 0x80, S::SwitchOnDisabled, 15),
    ];

    /// Lead a drive into `state` by the shortest legal path.
    fn drive_in(state: State) -> DriveStateMachine {
        let mut d = DriveStateMachine::new();
        d.initialised();
        let path: &[u16] = match state {
            S::SwitchOnDisabled => &[],
            S::ReadyToSwitchOn => &[0x06],
            S::SwitchedOn => &[0x06, 0x07],
            S::OperationEnabled => &[0x06, 0x07, 0x0F],
            S::QuickStopActive => &[0x06, 0x07, 0x0F, 0x02],
            S::Fault => {
                d.fault(0x2310);
                d.tick();
                &[]
            }
            _ => unreachable!("not a starting state of the table"),
        };
        for cw in path {
            d.on_controlword(*cw);
        }
        assert_eq!(d.state(), state);
        d
    }

    #[test]
    fn every_commanded_transition_of_table_3() {
        for (from, cw, to, number) in TRANSITIONS {
            let mut d = drive_in(from);
            assert_eq!(d.on_controlword(cw), Some(number), "{from:?} + {cw:#06x}");
            assert_eq!(d.state(), to, "{from:?} + {cw:#06x}");
            // The statusword the drive then shows decodes to the same state.
            assert_eq!(State::from_statusword(d.statusword()), Some(to));
        }
    }

    #[test]
    fn commands_outside_the_table_change_nothing() {
        let mut d = drive_in(S::SwitchOnDisabled);
        // Switch on and enable operation are not allowed from "switch on disabled".
        assert_eq!(d.on_controlword(0x07), None);
        assert_eq!(d.on_controlword(0x0F), None);
        assert_eq!(d.state(), S::SwitchOnDisabled);
        // A fault ignores everything but the reset edge; bit 7 held high resets once only.
        let mut d = drive_in(S::Fault);
        assert_eq!(d.on_controlword(0x0F), None);
        let mut d2 = drive_in(S::Fault);
        d2.on_controlword(0x80);
        d2.fault(0x4310);
        d2.tick();
        assert_eq!(d2.on_controlword(0x80), None, "no new edge");
        assert_eq!(d2.state(), S::Fault);
        assert_eq!(d.on_controlword(0x80), Some(15));
    }

    #[test]
    fn a_fault_passes_through_the_reaction_and_keeps_its_code_until_reset() {
        let mut d = drive_in(S::OperationEnabled);
        d.fault(0x4310);
        assert_eq!(d.state(), S::FaultReactionActive);
        assert_eq!(d.statusword() & 0x4F, 0x0F);
        d.fault(0x2310);
        d.tick();
        assert_eq!(d.state(), S::Fault);
        assert_eq!(d.statusword() & 0x4F, 0x08);
        assert_eq!(d.error_code(), 0x4310);
        d.on_controlword(0x00);
        d.on_controlword(0x80);
        assert_eq!(d.state(), S::SwitchOnDisabled);
        assert_eq!(d.error_code(), 0);
    }

    #[test]
    fn quick_stop_ends_by_option_code() {
        let mut d = drive_in(S::QuickStopActive);
        d.tick();
        assert_eq!(d.state(), S::SwitchOnDisabled, "option 2 (default)");
        let mut d = drive_in(S::OperationEnabled);
        d.set_quick_stop_option(6);
        d.on_controlword(0x02);
        d.tick();
        assert_eq!(d.state(), S::QuickStopActive);
        assert_eq!(d.on_controlword(0x0F), Some(16));
    }

    #[test]
    fn statusword_table_7() {
        for (sw, state) in [
            (0x0000, S::NotReadyToSwitchOn),
            (0x0250, S::SwitchOnDisabled),
            (0x0231, S::ReadyToSwitchOn),
            (0x0233, S::SwitchedOn),
            (0x0237, S::OperationEnabled),
            (0x0217, S::QuickStopActive),
            (0x021F, S::FaultReactionActive),
            (0x0218, S::Fault),
            // Bits outside the state pattern (warning, target reached) do not matter.
            (0x06B7, S::OperationEnabled),
        ] {
            assert_eq!(State::from_statusword(sw), Some(state), "{sw:#06x}");
        }
        assert_eq!(State::from_statusword(0x0001), None);
    }

    /// The controlling side against the drive: from power on it reaches "operation enabled";
    /// a fault is reset only on request, and the drive is brought back.
    #[test]
    fn the_driver_leads_the_drive_to_operation_and_back_after_a_fault() {
        let mut drive = DriveStateMachine::new();
        let mut driver = PowerDriver::new();
        driver.set_target(Target::Enabled);
        let run = |drive: &mut DriveStateMachine, driver: &mut PowerDriver, n: usize| {
            let mut states = vec![];
            for _ in 0..n {
                driver.on_statusword(drive.statusword());
                let cw = driver.controlword();
                drive.on_controlword(cw);
                drive.tick();
                drive.initialised();
                states.push(drive.state());
            }
            states
        };
        let states = run(&mut drive, &mut driver, 5);
        assert_eq!(
            &states[..4],
            &[
                S::SwitchOnDisabled,
                S::ReadyToSwitchOn,
                S::SwitchedOn,
                S::OperationEnabled
            ]
        );
        drive.fault(0x2310);
        let states = run(&mut drive, &mut driver, 5);
        assert!(states.iter().all(|s| *s == S::Fault), "{states:?}");
        driver.request_fault_reset();
        let states = run(&mut drive, &mut driver, 6);
        assert_eq!(states.last(), Some(&S::OperationEnabled), "{states:?}");
        assert!(states.contains(&S::SwitchOnDisabled));
        // Quick stop and disable.
        driver.set_target(Target::QuickStop);
        let states = run(&mut drive, &mut driver, 3);
        assert_eq!(states.last(), Some(&S::SwitchOnDisabled), "{states:?}");
        driver.set_target(Target::Enabled);
        let states = run(&mut drive, &mut driver, 4);
        assert_eq!(states.last(), Some(&S::OperationEnabled));
    }

    /// A drive whose statusword reaches the driver `lag` cycles late (its TPDO went out before
    /// it took the cycle's RPDO): bit 7 rises once and stays high until the drive has left
    /// "fault", so the controlwords read low, the edge, then the way back to operation; a fault
    /// that does not clear gets a fresh edge after the hold.
    #[test]
    fn a_late_answering_drive_sees_one_reset_edge_held_until_it_leaves_fault() {
        for lag in 0..=3usize {
            let mut drive = DriveStateMachine::new();
            drive.initialised();
            let mut driver = PowerDriver::new();
            driver.set_target(Target::Enabled);
            let mut seen = std::collections::VecDeque::new();
            let mut words = vec![];
            let mut step = |drive: &mut DriveStateMachine, driver: &mut PowerDriver| {
                seen.push_back(drive.statusword());
                if seen.len() > lag {
                    if let Some(sw) = seen.pop_front() {
                        driver.on_statusword(sw);
                    }
                }
                let cw = driver.controlword();
                drive.on_controlword(cw);
                drive.tick();
                cw
            };
            for _ in 0..(4 + 4 * lag) {
                step(&mut drive, &mut driver);
            }
            assert_eq!(drive.state(), S::OperationEnabled, "lag {lag}");
            drive.fault(0x4310);
            for _ in 0..(3 + lag) {
                words = vec![step(&mut drive, &mut driver)];
            }
            driver.request_fault_reset();
            for _ in 0..(6 + 4 * lag) {
                words.push(step(&mut drive, &mut driver));
            }
            words.dedup();
            assert_eq!(
                &words[..5],
                &[0x00, 0x80, 0x06, 0x07, 0x0F],
                "lag {lag}: {words:x?}"
            );
            assert_eq!(drive.state(), S::OperationEnabled, "lag {lag}");
        }
        // A fault that stays: after the hold, bit 7 falls for a cycle and rises again.
        let mut driver = PowerDriver::new();
        driver.set_target(Target::Enabled);
        driver.on_statusword(0x0008);
        driver.request_fault_reset();
        let mut words: Vec<u16> = (0..2 * (FAULT_RESET_HOLD_CYCLES as usize + 2))
            .map(|_| driver.controlword())
            .collect();
        words.dedup();
        assert_eq!(&words[..4], &[0x80, 0x00, 0x80, 0x00], "{words:x?}");
    }
}
