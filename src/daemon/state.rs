//! The state file: what the axes have learned, kept across restarts.
//!
//! The cycle never touches the disk. Every `save_interval_s` it copies what its axes have
//! learned into one of two preallocated snapshots ([`StateSink::offer`], no allocation, never
//! blocks: when the writer is still busy with both, the offer is skipped); a writer thread turns
//! the snapshot into TOML and, when it differs from what the file holds, writes it atomically
//! (temporary file in the same folder, fsync, rename, fsync of the folder), so a power cut
//! leaves either the old file or the new one, never half of one. At start-up the daemon reads
//! the file back ([`load`]) and gives each axis what it learned ([`restore`]); an unreadable
//! file is set aside as `<file>.rejected` and the axes learn again.
//!
//! The file also keeps the pre-defined error field (1003h): the EMCYs the daemon sent, newest
//! first, each with its time. A change of the field is offered at once, not at the next
//! interval, so an error (or a clear over SDO) is on disk before the next restart can lose it.

use super::axis::Axis;
use super::config::NominalParameters;
use super::learned::AxisLearned;
use super::node::ControllerNode;
use crate::canopen::{ErrorEntry, ErrorField};
use crate::control::{LearnedTable, LearnedTableState};
use crate::supervise::{Nominal, PhysicalParameters, PHYSICAL_PARAMS};
use serde::{Deserialize, Serialize};
use std::cell::Cell;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};

/// Version of the file format; a file of another version is set aside, not misread.
pub const STATE_VERSION: u32 = 1;

/// Snapshots in flight between the cycle and the writer.
const SNAPSHOTS: usize = 2;

#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("{file}: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Parse { file: PathBuf, message: String },
    #[error("{file}: {key} {rule}")]
    Invalid {
        file: PathBuf,
        key: String,
        rule: String,
    },
}

/// The file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StateFile {
    pub version: u32,
    #[serde(default)]
    pub axis: Vec<AxisState>,
    /// The pre-defined error field (1003h), newest first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub error_history: Vec<ErrorState>,
}

/// One entry of the error history: an EMCY the daemon sent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ErrorState {
    pub error_code: u16,
    /// Bits 16..31 of the 1003h entry: the error register, and the axis node id above it.
    pub additional_info: u16,
    /// When the EMCY was sent: seconds since 1970-01-01 00:00 UTC, by the daemon's wall clock.
    pub time_unix_s: f64,
}

impl ErrorState {
    fn of(e: ErrorEntry) -> Self {
        Self {
            error_code: e.error_code,
            additional_info: e.additional_info,
            time_unix_s: e.time_s,
        }
    }

    pub fn entry(&self) -> ErrorEntry {
        ErrorEntry {
            error_code: self.error_code,
            additional_info: self.additional_info,
            time_s: self.time_unix_s,
        }
    }
}

fn error_history(field: &ErrorField) -> Vec<ErrorState> {
    field.iter().map(ErrorState::of).collect()
}

/// One axis in the file, found again by its name and actuator node id.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisState {
    pub name: String,
    pub actuator_node_id: u8,
    /// Adapted `U_comp+`, `U_comp-` (command unit).
    pub friction_compensation_pos: Option<f64>,
    pub friction_compensation_neg: Option<f64>,
    /// Learned nominal bands of the observer's `x4` per direction.
    pub observer_bands: Option<ObserverBandsState>,
    /// Nominal physical parameters of the parameter-estimation diagnosis, with the standard
    /// deviation of each nominal value and the spread of single windows seen while learning
    /// (in the order of `nominal`'s keys), which set the symptom thresholds.
    pub nominal: Option<NominalParameters>,
    pub nominal_deviation: Option<[f64; PHYSICAL_PARAMS]>,
    pub nominal_window_spread: Option<[f64; PHYSICAL_PARAMS]>,
    /// The learned table of tuned parameters by operating point.
    pub learned_table: Option<LearnedTableState>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverBandsState {
    pub x4_pos_low_m: f64,
    pub x4_pos_high_m: f64,
    pub x4_neg_low_m: f64,
    pub x4_neg_high_m: f64,
}

