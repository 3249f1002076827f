//! The pre-defined error field (CiA 301 §7.5.2.3, object 1003h): the errors a node announced by
//! EMCY, newest first. A ring of fixed size, so noting an error on the cycle thread costs a few
//! stores and never allocates; the oldest entry goes when a newer one needs its place.

/// Entries the field holds: subindexes 1..=16 of 1003h.
pub const ERROR_FIELD_LEN: usize = 16;

/// One announced error.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ErrorEntry {
    /// The EMCY's error code (CiA 301 Table 21).
    pub error_code: u16,
    /// Manufacturer-specific additional information: bits 16..31 of the entry.
    pub additional_info: u16,
    /// When it was announced, s: a Unix time where the node knows the wall clock, else the
    /// node's own time since its start.
    pub time_s: f64,
}

impl ErrorEntry {
    /// The entry as 1003h sub 1.. holds it: additional information in bits 16..31, the error
    /// code in bits 0..15.
    pub fn field(&self) -> u32 {
        (u32::from(self.additional_info) << 16) | u32::from(self.error_code)
    }

    /// The entry a 1003h value stands for, announced at `time_s`.
    pub fn from_field(value: u32, time_s: f64) -> Self {
        Self {
            error_code: (value & 0xFFFF) as u16,
            additional_info: (value >> 16) as u16,
            time_s,
        }
    }
}

/// The last [`ERROR_FIELD_LEN`] errors, newest first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorField {
    ring: [ErrorEntry; ERROR_FIELD_LEN],
    /// Where the newest entry is in `ring` (meaningless while empty).
    newest: usize,
    len: usize,
    /// Counts every change, so a reader that saw one count can tell whether it must look again.
    changes: u64,
}

impl Default for ErrorField {
    fn default() -> Self {
        Self {
            ring: [ErrorEntry::default(); ERROR_FIELD_LEN],
            newest: 0,
            len: 0,
            changes: 0,
        }
    }
}

impl ErrorField {
    /// A field holding `entries`, given newest first; beyond [`ERROR_FIELD_LEN`] the oldest are
    /// left out.
    pub fn from_newest_first(entries: impl IntoIterator<Item = ErrorEntry>) -> Self {
        let mut field = Self::default();
        for e in entries.into_iter().take(ERROR_FIELD_LEN) {
            field.ring[field.len] = e;
            field.len += 1;
        }
        // Kept oldest first, so the newest is the last one written.
        field.ring[..field.len].reverse();
        field.newest = field.len.saturating_sub(1);
        field
    }

    /// Note a newly announced error: it becomes entry 0 (sub 1), the others move down one.
    pub fn push(&mut self, entry: ErrorEntry) {
        self.newest = if self.len == 0 {
            0
        } else {
            (self.newest + 1) % ERROR_FIELD_LEN
        };
        self.ring[self.newest] = entry;
        self.len = (self.len + 1).min(ERROR_FIELD_LEN);
        self.changes = self.changes.wrapping_add(1);
    }

    /// Forget every entry (a write of 0 to 1003h sub 0).
    pub fn clear(&mut self) {
        self.len = 0;
        self.changes = self.changes.wrapping_add(1);
    }

    /// The number of errors held: 1003h sub 0.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Entry `i`, newest first (`i` = sub - 1).
    pub fn get(&self, i: usize) -> Option<ErrorEntry> {
        (i < self.len).then(|| self.ring[(self.newest + ERROR_FIELD_LEN - i) % ERROR_FIELD_LEN])
    }

    /// The entries, newest first.
    pub fn iter(&self) -> impl DoubleEndedIterator<Item = ErrorEntry> + ExactSizeIterator + '_ {
        (0..self.len).map(|i| self.ring[(self.newest + ERROR_FIELD_LEN - i) % ERROR_FIELD_LEN])
    }

    /// Changes since the field was made (pushes and clears; wraps).
    pub fn changes(&self) -> u64 {
        self.changes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(code: u16, t: f64) -> ErrorEntry {
        ErrorEntry {
            error_code: code,
            additional_info: code ^ 0xFFFF,
            time_s: t,
        }
    }

    fn codes(f: &ErrorField) -> Vec<u16> {
        f.iter().map(|e| e.error_code).collect()
    }

    #[test]
    fn the_newest_error_comes_first() {
        let mut f = ErrorField::default();
        assert!(f.is_empty());
        assert_eq!(f.get(0), None);
        f.push(entry(0x8611, 1.0));
        f.push(entry(0x8250, 2.0));
        f.push(entry(0x3100, 3.0));
        assert_eq!(f.len(), 3);
        assert_eq!(codes(&f), [0x3100, 0x8250, 0x8611]);
        assert_eq!(f.get(2), Some(entry(0x8611, 1.0)));
        assert_eq!(f.get(3), None);
    }

    #[test]
    fn past_its_size_the_oldest_entries_go() {
        let mut f = ErrorField::default();
        for k in 0..(ERROR_FIELD_LEN as u16 + 5) {
            f.push(entry(0x1000 + k, f64::from(k)));
        }
        assert_eq!(f.len(), ERROR_FIELD_LEN);
        let expected: Vec<u16> = (5..ERROR_FIELD_LEN as u16 + 5)
            .rev()
            .map(|k| 0x1000 + k)
            .collect();
        assert_eq!(codes(&f), expected);
        assert_eq!(f.get(ERROR_FIELD_LEN - 1).map(|e| e.time_s), Some(5.0));
    }

    #[test]
    fn a_clear_empties_the_field_and_counts_as_a_change() {
        let mut f = ErrorField::default();
        f.push(entry(0x8611, 1.0));
        f.push(entry(0x8612, 2.0));
        let before = f.changes();
        f.clear();
        assert!(f.is_empty());
        assert_eq!(f.iter().count(), 0);
        assert_eq!(f.changes(), before + 1);
        f.push(entry(0x2310, 3.0));
        assert_eq!(codes(&f), [0x2310]);
    }

    #[test]
    fn a_field_rebuilt_from_its_entries_is_the_same_field() {
        let mut f = ErrorField::default();
        for k in 0..20u16 {
            f.push(entry(0x8100 + k, f64::from(k) * 0.5));
        }
        let back = ErrorField::from_newest_first(f.iter());
        assert_eq!(
            back.iter().collect::<Vec<_>>(),
            f.iter().collect::<Vec<_>>()
        );
        // More than fit: the newest are kept.
        let many = (0..40u16).rev().map(|k| entry(k, 0.0));
        let kept = ErrorField::from_newest_first(many);
        assert_eq!(kept.get(0).map(|e| e.error_code), Some(39));
        assert_eq!(kept.len(), ERROR_FIELD_LEN);
    }

    #[test]
    fn an_entry_packs_the_additional_information_above_the_code() {
        let e = ErrorEntry {
            error_code: 0x8250,
            additional_info: 0x1011,
            time_s: 0.0,
        };
        assert_eq!(e.field(), 0x1011_8250);
        assert_eq!(ErrorEntry::from_field(0x1011_8250, 0.0), e);
    }
}
