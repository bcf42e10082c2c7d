//! The 34-byte configuration block of `74`/`F4` (read) and `77`/`F7`
//! (write), PROTOCOL.md §2.
//!
//! | index | field |
//! |---|---|
//! | `[0..=1]` | blanking (u16 LE, raw sensor units) |
//! | `[4]` | availability (bit 1 = real-time indices, [`Config::real_time_indices`]) |
//! | `[5]` | measuring mode (decides 13/14/15 range bits) |
//! | `[6]` | units (0 cm, 1 mm) |
//!
//! The other bytes are kept as they are and exposed through
//! [`Config::as_bytes`].

use super::{le_u16, put_le_u16};

/// Availability byte bit 1: real-time scan indices.
pub const REAL_TIME_INDICES_BIT: u8 = 0x02;
/// Bytes in a configuration block.
pub const CONFIG_LEN: usize = 34;

byte_block!(
    Config,
    CONFIG_LEN,
    "34",
    "A configuration block (the data of `F4`, and of `77`/`F7` after the first byte of `F7`); all bytes 0, the default, is no blanking, no real-time indices, mode 0, cm."
);

impl Config {
    /// Blanking, `[0..=1]` (u16 LE, raw sensor units).
    #[inline]
    pub fn blanking(&self) -> u16 {
        le_u16(&self.bytes, Self::BLANKING)
    }

    /// Set the blanking word.
    #[inline]
    pub fn set_blanking(&mut self, value: u16) {
        put_le_u16(&mut self.bytes, Self::BLANKING, value);
    }

    /// Availability byte, `[4]` (bit 1 = real-time indices).
    #[inline]
    pub const fn availability(&self) -> u8 {
        self.bytes[Self::AVAILABILITY]
    }

    /// Availability bit 1: the sensor sends a real-time scan index after
    /// the values of every `B0` (and `B6`/`B7`/`BF`).
    pub const fn real_time_indices(&self) -> bool {
        self.availability() & REAL_TIME_INDICES_BIT != 0
    }

    /// Set the availability byte.
    #[inline]
    pub fn set_availability(&mut self, value: u8) {
        self.bytes[Self::AVAILABILITY] = value;
    }

    /// Measuring mode, `[5]` (raw code).
    #[inline]
    pub const fn measuring_mode(&self) -> u8 {
        self.bytes[Self::MEASURING_MODE]
    }

    /// Set the measuring mode.
    #[inline]
    pub fn set_measuring_mode(&mut self, value: u8) {
        self.bytes[Self::MEASURING_MODE] = value;
    }

    /// Set the units code (0 cm, 1 mm).
    #[inline]
    pub fn set_units_code(&mut self, code: u8) {
        self.bytes[Self::UNITS] = code;
    }

    /// This block with the units code `code` (0 cm, 1 mm); `const`.
    #[inline]
    pub const fn with_units_code(self, code: u8) -> Config {
        let mut bytes = self.bytes;
        bytes[Self::UNITS] = code;
        Config { bytes }
    }

    /// Byte offset of the blanking word.
    pub const BLANKING: usize = 0;
    /// Byte offset of the availability byte.
    pub const AVAILABILITY: usize = 4;
    /// Byte offset of the measuring-mode byte.
    pub const MEASURING_MODE: usize = 5;
    /// Byte offset of the units byte.
    pub const UNITS: usize = 6;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::Unit;

    #[test]
    fn telegram_config_fields() {
        let mut c = Config::default();
        c.set_blanking(0x0102);
        c.set_availability(0x02);
        c.set_measuring_mode(0x06);
        c.set_units_code(1);
        let mut expected = [0u8; CONFIG_LEN];
        expected[..7].copy_from_slice(&[0x02, 0x01, 0, 0, 0x02, 0x06, 0x01]);
        assert_eq!(c.as_bytes(), &expected);
        assert_eq!(c.blanking(), 0x0102);
        assert_eq!(c.availability(), 2);
        assert_eq!(c.measuring_mode(), 6);
        assert_eq!(c.units(), Some(Unit::Millimetre));
        assert_eq!(Config::from_slice(&expected), Some(c));
        assert_eq!(Config::from_slice(&expected[..33]), None);
    }
}
