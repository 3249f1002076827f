//! Data types and typed values of the object dictionary (CiA 301 §7.1 "data types and encoding
//! rules"): little-endian bytes on the bus, text at the tools, a `Copy` value in the dictionary.

use std::fmt;

/// Longest VISIBLE_STRING the dictionary stores. Strings are held inline so that neither a read
/// nor a write allocates.
pub const STRING_CAPACITY: usize = 64;

/// The CiA 301 basic data types this dictionary uses (CiA 301 Table 44, object index = code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataType {
    Boolean,
    Integer8,
    Integer16,
    Integer32,
    Unsigned8,
    Unsigned16,
    Unsigned32,
    Real32,
    Real64,
    VisibleString,
}

impl DataType {
    /// Every type, in code order.
    pub const ALL: [DataType; 10] = [
        DataType::Boolean,
        DataType::Integer8,
        DataType::Integer16,
        DataType::Integer32,
        DataType::Unsigned8,
        DataType::Unsigned16,
        DataType::Unsigned32,
        DataType::Real32,
        DataType::VisibleString,
        DataType::Real64,
    ];

    /// The data type's object index, as written in an EDS `DataType=` (CiA 301 Table 44).
    pub fn code(self) -> u16 {
        match self {
            DataType::Boolean => 0x0001,
            DataType::Integer8 => 0x0002,
            DataType::Integer16 => 0x0003,
            DataType::Integer32 => 0x0004,
            DataType::Unsigned8 => 0x0005,
            DataType::Unsigned16 => 0x0006,
            DataType::Unsigned32 => 0x0007,
            DataType::Real32 => 0x0008,
            DataType::VisibleString => 0x0009,
            DataType::Real64 => 0x0011,
        }
    }

    pub fn from_code(code: u16) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.code() == code)
    }

    /// The CiA 301 name, e.g. `UNSIGNED16`.
    pub fn name(self) -> &'static str {
        match self {
            DataType::Boolean => "BOOLEAN",
            DataType::Integer8 => "INTEGER8",
            DataType::Integer16 => "INTEGER16",
            DataType::Integer32 => "INTEGER32",
            DataType::Unsigned8 => "UNSIGNED8",
            DataType::Unsigned16 => "UNSIGNED16",
            DataType::Unsigned32 => "UNSIGNED32",
            DataType::Real32 => "REAL32",
            DataType::Real64 => "REAL64",
            DataType::VisibleString => "VISIBLE_STRING",
        }
    }

    /// Encoded size in bytes; `None` for the variable-length VISIBLE_STRING.
    pub fn size(self) -> Option<usize> {
        match self {
            DataType::Boolean | DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer32 | DataType::Unsigned32 | DataType::Real32 => Some(4),
            DataType::Real64 => Some(8),
            DataType::VisibleString => None,
        }
    }

    pub fn is_real(self) -> bool {
        matches!(self, DataType::Real32 | DataType::Real64)
    }
}

impl fmt::Display for DataType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A VISIBLE_STRING of at most [`STRING_CAPACITY`] bytes, stored inline.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct VisibleString {
    len: u8,
    bytes: [u8; STRING_CAPACITY],
}

impl VisibleString {
    /// `None` if `bytes` is longer than [`STRING_CAPACITY`] or holds a byte outside printable
    /// ASCII (CiA 301 VISIBLE_STRING is ISO 646, codes 0x20..=0x7E; a trailing NUL is dropped).
    pub fn from_bytes(bytes: &[u8]) -> Option<Self> {
        let bytes = match bytes.iter().position(|&b| b == 0) {
            Some(end) if bytes[end..].iter().all(|&b| b == 0) => &bytes[..end],
            _ => bytes,
        };
        if bytes.len() > STRING_CAPACITY || !bytes.iter().all(|b| (0x20..=0x7E).contains(b)) {
            return None;
        }
        let mut out = [0u8; STRING_CAPACITY];
        out[..bytes.len()].copy_from_slice(bytes);
        Some(Self {
            len: bytes.len() as u8,
            bytes: out,
        })
    }

    pub fn new(text: &str) -> Option<Self> {
        Self::from_bytes(text.as_bytes())
    }

    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    pub fn as_str(&self) -> &str {
        // Only printable ASCII gets in, which is valid UTF-8.
        std::str::from_utf8(self.as_bytes()).unwrap_or_default()
    }
}

impl fmt::Debug for VisibleString {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

/// One typed value. `Copy` and fixed-size: the dictionary stores, stages and hands these out
/// without allocating.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    Boolean(bool),
    Integer8(i8),
    Integer16(i16),
    Integer32(i32),
    Unsigned8(u8),
    Unsigned16(u16),
    Unsigned32(u32),
    Real32(f32),
    Real64(f64),
    VisibleString(VisibleString),
}

