//! The fault-symptom table as data: `config/fault_symptoms.toml`, written by
//! `actuator bench fault-table` from simulations of the solenoid with each fault
//! ([`crate::bench::fault_table`]), read by the daemon's parameter diagnosis.
//!
//! [`FaultTableFile`] is the file as written, with the measured figures kept for the record;
//! [`FaultSymptomTable`] is what the diagnosis needs, checked: known faults with their codes, six
//! symptoms each, no all-zero row, and every pattern distinct.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::param_diagnosis::{DiagnosedFault, Symptom, PHYSICAL_NAMES, PHYSICAL_PARAMS};

/// The table shipped with the sources, compiled in: the daemon works without the file.
pub const SHIPPED_FAULT_TABLE: &str = include_str!("../../config/fault_symptoms.toml");
/// Where the shipped table lives in the source tree.
pub const SHIPPED_FAULT_TABLE_PATH: &str = "config/fault_symptoms.toml";

/// Why a table cannot be used; names the file and the key.
#[derive(Debug, thiserror::Error)]
pub enum FaultTableError {
    #[error("{origin}: {source}")]
    Io {
        origin: String,
        source: std::io::Error,
    },
    #[error("{origin}: {message}")]
    Parse { origin: String, message: String },
    #[error("{origin}: {key}: {rule}")]
    Invalid {
        origin: String,
        key: String,
        rule: String,
    },
}

/// The table file as written: rows with the figures that led to them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultTableFile {
    /// Names of the physical parameters, in the order of every vector below.
    pub parameters: Vec<String>,
    #[serde(default)]
    pub fault: Vec<FaultRowFile>,
    #[serde(default)]
    pub not_diagnosed: Vec<NotDiagnosedFile>,
}

/// One row: a fault, its pattern, and the simulation behind it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultRowFile {
    pub code: String,
    pub name: String,
    /// `+`, `-` or `0` per parameter.
    pub symptoms: Vec<String>,
    /// The plant fault simulated for this row (text form of [`crate::physics::Fault`]).
    pub simulated: String,
    /// `(p - p_nom) / |p_nom|` of the mean estimate over the faulty run's windows.
    pub relative_change: Vec<f64>,
    /// The symptom test's bound relative to `|p_nom|`.
    pub relative_bound: Vec<f64>,
    /// Other simulated faults that give the same pattern: the diagnosis cannot tell them apart.
    #[serde(default)]
    pub same_pattern: Vec<SamePatternFile>,
}

/// A simulated fault merged into a row because its pattern is the row's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamePatternFile {
    pub simulated: String,
    pub relative_change: Vec<f64>,
    pub note: String,
}

/// A simulated fault the parameter diagnosis does not see, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NotDiagnosedFile {
    pub simulated: String,
    pub reason: String,
    /// Present when the run gave estimates.
    #[serde(default)]
    pub relative_change: Option<Vec<f64>>,
}

/// One row of the checked table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableRow {
    pub fault: DiagnosedFault,
    pub symptoms: [Symptom; PHYSICAL_PARAMS],
}

/// The checked fault-symptom table the diagnosis uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultSymptomTable {
    rows: Vec<TableRow>,
}

fn invalid(origin: &str, key: String, rule: impl Into<String>) -> FaultTableError {
    FaultTableError::Invalid {
        origin: origin.to_string(),
        key,
        rule: rule.into(),
    }
}

/// `+`, `-`, `0` as a pattern string, e.g. `00000+`.
pub fn pattern_text(symptoms: &[Symptom; PHYSICAL_PARAMS]) -> String {
    symptoms.iter().map(|s| s.as_char()).collect()
}

