//! PDO communication and mapping parameters (CiA 301 §7.5.2.35–§7.5.2.38), sans-I/O: what a
//! PDO carries, the SDO writes that configure it on a node in the order CiA 301 prescribes, the
//! reads that check it, and the packing of its frame.

use crate::canopen::od::ObjectId;
use crate::canopen::Frame;

/// RPDO communication parameters, 1400h + n - 1.
pub const RPDO_COMMUNICATION: u16 = 0x1400;
/// RPDO mapping parameters, 1600h + n - 1.
pub const RPDO_MAPPING: u16 = 0x1600;
/// TPDO communication parameters, 1800h + n - 1.
pub const TPDO_COMMUNICATION: u16 = 0x1800;
/// TPDO mapping parameters, 1A00h + n - 1.
pub const TPDO_MAPPING: u16 = 0x1A00;
/// COB-ID bit 31: the PDO does not exist (is not valid). Set it before changing a PDO.
pub const COB_ID_INVALID: u32 = 1 << 31;
/// COB-ID bit 30: no RTR allowed on this PDO.
pub const COB_ID_NO_RTR: u32 = 1 << 30;
/// Transmission type 1: synchronous, every SYNC (a TPDO is sent after each SYNC, an RPDO's
/// data takes effect at the next SYNC).
pub const TRANSMISSION_SYNC_EVERY: u8 = 1;
/// Transmission type 255: event-driven, device-profile specific (CiA 401's default).
pub const TRANSMISSION_EVENT_PROFILE: u8 = 255;

/// Abort codes of the mapping protocol (CiA 301 Table 22).
pub mod abort {
    use crate::canopen::sdo::AbortCode;
    /// A mapping entry written while the PDO is valid or its count is not 0.
    pub const UNSUPPORTED_ACCESS: AbortCode = AbortCode(0x0601_0000);
    /// The object does not exist or may not be mapped (in this direction).
    pub const CANNOT_BE_MAPPED: AbortCode = AbortCode(0x0604_0041);
    /// The mapped objects would not fit in 8 bytes.
    pub const EXCEEDS_PDO_LENGTH: AbortCode = AbortCode(0x0604_0042);
    /// A parameter that cannot change while the PDO is valid (its COB-ID, its type).
    pub const INVALID_VALUE: AbortCode = AbortCode(0x0609_0030);
}

/// The direction of a PDO, seen from the node that owns the parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// RPDO: the node receives it (commands to a drive).
    Receive,
    /// TPDO: the node transmits it (feedback from a drive).
    Transmit,
}

impl Direction {
    pub fn name(self) -> &'static str {
        match self {
            Direction::Receive => "RPDO",
            Direction::Transmit => "TPDO",
        }
    }
}

/// One mapping entry: the object and how many bits of the PDO it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MappedObject {
    pub id: ObjectId,
    pub bits: u8,
}

impl MappedObject {
    pub const fn new(index: u16, sub: u8, bits: u8) -> Self {
        Self {
            id: ObjectId::new(index, sub),
            bits,
        }
    }

    /// The entry as written to 1600h/1A00h: index (bits 31..16), subindex (15..8), length in
    /// bits (7..0).
    pub fn to_u32(self) -> u32 {
        (u32::from(self.id.index) << 16) | (u32::from(self.id.sub) << 8) | u32::from(self.bits)
    }

    pub fn from_u32(v: u32) -> Self {
        Self::new((v >> 16) as u16, (v >> 8) as u8, v as u8)
    }
}

/// One PDO of a node: its number (1..=512), COB-ID, transmission type and mapped objects.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pdo {
    pub direction: Direction,
    pub number: u16,
    /// The 11-bit CAN id.
    pub cob_id: u32,
    /// False: bit 31 of the COB-ID set, the PDO is not used.
    pub enabled: bool,
    pub transmission_type: u8,
    pub objects: Vec<MappedObject>,
}

/// One SDO write of a configuration sequence: object, value and its size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParameterWrite {
    pub id: ObjectId,
    pub value: u32,
    pub size: usize,
}

impl ParameterWrite {
    pub fn bytes(&self) -> Vec<u8> {
        self.value.to_le_bytes()[..self.size].to_vec()
    }
}

impl Pdo {
    /// A PDO with its objects, synchronous on every SYNC.
    pub fn sync(direction: Direction, number: u16, cob_id: u32, objects: &[MappedObject]) -> Self {
        Self {
            direction,
            number,
            cob_id,
            enabled: true,
            transmission_type: TRANSMISSION_SYNC_EVERY,
            objects: objects.to_vec(),
        }
    }