/// Why bytes or text do not make a value of the wanted type.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ValueError {
    #[error("{data_type} takes {expected} bytes, got {got}")]
    WrongLength {
        data_type: DataType,
        expected: usize,
        got: usize,
    },
    #[error("BOOLEAN must be 0 or 1, got {0}")]
    BadBoolean(u8),
    #[error("VISIBLE_STRING must be printable ASCII of at most {STRING_CAPACITY} bytes")]
    BadString,
    #[error("cannot read {text:?} as {data_type}")]
    Parse { data_type: DataType, text: String },
}

impl Value {
    pub fn data_type(&self) -> DataType {
        match self {
            Value::Boolean(_) => DataType::Boolean,
            Value::Integer8(_) => DataType::Integer8,
            Value::Integer16(_) => DataType::Integer16,
            Value::Integer32(_) => DataType::Integer32,
            Value::Unsigned8(_) => DataType::Unsigned8,
            Value::Unsigned16(_) => DataType::Unsigned16,
            Value::Unsigned32(_) => DataType::Unsigned32,
            Value::Real32(_) => DataType::Real32,
            Value::Real64(_) => DataType::Real64,
            Value::VisibleString(_) => DataType::VisibleString,
        }
    }

    /// The zero of a type (false, 0, 0.0, "").
    pub fn zero(data_type: DataType) -> Self {
        match data_type {
            DataType::Boolean => Value::Boolean(false),
            DataType::Integer8 => Value::Integer8(0),
            DataType::Integer16 => Value::Integer16(0),
            DataType::Integer32 => Value::Integer32(0),
            DataType::Unsigned8 => Value::Unsigned8(0),
            DataType::Unsigned16 => Value::Unsigned16(0),
            DataType::Unsigned32 => Value::Unsigned32(0),
            DataType::Real32 => Value::Real32(0.0),
            DataType::Real64 => Value::Real64(0.0),
            DataType::VisibleString => Value::VisibleString(VisibleString {
                len: 0,
                bytes: [0; STRING_CAPACITY],
            }),
        }
    }

    /// A string value; `None` if it is too long or not printable ASCII.
    pub fn string(text: &str) -> Option<Self> {
        VisibleString::new(text).map(Value::VisibleString)
    }

    /// The number a numeric value stands for (exact for every type here); `None` for a string.
    pub fn as_f64(&self) -> Option<f64> {
        Some(match *self {
            Value::Boolean(b) => f64::from(u8::from(b)),
            Value::Integer8(v) => f64::from(v),
            Value::Integer16(v) => f64::from(v),
            Value::Integer32(v) => f64::from(v),
            Value::Unsigned8(v) => f64::from(v),
            Value::Unsigned16(v) => f64::from(v),
            Value::Unsigned32(v) => f64::from(v),
            Value::Real32(v) => f64::from(v),
            Value::Real64(v) => v,
            Value::VisibleString(_) => return None,
        })
    }

    /// Little-endian encoding into `out` (CiA 301 §7.1.5); returns the length used.
    /// `out` must hold [`STRING_CAPACITY`] bytes for any value; shorter buffers get a prefix.
    pub fn encode(&self, out: &mut [u8]) -> usize {
        let mut tmp = [0u8; 8];
        let bytes: &[u8] = match *self {
            Value::Boolean(b) => {
                tmp[0] = u8::from(b);
                &tmp[..1]
            }
            Value::Integer8(v) => {
                tmp[..1].copy_from_slice(&v.to_le_bytes());
                &tmp[..1]
            }
            Value::Integer16(v) => {
                tmp[..2].copy_from_slice(&v.to_le_bytes());
                &tmp[..2]
            }
            Value::Integer32(v) => {
                tmp[..4].copy_from_slice(&v.to_le_bytes());
                &tmp[..4]
            }
            Value::Unsigned8(v) => {
                tmp[0] = v;
                &tmp[..1]
            }
            Value::Unsigned16(v) => {
                tmp[..2].copy_from_slice(&v.to_le_bytes());
                &tmp[..2]
            }
            Value::Unsigned32(v) => {
                tmp[..4].copy_from_slice(&v.to_le_bytes());
                &tmp[..4]
            }
            Value::Real32(v) => {
                tmp[..4].copy_from_slice(&v.to_le_bytes());
                &tmp[..4]
            }
            Value::Real64(v) => {
                tmp.copy_from_slice(&v.to_le_bytes());
                &tmp[..8]
            }
            Value::VisibleString(ref s) => {
                let n = s.as_bytes().len().min(out.len());
                out[..n].copy_from_slice(&s.as_bytes()[..n]);
                return n;
            }
        };
        let n = bytes.len().min(out.len());
        out[..n].copy_from_slice(&bytes[..n]);
        n
    }

