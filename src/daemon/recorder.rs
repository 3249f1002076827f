//! The recorder: a bounded queue from the cycle to a writer thread that writes MCAP and logs
//! events. The cycle never waits for it; what does not fit in the queue is dropped and counted.

use super::record::{CycleRecord, Event, Record, RejoinStage};
use crate::bus::Frame;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

pub use crate::recording::{read_cycles, RecorderError, CAN_TOPIC, CYCLE_TOPIC, EVENT_TOPIC};

/// JSON schema of a cycle record, so MCAP viewers can show field types and units.
const CYCLE_SCHEMA: &str = r#"{
  "title": "actuatord cycle",
  "description": "One axis in one control cycle. SI units; names as in dbc/actuatord.dbc.",
  "type": "object",
  "properties": {
    "t_s": {"type": "number", "description": "release time since start, s"},
    "cycle": {"type": "integer"},
    "axis_node_id": {"type": "integer"},
    "setpoint_position": {"type": "number", "description": "m"},
    "reference_position": {"type": "number", "description": "rate-limited setpoint the loop tracks, m"},
    "position": {"type": "number", "description": "m"},
    "current": {"type": "number", "description": "A"},
    "supply_voltage": {"type": "number", "description": "V"},
    "supply_pressure": {"type": "number", "description": "Pa"},
    "command_voltage": {"type": "number", "description": "V"},
    "command_duty": {"type": "number", "description": "signed valve duty, -1..1"},
    "command_torque": {"type": "number", "description": "CiA 402 target torque, N m (N on a linear axis)"},
    "command_velocity": {"type": "number", "description": "CiA 402 target velocity, m/s"},
    "drive_statusword": {"type": "integer", "description": "CiA 402 statusword 6041h, 0 for other nodes"},
    "friction_compensation": {"type": "number", "description": "command unit"},
    "following_error": {"type": "number", "description": "setpoint - position, m"},
    "fault_state": {"type": "integer", "description": "0 ok, 1 warning, 2 fail_safe, 3 maintenance_requested"},
    "fault_flags": {"type": "integer", "description": "bit per fault, order as in the DBC"},
    "supervised_faults": {"type": "integer", "description": "latched supervised faults, bit per fault: spring_pretension, spring_stiffness, friction_increase, current_gain, observer_friction, estimator_implausible, limit_violation, sensor_offset"},
    "diagnosed_fault": {"type": "integer", "description": "0 none, else 1 + bit of the latest latched supervised fault"},
    "diagnosis_confidence": {"type": "number", "description": "0..1"},
    "symptoms": {"type": "array", "items": {"type": "integer"}, "description": "-1, 0, +1 per T_I, D, omega0, K_P, F_C, F_0"},
    "friction_compensation_pos": {"type": "number", "description": "U_comp+, command unit"},
    "friction_compensation_neg": {"type": "number", "description": "U_comp-, command unit"},
    "gain_schedule_factor": {"type": "number"},
    "dither": {"type": "number", "description": "command unit"},
    "arrival_relief": {"type": "number", "description": "taken out of the controller's stored output this cycle, command unit; the parameter estimation leaves the samples it disturbs out"},
    "gain_down": {"type": "number", "description": "direction P gain q01, 1/m"},
    "gain_up": {"type": "number", "description": "direction P gain q02, 1/m"},
    "drive_gain_down": {"type": "number", "description": "estimated K_I1, m/s"},
    "drive_gain_up": {"type": "number", "description": "estimated K_I2, m/s"},
    "observer_x4_pos": {"type": "number", "description": "smoothed observer x4 moving in +, m (0 until seen)"},
    "observer_x4_neg": {"type": "number", "description": "smoothed observer x4 moving in -, m (0 until seen)"},
    "sensor_fresh": {"type": "boolean"},
    "wake_latency": {"type": "number", "description": "s"},
    "cycle_latency": {"type": "number", "description": "release to command sent, s"},
    "sensor_to_command": {"type": "number", "description": "sensor frame received to command sent, s"},
    "stage_ns": {"type": "array", "items": {"type": "integer"}, "description": "compute time per stage, ns: scheduling, control, estimation, observer, supervision, encode_send"}
  }
}"#;