    /// A PDO that is switched off (COB-ID bit 31), nothing mapped.
    pub fn disabled(direction: Direction, number: u16, cob_id: u32) -> Self {
        Self {
            direction,
            number,
            cob_id,
            enabled: false,
            transmission_type: TRANSMISSION_EVENT_PROFILE,
            objects: Vec::new(),
        }
    }

    /// 1400h/1800h + n - 1.
    pub fn communication_index(&self) -> u16 {
        let base = match self.direction {
            Direction::Receive => RPDO_COMMUNICATION,
            Direction::Transmit => TPDO_COMMUNICATION,
        };
        base + self.number - 1
    }

    /// 1600h/1A00h + n - 1.
    pub fn mapping_index(&self) -> u16 {
        let base = match self.direction {
            Direction::Receive => RPDO_MAPPING,
            Direction::Transmit => TPDO_MAPPING,
        };
        base + self.number - 1
    }

    /// The COB-ID entry as stored at sub 1.
    pub fn cob_id_entry(&self) -> u32 {
        let valid = if self.enabled { 0 } else { COB_ID_INVALID };
        // TPDOs here never answer remote frames (CiA 301 advises against RTR).
        let rtr = match self.direction {
            Direction::Transmit => COB_ID_NO_RTR,
            Direction::Receive => 0,
        };
        self.cob_id | valid | rtr
    }

    /// Bits the mapped objects take.
    pub fn bits(&self) -> u32 {
        self.objects.iter().map(|o| u32::from(o.bits)).sum()
    }

    /// "RPDO1 (1400h/1600h)", for messages.
    pub fn label(&self) -> String {
        format!(
            "{}{} ({:04X}h/{:04X}h)",
            self.direction.name(),
            self.number,
            self.communication_index(),
            self.mapping_index()
        )
    }

    /// The SDO writes that give a node this PDO, in the order of CiA 301 §7.5.2.36/38:
    /// invalidate the PDO (COB-ID bit 31), set the transmission type, set the mapping count to
    /// 0, write the entries, write the count, and make the PDO valid with its COB-ID.
    pub fn configuration_writes(&self) -> Vec<ParameterWrite> {
        let comm = self.communication_index();
        let map = self.mapping_index();
        let w = |index, sub, value, size| ParameterWrite {
            id: ObjectId::new(index, sub),
            value,
            size,
        };
        let mut out = vec![
            w(comm, 1, self.cob_id_entry() | COB_ID_INVALID, 4),
            w(comm, 2, u32::from(self.transmission_type), 1),
            w(map, 0, 0, 1),
        ];
        for (i, o) in self.objects.iter().enumerate() {
            out.push(w(map, i as u8 + 1, o.to_u32(), 4));
        }
        out.push(w(map, 0, self.objects.len() as u32, 1));
        if self.enabled {
            out.push(w(comm, 1, self.cob_id_entry(), 4));
        }
        out
    }

    /// What a node configured with this PDO reads back, entry by entry: the COB-ID (bits 31
    /// and 29..0 compared, bit 30 is the node's business), the type, the count and the entries.
    pub fn expected_reads(&self) -> Vec<(ObjectId, u32, u32)> {
        let comm = self.communication_index();
        let map = self.mapping_index();
        let mut out = vec![
            (ObjectId::new(comm, 1), self.cob_id_entry(), !COB_ID_NO_RTR),
            (
                ObjectId::new(comm, 2),
                u32::from(self.transmission_type),
                u32::MAX,
            ),
        ];
        if self.enabled {
            out.push((ObjectId::new(map, 0), self.objects.len() as u32, u32::MAX));
            for (i, o) in self.objects.iter().enumerate() {
                out.push((ObjectId::new(map, i as u8 + 1), o.to_u32(), u32::MAX));
            }
        }
        out
    }

    /// Bytes on the bus.
    pub fn len_bytes(&self) -> usize {
        (self.bits() as usize).div_ceil(8)
    }