    /// Decode the little-endian bytes of a `data_type` value; the length must match exactly.
    pub fn decode(data_type: DataType, bytes: &[u8]) -> Result<Self, ValueError> {
        if let Some(expected) = data_type.size() {
            if bytes.len() != expected {
                return Err(ValueError::WrongLength {
                    data_type,
                    expected,
                    got: bytes.len(),
                });
            }
        }
        let arr = |n: usize| {
            let mut a = [0u8; 8];
            a[..n].copy_from_slice(&bytes[..n]);
            a
        };
        Ok(match data_type {
            DataType::Boolean => match bytes[0] {
                0 => Value::Boolean(false),
                1 => Value::Boolean(true),
                other => return Err(ValueError::BadBoolean(other)),
            },
            DataType::Integer8 => Value::Integer8(i8::from_le_bytes([bytes[0]])),
            DataType::Integer16 => {
                let a = arr(2);
                Value::Integer16(i16::from_le_bytes([a[0], a[1]]))
            }
            DataType::Integer32 => {
                let a = arr(4);
                Value::Integer32(i32::from_le_bytes([a[0], a[1], a[2], a[3]]))
            }
            DataType::Unsigned8 => Value::Unsigned8(bytes[0]),
            DataType::Unsigned16 => {
                let a = arr(2);
                Value::Unsigned16(u16::from_le_bytes([a[0], a[1]]))
            }
            DataType::Unsigned32 => {
                let a = arr(4);
                Value::Unsigned32(u32::from_le_bytes([a[0], a[1], a[2], a[3]]))
            }
            DataType::Real32 => {
                let a = arr(4);
                Value::Real32(f32::from_le_bytes([a[0], a[1], a[2], a[3]]))
            }
            DataType::Real64 => Value::Real64(f64::from_le_bytes(arr(8))),
            DataType::VisibleString => {
                Value::VisibleString(VisibleString::from_bytes(bytes).ok_or(ValueError::BadString)?)
            }
        })
    }

