//! candump log lines (`candump -L` / `-l` format): `(1700000000.123456) vcan0 18A#0011223344556677`.

use super::Frame;

/// One line of a candump log.
#[derive(Debug, Clone, PartialEq)]
pub struct CandumpRecord {
    /// Seconds, as candump printed them (wall clock since the epoch, or relative with `-ta`).
    pub time_s: f64,
    pub iface: String,
    pub frame: Frame,
}

/// Why a candump line could not be read. Carries the line's text for the message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CandumpError {
    #[error("not a candump -L line (expected \"(seconds) iface ID#DATA\"): {0:?}")]
    Shape(String),
    #[error("bad timestamp in candump line: {0:?}")]
    Time(String),
    #[error("bad CAN id or data in candump line: {0:?}")]
    Frame(String),
    /// Error frames, remote frames and CAN FD frames are valid candump lines this protocol does not use.
    #[error("not a classic data frame: {0:?}")]
    NotData(String),
}

/// Parse one `candump -L` line.
pub fn parse_candump_line(line: &str) -> Result<CandumpRecord, CandumpError> {
    let shape = || CandumpError::Shape(line.to_string());
    let mut parts = line.split_whitespace();
    let stamp = parts.next().ok_or_else(shape)?;
    let iface = parts.next().ok_or_else(shape)?;
    let body = parts.next().ok_or_else(shape)?;
    let time_s = stamp
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .ok_or_else(shape)?
        .parse::<f64>()
        .map_err(|_| CandumpError::Time(line.to_string()))?;
    let (id_text, data_text) = body.split_once('#').ok_or_else(shape)?;
    if data_text.starts_with('#') || data_text.starts_with('R') {
        return Err(CandumpError::NotData(line.to_string()));
    }
    let bad = || CandumpError::Frame(line.to_string());
    let id = u32::from_str_radix(id_text, 16).map_err(|_| bad())?;
    if data_text.len() % 2 != 0 || data_text.len() > 16 {
        return Err(bad());
    }
    let mut data = [0u8; 8];
    for (i, chunk) in data_text.as_bytes().chunks(2).enumerate() {
        let hex = std::str::from_utf8(chunk).map_err(|_| bad())?;
        data[i] = u8::from_str_radix(hex, 16).map_err(|_| bad())?;
    }
    let data = &data[..data_text.len() / 2];
    let frame = match id_text.len() {
        3 => Frame::new(id, data).map_err(|_| bad())?,
        // CAN_ERR_FLAG: candump prints error frames with this bit in an 8-digit id.
        8 if id & 0x2000_0000 != 0 => return Err(CandumpError::NotData(line.to_string())),
        8 => Frame::new_extended(id, data).map_err(|_| bad())?,
        _ => return Err(bad()),
    };
    Ok(CandumpRecord {
        time_s,
        iface: iface.to_string(),
        frame,
    })
}

/// Format one frame as a `candump -L` line (no newline).
pub fn write_candump_line(time_s: f64, iface: &str, frame: &Frame) -> String {
    format!("({time_s:.6}) {iface} {frame}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_what_candump_writes_and_back() {
        let line = "(1700000000.123456) vcan0 18A#00112233DEADBEEF";
        let rec = parse_candump_line(line).expect("valid line");
        assert_eq!(rec.iface, "vcan0");
        assert_eq!(rec.frame.id(), 0x18A);
        assert_eq!(
            rec.frame.data(),
            &[0x00, 0x11, 0x22, 0x33, 0xDE, 0xAD, 0xBE, 0xEF]
        );
        assert!((rec.time_s - 1_700_000_000.123456).abs() < 1e-6);
        assert_eq!(write_candump_line(rec.time_s, "vcan0", &rec.frame), line);
    }

    #[test]
    fn empty_and_extended_frames() {
        let rec = parse_candump_line("(0.000100) can0 080#").expect("valid line");
        assert!(rec.frame.is_empty());
        let ext = parse_candump_line("(1.0) can0 1234ABCD#01").expect("valid line");
        assert!(ext.frame.is_extended());
        assert_eq!(ext.frame.id(), 0x1234ABCD);
    }

    #[test]
    fn garbage_is_an_error_that_quotes_the_line() {
        for bad in [
            "",
            "hello",
            "(x) vcan0 123#00",
            "(1.0) vcan0 123#0",
            "(1.0) vcan0 XYZ#00",
            "(1.0) vcan0 123#001122334455667788",
        ] {
            let err = parse_candump_line(bad).expect_err(bad);
            if !bad.is_empty() {
                assert!(err.to_string().contains(bad), "{err}");
            }
        }
        assert!(matches!(
            parse_candump_line("(1.0) vcan0 20000004#0004000000000000"),
            Err(CandumpError::NotData(_))
        ));
        assert!(matches!(
            parse_candump_line("(1.0) vcan0 123#R"),
            Err(CandumpError::NotData(_))
        ));
    }
}
