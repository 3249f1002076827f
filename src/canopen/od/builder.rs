//! Building an [`ObjectDictionary`]: objects described with [`EntrySpec`]s, subindexes
//! assigned, and every rule of the table checked once, at [`ObjectDictionaryBuilder::build`].

use super::{
    check_bounds, Access, DataType, Entry, Object, ObjectDictionary, ObjectId, ObjectKind, Value,
};

/// A dictionary that cannot be built.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BuildError {
    #[error("object {index:04X}h is defined twice")]
    DuplicateIndex { index: u16 },
    #[error("object name {0} is used twice")]
    DuplicateObjectName(String),
    #[error("{object}: entry name {name} is used twice")]
    DuplicateEntryName { object: String, name: &'static str },
    #[error("{id} {name}: {problem}")]
    BadEntry {
        id: ObjectId,
        name: &'static str,
        problem: String,
    },
    #[error("object {0:04X}h has no entries")]
    EmptyObject(u16),
    #[error("ordered pair {0} < {1}: no such entries")]
    BadOrder(ObjectId, ObjectId),
}

/// A sub-entry description for the builder.
#[derive(Debug, Clone, PartialEq)]
pub struct EntrySpec {
    pub name: &'static str,
    pub data_type: DataType,
    pub unit: &'static str,
    pub access: Access,
    pub min: Option<Value>,
    pub max: Option<Value>,
    pub default: Value,
    pub pdo_mappable: bool,
    pub description: &'static str,
}

impl EntrySpec {
    /// An entry whose type is the default's type, without bounds, unit or description.
    pub fn new(name: &'static str, access: Access, default: impl Into<Value>) -> Self {
        let default = default.into();
        Self {
            name,
            data_type: default.data_type(),
            unit: "",
            access,
            min: None,
            max: None,
            default,
            pdo_mappable: false,
            description: "",
        }
    }

    /// A read-only result; the default is its value until the node publishes one.
    pub fn ro(name: &'static str, default: impl Into<Value>) -> Self {
        Self::new(name, Access::ReadOnly, default)
    }

    pub fn rw(name: &'static str, default: impl Into<Value>) -> Self {
        Self::new(name, Access::ReadWrite, default)
    }

    /// A safety-relevant parameter: writes refused while operational.
    pub fn rw_preop(name: &'static str, default: impl Into<Value>) -> Self {
        Self::new(name, Access::ReadWritePreOperational, default)
    }

    pub fn wo(name: &'static str, default: impl Into<Value>) -> Self {
        Self::new(name, Access::WriteOnly, default)
    }

    pub fn unit(mut self, unit: &'static str) -> Self {
        self.unit = unit;
        self
    }

    /// Inclusive bounds, of the entry's type. Give `None` to leave a side open.
    pub fn range(mut self, min: Option<Value>, max: Option<Value>) -> Self {
        self.min = min;
        self.max = max;
        self
    }

    /// Inclusive bounds for a REAL64 entry; an infinite bound leaves that side open.
    pub fn between(self, min: f64, max: f64) -> Self {
        let side = |x: f64| x.is_finite().then_some(Value::Real64(x));
        self.range(side(min), side(max))
    }

    pub fn pdo(mut self) -> Self {
        self.pdo_mappable = true;
        self
    }

    pub fn doc(mut self, description: &'static str) -> Self {
        self.description = description;
        self
    }
}

/// Builds an [`ObjectDictionary`]; checks every rule once, at [`build`](Self::build).
#[derive(Debug, Default, Clone)]
pub struct ObjectDictionaryBuilder {
    objects: Vec<ObjectSpec>,
    ordered: Vec<(ObjectId, ObjectId)>,
}

/// An object as given to the builder, before subindexes are assigned.
#[derive(Debug, Clone)]
struct ObjectSpec {
    index: u16,
    name: String,
    kind: ObjectKind,
    axis: Option<usize>,
    entries: Vec<EntrySpec>,
    /// Subindex 0 when it is more than the highest subindex (a PDO mapping's object count).
    sub0: Option<EntrySpec>,
}

impl ObjectDictionaryBuilder {
    /// A VAR object (one value at subindex 0).
    pub fn var(mut self, index: u16, spec: EntrySpec) -> Self {
        self.objects.push(ObjectSpec {
            index,
            name: spec.name.to_string(),
            kind: ObjectKind::Var,
            axis: None,
            entries: vec![spec],
            sub0: None,
        });
        self
    }

    /// A RECORD: entries get subindex 1, 2, ... in order; subindex 0 is added.
    pub fn record(
        mut self,
        index: u16,
        name: impl Into<String>,
        axis: Option<usize>,
        entries: Vec<EntrySpec>,
    ) -> Self {
        self.objects.push(ObjectSpec {
            index,
            name: name.into(),
            kind: ObjectKind::Record,
            axis,
            entries,
            sub0: None,
        });
        self
    }

    /// A RECORD whose subindex 0 is an entry of its own, e.g. the number of mapped objects of
    /// a PDO mapping parameter (CiA 301 §7.5.2.36), writable and smaller than the capacity.
    pub fn record_counted(
        mut self,
        index: u16,
        name: impl Into<String>,
        sub0: EntrySpec,
        entries: Vec<EntrySpec>,
    ) -> Self {
        self.objects.push(ObjectSpec {
            index,
            name: name.into(),
            kind: ObjectKind::Record,
            axis: None,
            entries,
            sub0: Some(sub0),
        });
        self
    }

