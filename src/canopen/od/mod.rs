//! The object dictionary (CiA 301 §7.4): every parameter, result and statistic the node exposes,
//! addressed by a 16-bit index and an 8-bit subindex, with its type, unit, access and bounds.
//!
//! # How live values are bound without locks
//!
//! The dictionary is plain data owned by the controller node, in the real-time thread, next to
//! the SDO server; nothing in it is shared or locked.
//!
//! - **Reads** see a snapshot: the node [`publish`](ObjectDictionary::publish)es the values it
//!   owns (counters, fault state, estimates, statistics) through [`Handle`]s it resolved once at
//!   start, at whatever rate it likes (each cycle, or each status period). An SDO upload copies
//!   one value out of that snapshot at its first frame, so a segmented read is consistent even
//!   while the node keeps publishing.
//! - **Writes** are staged: an SDO download is decoded, type-, range- and state-checked as a whole
//!   and only then staged ([`stage_write`](ObjectDictionary::stage_write)). A segmented download
//!   stages nothing until its last segment has arrived, so a value is never half-written. The
//!   node takes every staged write at a cycle boundary with
//!   [`take_pending_writes`](ObjectDictionary::take_pending_writes) and applies them together
//!   before the next cycle runs. A staged value is not visible to reads until it is taken, so a
//!   read always tells what the node runs with.
//!
//! Nothing here allocates after [`ObjectDictionaryBuilder::build`]: values are `Copy`, strings
//! are inline, and the staging area has one slot per writable entry (a second write to the same
//! entry before the boundary replaces the first).

mod builder;
mod table;
mod value;

pub use builder::{BuildError, EntrySpec, ObjectDictionaryBuilder};
pub use table::markdown_table;
pub use value::{
    format_hex, parse_hex, DataType, Value, ValueError, VisibleString, STRING_CAPACITY,
};

use super::nmt::NmtState;
use std::fmt;

/// Where an entry lives: index and subindex (CiA 301 §7.4.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObjectId {
    pub index: u16,
    pub sub: u8,
}

impl ObjectId {
    pub const fn new(index: u16, sub: u8) -> Self {
        Self { index, sub }
    }

    /// Read `INDEX:SUB` as the tools take it; both numbers are hexadecimal as in CiA documents
    /// and EDS section names, with or without `0x` (`1018:4`, `0x2001:0x0d`, `2001:d`).
    pub fn parse(text: &str) -> Option<Self> {
        let (i, s) = text.trim().split_once(':')?;
        let hex = |t: &str| {
            let t = t.trim();
            let t = t
                .strip_prefix("0x")
                .or_else(|| t.strip_prefix("0X"))
                .unwrap_or(t);
            u32::from_str_radix(t, 16).ok()
        };
        Some(Self {
            index: u16::try_from(hex(i)?).ok()?,
            sub: u8::try_from(hex(s)?).ok()?,
        })
    }
}

/// `2001:0D`, the form [`ObjectId::parse`] reads.
impl fmt::Display for ObjectId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04X}:{:02X}", self.index, self.sub)
    }
}

/// Who may read and write an entry, and when.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Read only: results, statistics, identity.
    ReadOnly,
    /// Read and write in any state that serves SDO.
    ReadWrite,
    /// Read always; write only while the node is not operational. For safety-relevant
    /// parameters (controller, limits, safe command): change them with the axes stopped.
    ReadWritePreOperational,
    /// Write only: commands such as a fault reset.
    WriteOnly,
}

impl Access {
    pub fn readable(self) -> bool {
        self != Access::WriteOnly
    }

    pub fn writable(self) -> bool {
        self != Access::ReadOnly
    }

    /// Short name used in the table: `ro`, `rw`, `rw-preop`, `wo`.
    pub fn name(self) -> &'static str {
        match self {
            Access::ReadOnly => "ro",
            Access::ReadWrite => "rw",
            Access::ReadWritePreOperational => "rw-preop",
            Access::WriteOnly => "wo",
        }
    }
}

/// Object code (CiA 301 Table 42): one variable, or a group behind subindex 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectKind {
    /// VAR: a single value at subindex 0.
    Var,
    /// ARRAY: subindex 0 holds the highest subindex; entries 1..=n share one type.
    Array,
    /// RECORD: subindex 0 holds the highest subindex; entries 1..=n have their own types.
    Record,
}

