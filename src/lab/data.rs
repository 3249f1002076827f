//! Data sets: measured (or simulated) time series read from CSV or from the daemon's MCAP
//! recordings, in SI units.

use std::fmt;
use std::path::Path;

/// Which columns of a CSV file hold which signal. The defaults match `actuator sim --record`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Columns {
    /// Time in s.
    pub time: String,
    /// The actuator command (N, V, duty or N·m).
    pub input: String,
    /// The measured position (m or rad).
    pub output: String,
    /// Supply voltage (V) or pressure (Pa), optional.
    pub supply: Option<String>,
    /// Coil or armature current (A), optional.
    pub current: Option<String>,
}

impl Default for Columns {
    fn default() -> Self {
        Columns {
            time: "time".into(),
            input: "u".into(),
            output: "y".into(),
            supply: Some("supply".into()),
            current: Some("i".into()),
        }
    }
}

/// An error reading a data set; the message names the file, row and column at fault.
#[derive(Debug)]
pub struct DataError(pub String);

impl fmt::Display for DataError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for DataError {}

/// A data set: equally long series, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Where it came from (file name), for messages.
    pub origin: String,
    /// Time in s, strictly increasing.
    pub time: Vec<f64>,
    /// Command.
    pub input: Vec<f64>,
    /// Measured position.
    pub output: Vec<f64>,
    /// Supply voltage (V) or pressure (Pa), when recorded.
    pub supply: Option<Vec<f64>>,
    /// Current (A), when recorded.
    pub current: Option<Vec<f64>>,
}

impl Dataset {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Mean sample period in s: `T_0 = (t_N - t_1) / (N - 1)`.
    pub fn period_s(&self) -> f64 {
        let n = self.len();
        if n < 2 {
            return 0.0;
        }
        (self.time[n - 1] - self.time[0]) / (n - 1) as f64
    }

    /// Samples `range` as a data set of their own.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Dataset {
        Dataset {
            origin: self.origin.clone(),
            time: self.time[range.clone()].to_vec(),
            input: self.input[range.clone()].to_vec(),
            output: self.output[range.clone()].to_vec(),
            supply: self.supply.as_ref().map(|s| s[range.clone()].to_vec()),
            current: self.current.as_ref().map(|s| s[range].to_vec()),
        }
    }

    /// Check lengths, finiteness and a strictly increasing time with a near-constant period.
    pub fn validate(&self) -> Result<(), DataError> {
        let n = self.len();
        if n < 50 {
            return Err(DataError(format!(
                "{}: {n} samples, the lab needs at least 50",
                self.origin
            )));
        }
        let lens = [
            ("input", self.input.len()),
            ("output", self.output.len()),
            ("supply", self.supply.as_ref().map_or(n, Vec::len)),
            ("current", self.current.as_ref().map_or(n, Vec::len)),
        ];
        for (name, len) in lens {
            if len != n {
                return Err(DataError(format!(
                    "{}: {name} has {len} samples, time has {n}",
                    self.origin
                )));
            }
        }
        let t0 = self.period_s();
        for k in 1..n {
            let dt = self.time[k] - self.time[k - 1];
            if dt.is_nan() || dt <= 0.0 {
                return Err(DataError(format!(
                    "{}: sample {}: time does not increase ({} after {})",
                    self.origin,
                    k + 1,
                    self.time[k],
                    self.time[k - 1]
                )));
            }
            if dt > 5.0 * t0 || dt < 0.2 * t0 {
                return Err(DataError(format!(
                    "{}: sample {}: time step {dt} s far from the mean period {t0} s (gaps or \
                     jitter; resample the data first)",
                    self.origin,
                    k + 1
                )));
            }
        }
        Ok(())
    }
}

