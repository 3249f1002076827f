//! The simulated node's heartbeat consumer (1016h sub 1): the master's heartbeat watched on the
//! node's own clock, which runs on when the master (and with it the SYNC) stops. On a loss the
//! drive reacts as its abort connection option code 6007h says and the module sets its outputs
//! to their safe value (0); both announce it with EMCY 8130h.

use super::{Profile, ProfileNode};
use crate::bus::Frame;
use crate::canopen::heartbeat::{
    ConsumerEvent, HeartbeatConsumer, CONSUMER_HEARTBEAT_TIME, HEARTBEAT_ERROR,
};
use crate::canopen::od::ObjectId;
use crate::canopen::Value;
use crate::device::profile::cia401;
use crate::device::profile::cia402::{self, abort_connection, command};

/// Error register 1001h of the heartbeat event: generic (bit 0) and communication (bit 4).
const HEARTBEAT_ERROR_REGISTER: u8 = 0x11;

impl ProfileNode {
    /// 1016h sub 1 was written: watch the producer it names (or nothing), from its next
    /// heartbeat on.
    pub(super) fn on_consumer_time_written(&mut self) {
        let entry = self.u32_at(CONSUMER_HEARTBEAT_TIME, 1);
        self.consumer = HeartbeatConsumer::from_entry(entry);
    }

    /// A heartbeat (or boot-up) of `node` heard at `now_s` on the node's clock.
    pub fn on_heartbeat(&mut self, node: u8, now_s: f64, send: &mut dyn FnMut(&Frame)) {
        let back = self
            .consumer
            .as_mut()
            .and_then(|c| c.on_heartbeat(node, now_s));
        // The master is back: "error reset" unless the drive stays in fault until reset.
        if back == Some(ConsumerEvent::Back) && !self.drive.state().is_fault() {
            send(&self.emcy(0, 0));
        }
    }

    /// When the consumer's time runs out unless the producer speaks first (node clock, s).
    pub fn consumer_deadline_s(&self) -> Option<f64> {
        self.consumer
            .as_ref()
            .and_then(HeartbeatConsumer::deadline_s)
    }

    /// True from a heartbeat event until the producer is heard again.
    pub fn master_lost(&self) -> bool {
        self.consumer
            .as_ref()
            .is_some_and(HeartbeatConsumer::is_lost)
    }

    /// Look at the node's clock: on a heartbeat event, the reaction and its EMCY.
    pub fn poll(&mut self, now_s: f64, send: &mut dyn FnMut(&Frame)) {
        let lost = self.consumer.as_mut().and_then(|c| c.poll(now_s));
        if lost != Some(ConsumerEvent::Lost) {
            return;
        }
        match self.profile {
            Profile::Cia402 => self.abort_connection(),
            Profile::Cia401 => {
                for sub in 1..=2 {
                    self.set(
                        ObjectId::new(cia401::ANALOG_OUTPUTS_16, sub),
                        Value::Integer16(0),
                    );
                }
            }
        }
        send(&self.emcy(HEARTBEAT_ERROR, HEARTBEAT_ERROR_REGISTER));
    }