const EVENT_SCHEMA: &str = r#"{
  "title": "actuatord event",
  "type": "object",
  "properties": {
    "t_s": {"type": "number"},
    "kind": {"type": "string"},
    "message": {"type": "string"}
  }
}"#;

const CAN_SCHEMA: &str = r#"{
  "title": "actuatord CAN frame",
  "description": "A frame the controller sent or received; decode with dbc/actuatord.dbc.",
  "type": "object",
  "properties": {
    "t_s": {"type": "number", "description": "cycle time, s"},
    "id": {"type": "integer"},
    "extended": {"type": "boolean"},
    "data": {"type": "string", "description": "data bytes, hex"},
    "direction": {"type": "string", "enum": ["rx", "tx"]}
  }
}"#;

/// The cycle's end of the queue. `push` never blocks.
#[derive(Clone)]
pub struct RecordSink {
    tx: SyncSender<Record>,
    dropped: Arc<AtomicU64>,
}

impl RecordSink {
    /// A sink whose records go to the returned receiver instead of a writer thread
    /// (benches, tests, anything that consumes records itself).
    pub fn channel(queue_depth: usize) -> (RecordSink, Receiver<Record>) {
        let (tx, rx) = std::sync::mpsc::sync_channel(queue_depth);
        (
            RecordSink {
                tx,
                dropped: Arc::new(AtomicU64::new(0)),
            },
            rx,
        )
    }