impl AxisState {
    fn from_axis(name: &str, node: u8, l: &AxisLearned, table: Option<&LearnedTable>) -> Self {
        Self {
            name: name.to_string(),
            actuator_node_id: node,
            friction_compensation_pos: l.friction_compensation.map(|f| f.0),
            friction_compensation_neg: l.friction_compensation.map(|f| f.1),
            observer_bands: l.observer_bands.map(|[p, n]| ObserverBandsState {
                x4_pos_low_m: p.0,
                x4_pos_high_m: p.1,
                x4_neg_low_m: n.0,
                x4_neg_high_m: n.1,
            }),
            nominal: l.nominal.map(|n| {
                let v = n.p.values;
                NominalParameters {
                    current_time_constant_s: v[0],
                    damping_ratio: v[1],
                    natural_frequency_rad_per_s: v[2],
                    static_gain_m_per_v: v[3],
                    coulomb_friction_n: v[4],
                    pretension_n: v[5],
                }
            }),
            nominal_deviation: l.nominal.map(|n| n.deviation),
            nominal_window_spread: l.nominal.map(|n| n.window_spread),
            learned_table: table
                .filter(|t| t.populated_cells() > 0)
                .map(LearnedTable::to_state),
        }
    }

    fn learned(&self) -> AxisLearned {
        AxisLearned {
            friction_compensation: self
                .friction_compensation_pos
                .zip(self.friction_compensation_neg),
            observer_bands: self.observer_bands.map(|b| {
                [
                    (b.x4_pos_low_m, b.x4_pos_high_m),
                    (b.x4_neg_low_m, b.x4_neg_high_m),
                ]
            }),
            // Without the spreads (a hand-written file) the values count as exact.
            nominal: self.nominal.map(|n| Nominal {
                p: PhysicalParameters { values: n.values() },
                deviation: self.nominal_deviation.unwrap_or([0.0; PHYSICAL_PARAMS]),
                window_spread: self.nominal_window_spread.unwrap_or([0.0; PHYSICAL_PARAMS]),
            }),
        }
    }
}

impl StateFile {
    /// What the axes of `node` have learned. Allocates: for start-up, shutdown and tests.
    pub fn of_node(node: &ControllerNode) -> Self {
        Self {
            version: STATE_VERSION,
            axis: node
                .axes()
                .iter()
                .map(|a| {
                    AxisState::from_axis(
                        &a.name,
                        a.actuator_node_id,
                        &a.learned(),
                        a.learned_table(),
                    )
                })
                .collect(),
            error_history: error_history(node.error_field()),
        }
    }

    /// The error history as the daemon's 1003h held it.
    pub fn error_field(&self) -> ErrorField {
        ErrorField::from_newest_first(self.error_history.iter().map(ErrorState::entry))
    }

    /// The file's text, with a header saying what it is.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        Ok(format!(
            "# actuatord: what the axes have learned, and the daemon's error history (1003h).\n\
             # Written by the daemon (atomically); edit only while it is stopped. Delete it to\n\
             # make every axis learn again and forget the errors.\n{}",
            toml::to_string(self)?
        ))
    }

    /// Parse and check the text of `file`.
    pub fn from_toml(text: &str, file: &Path) -> Result<Self, StateError> {
        let state: StateFile = toml::from_str(text).map_err(|e| StateError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })?;
        if state.version != STATE_VERSION {
            return Err(StateError::Invalid {
                file: file.to_path_buf(),
                key: "version".into(),
                rule: format!("is {}, this daemon reads {STATE_VERSION}", state.version),
            });
        }
        for (i, a) in state.axis.iter().enumerate() {
            if let Some(t) = &a.learned_table {
                LearnedTable::from_state(t).map_err(|e| StateError::Invalid {
                    file: file.to_path_buf(),
                    key: format!(
                        "{}[{i}] ({}).{}.{}",
                        crate::param_key!(StateFile, axis),
                        a.name,
                        crate::param_key!(AxisState, learned_table),
                        e.name
                    ),
                    rule: e.reason,
                })?;
            }
        }
        if let Some(i) = state
            .error_history
            .iter()
            .position(|e| !e.time_unix_s.is_finite())
        {
            return Err(StateError::Invalid {
                file: file.to_path_buf(),
                key: format!(
                    "{}[{i}].{}",
                    crate::param_key!(StateFile, error_history),
                    crate::param_key!(ErrorState, time_unix_s)
                ),
                rule: "must be a finite time".into(),
            });
        }
        Ok(state)
    }
}

/// Read the state file; `Ok(None)` when there is none yet.
pub fn load(file: &Path) -> Result<Option<StateFile>, StateError> {
    match std::fs::read_to_string(file) {
        Ok(text) => StateFile::from_toml(&text, file).map(Some),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(StateError::Io {
            file: file.to_path_buf(),
            source,
        }),
    }
}