    /// The drive's reaction to the lost connection, as 6007h says (CiA 402 §6.3.1); the
    /// quick stop then ends as 605Ah says.
    fn abort_connection(&mut self) {
        let option = self.f64_at(cia402::ABORT_CONNECTION_OPTION, 0) as i16;
        match option {
            abort_connection::FAULT => self.drive.fault(HEARTBEAT_ERROR),
            abort_connection::DISABLE_VOLTAGE => {
                self.drive.on_controlword(command::DISABLE_VOLTAGE);
            }
            abort_connection::QUICK_STOP => {
                self.drive.on_controlword(command::QUICK_STOP);
            }
            _ => return,
        }
        if !self.drive.state().is_enabled() {
            if self.homing.is_moving() {
                self.homing.interrupt();
            }
            self.velocity_integral = 0.0;
            self.last_target_m = None;
        }
        self.publish_status();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::canopen::NmtState;
    use crate::device::profile::cia402::State;

    /// An expedited SDO download of `size` bytes; the answer must not be an abort.
    fn write(n: &mut ProfileNode, index: u16, sub: u8, value: u32, size: usize) {
        let (_, req) = crate::canopen::sdo::Expedited::write(
            n.node_id,
            crate::canopen::od::ObjectId::new(index, sub),
            &value.to_le_bytes()[..size],
        );
        let mut out = vec![];
        n.handle(&req, NmtState::PreOperational, &mut |f| out.push(*f));
        assert_eq!(out.len(), 1);
        assert_ne!(
            out[0].data()[0],
            0x80,
            "{index:04X}:{sub} refused: {}",
            out[0]
        );
    }

    /// A drive watching node 1 with 150 ms, abort connection option `option`, enabled, and
    /// the producer's first heartbeat heard at 1 s.
    fn watching_drive(option: i16) -> ProfileNode {
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        write(&mut n, CONSUMER_HEARTBEAT_TIME, 1, 0x0001_0096, 4);
        write(
            &mut n,
            cia402::ABORT_CONNECTION_OPTION,
            0,
            option as u16 as u32,
            2,
        );
        for cw in [command::SHUTDOWN, command::ENABLE_OPERATION] {
            write(&mut n, cia402::CONTROLWORD, 0, u32::from(cw), 2);
        }
        assert_eq!(n.drive_state(), State::OperationEnabled);
        n.on_heartbeat(1, 1.0, &mut |f| panic!("nothing to say: {f}"));
        n
    }

    fn poll(n: &mut ProfileNode, now_s: f64) -> Vec<Frame> {
        let mut out = vec![];
        n.poll(now_s, &mut |f| out.push(*f));
        out
    }

    #[test]
    fn a_drive_quick_stops_when_the_master_is_silent_beyond_its_consumer_time() {
        let mut n = watching_drive(abort_connection::QUICK_STOP);
        assert_eq!(n.consumer_deadline_s(), Some(1.15));
        assert!(poll(&mut n, 1.15).is_empty(), "at the time, not beyond it");
        let emcy = poll(&mut n, 1.151);
        assert_eq!(emcy.len(), 1);
        assert_eq!(emcy[0].id(), 0x90);
        assert_eq!(emcy[0].data()[..3], [0x30, 0x81, 0x11]);
        assert_eq!(n.drive_state(), State::QuickStopActive);
        assert!(n.master_lost());
        assert!(poll(&mut n, 2.0).is_empty(), "once per silence");
        // Heard again: "error reset", watched again.
        let mut out = vec![];
        n.on_heartbeat(1, 2.5, &mut |f| out.push(*f));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].data()[..3], [0, 0, 0]);
        assert!(!n.master_lost());
        assert_eq!(n.consumer_deadline_s(), Some(2.65));
    }

    #[test]
    fn the_abort_connection_option_picks_the_reaction() {
        for (option, state) in [
            (abort_connection::NO_ACTION, State::OperationEnabled),
            (abort_connection::FAULT, State::FaultReactionActive),
            (abort_connection::DISABLE_VOLTAGE, State::SwitchOnDisabled),
            (abort_connection::QUICK_STOP, State::QuickStopActive),
        ] {
            let mut n = watching_drive(option);
            let emcy = poll(&mut n, 1.2);
            assert_eq!(emcy.len(), 1, "option {option}");
            assert_eq!(n.drive_state(), state, "option {option}");
        }
        // A drive left in fault stays there, silent, when the master is back.
        let mut n = watching_drive(abort_connection::FAULT);
        poll(&mut n, 1.2);
        n.on_heartbeat(1, 2.0, &mut |f| panic!("no error reset in fault: {f}"));
    }

    #[test]
    fn an_unwatched_node_never_reacts_and_the_module_zeroes_its_outputs() {
        let mut n = ProfileNode::new(Profile::Cia402, 16, vec![]);
        n.on_heartbeat(1, 1.0, &mut |_| {});
        assert!(poll(&mut n, 100.0).is_empty(), "1016h unused at power-on");
        let mut m = ProfileNode::new(Profile::Cia401, 17, vec![]);
        write(&mut m, CONSUMER_HEARTBEAT_TIME, 1, 0x0001_0096, 4);
        write(&mut m, cia401::ANALOG_OUTPUTS_16, 1, 1234, 2);
        m.on_heartbeat(1, 1.0, &mut |_| {});
        let emcy = poll(&mut m, 1.2);
        assert_eq!(emcy.len(), 1);
        assert_eq!(emcy[0].id(), 0x91);
        assert_eq!(m.f64_at(cia401::ANALOG_OUTPUTS_16, 1), 0.0);
    }
}
