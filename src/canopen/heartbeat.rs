//! Heartbeat consumption (CiA 301 §7.2.8.3.2.2): a node watches one producer's heartbeat with
//! the time of its consumer heartbeat object 1016h, and raises a heartbeat event once when the
//! producer stays silent for longer. Sans-I/O: times in, events out.

/// Index of the consumer heartbeat time (CiA 301 §7.5.2.4).
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
/// Index of the producer heartbeat time (CiA 301 §7.5.2.5), ms.
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// EMCY error code of a heartbeat event or life guard error (CiA 301 Table 21).
pub const HEARTBEAT_ERROR: u16 = 0x8130;

/// One 1016h entry: the producer's node-ID in bits 16..=23, the time in ms in bits 0..=15.
/// A time of 0 or node-ID 0 leaves the entry unused.
pub fn encode_consumer_entry(producer: u8, time_ms: u16) -> u32 {
    (u32::from(producer) << 16) | u32::from(time_ms)
}

/// The producer and time (s) of a 1016h entry, or `None` for an unused one.
pub fn decode_consumer_entry(entry: u32) -> Option<(u8, f64)> {
    let producer = ((entry >> 16) & 0xFF) as u8;
    let time_ms = (entry & 0xFFFF) as u16;
    (producer != 0 && producer <= 127 && time_ms != 0)
        .then(|| (producer, f64::from(time_ms) * 1e-3))
}

/// What one look at the consumer found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConsumerEvent {
    /// The producer was silent for longer than the consumer time: raised once per silence.
    Lost,
    /// A heartbeat after a silence.
    Back,
}

/// The watch on one producer. Monitoring starts with the first heartbeat received after the
/// entry was set (CiA 301): a producer that never spoke is not lost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeartbeatConsumer {
    producer: u8,
    time_s: f64,
    last_s: Option<f64>,
    lost: bool,
}

impl HeartbeatConsumer {
    /// The watch a 1016h entry asks for (`None`: unused).
    pub fn from_entry(entry: u32) -> Option<Self> {
        decode_consumer_entry(entry).map(|(producer, time_s)| Self {
            producer,
            time_s,
            last_s: None,
            lost: false,
        })
    }

    pub fn producer(&self) -> u8 {
        self.producer
    }

    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// True from the event until the producer's next heartbeat.
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// A heartbeat (or boot-up) of `node` at `now_s`.
    pub fn on_heartbeat(&mut self, node: u8, now_s: f64) -> Option<ConsumerEvent> {
        if node != self.producer {
            return None;
        }
        self.last_s = Some(now_s);
        std::mem::take(&mut self.lost).then_some(ConsumerEvent::Back)
    }

    /// When the producer is lost unless it speaks before: its last heartbeat plus the time.
    pub fn deadline_s(&self) -> Option<f64> {
        match (self.lost, self.last_s) {
            (false, Some(last)) => Some(last + self.time_s),
            _ => None,
        }
    }

    /// Look at the clock: the heartbeat event, once, when the time has run out.
    pub fn poll(&mut self, now_s: f64) -> Option<ConsumerEvent> {
        let due = self.deadline_s().is_some_and(|d| now_s > d);
        if due {
            self.lost = true;
        }
        due.then_some(ConsumerEvent::Lost)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_entry_packs_node_and_milliseconds() {
        let e = encode_consumer_entry(1, 150);
        assert_eq!(e, 0x0001_0096);
        assert_eq!(decode_consumer_entry(e), Some((1, 0.15)));
        assert_eq!(decode_consumer_entry(0x0001_0000), None, "time 0: unused");
        assert_eq!(decode_consumer_entry(0x0000_0096), None, "node 0: unused");
    }

    #[test]
    fn the_event_comes_once_after_the_time_and_ends_with_the_next_heartbeat() {
        let mut c = HeartbeatConsumer::from_entry(encode_consumer_entry(1, 150)).expect("used");
        // Not watched before the first heartbeat.
        assert_eq!(c.poll(10.0), None);
        assert_eq!(c.on_heartbeat(2, 10.0), None, "another node");
        assert_eq!(c.poll(10.5), None);
        assert_eq!(c.on_heartbeat(1, 11.0), None);
        assert_eq!(c.poll(11.15), None, "at the time, not yet beyond it");
        assert_eq!(c.poll(11.151), Some(ConsumerEvent::Lost));
        assert!(c.is_lost());
        assert_eq!(c.poll(12.0), None, "once per silence");
        assert_eq!(c.deadline_s(), None);
        assert_eq!(c.on_heartbeat(1, 12.5), Some(ConsumerEvent::Back));
        assert_eq!(c.deadline_s(), Some(12.65));
    }
}
