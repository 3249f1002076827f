//! EMCY framing (CiA 301 §7.2.7): COB-ID 80h + node id; error code, error register and five
//! bytes the manufacturer fills. What the codes and those bytes mean is the device profile's.

use super::Frame;

/// Function code of EMCY; the COB-ID adds the producer's node id.
pub const EMCY_FUNCTION_CODE: u32 = 0x080;

/// One emergency message of any node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EmcyFrame {
    pub node_id: u8,
    /// Error code (CiA 301 Table 21; 0000h: error reset).
    pub error_code: u16,
    /// The producer's error register (1001h).
    pub error_register: u8,
    pub manufacturer: [u8; 5],
}

impl EmcyFrame {
    pub fn encode(&self) -> Frame {
        let [lo, hi] = self.error_code.to_le_bytes();
        let m = self.manufacturer;
        Frame::new(
            EMCY_FUNCTION_CODE + u32::from(self.node_id),
            &[lo, hi, self.error_register, m[0], m[1], m[2], m[3], m[4]],
        )
        .unwrap_or_else(|e| unreachable!("an 11-bit id and 8 bytes: {e}"))
    }

    /// The EMCY of `node_id`, or None when `frame` is not one (another id, or too short to
    /// carry an error code). Missing manufacturer bytes read as 0.
    pub fn decode(frame: &Frame, node_id: u8) -> Option<Self> {
        if frame.is_extended() || frame.id() != EMCY_FUNCTION_CODE + u32::from(node_id) {
            return None;
        }
        let d = frame.data();
        let (&lo, &hi) = (d.first()?, d.get(1)?);
        let mut manufacturer = [0u8; 5];
        for (slot, b) in manufacturer.iter_mut().zip(d.iter().skip(3)) {
            *slot = *b;
        }
        Some(Self {
            node_id,
            error_code: u16::from_le_bytes([lo, hi]),
            error_register: d.get(2).copied().unwrap_or(0),
            manufacturer,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_emcy_round_trips_and_other_frames_are_not_one() {
        let e = EmcyFrame {
            node_id: 5,
            error_code: 0x8611,
            error_register: 0x01,
            manufacturer: [1, 2, 3, 4, 5],
        };
        let f = e.encode();
        assert_eq!(f.id(), 0x85);
        assert_eq!(f.data(), &[0x11, 0x86, 0x01, 1, 2, 3, 4, 5]);
        assert_eq!(EmcyFrame::decode(&f, 5), Some(e));
        assert_eq!(EmcyFrame::decode(&f, 6), None);
        let short = Frame::new(0x85, &[0x11]).expect("frame");
        assert_eq!(EmcyFrame::decode(&short, 5), None);
        let two = Frame::new(0x85, &[0x10, 0x32]).expect("frame");
        assert_eq!(
            EmcyFrame::decode(&two, 5).map(|e| e.error_code),
            Some(0x3210)
        );
    }
}