    /// Read a value of `data_type` from text, as a user types it: integers in decimal or
    /// `0x` hex, reals in any Rust float syntax (`inf` too), booleans as `true`/`false`/`1`/`0`,
    /// strings as they are.
    pub fn parse(data_type: DataType, text: &str) -> Result<Self, ValueError> {
        let t = text.trim();
        let bad = || ValueError::Parse {
            data_type,
            text: text.to_string(),
        };
        Ok(match data_type {
            DataType::Boolean => match t.to_ascii_lowercase().as_str() {
                "1" | "true" | "on" | "yes" => Value::Boolean(true),
                "0" | "false" | "off" | "no" => Value::Boolean(false),
                _ => return Err(bad()),
            },
            DataType::Integer8 => {
                Value::Integer8(i8::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Integer16 => {
                Value::Integer16(i16::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Integer32 => {
                Value::Integer32(i32::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Unsigned8 => {
                Value::Unsigned8(u8::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Unsigned16 => {
                Value::Unsigned16(u16::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Unsigned32 => {
                Value::Unsigned32(u32::try_from(parse_int(t).ok_or_else(bad)?).map_err(|_| bad())?)
            }
            DataType::Real32 => Value::Real32(t.parse().map_err(|_| bad())?),
            DataType::Real64 => Value::Real64(t.parse().map_err(|_| bad())?),
            DataType::VisibleString => Value::string(text).ok_or(ValueError::BadString)?,
        })
    }
}

/// An integer in decimal or `0x` hex, with an optional sign.
fn parse_int(text: &str) -> Option<i64> {
    let (negative, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let magnitude = match digits
        .strip_prefix("0x")
        .or_else(|| digits.strip_prefix("0X"))
    {
        Some(hex) => i64::from_str_radix(hex, 16).ok()?,
        None => digits.parse::<i64>().ok()?,
    };
    Some(if negative { -magnitude } else { magnitude })
}

/// Text as [`Value::parse`] reads it back: integers in decimal, reals in the shortest form that
/// round-trips, booleans as `true`/`false`.
impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Boolean(b) => write!(f, "{b}"),
            Value::Integer8(v) => write!(f, "{v}"),
            Value::Integer16(v) => write!(f, "{v}"),
            Value::Integer32(v) => write!(f, "{v}"),
            Value::Unsigned8(v) => write!(f, "{v}"),
            Value::Unsigned16(v) => write!(f, "{v}"),
            Value::Unsigned32(v) => write!(f, "{v}"),
            Value::Real32(v) => write!(f, "{v:?}"),
            Value::Real64(v) => write!(f, "{v:?}"),
            Value::VisibleString(s) => f.write_str(s.as_str()),
        }
    }
}

macro_rules! value_from {
    ($($t:ty => $v:ident),* $(,)?) => {
        $(impl From<$t> for Value {
            fn from(x: $t) -> Self {
                Value::$v(x)
            }
        })*
    };
}

value_from!(bool => Boolean, i8 => Integer8, i16 => Integer16, i32 => Integer32,
    u8 => Unsigned8, u16 => Unsigned16, u32 => Unsigned32, f32 => Real32, f64 => Real64);

/// Bytes as space-separated hex, for values whose type a tool does not know.
pub fn format_hex(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        out.push_str(&format!("{b:02x}"));
    }
    out
}

/// Raw bytes from hex text, spaces optional (`"de ad be ef"`, `"deadbeef"`, `"0xdeadbeef"`).
pub fn parse_hex(text: &str) -> Option<Vec<u8>> {
    let t = text.trim();
    let t = t
        .strip_prefix("0x")
        .or_else(|| t.strip_prefix("0X"))
        .unwrap_or(t);
    let digits: Vec<u8> = t.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    if digits.is_empty() || digits.len() % 2 != 0 {
        return None;
    }
    digits
        .chunks(2)
        .map(|pair| {
            let s = std::str::from_utf8(pair).ok()?;
            u8::from_str_radix(s, 16).ok()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_round_trips_through_bytes_and_text() {
        let samples = [
            Value::Boolean(true),
            Value::Integer8(-100),
            Value::Integer16(-30_000),
            Value::Integer32(-2_000_000_000),
            Value::Unsigned8(200),
            Value::Unsigned16(60_000),
            Value::Unsigned32(4_000_000_000),
            Value::Real32(-1.25e-3),
            Value::Real64(2231.0e-7),
            Value::string("solenoid").expect("ascii"),
        ];
        for v in samples {
            let mut buf = [0u8; STRING_CAPACITY];
            let n = v.encode(&mut buf);
            assert_eq!(Some(n), v.data_type().size().or(Some(8)), "{v:?}");
            assert_eq!(Value::decode(v.data_type(), &buf[..n]), Ok(v));
            assert_eq!(Value::parse(v.data_type(), &v.to_string()), Ok(v));
            assert_eq!(
                DataType::from_code(v.data_type().code()),
                Some(v.data_type())
            );
        }
    }

    #[test]
    fn encoding_is_little_endian() {
        let mut buf = [0u8; 8];
        assert_eq!(Value::Unsigned32(0x1234_5678).encode(&mut buf), 4);
        assert_eq!(&buf[..4], &[0x78, 0x56, 0x34, 0x12]);
        assert_eq!(Value::Integer16(-2).encode(&mut buf), 2);
        assert_eq!(&buf[..2], &[0xFE, 0xFF]);
    }

    #[test]
    fn bad_bytes_and_text_are_refused() {
        assert!(matches!(
            Value::decode(DataType::Unsigned16, &[1]),
            Err(ValueError::WrongLength { expected: 2, .. })
        ));
        assert_eq!(
            Value::decode(DataType::Boolean, &[2]),
            Err(ValueError::BadBoolean(2))
        );
        assert_eq!(
            Value::decode(DataType::VisibleString, &[0x41, 0x07]),
            Err(ValueError::BadString)
        );
        assert!(Value::parse(DataType::Unsigned8, "256").is_err());
        assert!(Value::parse(DataType::Integer8, "-129").is_err());
        assert!(Value::parse(DataType::Real64, "fast").is_err());
        assert_eq!(
            Value::parse(DataType::Unsigned16, "0x1F4"),
            Ok(Value::Unsigned16(500))
        );
        assert!(Value::string(&"x".repeat(STRING_CAPACITY + 1)).is_none());
    }

    #[test]
    fn trailing_nul_of_a_c_string_is_dropped() {
        assert_eq!(
            Value::decode(DataType::VisibleString, b"abc\0\0"),
            Ok(Value::string("abc").expect("ascii"))
        );
    }

    #[test]
    fn hex_round_trip() {
        assert_eq!(format_hex(&[0xde, 0xad, 0x01]), "de ad 01");
        assert_eq!(parse_hex("de ad 01"), Some(vec![0xde, 0xad, 0x01]));
        assert_eq!(parse_hex("0xDEAD"), Some(vec![0xde, 0xad]));
        assert_eq!(parse_hex("abc"), None);
        assert_eq!(parse_hex("zz"), None);
    }
}