impl ObjectKind {
    /// The object code as written in an EDS `ObjectType=`.
    pub fn code(self) -> u8 {
        match self {
            ObjectKind::Var => 0x7,
            ObjectKind::Array => 0x8,
            ObjectKind::Record => 0x9,
        }
    }
}

/// One object: a VAR, or an ARRAY/RECORD with its sub-entries.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    pub index: u16,
    /// Unique in the dictionary, snake_case; per-axis objects are `axis<N>_<group>`.
    pub name: String,
    pub kind: ObjectKind,
    /// The axis (0-based) a manufacturer object belongs to; `None` for node-wide objects.
    pub axis: Option<usize>,
    entries: std::ops::Range<usize>,
}

/// One addressable value.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub id: ObjectId,
    /// snake_case, the same word as the config key or DBC signal; unique within its object.
    pub name: &'static str,
    pub data_type: DataType,
    /// SI unit (`m`, `N`, `s`, `us`, `V`...), empty when dimensionless.
    pub unit: &'static str,
    pub access: Access,
    /// Inclusive bounds for numeric types; `None` is unbounded (reals still refuse NaN).
    pub min: Option<Value>,
    pub max: Option<Value>,
    /// The value at start-up (for a configured parameter: the configured value).
    pub default: Value,
    pub pdo_mappable: bool,
    pub description: &'static str,
    /// The axis (0-based) of its object, `None` if node-wide.
    pub axis: Option<usize>,
}

/// A resolved position in the dictionary: the node looks entries up once and then publishes
/// and matches by handle, without searching.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Handle(usize);

/// Why a read or write is refused; the SDO server turns each into its abort code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum OdError {
    #[error("object does not exist")]
    NoObject,
    #[error("subindex does not exist")]
    NoSubIndex,
    #[error("object is read-only")]
    ReadOnly,
    #[error("object is write-only")]
    WriteOnly,
    #[error("length does not match the data type")]
    WrongLength,
    #[error("value out of range")]
    OutOfRange,
    #[error("value too high")]
    TooHigh,
    #[error("value too low")]
    TooLow,
    #[error("writable only while not operational")]
    RefusedInState,
    #[error("value of type {got} given for an entry of type {expected}")]
    TypeMismatch { expected: DataType, got: DataType },
}

/// A write that passed every check, waiting for the cycle boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PendingWrite {
    pub handle: Handle,
    pub id: ObjectId,
    /// Axis of the entry, `None` if node-wide; with `name` it says what to change.
    pub axis: Option<usize>,
    pub name: &'static str,
    pub value: Value,
}

/// The dictionary: objects sorted by index, entries by (index, subindex), one value per entry.
#[derive(Debug, Clone)]
pub struct ObjectDictionary {
    objects: Vec<Object>,
    entries: Vec<Entry>,
    values: Vec<Value>,
    pending: Vec<PendingWrite>,
    /// Pairs (low, high) that must stay strictly ordered, e.g. output_min < output_max.
    ordered: Vec<(Handle, Handle)>,
}

impl ObjectDictionary {
    pub fn builder() -> ObjectDictionaryBuilder {
        ObjectDictionaryBuilder::default()
    }

    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Every entry, sorted by index then subindex.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The entries of one object, subindex 0 first.
    pub fn object_entries(&self, object: &Object) -> &[Entry] {
        &self.entries[object.entries.clone()]
    }

    pub fn object(&self, index: u16) -> Option<&Object> {
        self.objects
            .binary_search_by_key(&index, |o| o.index)
            .ok()
            .map(|i| &self.objects[i])
    }

    /// The handle of an entry, or which level of the address is missing.
    pub fn find(&self, id: ObjectId) -> Result<Handle, OdError> {
        match self.entries.binary_search_by_key(&id, |e| e.id) {
            Ok(i) => Ok(Handle(i)),
            Err(_) if self.object(id.index).is_some() => Err(OdError::NoSubIndex),
            Err(_) => Err(OdError::NoObject),
        }
    }

    pub fn handle(&self, id: ObjectId) -> Option<Handle> {
        self.find(id).ok()
    }