    /// Each mapped object's raw value from a received frame, in mapping order; `None` when the
    /// frame is shorter than the mapping (CiA 301: such a PDO is not processed).
    pub fn unpack<'a>(
        &'a self,
        data: &'a [u8],
    ) -> Option<impl Iterator<Item = (MappedObject, u64)> + 'a> {
        if data.len() < self.len_bytes() {
            return None;
        }
        let mut word = [0u8; 8];
        word[..data.len().min(8)].copy_from_slice(&data[..data.len().min(8)]);
        let all = u64::from_le_bytes(word);
        let mut offset = 0u32;
        Some(self.objects.iter().map(move |o| {
            let bits = u32::from(o.bits);
            let raw = if bits >= 64 {
                all
            } else {
                (all >> offset) & ((1u64 << bits) - 1)
            };
            offset += bits;
            (*o, raw)
        }))
    }

    /// The frame with each mapped object's raw value from `value` (little endian, packed in
    /// mapping order, CiA 301 §7.5.2.38).
    pub fn pack(&self, mut value: impl FnMut(ObjectId) -> u64) -> Frame {
        let mut all = 0u64;
        let mut offset = 0u32;
        for o in &self.objects {
            let bits = u32::from(o.bits);
            let mask = if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            };
            if offset < 64 {
                all |= (value(o.id) & mask) << offset;
            }
            offset += bits;
        }
        let bytes = all.to_le_bytes();
        Frame::new(self.cob_id & 0x7FF, &bytes[..self.len_bytes().min(8)])
            .expect("an 11-bit id and at most 8 bytes")
    }
}

/// A raw field of `bits` bits as a signed value (INTEGERn).
pub fn sign_extend(raw: u64, bits: u8) -> i64 {
    if bits == 0 || bits >= 64 {
        return raw as i64;
    }
    let shift = 64 - u32::from(bits);
    ((raw << shift) as i64) >> shift
}

/// A signed value as the raw field of `bits` bits, saturated to what fits.
pub fn to_raw_signed(value: f64, bits: u8) -> u64 {
    let max = (1i64 << (bits - 1)) - 1;
    let min = -(1i64 << (bits - 1));
    let v = if value.is_finite() {
        (value.round() as i64).clamp(min, max)
    } else {
        0
    };
    (v as u64)
        & if bits >= 64 {
            u64::MAX
        } else {
            (1 << bits) - 1
        }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_entry_is_index_sub_and_length() {
        let e = MappedObject::new(0x6041, 0, 16);
        assert_eq!(e.to_u32(), 0x6041_0010);
        assert_eq!(
            MappedObject::from_u32(0x6064_0020),
            MappedObject::new(0x6064, 0, 32)
        );
    }

    #[test]
    fn configuration_follows_the_cia301_sequence() {
        let pdo = Pdo::sync(
            Direction::Transmit,
            1,
            0x190,
            &[
                MappedObject::new(0x6041, 0, 16),
                MappedObject::new(0x6064, 0, 32),
            ],
        );
        let w: Vec<_> = pdo
            .configuration_writes()
            .iter()
            .map(|w| (w.id.to_string(), w.value, w.size))
            .collect();
        assert_eq!(
            w,
            vec![
                ("1800:01".to_string(), 0xC000_0190, 4),
                ("1800:02".to_string(), 1, 1),
                ("1A00:00".to_string(), 0, 1),
                ("1A00:01".to_string(), 0x6041_0010, 4),
                ("1A00:02".to_string(), 0x6064_0020, 4),
                ("1A00:00".to_string(), 2, 1),
                ("1800:01".to_string(), 0x4000_0190, 4),
            ]
        );
    }

    #[test]
    fn pack_and_unpack_are_inverse_and_little_endian() {
        let pdo = Pdo::sync(
            Direction::Receive,
            1,
            0x210,
            &[
                MappedObject::new(0x6040, 0, 16),
                MappedObject::new(0x6071, 0, 16),
            ],
        );
        let f = pdo.pack(|id| match id.index {
            0x6040 => 0x000F,
            0x6071 => to_raw_signed(-250.0, 16),
            _ => 0,
        });
        assert_eq!(f.to_string(), "210#0F0006FF");
        let values: Vec<_> = pdo.unpack(f.data()).expect("long enough").collect();
        assert_eq!(values[0].1, 0x000F);
        assert_eq!(sign_extend(values[1].1, 16), -250);
        assert!(pdo.unpack(&f.data()[..3]).is_none());
    }

    #[test]
    fn sign_extension_and_saturation() {
        assert_eq!(sign_extend(0xFFFF_FFFF, 32), -1);
        assert_eq!(sign_extend(0x7FFF, 16), 32767);
        assert_eq!(to_raw_signed(1e9, 16), 0x7FFF);
        assert_eq!(to_raw_signed(-1e9, 16), 0x8000);
        assert_eq!(to_raw_signed(f64::NAN, 16), 0);
    }
}