/// Set an unreadable state file aside (`<file>.rejected`) so the next save does not destroy
/// what someone may want to look at; returns where it went.
pub fn set_aside(file: &Path) -> Result<PathBuf, StateError> {
    let mut aside = file.as_os_str().to_owned();
    aside.push(".rejected");
    let aside = PathBuf::from(aside);
    std::fs::rename(file, &aside).map_err(|source| StateError::Io {
        file: file.to_path_buf(),
        source,
    })?;
    Ok(aside)
}

/// Give each axis of `node` what the file holds for it (same name and actuator node id), and
/// the node its error history. Returns one line per axis restored, and per part that did not
/// fit (another grid), and one for the error history when it holds errors.
pub fn restore(node: &mut ControllerNode, state: &StateFile, file: &Path) -> Vec<String> {
    let mut lines = Vec::new();
    let field = state.error_field();
    if !field.is_empty() {
        lines.push(format!(
            "{}: {} errors of earlier runs in the error history (1003h)",
            file.display(),
            field.len()
        ));
    }
    node.restore_error_field(field);
    for axis in node.axes_mut() {
        let Some((i, s)) = state
            .axis
            .iter()
            .enumerate()
            .find(|(_, s)| s.name == axis.name && s.actuator_node_id == axis.actuator_node_id)
        else {
            continue;
        };
        lines.push(restore_axis(axis, i, s, file));
    }
    lines
}

fn restore_axis(axis: &mut Axis, i: usize, s: &AxisState, file: &Path) -> String {
    axis.restore_learned(&s.learned());
    let mut line = format!(
        "{}: axis {} restored what it learned",
        file.display(),
        axis.name
    );
    if let Some(t) = &s.learned_table {
        let key = format!(
            "{}[{i}].{}",
            crate::param_key!(StateFile, axis),
            crate::param_key!(AxisState, learned_table)
        );
        match LearnedTable::from_state(t) {
            Ok(table) if axis.restore_learned_table(&table) => {
                line += &format!(" (learned table: {} cells)", table.populated_cells());
            }
            Ok(_) => {
                line += &format!("; {key} not taken: the axis has another grid or none");
            }
            Err(e) => line += &format!("; {key}.{}: {}", e.name, e.reason),
        }
    }
    line
}

/// Write `text` to `file` so that the file is always either the old or the new text.
pub fn write_atomic(file: &Path, text: &str) -> Result<(), StateError> {
    let io = |source| StateError::Io {
        file: file.to_path_buf(),
        source,
    };
    let folder = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut tmp_name = file
        .file_name()
        .map(|n| n.to_owned())
        .unwrap_or_else(|| "state".into());
    tmp_name.push(".tmp");
    let tmp = folder.join(tmp_name);
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(text.as_bytes()).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, file).map_err(io)?;
    // The rename itself must reach the disk too.
    std::fs::File::open(folder)
        .and_then(|d| d.sync_all())
        .map_err(io)?;
    Ok(())
}

/// A copy of what one axis has learned, sized once so filling it does not allocate.
#[derive(Debug, Clone)]
struct AxisSnapshot {
    learned: AxisLearned,
    table: Option<LearnedTable>,
    table_valid: bool,
}

/// What every axis of a node has learned at one moment.
#[derive(Debug, Clone)]
pub struct Snapshot {
    axes: Vec<AxisSnapshot>,
    names: Vec<(String, u8)>,
    errors: ErrorField,
}

impl Snapshot {
    fn of(node: &ControllerNode) -> Self {
        Self {
            axes: node
                .axes()
                .iter()
                .map(|a| AxisSnapshot {
                    learned: a.learned(),
                    table: a.learned_table().cloned(),
                    table_valid: true,
                })
                .collect(),
            names: node
                .axes()
                .iter()
                .map(|a| (a.name.clone(), a.actuator_node_id))
                .collect(),
            errors: *node.error_field(),
        }
    }

    /// Copy what the axes have learned now; allocation-free while the axes keep the grids the
    /// snapshot was sized for (a reload that changes a grid costs one allocation here).
    fn fill(&mut self, node: &ControllerNode) {
        self.errors = *node.error_field();
        for (s, a) in self.axes.iter_mut().zip(node.axes()) {
            s.learned = a.learned();
            s.table_valid = match (s.table.as_mut(), a.learned_table()) {
                (Some(dst), Some(src)) => {
                    dst.copy_cells_from(src) || {
                        *dst = src.clone();
                        true
                    }
                }
                (None, Some(src)) => {
                    s.table = Some(src.clone());
                    true
                }
                (_, None) => false,
            };
        }
    }