    /// An ARRAY: like a record, but every entry must have the same type.
    pub fn array(
        mut self,
        index: u16,
        name: impl Into<String>,
        axis: Option<usize>,
        entries: Vec<EntrySpec>,
    ) -> Self {
        self.objects.push(ObjectSpec {
            index,
            name: name.into(),
            kind: ObjectKind::Array,
            axis,
            entries,
            sub0: None,
        });
        self
    }

    /// An ARRAY whose subindex 0 is an entry of its own, e.g. the number of errors of the
    /// pre-defined error field (1003h), which a write of 0 clears.
    pub fn array_counted(
        mut self,
        index: u16,
        name: impl Into<String>,
        sub0: EntrySpec,
        entries: Vec<EntrySpec>,
    ) -> Self {
        self.objects.push(ObjectSpec {
            index,
            name: name.into(),
            kind: ObjectKind::Array,
            axis: None,
            entries,
            sub0: Some(sub0),
        });
        self
    }

    /// Require `low < high` for every write to either (both must be numeric entries).
    pub fn ordered(mut self, low: ObjectId, high: ObjectId) -> Self {
        self.ordered.push((low, high));
        self
    }

    pub fn build(self) -> Result<ObjectDictionary, BuildError> {
        let mut objects = self.objects;
        objects.sort_by_key(|o| o.index);
        let mut out_objects = Vec::with_capacity(objects.len());
        let mut entries = Vec::new();
        for ObjectSpec {
            index,
            name,
            kind,
            axis,
            entries: specs,
            sub0,
        } in objects
        {
            if out_objects
                .last()
                .is_some_and(|o: &Object| o.index == index)
            {
                return Err(BuildError::DuplicateIndex { index });
            }
            if out_objects.iter().any(|o: &Object| o.name == name) {
                return Err(BuildError::DuplicateObjectName(name));
            }
            if specs.is_empty() || specs.len() > 254 {
                return Err(BuildError::EmptyObject(index));
            }
            let first = entries.len();
            if kind == ObjectKind::Var {
                for spec in specs {
                    entries.push(entry(index, 0, axis, spec)?);
                }
            } else {
                let count = specs.len() as u8;
                let sub0 = sub0.unwrap_or_else(|| {
                    EntrySpec::ro("highest_sub_index", count)
                        .doc("highest subindex of this object (CiA 301 §7.4.3)")
                });
                entries.push(entry(index, 0, axis, sub0)?);
                for (i, spec) in specs.into_iter().enumerate() {
                    if kind == ObjectKind::Array
                        && entries.len() > first + 1
                        && entries[first + 1].data_type != spec.data_type
                    {
                        return Err(BuildError::BadEntry {
                            id: ObjectId::new(index, i as u8 + 1),
                            name: spec.name,
                            problem: "an ARRAY's entries must share one type".into(),
                        });
                    }
                    if entries[first..].iter().any(|e| e.name == spec.name) {
                        return Err(BuildError::DuplicateEntryName {
                            object: name,
                            name: spec.name,
                        });
                    }
                    entries.push(entry(index, i as u8 + 1, axis, spec)?);
                }
            }
            out_objects.push(Object {
                index,
                name,
                kind,
                axis,
                entries: first..entries.len(),
            });
        }
        let values: Vec<Value> = entries.iter().map(|e| e.default).collect();
        let writable = entries.iter().filter(|e| e.access.writable()).count();
        let mut od = ObjectDictionary {
            objects: out_objects,
            entries,
            values,
            pending: Vec::with_capacity(writable),
            ordered: Vec::new(),
        };
        for (lo, hi) in self.ordered {
            match (od.handle(lo), od.handle(hi)) {
                (Some(l), Some(h))
                    if od.entry(l).default.as_f64().is_some()
                        && od.entry(h).default.as_f64().is_some() =>
                {
                    od.ordered.push((l, h))
                }
                _ => return Err(BuildError::BadOrder(lo, hi)),
            }
        }
        Ok(od)
    }
}

fn entry(index: u16, sub: u8, axis: Option<usize>, spec: EntrySpec) -> Result<Entry, BuildError> {
    let id = ObjectId::new(index, sub);
    let bad = |problem: String| BuildError::BadEntry {
        id,
        name: spec.name,
        problem,
    };
    for (what, v) in [
        ("default", Some(spec.default)),
        ("min", spec.min),
        ("max", spec.max),
    ] {
        if let Some(v) = v {
            if v.data_type() != spec.data_type {
                return Err(bad(format!(
                    "{what} is {} but the entry is {}",
                    v.data_type(),
                    spec.data_type
                )));
            }
        }
    }
    let e = Entry {
        id,
        name: spec.name,
        data_type: spec.data_type,
        unit: spec.unit,
        access: spec.access,
        min: spec.min,
        max: spec.max,
        default: spec.default,
        pdo_mappable: spec.pdo_mappable,
        description: spec.description,
        axis,
    };
    // A configured default outside the bounds would be refused when written back: catch it here.
    if e.access.writable() {
        check_bounds(&e, &e.default)
            .map_err(|err| bad(format!("default {} is {err}", e.default)))?;
    }
    Ok(e)
}
