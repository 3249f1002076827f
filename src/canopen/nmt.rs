//! NMT (network management): node states, commands, heartbeat and SYNC (CiA 301 style).

use super::{DecodeError, Frame};

/// COB-ID of NMT node control (CiA 301 §7.2.8.3.1): a broadcast, fixed id.
pub const NMT_COB_ID: u32 = 0x000;
/// COB-ID of SYNC (CiA 301 §7.2.5): a broadcast, fixed id.
pub const SYNC_COB_ID: u32 = 0x080;
/// Function code of the heartbeat (CiA 301 §7.2.8.3.2); the COB-ID adds the producer's node id.
pub const HEARTBEAT_FUNCTION_CODE: u32 = 0x700;

/// Frame names in decode errors, the same as in the message tables of the profiles.
const NMT_NAME: &str = "nmt";
const SYNC_NAME: &str = "sync";
const HEARTBEAT_NAME: &str = "heartbeat";

/// A node's NMT state, as carried in its heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtState {
    /// Sent once as the boot-up message; the node then enters pre-operational by itself.
    Initialising,
    Stopped,
    Operational,
    PreOperational,
}

impl NmtState {
    pub fn code(self) -> u8 {
        match self {
            NmtState::Initialising => 0x00,
            NmtState::Stopped => 0x04,
            NmtState::Operational => 0x05,
            NmtState::PreOperational => 0x7F,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        match code & 0x7F {
            0x00 => Some(NmtState::Initialising),
            0x04 => Some(NmtState::Stopped),
            0x05 => Some(NmtState::Operational),
            0x7F => Some(NmtState::PreOperational),
            _ => None,
        }
    }

    /// The state a node moves to on `command` (CiA 301 NMT state diagram).
    pub fn on_command(self, command: NmtCommand) -> Self {
        match command {
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::EnterPreOperational => NmtState::PreOperational,
            // A reset reboots the node: boot-up, then pre-operational.
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => NmtState::PreOperational,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            NmtState::Initialising => "initialising",
            NmtState::Stopped => "stopped",
            NmtState::Operational => "operational",
            NmtState::PreOperational => "pre-operational",
        }
    }
}

/// NMT node-control commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmtCommand {
    Start,
    Stop,
    EnterPreOperational,
    ResetNode,
    ResetCommunication,
}

impl NmtCommand {
    pub fn code(self) -> u8 {
        match self {
            NmtCommand::Start => 0x01,
            NmtCommand::Stop => 0x02,
            NmtCommand::EnterPreOperational => 0x80,
            NmtCommand::ResetNode => 0x81,
            NmtCommand::ResetCommunication => 0x82,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0x01 => Some(NmtCommand::Start),
            0x02 => Some(NmtCommand::Stop),
            0x80 => Some(NmtCommand::EnterPreOperational),
            0x81 => Some(NmtCommand::ResetNode),
            0x82 => Some(NmtCommand::ResetCommunication),
            _ => None,
        }
    }

    /// The command frame; `node_id` 0 addresses every node.
    pub fn encode(self, node_id: u8) -> Frame {
        frame(NMT_COB_ID, &[self.code(), node_id])
    }

    /// Decode an NMT frame into (command, addressed node id).
    pub fn decode(frame: &Frame) -> Result<(Self, u8), DecodeError> {
        DecodeError::check_length(NMT_NAME, frame, 2)?;
        let d = frame.data();
        let command = Self::from_code(d[0]).ok_or(DecodeError::BadValue {
            name: NMT_NAME,
            id: frame.id(),
            signal: "nmt_command",
            value: i64::from(d[0]),
        })?;
        Ok((command, d[1]))
    }

    /// Does a command for `target` (0 = all) address `node_id`?
    pub fn addresses(target: u8, node_id: u8) -> bool {
        target == 0 || target == node_id
    }
}

/// Heartbeat frame of `node_id` in `state`.
pub fn encode_heartbeat(node_id: u8, state: NmtState) -> Frame {
    frame(
        HEARTBEAT_FUNCTION_CODE + u32::from(node_id),
        &[state.code()],
    )
}