    fn to_file(&self) -> StateFile {
        StateFile {
            version: STATE_VERSION,
            axis: self
                .axes
                .iter()
                .zip(&self.names)
                .map(|(s, (name, node))| {
                    let table = s.table.as_ref().filter(|_| s.table_valid);
                    AxisState::from_axis(name, *node, &s.learned, table)
                })
                .collect(),
            error_history: error_history(&self.errors),
        }
    }
}

/// The cycle's end of the state writer.
pub struct StateSink {
    full: SyncSender<Snapshot>,
    empty: Receiver<Snapshot>,
    every_cycles: u64,
    /// The error field's change count in the last offer that reached the writer.
    errors_offered: Cell<u64>,
}

impl StateSink {
    /// Cycles between offers.
    pub fn every_cycles(&self) -> u64 {
        self.every_cycles
    }

    /// Whether the node's error field changed since the last offer: an offer is due now.
    pub fn errors_changed(&self, node: &ControllerNode) -> bool {
        self.errors_offered.get() != node.error_field().changes()
    }

    /// Hand what the axes learned to the writer, if it has a free snapshot; never blocks.
    pub fn offer(&self, node: &ControllerNode) {
        let Ok(mut snapshot) = self.empty.try_recv() else {
            return;
        };
        snapshot.fill(node);
        match self.full.try_send(snapshot) {
            Ok(()) | Err(TrySendError::Disconnected(_)) => {
                self.errors_offered.set(node.error_field().changes());
            }
            // Cannot happen with two snapshots and a queue of two; dropping it loses one offer.
            Err(TrySendError::Full(_)) => {}
        }
    }

    /// The last offer, when the cycle has ended: waits for a free snapshot.
    pub fn finish(self, node: &ControllerNode) {
        if let Ok(mut snapshot) = self.empty.recv() {
            snapshot.fill(node);
            let _ = self.full.send(snapshot);
        }
    }
}

/// The writer thread.
pub struct StateWriter {
    thread: std::thread::JoinHandle<WriterReport>,
}

/// What the writer did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WriterReport {
    pub writes: u64,
    pub unchanged: u64,
    pub errors: u64,
    pub last_error: Option<String>,
}

impl StateWriter {
    /// Start the writer for `file`, with snapshots sized for `node`'s axes.
    pub fn spawn(
        file: &Path,
        node: &ControllerNode,
        every_cycles: u64,
    ) -> std::io::Result<(StateSink, StateWriter)> {
        let (full_tx, full_rx) = std::sync::mpsc::sync_channel::<Snapshot>(SNAPSHOTS);
        let (empty_tx, empty_rx) = std::sync::mpsc::sync_channel::<Snapshot>(SNAPSHOTS);
        for _ in 0..SNAPSHOTS {
            // The queue holds both: this cannot fail.
            let _ = empty_tx.try_send(Snapshot::of(node));
        }
        let file = file.to_path_buf();
        let thread = std::thread::Builder::new()
            .name("state-writer".into())
            .spawn(move || write_loop(&file, &full_rx, &empty_tx))?;
        Ok((
            StateSink {
                full: full_tx,
                empty: empty_rx,
                every_cycles: every_cycles.max(1),
                errors_offered: Cell::new(node.error_field().changes()),
            },
            StateWriter { thread },
        ))
    }

    /// Wait until the last snapshot is written (after the sink is finished or dropped).
    pub fn finish(self) -> WriterReport {
        self.thread.join().unwrap_or_else(|_| WriterReport {
            errors: 1,
            last_error: Some("the state writer panicked".into()),
            ..Default::default()
        })
    }
}

fn write_loop(
    file: &Path,
    full: &Receiver<Snapshot>,
    empty: &SyncSender<Snapshot>,
) -> WriterReport {
    let mut report = WriterReport::default();
    let mut last = std::fs::read_to_string(file).ok();
    while let Ok(snapshot) = full.recv() {
        let result = snapshot.to_file().to_toml();
        // The snapshot goes back at once, so the cycle has one while the disk is slow.
        let _ = empty.try_send(snapshot);
        let text = match result {
            Ok(t) => t,
            Err(e) => {
                note_error(&mut report, format!("{}: {e}", file.display()));
                continue;
            }
        };
        if last.as_deref() == Some(text.as_str()) {
            report.unchanged += 1;
            continue;
        }
        match write_atomic(file, &text) {
            Ok(()) => {
                report.writes += 1;
                last = Some(text);
            }
            Err(e) => note_error(&mut report, e.to_string()),
        }
    }
    report
}