    pub fn push(&self, record: Record) {
        match self.tx.try_send(record) {
            Ok(()) => {}
            Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// What the writer did, when it ends.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecorderReport {
    pub path: Option<PathBuf>,
    pub cycles_written: u64,
    pub events: u64,
    pub frames: u64,
    pub dropped: u64,
}

/// The writer thread; join it after the cycle ended and every sink is dropped.
pub struct Recorder {
    handle: JoinHandle<Result<RecorderReport, RecorderError>>,
    dropped: Arc<AtomicU64>,
}

impl Recorder {
    /// Start the writer. With a path, records go to an MCAP file; events are logged either way.
    pub fn spawn(
        path: Option<&Path>,
        queue_depth: usize,
    ) -> Result<(RecordSink, Recorder), RecorderError> {
        let (tx, rx) = std::sync::mpsc::sync_channel(queue_depth);
        let dropped = Arc::new(AtomicU64::new(0));
        let writer = match path {
            Some(p) => Some(McapOut::create(p)?),
            None => None,
        };
        let handle = std::thread::Builder::new()
            .name("actuatord-recorder".into())
            .spawn(move || write_loop(rx, writer))
            .map_err(|e| RecorderError::File {
                path: path.map(Path::to_path_buf).unwrap_or_default(),
                message: format!("cannot start the writer thread: {e}"),
            })?;
        Ok((
            RecordSink {
                tx,
                dropped: dropped.clone(),
            },
            Recorder { handle, dropped },
        ))
    }

    /// Wait for the writer to drain the queue and close the file.
    pub fn finish(self) -> Result<RecorderReport, RecorderError> {
        let mut report = self.handle.join().map_err(|_| RecorderError::Panicked)??;
        report.dropped = self.dropped.load(Ordering::Relaxed);
        Ok(report)
    }
}

struct McapOut {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<File>>,
    cycle_channel: u16,
    event_channel: u16,
    can_channel: u16,
    cycle_seq: u32,
    event_seq: u32,
    can_seq: u32,
}

impl McapOut {
    fn create(path: &Path) -> Result<Self, RecorderError> {
        let err = |message: String| RecorderError::File {
            path: path.to_path_buf(),
            message,
        };
        let file = File::create(path).map_err(|e| err(e.to_string()))?;
        // Small chunks: a killed daemon leaves a file readable up to its last finished chunk,
        // so this bounds what is lost to well under a second of recording.
        let mut writer = mcap::WriteOptions::new()
            .library(concat!("actuatord ", env!("CARGO_PKG_VERSION")))
            .chunk_size(Some(64 * 1024))
            .create(BufWriter::new(file))
            .map_err(|e| err(e.to_string()))?;
        let cycle_schema = writer
            .add_schema("actuatord.Cycle", "jsonschema", CYCLE_SCHEMA.as_bytes())
            .map_err(|e| err(e.to_string()))?;
        let event_schema = writer
            .add_schema("actuatord.Event", "jsonschema", EVENT_SCHEMA.as_bytes())
            .map_err(|e| err(e.to_string()))?;
        let cycle_channel = writer
            .add_channel(cycle_schema, CYCLE_TOPIC, "json", &BTreeMap::new())
            .map_err(|e| err(e.to_string()))?;
        let event_channel = writer
            .add_channel(event_schema, EVENT_TOPIC, "json", &BTreeMap::new())
            .map_err(|e| err(e.to_string()))?;
        let can_schema = writer
            .add_schema("actuatord.CanFrame", "jsonschema", CAN_SCHEMA.as_bytes())
            .map_err(|e| err(e.to_string()))?;
        let can_channel = writer
            .add_channel(can_schema, CAN_TOPIC, "json", &BTreeMap::new())
            .map_err(|e| err(e.to_string()))?;
        Ok(Self {
            path: path.to_path_buf(),
            writer,
            cycle_channel,
            event_channel,
            can_channel,
            cycle_seq: 0,
            event_seq: 0,
            can_seq: 0,
        })
    }

    fn err(&self, e: impl std::fmt::Display) -> RecorderError {
        RecorderError::File {
            path: self.path.clone(),
            message: e.to_string(),
        }
    }

    fn write_cycle(&mut self, c: &CycleRecord) -> Result<(), RecorderError> {
        let data = serde_json::to_vec(c).map_err(|e| self.err(e))?;
        let time = (c.t_s * 1e9) as u64;
        self.cycle_seq = self.cycle_seq.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: self.cycle_channel,
            sequence: self.cycle_seq,
            log_time: time,
            publish_time: time,
        };
        self.writer
            .write_to_known_channel(&header, &data)
            .map_err(|e| self.err(e))
    }

    fn write_event(&mut self, e: &Event) -> Result<(), RecorderError> {
        let data = serde_json::to_vec(&serde_json::json!({
            "t_s": e.t_s(),
            "kind": e.kind(),
            "message": e.to_string(),
        }))
        .map_err(|x| self.err(x))?;
        let time = (e.t_s() * 1e9) as u64;
        self.event_seq = self.event_seq.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: self.event_channel,
            sequence: self.event_seq,
            log_time: time,
            publish_time: time,
        };
        self.writer
            .write_to_known_channel(&header, &data)
            .map_err(|x| self.err(x))
    }

    fn write_frame(
        &mut self,
        t_s: f64,
        frame: &Frame,
        received: bool,
    ) -> Result<(), RecorderError> {
        let data: String = frame.data().iter().map(|b| format!("{b:02X}")).collect();
        let json = serde_json::to_vec(&serde_json::json!({
            "t_s": t_s,
            "id": frame.id(),
            "extended": frame.is_extended(),
            "data": data,
            "direction": if received { "rx" } else { "tx" },
        }))
        .map_err(|x| self.err(x))?;
        let time = (t_s * 1e9) as u64;
        self.can_seq = self.can_seq.wrapping_add(1);
        let header = mcap::records::MessageHeader {
            channel_id: self.can_channel,
            sequence: self.can_seq,
            log_time: time,
            publish_time: time,
        };
        self.writer
            .write_to_known_channel(&header, &json)
            .map_err(|x| self.err(x))
    }

    fn finish(mut self) -> Result<PathBuf, RecorderError> {
        self.writer.finish().map_err(|e| self.err(e))?;
        Ok(self.path)
    }
}