/// Decode a heartbeat: (node id, state).
pub fn decode_heartbeat(frame: &Frame) -> Result<(u8, NmtState), DecodeError> {
    DecodeError::check_length(HEARTBEAT_NAME, frame, 1)?;
    let code = frame.data()[0];
    let state = NmtState::from_code(code).ok_or(DecodeError::BadValue {
        name: HEARTBEAT_NAME,
        id: frame.id(),
        signal: "nmt_state",
        value: i64::from(code),
    })?;
    Ok(((frame.id() - HEARTBEAT_FUNCTION_CODE) as u8, state))
}

/// Is `frame` a heartbeat (COB-ID 0x701..=0x77F)?
pub fn is_heartbeat(frame: &Frame) -> bool {
    (0x701..=0x77F).contains(&frame.id()) && !frame.is_extended()
}

/// The SYNC counter of CiA 301: 1..=240, then back to 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SyncCounter(u8);

impl Default for SyncCounter {
    fn default() -> Self {
        Self(1)
    }
}

impl SyncCounter {
    pub const MAX: u8 = 240;

    pub fn value(self) -> u8 {
        self.0
    }

    pub fn next(self) -> Self {
        if self.0 >= Self::MAX {
            Self(1)
        } else {
            Self(self.0 + 1)
        }
    }

    pub fn encode(self) -> Frame {
        frame(SYNC_COB_ID, &[self.0])
    }
}

/// Decode a SYNC frame: its counter, or None for a counter-less SYNC (length 0).
pub fn decode_sync(frame: &Frame) -> Result<Option<u8>, DecodeError> {
    match frame.len() {
        0 => Ok(None),
        1 => Ok(Some(frame.data()[0])),
        got => Err(DecodeError::WrongLength {
            name: SYNC_NAME,
            id: frame.id(),
            got,
            expected: 1,
        }),
    }
}

fn frame(id: u32, data: &[u8]) -> Frame {
    Frame::new(id, data).unwrap_or_else(|e| unreachable!("fixed NMT layout: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nmt_commands_round_trip_and_garbage_is_rejected() {
        for c in [
            NmtCommand::Start,
            NmtCommand::Stop,
            NmtCommand::EnterPreOperational,
            NmtCommand::ResetNode,
            NmtCommand::ResetCommunication,
        ] {
            let f = c.encode(16);
            assert_eq!(f.id(), 0);
            assert_eq!(NmtCommand::decode(&f), Ok((c, 16)));
        }
        let junk = Frame::new(0, &[0x55, 1]).expect("frame");
        assert!(NmtCommand::decode(&junk).is_err());
        let short = Frame::new(0, &[1]).expect("frame");
        assert!(matches!(
            NmtCommand::decode(&short),
            Err(DecodeError::WrongLength { .. })
        ));
    }

    #[test]
    fn heartbeat_carries_node_and_state() {
        let f = encode_heartbeat(0x10, NmtState::Operational);
        assert_eq!(f.to_string(), "710#05");
        assert!(is_heartbeat(&f));
        assert_eq!(decode_heartbeat(&f), Ok((0x10, NmtState::Operational)));
    }

    #[test]
    fn sync_counter_wraps_after_240() {
        let mut c = SyncCounter::default();
        for _ in 0..239 {
            c = c.next();
        }
        assert_eq!(c.value(), 240);
        assert_eq!(c.next().value(), 1);
        assert_eq!(decode_sync(&c.encode()), Ok(Some(240)));
    }

    #[test]
    fn state_machine_follows_commands() {
        let s = NmtState::PreOperational.on_command(NmtCommand::Start);
        assert_eq!(s, NmtState::Operational);
        assert_eq!(s.on_command(NmtCommand::Stop), NmtState::Stopped);
        assert_eq!(
            NmtState::Stopped.on_command(NmtCommand::ResetNode),
            NmtState::PreOperational
        );
    }
}