/// Log an error once per different message, so a read-only disk does not flood the journal.
fn note_error(report: &mut WriterReport, message: String) {
    report.errors += 1;
    if report.last_error.as_deref() != Some(message.as_str()) {
        tracing::error!("state file not written: {message}");
        report.last_error = Some(message);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::Config;

    /// The shipped solenoid axis with the learned table its file describes.
    fn node() -> ControllerNode {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/solenoid.toml");
        let text = std::fs::read_to_string(&file).expect("config")
            + "[axis.learned_table]\nposition_edges_m = [0.0, 0.006, 0.012, 0.025]\n\
               supply_voltage_edges_v = [18.0, 24.0, 32.0]\n";
        let config = Config::from_toml(&text, &file).expect("config");
        ControllerNode::new(&config).expect("node")
    }

    fn learned() -> AxisLearned {
        AxisLearned {
            friction_compensation: Some((0.21, 0.17)),
            observer_bands: Some([(-3e-4, -1e-4), (1e-4, 2.5e-4)]),
            nominal: Some(Nominal {
                p: crate::supervise::PhysicalParameters {
                    values: [0.0086, 1.4, 57.0, 0.001, 0.2, 1.5],
                },
                deviation: [1e-4, 0.01, 0.2, 1e-6, 0.02, 0.01],
                window_spread: [3e-4, 0.02, 0.4, 2e-6, 0.03, 0.02],
            }),
        }
    }

    /// A node whose axis has learned `learned()` and two cells of its table.
    fn taught() -> ControllerNode {
        let mut n = node();
        let axis = &mut n.axes_mut()[0];
        axis.restore_learned(&learned());
        let mut table = axis.learned_table().expect("configured").clone();
        let op = |y| crate::control::OperatingPoint {
            position_m: y,
            load_n: 0.0,
            supply: 24.0,
        };
        table.learn(&op(0.003), &[0.2, 0.18]);
        table.learn(&op(0.015), &[0.25, 0.22]);
        assert!(axis.restore_learned_table(&table));
        n
    }

    #[test]
    fn what_an_axis_learned_goes_through_the_file_and_back() {
        let n = taught();
        let file = StateFile::of_node(&n);
        let text = file.to_toml().expect("toml");
        let back = StateFile::from_toml(&text, Path::new("s.toml")).expect("parses");
        assert_eq!(back, file);
        let mut fresh = node();
        assert_ne!(
            fresh.axes()[0].learned(),
            learned(),
            "a new axis starts afresh"
        );
        let lines = restore(&mut fresh, &back, Path::new("s.toml"));
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(lines[0].contains("learned table: 2 cells"), "{lines:?}");
        let a = &fresh.axes()[0];
        assert_eq!(a.learned(), learned());
        assert_eq!(
            a.learned_table().map(LearnedTable::populated_cells),
            Some(2)
        );
        assert_eq!(StateFile::of_node(&fresh), file);
    }

    #[test]
    fn an_axis_of_another_name_or_node_is_left_alone() {
        let mut file = StateFile::of_node(&taught());
        file.axis[0].actuator_node_id = 17;
        let mut fresh = node();
        let before = fresh.axes()[0].learned();
        assert!(restore(&mut fresh, &file, Path::new("s.toml")).is_empty());
        assert_eq!(fresh.axes()[0].learned(), before);
    }

    #[test]
    fn a_bad_file_is_refused_with_the_file_and_key() {
        let file = Path::new("/var/lib/actuatord/s.toml");
        let e = StateFile::from_toml("version = 7\n", file).expect_err("version");
        assert_eq!(
            e.to_string(),
            "/var/lib/actuatord/s.toml: version is 7, this daemon reads 1"
        );
        let mut s = StateFile::of_node(&taught());
        if let Some(t) = s.axis[0].learned_table.as_mut() {
            t.cells[0].position_band = 9;
        }
        let text = s.to_toml().expect("toml");
        let e = StateFile::from_toml(&text, file).expect_err("cell outside the grid");
        assert!(
            e.to_string()
                .starts_with("/var/lib/actuatord/s.toml: axis[0] (solenoid).learned_table.cells"),
            "{e}"
        );
        let e = StateFile::from_toml("version = 1\nfriction = 2\n", file).expect_err("key");
        assert!(e.to_string().contains("friction"), "{e}");
    }

    #[test]
    fn the_writer_keeps_the_last_offer_and_skips_unchanged_ones() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = dir.path().join("state.toml");
        let n = taught();
        let (sink, writer) = StateWriter::spawn(&file, &n, 1).expect("spawn");
        sink.offer(&n);
        sink.finish(&n);
        let report = writer.finish();
        assert_eq!(report.errors, 0, "{report:?}");
        assert!(report.writes >= 1, "{report:?}");
        assert!(report.writes + report.unchanged == 2, "{report:?}");
        let back = load(&file).expect("readable").expect("written");
        assert_eq!(back, StateFile::of_node(&n));
        assert!(!dir.path().join("state.toml.tmp").exists());
        // Same values again: the file is not rewritten.
        let (sink, writer) = StateWriter::spawn(&file, &n, 1).expect("spawn");
        sink.finish(&n);
        assert_eq!(writer.finish().unchanged, 1);
    }

    #[test]
    fn the_error_history_goes_through_the_file_newest_first_with_its_times() {
        let mut n = node();
        let mut field = ErrorField::default();
        let entry = |code, info, t| ErrorEntry {
            error_code: code,
            additional_info: info,
            time_s: t,
        };
        field.push(entry(0x8611, 0x1081, 1_700_000_000.25));
        field.push(entry(0x8250, 0x1011, 1_700_000_060.5));
        n.restore_error_field(field);
        let text = StateFile::of_node(&n).to_toml().expect("toml");
        let at = |needle: &str| {
            text.find(needle)
                .unwrap_or_else(|| panic!("{needle}: {text}"))
        };
        // 8250h = 33360 first, 8611h = 34321 after it.
        assert!(
            at("error_code = 33360") < at("error_code = 34321"),
            "{text}"
        );
        assert!(text.contains("time_unix_s = 1700000060.5"), "{text}");
        let back = StateFile::from_toml(&text, Path::new("s.toml")).expect("parses");
        assert_eq!(
            back.error_field().iter().collect::<Vec<_>>(),
            field.iter().collect::<Vec<_>>()
        );
        let mut fresh = node();
        let lines = restore(&mut fresh, &back, Path::new("s.toml"));
        assert!(
            lines
                .iter()
                .any(|l| l == "s.toml: 2 errors of earlier runs in the error history (1003h)"),
            "{lines:?}"
        );
        assert_eq!(
            fresh.error_field().iter().collect::<Vec<_>>(),
            field.iter().collect::<Vec<_>>()
        );
        // A file from before the history reads as an empty one.
        let old = StateFile::from_toml("version = 1\n", Path::new("s.toml")).expect("parses");
        assert!(old.error_field().is_empty());

        let bad = text.replace("1700000060.5", "nan");
        let e = StateFile::from_toml(&bad, Path::new("/var/lib/actuatord/s.toml"))
            .expect_err("no time");
        assert_eq!(
            e.to_string(),
            "/var/lib/actuatord/s.toml: error_history[0].time_unix_s must be a finite time"
        );
        let bad = text.replace("error_code = 33360", "error_code = 70000");
        let e = StateFile::from_toml(&bad, Path::new("/var/lib/actuatord/s.toml"))
            .expect_err("16 bits");
        assert!(
            e.to_string().starts_with("/var/lib/actuatord/s.toml: "),
            "{e}"
        );
        assert!(e.to_string().contains("error_code"), "{e}");
    }

    #[test]
    fn a_missing_file_is_none_and_an_unreadable_one_is_set_aside() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = dir.path().join("state.toml");
        assert!(load(&file).expect("no file is fine").is_none());
        std::fs::write(&file, "not toml [").expect("write");
        assert!(load(&file).is_err());
        let aside = set_aside(&file).expect("renamed");
        assert_eq!(std::fs::read_to_string(aside).expect("kept"), "not toml [");
        assert!(!file.exists());
    }

    #[test]
    fn a_write_error_names_the_file() {
        let e = write_atomic(Path::new("/nonexistent-dir/state.toml"), "x").expect_err("no dir");
        assert!(
            e.to_string().starts_with("/nonexistent-dir/state.toml: "),
            "{e}"
        );
    }
}
