//! `actuator faults`: the daemon's error history, the pre-defined error field 1003h with the
//! time of each entry (2F01h), read from a running daemon over SDO or from its state file, and
//! printed newest first with what each error code means.

use actuatord::bus::SocketCanBus;
use actuatord::canopen::od::ObjectId;
use actuatord::canopen::ErrorEntry;
use actuatord::daemon::record_dir::utc_stamp;
use actuatord::daemon::state;
use actuatord::device::error_code_meaning;
use actuatord::device::objects::index;
use std::path::Path;
use std::time::Duration;

/// Before 1980 a time is no wall-clock time: a node without one counts from its start.
const WALL_CLOCK_FROM_S: f64 = 315_532_800.0;

/// The history in the state file `file`.
pub fn from_state_file(file: &Path) -> anyhow::Result<Vec<ErrorEntry>> {
    let kept = state::load(file)?
        .ok_or_else(|| anyhow::anyhow!("{}: no such state file", file.display()))?;
    Ok(kept.error_field().iter().collect())
}

/// The history of the daemon `node` on `iface`: 1003h sub 0, then each entry and its time.
pub fn from_daemon(iface: &str, node: u8, timeout: Duration) -> anyhow::Result<Vec<ErrorEntry>> {
    anyhow::ensure!(
        (1..=127).contains(&node),
        "--node must be 1..=127, got {node}"
    );
    let mut bus = SocketCanBus::open(iface).map_err(|e| anyhow::anyhow!("{iface}: {e}"))?;
    let mut read = |id: ObjectId| -> anyhow::Result<Vec<u8>> {
        actuatord::client::sdo_read(&mut bus, node, id, timeout)
            .map_err(|e| anyhow::anyhow!("{iface}: {e}"))?
            .map_err(|e| anyhow::anyhow!("node {node} on {iface}: {e}"))
    };
    let count = read(ObjectId::new(index::PRE_DEFINED_ERROR_FIELD, 0))?;
    let &[count] = count.as_slice() else {
        anyhow::bail!(
            "node {node} on {iface}: 1003:00 answered {} bytes, not the one of UNSIGNED8",
            count.len()
        );
    };
    let mut entries = Vec::with_capacity(usize::from(count));
    for sub in 1..=count {
        let id = ObjectId::new(index::PRE_DEFINED_ERROR_FIELD, sub);
        let bytes = read(id)?;
        let field = <[u8; 4]>::try_from(bytes.as_slice())
            .map(u32::from_le_bytes)
            .map_err(|_| {
                anyhow::anyhow!(
                    "node {node} on {iface}: {id} answered {} bytes, not the 4 of UNSIGNED32",
                    bytes.len()
                )
            })?;
        // A node without 2F01h (another device) still tells its errors, without their times.
        let time_s = read(ObjectId::new(index::ERROR_FIELD_TIME, sub))
            .ok()
            .and_then(|b| <[u8; 8]>::try_from(b.as_slice()).ok())
            .map_or(f64::NAN, f64::from_le_bytes);
        entries.push(ErrorEntry::from_field(field, time_s));
    }
    Ok(entries)
}

/// `2023-11-14 22:13:20.250 UTC`, or the time since the node's start where it had no wall
/// clock, or `-` where the time is not known.
pub fn time_text(time_s: f64) -> String {
    if !time_s.is_finite() || time_s < 0.0 {
        return "-".into();
    }
    if time_s < WALL_CLOCK_FROM_S {
        return format!("{time_s:.3} s after start");
    }
    let whole = time_s.floor();
    let ms = ((time_s - whole) * 1e3).floor() as u32;
    // YYYYMMDDTHHMMSSZ
    let s = utc_stamp(whole as u64);
    format!(
        "{}-{}-{} {}:{}:{}.{ms:03} UTC",
        &s[0..4],
        &s[4..6],
        &s[6..8],
        &s[9..11],
        &s[11..13],
        &s[13..15]
    )
}

/// The history as a table, newest first; `source` says where it was read.
pub fn render(source: &str, entries: &[ErrorEntry]) -> String {
    let mut out = format!(
        "{source}: {} error{} in the history (1003h), newest first\n",
        entries.len(),
        if entries.len() == 1 { "" } else { "s" }
    );
    if entries.is_empty() {
        return out;
    }
    out += "sub  code   register  axis  time                         meaning\n";
    for (sub, e) in (1..).zip(entries) {
        let [register, axis] = e.additional_info.to_le_bytes();
        let axis_text = if axis == 0 {
            "-".to_string()
        } else {
            axis.to_string()
        };
        out += &format!(
            "{sub:>3}  {:04X}h  {register:02X}h       {axis_text:>4}  {:<27}  {}\n",
            e.error_code,
            time_text(e.time_s),
            error_code_meaning(e.error_code, axis)
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_print_as_utc_or_since_start() {
        assert_eq!(time_text(1_700_000_000.25), "2023-11-14 22:13:20.250 UTC");
        assert_eq!(time_text(12.5), "12.500 s after start");
        assert_eq!(time_text(f64::NAN), "-");
    }

    #[test]
    fn the_table_names_code_register_axis_time_and_meaning() {
        let entries = [
            ErrorEntry {
                error_code: 0x8250,
                additional_info: 0x1011,
                time_s: 1_700_000_060.5,
            },
            ErrorEntry {
                error_code: 0x8140,
                additional_info: 0x0011,
                time_s: f64::NAN,
            },
        ];
        let text = render("state.toml", &entries);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "state.toml: 2 errors in the history (1003h), newest first"
        );
        assert!(lines[2].starts_with("  1  8250h  11h         16  2023-11-14 22:14:20.500 UTC"));
        assert!(lines[2].ends_with("set-point timeout: no set-point from the commander"));
        // 8140h of axis 0 is the bus's bus-off, not an axis' node state.
        assert!(lines[3].contains("   -  -  "), "{}", lines[3]);
        assert!(lines[3].ends_with("bus fault: bus_off"), "{}", lines[3]);
    }
}
