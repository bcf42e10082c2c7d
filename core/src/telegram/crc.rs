//! The LMS 2xx checksum (PROTOCOL.md §1).
//!
//! Not a textbook CRC-16: the register starts at 0 and for every byte `b`
//! is first shifted left by one bit (folding the bit shifted out back in
//! with the polynomial `0x8005`), then XORed with the 16-bit word made of
//! the previous byte (high) and `b` (low):
//!
//! ```text
//! crc = crc & 0x8000 != 0 ? ((crc & 0x7FFF) << 1) ^ 0x8005 : crc << 1
//! crc ^= (prev << 8) | b;   prev = b
//! ```
//!
//! It covers every byte from `STX` to the last byte before the checksum
//! (`4 + LEN` bytes) and is sent low byte first.

/// The polynomial folded in when the top bit is shifted out.
pub const POLYNOMIAL: u16 = 0x8005;

/// Incremental LMS checksum, for bytes that arrive in pieces.
///
/// ```
/// use lms_core::telegram::{crc16, Crc};
/// let bytes = [0x02, 0x00, 0x01, 0x00, 0x31];
/// let mut crc = Crc::new();
/// crc.update(&bytes[..2]);
/// crc.update(&bytes[2..]);
/// assert_eq!(crc.value(), 0x1215);
/// assert_eq!(crc16(&bytes), 0x1215);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Crc {
    crc: u16,
    prev: u8,
}

impl Crc {
    /// A checksum over no bytes (register 0, previous byte 0).
    #[inline]
    pub const fn new() -> Self {
        Crc { crc: 0, prev: 0 }
    }

    /// Add one byte.
    #[inline]
    pub const fn push(&mut self, b: u8) {
        self.crc = if self.crc & 0x8000 != 0 {
            ((self.crc & 0x7FFF) << 1) ^ POLYNOMIAL
        } else {
            self.crc << 1
        };
        self.crc ^= (b as u16) | ((self.prev as u16) << 8);
        self.prev = b;
    }

    /// Add bytes in order.
    #[inline]
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.push(b);
        }
    }

    /// The checksum of the bytes added so far.
    #[inline]
    pub const fn value(&self) -> u16 {
        self.crc
    }
}

/// The LMS checksum of `bytes` (give it `STX` … the byte before the CRC).
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc = Crc::new();
    crc.update(bytes);
    crc.value()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn telegram_crc_vectors() {
        // (bytes before the CRC, CRC as sent low byte first), PROTOCOL.md §4.
        let cases: [(&[u8], [u8; 2]); 4] = [
            (&[0x02, 0x00, 0x01, 0x00, 0x31], [0x15, 0x12]),
            (&[0x02, 0x00, 0x02, 0x00, 0x30, 0x01], [0x31, 0x18]),
            (&[0x02, 0x80, 0x02, 0x00, 0x92, 0x10], [0x7F, 0x33]),
            (
                &[
                    0x02, 0x80, 0x07, 0x00, 0xBB, 0x01, 0xB4, 0x00, 0x32, 0x00, 0x10,
                ],
                [0x03, 0x9D],
            ),
        ];
        for (bytes, crc) in cases {
            assert_eq!(crc16(bytes).to_le_bytes(), crc);
        }
    }

    #[test]
    fn telegram_crc_incremental_matches_whole() {
        let bytes: [u8; 11] = [
            0x02, 0x00, 0x05, 0x00, 0x3B, 0x64, 0x00, 0x19, 0x00, 0xFF, 0x80,
        ];
        for split in 0..=bytes.len() {
            let mut c = Crc::new();
            c.update(&bytes[..split]);
            c.update(&bytes[split..]);
            assert_eq!(c.value(), crc16(&bytes), "split at {split}");
        }
        assert_eq!(crc16(&[]), 0);
        // Top bit set on the next shift: exercises the polynomial branch.
        assert_eq!(crc16(&bytes[..9]), 0x72E7);
    }
}