    /// The handle of a named entry of `axis` (`None` = node-wide), e.g. `(Some(0), "q0_per_m")`.
    pub fn handle_by_name(&self, axis: Option<usize>, name: &str) -> Option<Handle> {
        self.entries
            .iter()
            .position(|e| {
                e.axis == axis && e.name == name && (e.id.sub != 0 || self.is_var(e.id.index))
            })
            .map(Handle)
    }

    /// Resolve what a user typed: `INDEX:SUB` (hex, see [`ObjectId::parse`]), `object.entry`
    /// (`axis0_controller.q0_per_m`) or the name of a VAR object (`producer_heartbeat_time`).
    pub fn lookup(&self, text: &str) -> Result<Handle, OdError> {
        if let Some(id) = ObjectId::parse(text) {
            return self.find(id);
        }
        let (object_name, entry_name) = match text.split_once('.') {
            Some((o, e)) => (o, Some(e)),
            None => (text, None),
        };
        let object = self
            .objects
            .iter()
            .find(|o| o.name == object_name)
            .ok_or(OdError::NoObject)?;
        let entries = self.object_entries(object);
        let found = match entry_name {
            Some(name) => entries.iter().find(|e| e.name == name),
            None if object.kind == ObjectKind::Var => entries.first(),
            None => None,
        };
        found
            .and_then(|e| self.handle(e.id))
            .ok_or(OdError::NoSubIndex)
    }

    fn is_var(&self, index: u16) -> bool {
        self.object(index)
            .is_some_and(|o| o.kind == ObjectKind::Var)
    }

    pub fn entry(&self, handle: Handle) -> &Entry {
        &self.entries[handle.0]
    }

    /// The value reads see now (the last published or taken one).
    pub fn value(&self, handle: Handle) -> Value {
        self.values[handle.0]
    }

    /// Look up and check an SDO read: the entry must exist and be readable.
    pub fn read(&self, id: ObjectId) -> Result<Value, OdError> {
        let h = self.find(id)?;
        if !self.entries[h.0].access.readable() {
            return Err(OdError::WriteOnly);
        }
        Ok(self.values[h.0])
    }

    /// The node's side: set the value reads will see. Type-checked, not range-checked (the node
    /// reports what is, e.g. a counter that wrapped); never staged.
    pub fn publish(&mut self, handle: Handle, value: impl Into<Value>) -> Result<(), OdError> {
        let value = value.into();
        let expected = self.entries[handle.0].data_type;
        if value.data_type() != expected {
            return Err(OdError::TypeMismatch {
                expected,
                got: value.data_type(),
            });
        }
        self.values[handle.0] = value;
        Ok(())
    }

    /// Check where a write to `id` would go, before its data arrives (used at the first frame
    /// of a segmented download so a refused write fails early).
    pub fn check_writable(&self, id: ObjectId, state: NmtState) -> Result<Handle, OdError> {
        let h = self.find(id)?;
        match self.entries[h.0].access {
            Access::ReadOnly => Err(OdError::ReadOnly),
            Access::ReadWritePreOperational if state == NmtState::Operational => {
                Err(OdError::RefusedInState)
            }
            _ => Ok(h),
        }
    }

    /// An SDO write: decode `bytes` as the entry's type, check access in `state`, bounds and
    /// ordering, then stage it for the next [`take_pending_writes`](Self::take_pending_writes).
    /// On any error nothing is staged.
    pub fn stage_write(
        &mut self,
        id: ObjectId,
        bytes: &[u8],
        state: NmtState,
    ) -> Result<(), OdError> {
        let h = self.check_writable(id, state)?;
        let entry = &self.entries[h.0];
        let value = Value::decode(entry.data_type, bytes).map_err(|e| match e {
            ValueError::WrongLength { .. } => OdError::WrongLength,
            ValueError::BadString if bytes.len() > STRING_CAPACITY => OdError::WrongLength,
            _ => OdError::OutOfRange,
        })?;
        self.stage_value(h, value, state)
    }