impl FaultSymptomTable {
    /// A table from rows; the same checks as for a file.
    pub fn new(rows: Vec<TableRow>, origin: &str) -> Result<Self, FaultTableError> {
        if rows.is_empty() {
            return Err(invalid(origin, "fault".into(), "the table has no rows"));
        }
        for (i, row) in rows.iter().enumerate() {
            if row.symptoms.iter().all(|s| *s == Symptom::Zero) {
                return Err(invalid(
                    origin,
                    format!("fault[{i}].symptoms"),
                    format!(
                        "{}: all symptoms 0 cannot be told from healthy",
                        row.fault.name()
                    ),
                ));
            }
            for (k, other) in rows[..i].iter().enumerate() {
                if other.fault == row.fault {
                    return Err(invalid(
                        origin,
                        format!("fault[{i}].name"),
                        format!("{} is already fault[{k}]", row.fault.name()),
                    ));
                }
                if other.symptoms == row.symptoms {
                    return Err(invalid(
                        origin,
                        format!("fault[{i}].symptoms"),
                        format!(
                            "{} has the pattern {} of fault[{k}] {}: indistinguishable",
                            row.fault.name(),
                            pattern_text(&row.symptoms),
                            other.fault.name()
                        ),
                    ));
                }
            }
        }
        Ok(Self { rows })
    }

    /// The table compiled into the program.
    pub fn shipped() -> Result<Self, FaultTableError> {
        Self::from_toml(SHIPPED_FAULT_TABLE, SHIPPED_FAULT_TABLE_PATH)
    }

    /// Read a table file.
    pub fn load(path: &Path) -> Result<Self, FaultTableError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| FaultTableError::Io {
            origin: origin.clone(),
            source,
        })?;
        Self::from_toml(&text, &origin)
    }

    /// Parse table text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, FaultTableError> {
        FaultTableFile::from_toml(text, origin)?.table(origin)
    }

    pub fn rows(&self) -> &[TableRow] {
        &self.rows
    }

    /// The row of `fault`, if the table has one.
    pub fn row(&self, fault: DiagnosedFault) -> Option<&TableRow> {
        self.rows.iter().find(|r| r.fault == fault)
    }
}