fn log_event(e: &Event) {
    match e {
        Event::FaultRaised { .. }
        | Event::Diagnosed { .. }
        | Event::Overrun { .. }
        | Event::BusError { .. }
        | Event::BusRestored { .. }
        | Event::SetpointSource { .. }
        | Event::ReactionApplied { .. }
        | Event::NodeRejoin {
            stage: RejoinStage::Rebooted { .. },
            ..
        } => {
            tracing::warn!(kind = e.kind(), "{e}")
        }
        Event::NodeRejoin {
            stage: RejoinStage::Failed { .. },
            ..
        } => tracing::error!(kind = e.kind(), "{e}"),
        Event::BusFault { .. } => tracing::error!(kind = e.kind(), "{e}"),
        Event::Malformed { .. } => tracing::warn!(kind = e.kind(), "{e}"),
        Event::Started {
            realtime_requested,
            realtime,
            lock_requested,
            memory_locked,
        } if (*realtime_requested && !realtime) || (*lock_requested && !memory_locked) => {
            tracing::warn!(kind = e.kind(), "{e}")
        }
        _ => tracing::info!(kind = e.kind(), "{e}"),
    }
}

fn write_loop(
    rx: Receiver<Record>,
    mut out: Option<McapOut>,
) -> Result<RecorderReport, RecorderError> {
    let mut report = RecorderReport::default();
    let mut first_error = None;
    // Ends when every sink is dropped and the queue is empty, so nothing queued is lost.
    for record in rx {
        let result = match (&record, out.as_mut()) {
            (Record::Cycle(c), Some(o)) => {
                report.cycles_written += 1;
                o.write_cycle(c)
            }
            (Record::Event(e), o) => {
                report.events += 1;
                log_event(e);
                o.map_or(Ok(()), |o| o.write_event(e))
            }
            (
                Record::Frame {
                    t_s,
                    frame,
                    received,
                },
                Some(o),
            ) => {
                report.frames += 1;
                o.write_frame(*t_s, frame, *received)
            }
            (Record::Cycle(_), None) | (Record::Frame { .. }, None) => Ok(()),
        };
        if let Err(e) = result {
            // Keep draining so the cycle's queue never fills because the disk failed.
            tracing::error!("{e}; recording stops, the cycle goes on");
            first_error.get_or_insert(e);
            out = None;
        }
    }
    if let Some(o) = out {
        report.path = Some(o.finish()?);
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok(report),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_reach_an_mcap_file_that_reads_back() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.mcap");
        let (sink, rec) = Recorder::spawn(Some(&path), 64).expect("spawn");
        for k in 0..10 {
            sink.push(Record::Cycle(CycleRecord {
                t_s: k as f64 * 0.0025,
                cycle: k,
                position: 0.001 * k as f64,
                ..Default::default()
            }));
        }
        sink.push(Record::Event(Event::FaultsReset {
            t_s: 0.01,
            axis_node_id: 16,
        }));
        drop(sink);
        let report = rec.finish().expect("finish");
        assert_eq!(report.cycles_written, 10);
        assert_eq!(report.events, 1);
        let bytes = std::fs::read(&path).expect("read");
        let mut positions = vec![];
        for m in mcap::MessageStream::new(&bytes).expect("mcap") {
            let m = m.expect("message");
            if m.channel.topic == CYCLE_TOPIC {
                let v: serde_json::Value = serde_json::from_slice(&m.data).expect("json");
                positions.push(v["position"].as_f64().expect("position"));
            }
        }
        assert_eq!(positions.len(), 10);
        assert!((positions[9] - 0.009).abs() < 1e-12);
    }

    #[test]
    fn a_full_queue_drops_and_counts_instead_of_blocking() {
        let (tx, _rx) = std::sync::mpsc::sync_channel(2);
        let sink = RecordSink {
            tx,
            dropped: Arc::new(AtomicU64::new(0)),
        };
        for _ in 0..5 {
            sink.push(Record::Cycle(CycleRecord::default()));
        }
        assert_eq!(sink.dropped(), 3);
    }
}
