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

/// A time step longer than this many periods is a gap: the samples after it are a new
/// continuous stretch.
pub const GAP_PERIODS: f64 = 5.0;

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

    /// Sample period in s: the median time step, so that the gaps between continuous stretches
    /// (see [`Dataset::segments`]) do not count.
    pub fn period_s(&self) -> f64 {
        let n = self.len();
        if n < 2 {
            return 0.0;
        }
        let mut steps: Vec<f64> = self.time.windows(2).map(|w| w[1] - w[0]).collect();
        let mid = steps.len() / 2;
        let (_, median, _) = steps.select_nth_unstable_by(mid, f64::total_cmp);
        *median
    }

    /// The continuous stretches of the record, as sample ranges: a time step longer than
    /// [`GAP_PERIODS`] periods starts a new one (a gap in the logging, or the next file of
    /// several given together). Derivatives are taken within a stretch, never across a gap.
    pub fn segments(&self) -> Vec<std::ops::Range<usize>> {
        let n = self.len();
        let gap = GAP_PERIODS * self.period_s();
        let mut out = Vec::new();
        let mut start = 0;
        for k in 1..n {
            if self.time[k] - self.time[k - 1] > gap {
                out.push(start..k);
                start = k;
            }
        }
        if n > 0 {
            out.push(start..n);
        }
        out
    }

    /// Several data sets as one, each after the last with a gap of [`GAP_PERIODS`] × 2 periods
    /// so that each stays a stretch of its own. All must record the same signals.
    pub fn concat(sets: Vec<Dataset>) -> Result<Dataset, DataError> {
        let mut it = sets.into_iter();
        let Some(mut all) = it.next() else {
            return Err(DataError("no data set given".into()));
        };
        for d in it {
            for (name, a, b) in [
                ("supply", all.supply.is_some(), d.supply.is_some()),
                ("current", all.current.is_some(), d.current.is_some()),
            ] {
                if a != b {
                    return Err(DataError(format!(
                        "{}: {} a {name} column, {} not: every data set given together must \
                         record the same signals",
                        d.origin,
                        if b { "has" } else { "lacks" },
                        all.origin
                    )));
                }
            }
            let (Some(&end), Some(&first)) = (all.time.last(), d.time.first()) else {
                continue;
            };
            let shift = end + 2.0 * GAP_PERIODS * all.period_s().max(d.period_s()) - first;
            all.time.extend(d.time.iter().map(|t| t + shift));
            all.input.extend(d.input);
            all.output.extend(d.output);
            if let (Some(a), Some(b)) = (all.supply.as_mut(), d.supply) {
                a.extend(b);
            }
            if let (Some(a), Some(b)) = (all.current.as_mut(), d.current) {
                a.extend(b);
            }
            all.origin = format!("{} + {}", all.origin, d.origin);
        }
        Ok(all)
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
            // Steps over GAP_PERIODS periods are gaps between stretches (a lost period or two
            // of a recording is not); one under a fifth of the period is jitter the filter
            // cannot take.
            if dt < 0.2 * t0 {
                return Err(DataError(format!(
                    "{}: sample {}: time step {dt} s far from the period {t0} s (jitter; \
                     resample the data first)",
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
        let bytes =
            std::fs::read(path).map_err(|e| DataError(format!("{}: {e}", path.display())))?;
        parse_csv_bytes(&bytes, &path.display().to_string(), columns)?
    };
    data.validate()?;
    Ok(data)
}

/// Parse CSV text with a header row. `origin` prefixes every error, e.g.
/// `data.csv:123: column y: not a number: 'abc'`. Default optional columns that are absent
/// are skipped; optional columns named explicitly must exist.
pub fn parse_csv(text: &str, origin: &str, columns: &Columns) -> Result<Dataset, DataError> {
    parse_csv_bytes(text.as_bytes(), origin, columns)
}

/// Roles of the columns read, in the order their errors are reported.
const ROLES: usize = 5;
const SUPPLY: usize = 3;
const CURRENT: usize = 4;

/// Files smaller than this are parsed on one thread; thread start-up would cost more.
const PARALLEL_BYTES: usize = 1 << 20;

/// [`parse_csv`] on raw bytes: a hand parser over the bytes (rows split across the available
/// cores for large files), with the same messages as a line-by-line parse. Lines end in `\n` or
/// `\r\n`; blank lines are skipped but counted in row numbers; fields are trimmed and may be
/// quoted.
pub fn parse_csv_bytes(
    bytes: &[u8],
    origin: &str,
    columns: &Columns,
) -> Result<Dataset, DataError> {
    // The header: the first line that is not blank.
    let mut pos = 0;
    let mut header_line = 0;
    let header = loop {
        if pos >= bytes.len() {
            return Err(DataError(format!(
                "{origin}: empty file, expected a header row"
            )));
        }
        let (line, next) = next_line(bytes, pos);
        pos = next;
        header_line += 1;
        if !is_blank(line) {
            break String::from_utf8_lossy(line);
        }
    };
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
    let roles: [Option<usize>; ROLES] = [
        Some(need(&columns.time, "time")?),
        Some(need(&columns.input, "input")?),
        Some(need(&columns.output, "output")?),
        optional(&columns.supply, &defaults.supply, "supply")?,
        optional(&columns.current, &defaults.current, "current")?,
    ];
    let layout = Layout {
        fields: names.len(),
        roles,
    };
    let body = &bytes[pos..];
    let threads = if body.len() < PARALLEL_BYTES {
        1
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get().min(8))
    };
    let chunks = split_at_lines(body, threads);
    let parsed: Vec<Result<Parsed, RowFault>> = if chunks.len() == 1 {
        vec![parse_rows(chunks[0], &layout)]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = chunks
                .iter()
                .map(|c| {
                    let layout = &layout;
                    s.spawn(move || parse_rows(c, layout))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    let mut cols: [Vec<f64>; ROLES] = Default::default();
    for (i, part) in parsed.into_iter().enumerate() {
        match part {
            Ok(p) => {
                for (all, mut mine) in cols.iter_mut().zip(p.cols) {
                    if all.is_empty() {
                        *all = std::mem::take(&mut mine);
                    } else {
                        all.extend_from_slice(&mine);
                    }
                }
            }
            Err(fault) => {
                // Rows of the chunks before this one, counted only now that a message needs them.
                let before: usize = chunks[..i].iter().map(|c| count_lines(c)).sum();
                let row = header_line + before + fault.line + 1;
                return Err(fault.message(origin, row, &names));
            }
        }
    }
    let [time, input, output, supply, current] = cols;
    let mut d = Dataset {
        origin: origin.to_string(),
        time,
        input,
        output,
        supply: roles[SUPPLY].map(|_| supply),
        current: roles[CURRENT].map(|_| current),
    };
    // A supply or current column of zeros was not recorded (e.g. a family without a supply).
    for col in [&mut d.supply, &mut d.current] {
        if col.as_ref().is_some_and(|v| v.iter().all(|x| *x == 0.0)) {
            *col = None;
        }
    }
    Ok(d)
}

/// Which field of a row each role reads.
struct Layout {
    /// Number of fields of every row.
    fields: usize,
    /// Field of each role, when read.
    roles: [Option<usize>; ROLES],
}

/// The columns of a run of rows, by role.
struct Parsed {
    cols: [Vec<f64>; ROLES],
}

/// What is wrong with a row: its line within the chunk and the fault.
struct RowFault {
    line: usize,
    kind: FaultKind,
}

enum FaultKind {
    /// Number of fields found.
    Fields(usize),
    /// Field index and its text (trimmed, unquoted).
    NotNumber(usize, String),
    NotFinite(usize, String),
}

impl RowFault {
    fn message(&self, origin: &str, row: usize, names: &[&str]) -> DataError {
        DataError(match &self.kind {
            FaultKind::Fields(n) => {
                format!("{origin}:{row}: {n} fields, the header has {}", names.len())
            }
            FaultKind::NotNumber(f, s) => {
                format!("{origin}:{row}: column {}: not a number: '{s}'", names[*f])
            }
            FaultKind::NotFinite(f, s) => format!(
                "{origin}:{row}: column {}: not a finite number: '{s}'",
                names[*f]
            ),
        })
    }
}

/// The line starting at `pos` (without its `\n` or `\r\n`) and where the next one starts.
fn next_line(bytes: &[u8], pos: usize) -> (&[u8], usize) {
    let rest = &bytes[pos..];
    let (mut line, next) = match rest.iter().position(|&b| b == b'\n') {
        Some(i) => (&rest[..i], pos + i + 1),
        None => (rest, bytes.len()),
    };
    if let [head @ .., b'\r'] = line {
        line = head;
    }
    (line, next)
}

/// Blank as `str::trim` sees it (Unicode white space).
fn is_blank(line: &[u8]) -> bool {
    line.iter().all(u8::is_ascii_whitespace)
        || std::str::from_utf8(line).is_ok_and(|s| s.trim().is_empty())
}

/// Lines in `chunk` as [`parse_rows`] counts them.
fn count_lines(chunk: &[u8]) -> usize {
    let newlines = chunk.iter().filter(|&&b| b == b'\n').count();
    newlines + usize::from(chunk.last().is_some_and(|&b| b != b'\n'))
}

/// Split `body` into at most `parts` pieces that each end after a `\n` (the last one at the end).
fn split_at_lines(body: &[u8], parts: usize) -> Vec<&[u8]> {
    let mut out = Vec::with_capacity(parts);
    let mut start = 0;
    for p in 1..parts {
        let guess = (body.len() * p / parts).max(start);
        if guess >= body.len() {
            break;
        }
        let Some(i) = body[guess..].iter().position(|&b| b == b'\n') else {
            break;
        };
        let end = guess + i + 1;
        out.push(&body[start..end]);
        start = end;
    }
    out.push(&body[start..]);
    out
}

/// Parse the rows of `chunk` (whole lines) into columns by role, in one pass over its bytes.
fn parse_rows(chunk: &[u8], layout: &Layout) -> Result<Parsed, RowFault> {
    // Valid UTF-8, the usual case, is checked once for the chunk, not field by field; otherwise
    // the replacement characters show in the messages.
    let lossy;
    let text: &str = match std::str::from_utf8(chunk) {
        Ok(t) => t,
        Err(_) => {
            lossy = String::from_utf8_lossy(chunk);
            &lossy
        }
    };
    let bytes = text.as_bytes();
    // About 12 bytes a field: a guess that saves most reallocations.
    let rows_guess = bytes.len() / (12 * layout.fields.max(1)) + 1;
    let mut cols: [Vec<f64>; ROLES] = Default::default();
    for (c, role) in cols.iter_mut().zip(layout.roles) {
        if role.is_some() {
            c.reserve(rows_guess);
        }
    }
    // Byte ranges of the fields of the current line.
    let mut fields: Vec<(usize, usize)> = Vec::with_capacity(layout.fields + 1);
    let mut pos = 0;
    let mut line_no = 0;
    while pos < bytes.len() {
        let (start, mut field_start, mut i) = (pos, pos, pos);
        fields.clear();
        while i < bytes.len() {
            match bytes[i] {
                b',' => {
                    fields.push((field_start, i));
                    field_start = i + 1;
                }
                b'\n' => break,
                _ => {}
            }
            i += 1;
        }
        fields.push((field_start, i));
        pos = i + 1;
        let this = line_no;
        line_no += 1;
        if fields.len() == 1 && text[start..i].trim().is_empty() {
            continue;
        }
        if fields.len() != layout.fields {
            return Err(RowFault {
                line: this,
                kind: FaultKind::Fields(fields.len()),
            });
        }
        for (col, role) in cols.iter_mut().zip(layout.roles) {
            if let Some(f) = role {
                let (a, b) = fields[f];
                let v = parse_field(&text[a..b]).map_err(|kind| RowFault {
                    line: this,
                    kind: kind.at(f),
                })?;
                col.push(v);
            }
        }
    }
    Ok(Parsed { cols })
}

/// Why a field is not a number, before its column is known.
enum FieldFault {
    NotNumber(String),
    NotFinite(String),
}

impl FieldFault {
    fn at(self, field: usize) -> FaultKind {
        match self {
            FieldFault::NotNumber(s) => FaultKind::NotNumber(field, s),
            FieldFault::NotFinite(s) => FaultKind::NotFinite(field, s),
        }
    }
}

/// A finite number from one field, white space and quotes around it dropped.
fn parse_field(raw: &str) -> Result<f64, FieldFault> {
    let s = raw.trim().trim_matches('"');
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(FieldFault::NotFinite(s.to_string())),
        Err(_) => Err(FieldFault::NotNumber(s.to_string())),
    }
}

/// Which command column of the daemon's recording an axis used: the one that is not zero
/// throughout (a voltage, a CiA 402 drive's target torque, or a valve duty; voltage when the
/// command never left zero). A velocity command is no drive force or torque: refused.
fn mcap_command(
    cycles: &[crate::recording::CycleRecord],
    origin: &str,
) -> Result<McapCommand, DataError> {
    let any = |f: fn(&crate::recording::CycleRecord) -> f64| cycles.iter().any(|c| f(c) != 0.0);
    Ok(if any(|c| c.command_voltage) {
        McapCommand::Voltage
    } else if any(|c| c.command_torque) {
        McapCommand::Torque
    } else if any(|c| c.command_duty) {
        McapCommand::Duty
    } else if any(|c| c.command_velocity) {
        return Err(DataError(format!(
            "{origin}: the axis was commanded a velocity (CiA 402 CSV); the lab needs the force, \
             torque, voltage, duty or current its drive was given"
        )));
    } else {
        McapCommand::Voltage
    })
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum McapCommand {
    Voltage,
    Torque,
    Duty,
}

/// Read the daemon's MCAP recording (topic `/actuatord/cycle`). The command is the column the
/// axis used (see [`mcap_command`]: voltage, torque or duty); the supply is the pressure when one
/// was recorded, otherwise the voltage.
pub fn load_mcap(path: &Path) -> Result<Dataset, DataError> {
    let origin = path.display().to_string();
    let recording =
        crate::recording::read_recording(path).map_err(|e| DataError(format!("{origin}: {e}")))?;
    let cycles = recording.cycles;
    // A recording whose writer was killed (the incident's own record) is read up to its last
    // complete record; every figure that names the data says so.
    let origin = match &recording.cut {
        Some(cut) => format!("{origin} (cut: {cut})"),
        None => origin,
    };
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
    from_cycles(&cycles, origin)
}

/// A data set from the cycle records of one axis.
fn from_cycles(
    cycles: &[crate::recording::CycleRecord],
    origin: String,
) -> Result<Dataset, DataError> {
    let command = mcap_command(cycles, &origin)?;
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
            .map(|c| match command {
                McapCommand::Voltage => c.command_voltage,
                McapCommand::Torque => c.command_torque,
                McapCommand::Duty => c.command_duty,
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
    fn blank_lines_crlf_and_quotes_keep_row_numbers() {
        let text =
            "\r\n\"time\", \"u\" ,y\r\n0,\"1\",2\r\n\r\n  \n0.001, 1.5 ,2.5\r\n0.002,1,x\r\n";
        let err = parse_csv(text, "d.csv", &Columns::default()).unwrap_err();
        assert_eq!(err.to_string(), "d.csv:7: column y: not a number: 'x'");
        let ok = text.replace(",x", ",3");
        let d = parse_csv(&ok, "d.csv", &Columns::default()).expect("parses");
        assert_eq!(d.time, vec![0.0, 0.001, 0.002]);
        assert_eq!(d.input, vec![1.0, 1.5, 1.0]);
        assert_eq!(d.output, vec![2.0, 2.5, 3.0]);
        assert_eq!(d.supply, None);
        let err = parse_csv("time,u,y\n0,1\n", "d.csv", &Columns::default()).unwrap_err();
        assert_eq!(err.to_string(), "d.csv:2: 2 fields, the header has 3");
        let err = parse_csv("time,u,y\n0,1,inf\n", "d.csv", &Columns::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            "d.csv:2: column y: not a finite number: 'inf'"
        );
    }

    #[test]
    fn a_large_file_is_read_whole_and_errors_keep_their_row() {
        // Large enough to be parsed in several pieces at once.
        let n = 120_000;
        let mut text = String::from("time,u,y,i\n");
        for k in 0..n {
            text.push_str(&format!(
                "{},{},{},{}\n",
                k as f64 * 1e-3,
                k % 7,
                -(k as f64),
                0.25
            ));
            if k % 1000 == 0 {
                text.push('\n');
            }
        }
        assert!(text.len() > 2 * PARALLEL_BYTES);
        let d = parse_csv(&text, "big.csv", &Columns::default()).expect("parses");
        assert_eq!(d.len(), n);
        assert!(d
            .time
            .iter()
            .enumerate()
            .all(|(k, t)| *t == k as f64 * 1e-3));
        assert!(d
            .input
            .iter()
            .enumerate()
            .all(|(k, u)| *u == (k % 7) as f64));
        assert!(d.output.iter().enumerate().all(|(k, y)| *y == -(k as f64)));
        assert_eq!(d.current.as_ref().map(Vec::len), Some(n));
        // Row of sample k: the header, k earlier rows and one blank line per thousand.
        let k = 110_500;
        let row = 1 + k + k / 1000 + 1 + 1;
        let bad = text.replacen(
            &format!("\n{},", k as f64 * 1e-3),
            &format!("\n{}s,", k as f64 * 1e-3),
            1,
        );
        let err = parse_csv(&bad, "big.csv", &Columns::default()).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "big.csv:{row}: column time: not a number: '{}s'",
                k as f64 * 1e-3
            )
        );
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

    fn ramp(origin: &str, n: usize, dt: f64, supply: bool) -> Dataset {
        let time: Vec<f64> = (0..n).map(|k| 3.0 + k as f64 * dt).collect();
        Dataset {
            origin: origin.into(),
            output: time.iter().map(|t| 0.01 * t).collect(),
            input: vec![1.0; n],
            supply: supply.then(|| vec![24.0; n]),
            current: None,
            time,
        }
    }

    #[test]
    fn records_given_together_stay_stretches_of_their_own() {
        let all = Dataset::concat(vec![
            ramp("a.csv", 100, 1e-3, true),
            ramp("b.csv", 60, 1e-3, true),
        ])
        .expect("same signals");
        all.validate().expect("a gap is not jitter");
        assert_eq!(all.segments(), vec![0..100, 100..160]);
        assert!((all.period_s() - 1e-3).abs() < 1e-12, "{}", all.period_s());
        assert_eq!(all.origin, "a.csv + b.csv");
        assert!(all.time[100] - all.time[99] > GAP_PERIODS * 1e-3);
        // A lost period or two of a recording is no gap.
        let mut lossy = ramp("c.csv", 100, 1e-3, false);
        for t in &mut lossy.time[50..] {
            *t += 2e-3;
        }
        lossy.validate().expect("valid");
        assert_eq!(lossy.segments(), vec![0..100]);
    }

    fn cycles(
        f: fn(&mut crate::recording::CycleRecord, f64),
    ) -> Vec<crate::recording::CycleRecord> {
        (0..60)
            .map(|k| {
                let mut c = crate::recording::CycleRecord {
                    t_s: k as f64 * 1e-3,
                    position: 1e-4 * k as f64,
                    ..Default::default()
                };
                f(&mut c, (k as f64 * 0.1).sin());
                c
            })
            .collect()
    }

    #[test]
    fn a_recording_gives_the_command_column_its_axis_used() {
        // A torque-commanded drive records no voltage: its command is the torque, not the
        // (zero) duty.
        let torque = from_cycles(&cycles(|c, u| c.command_torque = u), "t.mcap".into())
            .expect("torque record");
        let want: Vec<f64> = (0..60).map(|k| (k as f64 * 0.1).sin()).collect();
        assert_eq!(torque.input, want);
        let duty =
            from_cycles(&cycles(|c, u| c.command_duty = u), "d.mcap".into()).expect("duty record");
        assert_eq!(duty.input, want);
        let volt = from_cycles(
            &cycles(|c, u| {
                c.command_voltage = 12.0 * u;
                c.current = u;
            }),
            "v.mcap".into(),
        )
        .expect("voltage record");
        assert_eq!(volt.input[10], 12.0 * want[10]);
        assert_eq!(volt.current.as_ref().map(|i| i[10]), Some(want[10]));
        let err = from_cycles(&cycles(|c, u| c.command_velocity = u), "s.mcap".into())
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("s.mcap: the axis was commanded a velocity"),
            "{err}"
        );
    }

    #[test]
    fn records_with_different_signals_are_refused_by_name() {
        let err = Dataset::concat(vec![
            ramp("a.csv", 100, 1e-3, true),
            ramp("b.csv", 100, 1e-3, false),
        ])
        .unwrap_err();
        assert!(
            err.to_string()
                .starts_with("b.csv: lacks a supply column, a.csv not"),
            "{err}"
        );
    }
}
