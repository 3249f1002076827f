//! Signal packing shared by the codec and the DBC: one table, so the two can never disagree.
//!
//! Every signal is little-endian (DBC `@1`), `raw = round((physical - offset) / factor)`.

/// One signal inside a frame's data bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signal {
    pub name: &'static str,
    pub start_bit: u16,
    pub bits: u8,
    pub signed: bool,
    pub factor: f64,
    pub offset: f64,
    pub unit: &'static str,
    pub comment: &'static str,
}

impl Signal {
    /// An unsigned integer signal with factor 1 (counters, ids, states, flags).
    pub const fn raw(name: &'static str, start_bit: u16, bits: u8, comment: &'static str) -> Self {
        Self {
            name,
            start_bit,
            bits,
            signed: false,
            factor: 1.0,
            offset: 0.0,
            unit: "",
            comment,
        }
    }

    /// Smallest and largest raw value the signal can carry.
    pub fn raw_range(&self) -> (i64, i64) {
        if self.signed {
            let half = 1i64 << (self.bits - 1);
            (-half, half - 1)
        } else {
            (0, ((1u128 << self.bits) - 1) as i64)
        }
    }

    /// Smallest and largest physical value the signal can carry.
    pub fn physical_range(&self) -> (f64, f64) {
        let (lo, hi) = self.raw_range();
        (
            lo as f64 * self.factor + self.offset,
            hi as f64 * self.factor + self.offset,
        )
    }

    /// Pack a physical value; values outside the range saturate (and say so by returning false),
    /// because a clipped reading is safer on the bus than a wrapped one.
    pub fn encode(&self, value: f64, data: &mut [u8; 8]) -> bool {
        let (lo, hi) = self.raw_range();
        let scaled = ((value - self.offset) / self.factor).round();
        let (raw, in_range) = if scaled.is_nan() {
            (0, false)
        } else if scaled < lo as f64 {
            (lo, false)
        } else if scaled > hi as f64 {
            (hi, false)
        } else {
            (scaled as i64, true)
        };
        self.encode_raw(raw as u64, data);
        in_range
    }

    /// Pack a raw value (only its low `bits` bits are used).
    pub fn encode_raw(&self, raw: u64, data: &mut [u8; 8]) {
        let mask = if self.bits == 64 {
            u64::MAX
        } else {
            (1u64 << self.bits) - 1
        };
        let word = u64::from_le_bytes(*data);
        let shifted_mask = mask << self.start_bit;
        let word = (word & !shifted_mask) | ((raw & mask) << self.start_bit);
        *data = word.to_le_bytes();
    }

    /// The raw value, sign-extended for signed signals.
    pub fn decode_raw(&self, data: &[u8]) -> i64 {
        let mut buf = [0u8; 8];
        let n = data.len().min(8);
        buf[..n].copy_from_slice(&data[..n]);
        let word = u64::from_le_bytes(buf) >> self.start_bit;
        let mask = if self.bits == 64 {
            u64::MAX
        } else {
            (1u64 << self.bits) - 1
        };
        let raw = word & mask;
        if self.signed && self.bits < 64 && raw & (1 << (self.bits - 1)) != 0 {
            (raw | !mask) as i64
        } else {
            raw as i64
        }
    }

    /// The physical value.
    pub fn decode(&self, data: &[u8]) -> f64 {
        self.decode_raw(data) as f64 * self.factor + self.offset
    }

    /// Bytes a frame needs to hold this signal.
    pub fn end_byte(&self) -> usize {
        (self.start_bit as usize + self.bits as usize).div_ceil(8)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const POS: Signal = Signal {
        name: "position",
        start_bit: 0,
        bits: 32,
        signed: true,
        factor: 1e-7,
        offset: 0.0,
        unit: "m",
        comment: "",
    };

    #[test]
    fn negative_values_sign_extend() {
        let mut d = [0u8; 8];
        assert!(POS.encode(-0.0125, &mut d));
        assert_eq!(POS.decode_raw(&d), -125_000);
        assert!((POS.decode(&d) + 0.0125).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_saturates_and_reports_it() {
        let s = Signal::raw("counter", 8, 8, "");
        let mut d = [0u8; 8];
        assert!(!s.encode(300.0, &mut d));
        assert_eq!(s.decode_raw(&d), 255);
        assert!(!s.encode(-1.0, &mut d));
        assert_eq!(s.decode_raw(&d), 0);
        assert!(!s.encode(f64::NAN, &mut d));
    }

    proptest! {
        #[test]
        fn packing_leaves_neighbours_alone(start in 0u16..56, bits in 1u8..=8, raw in 0u64..256, fill in any::<u64>()) {
            let s = Signal::raw("x", start, bits, "");
            let mut d = fill.to_le_bytes();
            s.encode_raw(raw, &mut d);
            let mask = ((1u64 << bits) - 1) << start;
            prop_assert_eq!(u64::from_le_bytes(d) & !mask, fill & !mask);
            prop_assert_eq!(s.decode_raw(&d) as u64, raw & ((1 << bits) - 1));
        }
    }
}
