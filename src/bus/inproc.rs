//! An in-process bus with vcan semantics, for the demo and for tests: no kernel, no root.

use super::{Bus, BusError, BusEvent, Frame};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Instant;

/// Frames an endpoint can hold unread, like a controller's receive FIFO plus the socket queue.
const QUEUE_DEPTH: usize = 1024;

/// Builder for a set of connected endpoints.
pub struct InProcBus;

/// One node's connection to an [`InProcBus`].
///
/// Sending never blocks and never allocates: a peer whose queue is full loses the frame, as a
/// real receiver with an overrun would, and the loss is counted on that peer.
pub struct InProcEndpoint {
    name: String,
    rx: Receiver<Frame>,
    peers: Vec<(SyncSender<Frame>, Arc<AtomicU64>)>,
    overruns: Arc<AtomicU64>,
}

impl InProcBus {
    /// `count` endpoints, each hearing every frame sent by any other.
    pub fn endpoints(count: usize) -> Vec<InProcEndpoint> {
        let channels: Vec<_> = (0..count)
            .map(|_| {
                let (tx, rx) = std::sync::mpsc::sync_channel(QUEUE_DEPTH);
                (tx, rx, Arc::new(AtomicU64::new(0)))
            })
            .collect();
        let senders: Vec<_> = channels
            .iter()
            .map(|(tx, _, ovr)| (tx.clone(), ovr.clone()))
            .collect();
        channels
            .into_iter()
            .enumerate()
            .map(|(i, (_, rx, overruns))| InProcEndpoint {
                name: format!("inproc{i}"),
                rx,
                peers: senders
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, s)| s.clone())
                    .collect(),
                overruns,
            })
            .collect()
    }
}

impl InProcEndpoint {
    /// Frames this endpoint lost because it did not read fast enough.
    pub fn overruns(&self) -> u64 {
        self.overruns.load(Ordering::Relaxed)
    }

    /// Take every frame already queued, without waiting.
    pub fn drain(&mut self) -> Vec<Frame> {
        self.rx.try_iter().collect()
    }
}

impl Bus for InProcEndpoint {
    fn send(&mut self, frame: &Frame) -> Result<(), BusError> {
        let mut alive = 0;
        for (tx, overruns) in &self.peers {
            match tx.try_send(*frame) {
                Ok(()) => alive += 1,
                Err(TrySendError::Full(_)) => {
                    alive += 1;
                    overruns.fetch_add(1, Ordering::Relaxed);
                }
                Err(TrySendError::Disconnected(_)) => {}
            }
        }
        if alive == 0 && !self.peers.is_empty() {
            return Err(BusError::Closed);
        }
        Ok(())
    }

    fn recv_until(&mut self, deadline: Instant) -> Result<Option<BusEvent>, BusError> {
        let timeout = deadline.saturating_duration_since(Instant::now());
        match self.rx.recv_timeout(timeout) {
            Ok(frame) => Ok(Some(BusEvent::Frame(frame))),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(BusError::Closed),
        }
    }

    fn name(&self) -> &str {
        &self.name
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn frame(id: u32) -> Frame {
        Frame::new(id, &[id as u8]).expect("valid frame")
    }

    #[test]
    fn every_frame_reaches_every_other_endpoint_but_not_the_sender() {
        let mut eps = InProcBus::endpoints(3);
        eps[0].send(&frame(0x100)).expect("send");
        eps[2].send(&frame(0x200)).expect("send");
        assert_eq!(eps[0].drain(), vec![frame(0x200)]);
        assert_eq!(eps[1].drain(), vec![frame(0x100), frame(0x200)]);
        assert_eq!(eps[2].drain(), vec![frame(0x100)]);
    }

    #[test]
    fn receive_returns_none_at_the_deadline() {
        let mut eps = InProcBus::endpoints(2);
        let got = eps[0]
            .recv_until(Instant::now() + Duration::from_millis(5))
            .expect("bus open");
        assert_eq!(got, None);
    }

    #[test]
    fn a_full_peer_loses_frames_and_counts_them() {
        let mut eps = InProcBus::endpoints(2);
        for _ in 0..QUEUE_DEPTH + 10 {
            eps[0].send(&frame(0x1)).expect("send");
        }
        assert_eq!(eps[1].overruns(), 10);
        assert_eq!(eps[1].drain().len(), QUEUE_DEPTH);
    }

    #[test]
    fn sending_to_a_bus_with_no_one_left_is_an_error() {
        let mut eps = InProcBus::endpoints(2);
        let lone = eps.remove(0);
        drop(eps);
        let mut lone = lone;
        assert!(matches!(lone.send(&frame(0x1)), Err(BusError::Closed)));
    }
}
