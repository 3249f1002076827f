//! Where runs are recorded with `--record-dir`: a new file per run, never one overwritten, and
//! the oldest removed when the directory is over its budget.
//!
//! Names are `run-<sequence>-<UTC start time>[-<iface>].mcap`: the sequence orders runs even on
//! a machine whose clock jumps (no real-time clock, time set by the network after start).

use std::path::{Path, PathBuf};

/// How much the directory may hold; the run being started counts as one file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordBudget {
    /// At most this many recordings (runs × buses) in the directory.
    pub max_files: usize,
    /// At most this many bytes of recordings before the new run's, 0 for no limit.
    pub max_bytes: u64,
}

/// The runs' recordings of one start: where each bus records, and what the budget removed.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFiles {
    pub sequence: u64,
    pub paths: Vec<PathBuf>,
    pub removed: Vec<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
#[error("record directory {dir}: {message}")]
pub struct RecordDirError {
    pub dir: PathBuf,
    pub message: String,
}

/// A recording of ours in `dir`: its sequence number, path and size.
fn recordings(dir: &Path) -> Result<Vec<(u64, PathBuf, u64)>, RecordDirError> {
    let err = |message: String| RecordDirError {
        dir: dir.to_path_buf(),
        message,
    };
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| err(e.to_string()))? {
        let entry = entry.map_err(|e| err(e.to_string()))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(seq) = parse_sequence(name) else {
            continue;
        };
        let size = entry.metadata().map(|m| m.len()).unwrap_or(0);
        found.push((seq, entry.path(), size));
    }
    // Oldest first: by sequence, then name (several buses share one sequence).
    found.sort();
    Ok(found)
}

/// The sequence number of one of our file names, `run-<digits>-....mcap`.
fn parse_sequence(name: &str) -> Option<u64> {
    let rest = name.strip_prefix("run-")?;
    if !name.ends_with(".mcap") {
        return None;
    }
    let digits = rest.split('-').next()?;
    digits.parse().ok()
}

/// Prepare a run: create `dir` if needed, remove the oldest recordings beyond `budget`
/// (counting this run's `ifaces.len()` files), and name this run's files, one per interface
/// (no suffix when there is one bus). `unix_time_s` is the start time for the names.
pub fn prepare_run(
    dir: &Path,
    ifaces: &[&str],
    budget: RecordBudget,
    unix_time_s: u64,
) -> Result<RunFiles, RecordDirError> {
    let err = |message: String| RecordDirError {
        dir: dir.to_path_buf(),
        message,
    };
    std::fs::create_dir_all(dir).map_err(|e| err(format!("cannot create it: {e}")))?;
    let mut existing = recordings(dir)?;
    let sequence = existing.iter().map(|(s, _, _)| s + 1).max().unwrap_or(1);
    let mut removed = Vec::new();
    let keep = budget.max_files.saturating_sub(ifaces.len().max(1));
    let mut total: u64 = existing.iter().map(|(_, _, size)| size).sum();
    while !existing.is_empty()
        && (existing.len() > keep || (budget.max_bytes > 0 && total > budget.max_bytes))
    {
        let (_, path, size) = existing.remove(0);
        std::fs::remove_file(&path).map_err(|e| {
            err(format!(
                "cannot remove {} for the budget: {e}",
                path.display()
            ))
        })?;
        total -= size;
        removed.push(path);
    }
    let stamp = utc_stamp(unix_time_s);
    let paths = if ifaces.len() <= 1 {
        vec![dir.join(format!("run-{sequence:06}-{stamp}.mcap"))]
    } else {
        ifaces
            .iter()
            .map(|i| dir.join(format!("run-{sequence:06}-{stamp}-{i}.mcap")))
            .collect()
    };
    if let Some(p) = paths.iter().find(|p| p.exists()) {
        // Only a second daemon started in the same second on the same directory gets here.
        return Err(err(format!(
            "{} exists already; it is not overwritten",
            p.display()
        )));
    }
    Ok(RunFiles {
        sequence,
        paths,
        removed,
    })
}

/// `YYYYMMDDTHHMMSSZ` for a Unix time (proleptic Gregorian calendar, UTC).
pub fn utc_stamp(unix_time_s: u64) -> String {
    let days = (unix_time_s / 86_400) as i64;
    let secs = unix_time_s % 86_400;
    // Days since 1970-01-01 to a civil date, by 400-year eras (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}T{:02}{:02}{:02}Z",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_are_utc_calendar_times() {
        assert_eq!(utc_stamp(0), "19700101T000000Z");
        // date -u -d @1700000000: Tue Nov 14 22:13:20 UTC 2023
        assert_eq!(utc_stamp(1_700_000_000), "20231114T221320Z");
        // A leap day: date -u -d @951782400 is 2000-02-29 00:00:00.
        assert_eq!(utc_stamp(951_782_400), "20000229T000000Z");
    }

    #[test]
    fn each_run_gets_a_new_file_and_the_oldest_go_beyond_the_budget() {
        let dir = tempfile::tempdir().expect("tempdir");
        let budget = RecordBudget {
            max_files: 3,
            max_bytes: 0,
        };
        let mut all = Vec::new();
        for run in 0..5u64 {
            let files =
                prepare_run(dir.path(), &["vcan0"], budget, 1_700_000_000 + run).expect("prepare");
            assert_eq!(files.sequence, run + 1);
            std::fs::write(&files.paths[0], b"x").expect("write");
            all.push(files.paths[0].clone());
        }
        let left: Vec<bool> = all.iter().map(|p| p.exists()).collect();
        assert_eq!(left, [false, false, true, true, true]);
        // Foreign files are never touched.
        std::fs::write(dir.path().join("notes.txt"), b"keep").expect("write");
        let two =
            prepare_run(dir.path(), &["vcan0", "vcan1"], budget, 1_700_000_100).expect("prepare");
        assert_eq!(two.paths.len(), 2);
        assert!(two.paths[1].to_string_lossy().ends_with("-vcan1.mcap"));
        assert_eq!(two.removed.len(), 2, "{:?}", two.removed);
        assert!(dir.path().join("notes.txt").exists());
    }

    #[test]
    fn a_size_budget_removes_the_oldest_until_it_fits() {
        let dir = tempfile::tempdir().expect("tempdir");
        let budget = RecordBudget {
            max_files: 100,
            max_bytes: 2500,
        };
        let mut all = Vec::new();
        for run in 0..4u64 {
            let files = prepare_run(dir.path(), &["can0"], budget, run).expect("prepare");
            std::fs::write(&files.paths[0], vec![0u8; 1000]).expect("write");
            all.push(files.paths[0].clone());
        }
        // Before the fourth run: three files of 1000 bytes = 3000 > 2500, the oldest goes.
        let left: Vec<bool> = all.iter().map(|p| p.exists()).collect();
        assert_eq!(left, [false, true, true, true]);
    }
}