/// Read a data set: MCAP (`.mcap`, the daemon's recordings) or CSV (anything else).
pub fn load(path: &Path, columns: &Columns) -> Result<Dataset, DataError> {
    let is_mcap = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    let data = if is_mcap {
        load_mcap(path)?
    } else {
        let text = std::fs::read_to_string(path)
            .map_err(|e| DataError(format!("{}: {e}", path.display())))?;
        parse_csv(&text, &path.display().to_string(), columns)?
    };
    data.validate()?;
    Ok(data)
}

/// Parse CSV text with a header row. `origin` prefixes every error, e.g.
/// `data.csv:123: column y: not a number: 'abc'`. Default optional columns that are absent
/// are skipped; optional columns named explicitly must exist.
pub fn parse_csv(text: &str, origin: &str, columns: &Columns) -> Result<Dataset, DataError> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines
        .next()
        .ok_or_else(|| DataError(format!("{origin}: empty file, expected a header row")))?;
    let names: Vec<&str> = header
        .split(',')
        .map(|s| s.trim().trim_matches('"'))
        .collect();
    let find = |name: &str| names.iter().position(|n| *n == name);
    let need = |name: &str, what: &str| {
        find(name).ok_or_else(|| {
            DataError(format!(
                "{origin}:1: no column '{name}' for the {what}; the header has {}",
                names.join(", ")
            ))
        })
    };
    let defaults = Columns::default();
    let optional = |name: &Option<String>, default: &Option<String>, what: &str| {
        match name {
            None => Ok(None),
            Some(n) => match find(n) {
                Some(i) => Ok(Some(i)),
                // A default name that is absent simply means "not recorded".
                None if name == default => Ok(None),
                None => need(n, what).map(Some),
            },
        }
    };
    let it = need(&columns.time, "time")?;
    let iu = need(&columns.input, "input")?;
    let iy = need(&columns.output, "output")?;
    let is = optional(&columns.supply, &defaults.supply, "supply")?;
    let ic = optional(&columns.current, &defaults.current, "current")?;
    let mut d = Dataset {
        origin: origin.to_string(),
        time: Vec::new(),
        input: Vec::new(),
        output: Vec::new(),
        supply: is.map(|_| Vec::new()),
        current: ic.map(|_| Vec::new()),
    };
    let mut fields: Vec<&str> = Vec::with_capacity(names.len());
    for (line_no, line) in lines {
        fields.clear();
        fields.extend(line.split(',').map(str::trim));
        let row = line_no + 1;
        if fields.len() != names.len() {
            return Err(DataError(format!(
                "{origin}:{row}: {} fields, the header has {}",
                fields.len(),
                names.len()
            )));
        }
        let get = |i: usize| -> Result<f64, DataError> {
            let s = fields[i].trim_matches('"');
            let v: f64 = s.parse().map_err(|_| {
                DataError(format!(
                    "{origin}:{row}: column {}: not a number: '{s}'",
                    names[i]
                ))
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(DataError(format!(
                    "{origin}:{row}: column {}: not a finite number: '{s}'",
                    names[i]
                )))
            }
        };
        d.time.push(get(it)?);
        d.input.push(get(iu)?);
        d.output.push(get(iy)?);
        if let (Some(i), Some(v)) = (is, d.supply.as_mut()) {
            v.push(get(i)?);
        }
        if let (Some(i), Some(v)) = (ic, d.current.as_mut()) {
            v.push(get(i)?);
        }
    }
    // A supply or current column of zeros was not recorded (e.g. a family without a supply).
    for col in [&mut d.supply, &mut d.current] {
        if col.as_ref().is_some_and(|v| v.iter().all(|x| *x == 0.0)) {
            *col = None;
        }
    }
    Ok(d)
}