impl FaultTableFile {
    /// Parse (structure only; [`Self::table`] checks the content).
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, FaultTableError> {
        toml::from_str(text).map_err(|e| FaultTableError::Parse {
            origin: origin.to_string(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })
    }

    /// Check the content and give the table the diagnosis uses.
    pub fn table(&self, origin: &str) -> Result<FaultSymptomTable, FaultTableError> {
        if self
            .parameters
            .iter()
            .map(String::as_str)
            .ne(PHYSICAL_NAMES)
        {
            return Err(invalid(
                origin,
                "parameters".into(),
                format!("must be {PHYSICAL_NAMES:?}, got {:?}", self.parameters),
            ));
        }
        let six = |key: String, n: usize| {
            if n == PHYSICAL_PARAMS {
                Ok(())
            } else {
                Err(invalid(
                    origin,
                    key,
                    format!("needs {PHYSICAL_PARAMS} entries, one per parameter, got {n}"),
                ))
            }
        };
        let mut rows = Vec::with_capacity(self.fault.len());
        for (i, f) in self.fault.iter().enumerate() {
            let fault = DiagnosedFault::from_name(&f.name).ok_or_else(|| {
                let known: Vec<&str> = DiagnosedFault::ALL.iter().map(|f| f.name()).collect();
                invalid(
                    origin,
                    format!("fault[{i}].name"),
                    format!("unknown fault \"{}\", expected one of {known:?}", f.name),
                )
            })?;
            if f.code != fault.label() {
                return Err(invalid(
                    origin,
                    format!("fault[{i}].code"),
                    format!("{} has code {}, got \"{}\"", f.name, fault.label(), f.code),
                ));
            }
            six(format!("fault[{i}].symptoms"), f.symptoms.len())?;
            six(
                format!("fault[{i}].relative_change"),
                f.relative_change.len(),
            )?;
            six(format!("fault[{i}].relative_bound"), f.relative_bound.len())?;
            let mut symptoms = [Symptom::Zero; PHYSICAL_PARAMS];
            for (j, (s, text)) in symptoms.iter_mut().zip(&f.symptoms).enumerate() {
                *s = Symptom::from_text(text).ok_or_else(|| {
                    invalid(
                        origin,
                        format!("fault[{i}].symptoms[{j}]"),
                        format!("expected \"+\", \"-\" or \"0\", got \"{text}\""),
                    )
                })?;
            }
            for (k, m) in f.same_pattern.iter().enumerate() {
                six(
                    format!("fault[{i}].same_pattern[{k}].relative_change"),
                    m.relative_change.len(),
                )?;
            }
            rows.push(TableRow { fault, symptoms });
        }
        for (i, n) in self.not_diagnosed.iter().enumerate() {
            if let Some(r) = &n.relative_change {
                six(format!("not_diagnosed[{i}].relative_change"), r.len())?;
            }
        }
        FaultSymptomTable::new(rows, origin)
    }

    /// The file text, with a header naming the command that regenerates it.
    pub fn to_toml(&self, header: &str) -> String {
        let mut out = String::new();
        for line in header.lines() {
            let _ = writeln!(out, "{}", format!("# {line}").trim_end());
        }
        let strings = |v: &[String]| {
            let items: Vec<String> = v.iter().map(|s| format!("{s:?}")).collect();
            format!("[{}]", items.join(", "))
        };
        let numbers = |v: &[f64]| {
            let items: Vec<String> = v.iter().map(|x| format_number(*x)).collect();
            format!("[{}]", items.join(", "))
        };
        let _ = writeln!(out, "\nparameters = {}", strings(&self.parameters));
        for f in &self.fault {
            let _ = writeln!(out, "\n[[fault]]");
            let _ = writeln!(out, "code = {:?}", f.code);
            let _ = writeln!(out, "name = {:?}", f.name);
            let _ = writeln!(out, "symptoms = {}", strings(&f.symptoms));
            let _ = writeln!(out, "simulated = {:?}", f.simulated);
            let _ = writeln!(out, "relative_change = {}", numbers(&f.relative_change));
            let _ = writeln!(out, "relative_bound = {}", numbers(&f.relative_bound));
            for m in &f.same_pattern {
                let _ = writeln!(out, "\n[[fault.same_pattern]]");
                let _ = writeln!(out, "simulated = {:?}", m.simulated);
                let _ = writeln!(out, "relative_change = {}", numbers(&m.relative_change));
                let _ = writeln!(out, "note = {:?}", m.note);
            }
        }
        for n in &self.not_diagnosed {
            let _ = writeln!(out, "\n[[not_diagnosed]]");
            let _ = writeln!(out, "simulated = {:?}", n.simulated);
            let _ = writeln!(out, "reason = {:?}", n.reason);
            if let Some(r) = &n.relative_change {
                let _ = writeln!(out, "relative_change = {}", numbers(r));
            }
        }
        out
    }

    /// What differs from `other` (the committed file), one line each naming the key; numbers
    /// agree within `tolerance` (absolute, they are relative changes).
    pub fn differences(&self, other: &FaultTableFile, tolerance: f64) -> Vec<String> {
        let mut out = Vec::new();
        let mut text = |key: String, a: &str, b: &str| {
            if a != b {
                out.push(format!("{key}: derived \"{a}\", file \"{b}\""));
            }
        };
        text(
            "parameters".into(),
            &self.parameters.join(","),
            &other.parameters.join(","),
        );
        let rows = |f: &FaultTableFile| -> String {
            f.fault
                .iter()
                .map(|r| r.name.as_str())
                .collect::<Vec<_>>()
                .join(",")
        };
        text("fault (rows)".into(), &rows(self), &rows(other));
        let skipped = |f: &FaultTableFile| -> String {
            f.not_diagnosed
                .iter()
                .map(|r| r.simulated.as_str())
                .collect::<Vec<_>>()
                .join(",")
        };
        text("not_diagnosed".into(), &skipped(self), &skipped(other));
        let mut numbers = Vec::new();
        for (i, (a, b)) in self.fault.iter().zip(&other.fault).enumerate() {
            text(format!("fault[{i}].code"), &a.code, &b.code);
            text(
                format!("fault[{i}].symptoms"),
                &a.symptoms.concat(),
                &b.symptoms.concat(),
            );
            text(format!("fault[{i}].simulated"), &a.simulated, &b.simulated);
            numbers.push((
                format!("fault[{i}].relative_change"),
                &a.relative_change,
                &b.relative_change,
            ));
            numbers.push((
                format!("fault[{i}].relative_bound"),
                &a.relative_bound,
                &b.relative_bound,
            ));
            let merged = |r: &FaultRowFile| -> String {
                r.same_pattern
                    .iter()
                    .map(|m| m.simulated.as_str())
                    .collect::<Vec<_>>()
                    .join(",")
            };
            text(format!("fault[{i}].same_pattern"), &merged(a), &merged(b));
            for (k, (x, y)) in a.same_pattern.iter().zip(&b.same_pattern).enumerate() {
                text(
                    format!("fault[{i}].same_pattern[{k}].note"),
                    &x.note,
                    &y.note,
                );
                numbers.push((
                    format!("fault[{i}].same_pattern[{k}].relative_change"),
                    &x.relative_change,
                    &y.relative_change,
                ));
            }
        }
        for (i, (a, b)) in self
            .not_diagnosed
            .iter()
            .zip(&other.not_diagnosed)
            .enumerate()
        {
            text(format!("not_diagnosed[{i}].reason"), &a.reason, &b.reason);
            match (&a.relative_change, &b.relative_change) {
                (Some(x), Some(y)) => {
                    numbers.push((format!("not_diagnosed[{i}].relative_change"), x, y))
                }
                (None, None) => {}
                _ => text(
                    format!("not_diagnosed[{i}].relative_change"),
                    if a.relative_change.is_some() {
                        "present"
                    } else {
                        "absent"
                    },
                    if b.relative_change.is_some() {
                        "present"
                    } else {
                        "absent"
                    },
                ),
            }
        }
        for (key, a, b) in numbers {
            let close = a.len() == b.len()
                && a.iter().zip(b.iter()).all(|(x, y)| {
                    x == y || (x - y).abs() <= tolerance || (x.is_nan() && y.is_nan())
                });
            if !close {
                out.push(format!("{key}: derived {a:?}, file {b:?}"));
            }
        }
        out
    }
}

/// Four decimals; `inf`/`nan` as TOML writes them.
fn format_number(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        let s = format!("{x:.4}");
        // No negative zero in the file.
        if s == "-0.0000" {
            "0.0000".into()
        } else {
            s
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_table_loads_and_its_patterns_are_distinct() {
        let table = FaultSymptomTable::shipped().expect("shipped table is valid");
        // The paper's four faults are all there.
        for f in [
            DiagnosedFault::SpringPretension,
            DiagnosedFault::SpringStiffness,
            DiagnosedFault::FrictionIncrease,
            DiagnosedFault::CurrentGain,
        ] {
            assert!(table.row(f).is_some(), "{f:?} missing");
        }
        let rows = table.rows();
        for (i, a) in rows.iter().enumerate() {
            assert!(a.symptoms.iter().any(|s| *s != Symptom::Zero), "{a:?}");
            for b in &rows[i + 1..] {
                assert_ne!(a.symptoms, b.symptoms, "{a:?} {b:?}");
            }
        }
    }

    #[test]
    fn the_shipped_file_renders_back_to_itself() {
        let file = FaultTableFile::from_toml(SHIPPED_FAULT_TABLE, SHIPPED_FAULT_TABLE_PATH)
            .expect("parses");
        let header: String = SHIPPED_FAULT_TABLE
            .lines()
            .take_while(|l| l.starts_with('#'))
            .map(|l| {
                let text = l.strip_prefix("# ").or(l.strip_prefix('#')).unwrap_or(l);
                format!("{text}\n")
            })
            .collect();
        assert_eq!(file.to_toml(&header), SHIPPED_FAULT_TABLE);
    }

    fn file_with(rows: &[(&str, &str, [&str; 6])]) -> String {
        let mut f = FaultTableFile {
            parameters: PHYSICAL_NAMES.iter().map(|s| s.to_string()).collect(),
            fault: vec![],
            not_diagnosed: vec![],
        };
        for (code, name, s) in rows {
            f.fault.push(FaultRowFile {
                code: code.to_string(),
                name: name.to_string(),
                symptoms: s.iter().map(|s| s.to_string()).collect(),
                simulated: "x".into(),
                relative_change: vec![0.0; 6],
                relative_bound: vec![0.1; 6],
                same_pattern: vec![],
            });
        }
        f.to_toml("test")
    }

    #[test]
    fn errors_name_the_file_and_the_key() {
        let err = |text: &str| {
            FaultSymptomTable::from_toml(text, "table.toml")
                .expect_err("invalid")
                .to_string()
        };
        let same = file_with(&[
            ("F1", "spring_pretension", ["0", "0", "0", "0", "0", "+"]),
            ("F2", "spring_stiffness", ["0", "0", "0", "0", "0", "+"]),
        ]);
        let e = err(&same);
        assert!(
            e.starts_with("table.toml: fault[1].symptoms:") && e.contains("indistinguishable"),
            "{e}"
        );
        let e = err(&file_with(&[(
            "F1",
            "spring_pretension",
            ["0", "0", "0", "0", "0", "x"],
        )]));
        assert!(e.starts_with("table.toml: fault[0].symptoms[5]:"), "{e}");
        let e = err(&file_with(&[("F7", "spring_pretension", ["+"; 6])]));
        assert!(e.starts_with("table.toml: fault[0].code:"), "{e}");
        let e = err(&file_with(&[("F1", "rust", ["+"; 6])]));
        assert!(e.starts_with("table.toml: fault[0].name:"), "{e}");
        let e = err(&file_with(&[("F1", "spring_pretension", ["0"; 6])]));
        assert!(e.contains("all symptoms 0"), "{e}");
        let e = err("parameters = [\"a\"]\n");
        assert!(e.starts_with("table.toml: parameters:"), "{e}");
        let e = err("parameters = 3\n");
        assert!(e.starts_with("table.toml: "), "{e}");
        let ok = file_with(&[
            ("F1", "spring_pretension", ["0", "0", "0", "0", "0", "+"]),
            ("F4", "current_gain", ["0", "0", "0", "-", "0", "0"]),
        ]);
        let t = FaultSymptomTable::from_toml(&ok, "table.toml").expect("valid");
        assert_eq!(t.rows().len(), 2);
        assert_eq!(t.rows()[1].symptoms[3], Symptom::Minus);
    }

    #[test]
    fn differences_name_what_changed() {
        let a = FaultTableFile::from_toml(
            &file_with(&[("F1", "spring_pretension", ["0", "0", "0", "0", "0", "+"])]),
            "a",
        )
        .expect("parses");
        assert!(a.differences(&a, 1e-3).is_empty());
        let mut b = a.clone();
        b.fault[0].symptoms[5] = "-".into();
        b.fault[0].relative_change[2] = 0.01;
        let d = a.differences(&b, 1e-3);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(d[0].starts_with("fault[0].symptoms"), "{d:?}");
        assert!(d[1].starts_with("fault[0].relative_change"), "{d:?}");
        b.fault[0].relative_change[2] = 0.0005;
        b.fault[0].symptoms[5] = "+".into();
        assert!(a.differences(&b, 1e-3).is_empty());
    }
}