    /// Stage an already typed value (the same checks as [`stage_write`](Self::stage_write)).
    pub fn stage_value(&mut self, h: Handle, value: Value, state: NmtState) -> Result<(), OdError> {
        let entry = &self.entries[h.0];
        self.check_writable(entry.id, state)?;
        if value.data_type() != entry.data_type {
            return Err(OdError::TypeMismatch {
                expected: entry.data_type,
                got: value.data_type(),
            });
        }
        check_bounds(entry, &value)?;
        self.check_order(h, &value)?;
        let write = PendingWrite {
            handle: h,
            id: entry.id,
            axis: entry.axis,
            name: entry.name,
            value,
        };
        match self.pending.iter_mut().find(|w| w.handle == h) {
            Some(slot) => *slot = write,
            // Capacity is the number of writable entries, so this never reallocates.
            None => self.pending.push(write),
        }
        Ok(())
    }

    /// The value a write would be checked against: staged if any, else the current one.
    fn effective(&self, h: Handle) -> Value {
        self.pending
            .iter()
            .find(|w| w.handle == h)
            .map_or(self.values[h.0], |w| w.value)
    }

    fn check_order(&self, h: Handle, value: &Value) -> Result<(), OdError> {
        let v = value.as_f64();
        for &(lo, hi) in &self.ordered {
            if lo == h {
                if let (Some(v), Some(other)) = (v, self.effective(hi).as_f64()) {
                    if v >= other {
                        return Err(OdError::TooHigh);
                    }
                }
            } else if hi == h {
                if let (Some(v), Some(other)) = (v, self.effective(lo).as_f64()) {
                    if v <= other {
                        return Err(OdError::TooLow);
                    }
                }
            }
        }
        Ok(())
    }

    /// Writes staged since the last call, in arrival order (a rewrite keeps its first place).
    pub fn pending_writes(&self) -> &[PendingWrite] {
        &self.pending
    }

    /// The cycle boundary: every staged write becomes the current value at once, and is handed
    /// to the node to apply. Dropping the iterator early still clears the staging area.
    pub fn take_pending_writes(&mut self) -> std::vec::Drain<'_, PendingWrite> {
        for w in &self.pending {
            self.values[w.handle.0] = w.value;
        }
        self.pending.drain(..)
    }

    /// Take over from the dictionary this one replaces (same layout, rebuilt from a new
    /// configuration): the values it published (read-only entries) stay readable until they are
    /// published again, and writes staged on it are staged here. Allocation-free: the staging
    /// area holds one slot per writable entry. An entry the new table lacks, or types differently,
    /// is left as built.
    pub fn carry_over_from(&mut self, old: &mut ObjectDictionary) {
        for (e, v) in old.entries.iter().zip(&old.values) {
            if e.access != Access::ReadOnly {
                continue;
            }
            if let Some(h) = self.handle(e.id) {
                if self.entries[h.0].data_type == e.data_type {
                    self.values[h.0] = *v;
                }
            }
        }
        for w in old.pending.drain(..) {
            let Some(h) = self.handle(w.id) else { continue };
            if self.entries[h.0].data_type != w.value.data_type() {
                continue;
            }
            let moved = PendingWrite { handle: h, ..w };
            match self.pending.iter_mut().find(|p| p.handle == h) {
                Some(slot) => *slot = moved,
                None => self.pending.push(moved),
            }
        }
    }

    /// Drop every staged write (e.g. on an NMT reset).
    pub fn discard_pending_writes(&mut self) {
        self.pending.clear();
    }

    /// Set every value back to its default, dropping staged writes.
    pub fn reset_to_defaults(&mut self) {
        for (v, e) in self.values.iter_mut().zip(&self.entries) {
            *v = e.default;
        }
        self.pending.clear();
    }
}

fn check_bounds(entry: &Entry, value: &Value) -> Result<(), OdError> {
    let Some(v) = value.as_f64() else {
        return Ok(());
    };
    if v.is_nan() {
        return Err(OdError::OutOfRange);
    }
    // An entry that takes one value only (1003h sub 0 takes 0, to clear the field) has no
    // "too high" or "too low": any other value is simply invalid.
    if let (Some(min), Some(max)) = (entry.min, entry.max) {
        if min == max && min.as_f64() != Some(v) {
            return Err(OdError::OutOfRange);
        }
    }
    if let Some(min) = entry.min.as_ref().and_then(Value::as_f64) {
        if v < min {
            return Err(OdError::TooLow);
        }
    }
    if let Some(max) = entry.max.as_ref().and_then(Value::as_f64) {
        if v > max {
            return Err(OdError::TooHigh);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