/// Read the daemon's MCAP recording (topic `/actuatord/cycle`). The command is the voltage, or
/// the duty when no voltage was commanded; the supply is the pressure when one was recorded,
/// otherwise the voltage.
pub fn load_mcap(path: &Path) -> Result<Dataset, DataError> {
    let origin = path.display().to_string();
    let cycles = crate::daemon::recorder::read_cycles(path)
        .map_err(|e| DataError(format!("{origin}: {e}")))?;
    if cycles.is_empty() {
        return Err(DataError(format!(
            "{origin}: no messages on /actuatord/cycle"
        )));
    }
    let node = cycles[0].axis_node_id;
    let cycles: Vec<_> = cycles
        .into_iter()
        .filter(|c| c.axis_node_id == node)
        .collect();
    let duty = cycles.iter().all(|c| c.command_voltage == 0.0);
    let pressure = cycles.iter().any(|c| c.supply_pressure != 0.0);
    let any_supply = cycles
        .iter()
        .any(|c| c.supply_pressure != 0.0 || c.supply_voltage != 0.0);
    let any_current = cycles.iter().any(|c| c.current != 0.0);
    Ok(Dataset {
        origin,
        time: cycles.iter().map(|c| c.t_s).collect(),
        input: cycles
            .iter()
            .map(|c| {
                if duty {
                    c.command_duty
                } else {
                    c.command_voltage
                }
            })
            .collect(),
        output: cycles.iter().map(|c| c.position).collect(),
        supply: any_supply.then(|| {
            cycles
                .iter()
                .map(|c| {
                    if pressure {
                        c.supply_pressure
                    } else {
                        c.supply_voltage
                    }
                })
                .collect()
        }),
        current: any_current.then(|| cycles.iter().map(|c| c.current).collect()),
    })
}

/// Write a data set as CSV with the default header `time,u,y[,supply][,i]`.
pub fn to_csv(d: &Dataset) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("time,u,y");
    if d.supply.is_some() {
        s.push_str(",supply");
    }
    if d.current.is_some() {
        s.push_str(",i");
    }
    s.push('\n');
    for k in 0..d.len() {
        let _ = write!(s, "{},{},{}", d.time[k], d.input[k], d.output[k]);
        if let Some(v) = &d.supply {
            let _ = write!(s, ",{}", v[k]);
        }
        if let Some(v) = &d.current {
            let _ = write!(s, ",{}", v[k]);
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_number_names_file_row_and_column() {
        let text = "time,u,y\n0,1,2\n0.001,1,abc\n";
        let err = parse_csv(text, "data.csv", &Columns::default()).unwrap_err();
        assert_eq!(err.to_string(), "data.csv:3: column y: not a number: 'abc'");
    }

    #[test]
    fn missing_column_is_named() {
        let text = "t,u,y\n0,1,2\n";
        let err = parse_csv(text, "d.csv", &Columns::default()).unwrap_err();
        assert!(err.to_string().contains("no column 'time'"), "{err}");
        let cols = Columns {
            current: Some("amps".into()),
            ..Columns::default()
        };
        let err = parse_csv("time,u,y\n0,1,2\n", "d.csv", &cols).unwrap_err();
        assert!(err.to_string().contains("'amps'"), "{err}");
    }

    #[test]
    fn round_trip_and_optional_columns() {
        let text = "time,u,y,supply,i,setpoint\n0,1,2,24,0.5,0\n0.001,1.5,2.5,24,0.6,0\n";
        let d = parse_csv(text, "x", &Columns::default()).expect("parses");
        assert_eq!(d.input, vec![1.0, 1.5]);
        assert_eq!(d.current, Some(vec![0.5, 0.6]));
        let back = parse_csv(&to_csv(&d), "y", &Columns::default()).expect("parses");
        assert_eq!(back.output, d.output);
        assert_eq!(back.supply, d.supply);
    }

    #[test]
    fn time_must_increase() {
        let mut s = String::from("time,u,y\n");
        for k in 0..60 {
            let t = if k == 30 { 0.0 } else { k as f64 * 0.01 };
            s.push_str(&format!("{t},0,0\n"));
        }
        let d = parse_csv(&s, "d.csv", &Columns::default()).expect("parses");
        let err = d.validate().unwrap_err();
        assert!(err.to_string().contains("sample 31"), "{err}");
    }
}
